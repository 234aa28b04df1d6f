"""``python -m gearopt`` = the ``gearopt`` command."""

from .cli import main

raise SystemExit(main())
