"""``python -m motorid.cli``: the ``motorid`` command."""

from . import main

raise SystemExit(main())
