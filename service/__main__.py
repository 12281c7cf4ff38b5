"""``python -m service``: the same as ``impactnet serve`` (see :mod:`service.cli`)."""
from service.cli import main

raise SystemExit(main())
