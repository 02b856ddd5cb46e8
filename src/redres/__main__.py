"""``python -m redres`` runs the command line."""

from .cli import main

raise SystemExit(main())
