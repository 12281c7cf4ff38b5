"""``python -m impactnet.service``: the same as ``impactnet serve`` (see
:mod:`impactnet.service.cli`)."""
from impactnet.service.cli import main

raise SystemExit(main())
