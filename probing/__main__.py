"""``python -m probing`` runs the command line."""

from probing.cli import main

raise SystemExit(main())
