"""``python -m impactnet`` runs the command line."""
from impactnet.cli import main

raise SystemExit(main())
