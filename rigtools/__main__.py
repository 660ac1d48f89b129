"""``python -m rigtools``: the ``rig`` command line."""

from rigtools.cli import main

raise SystemExit(main())
