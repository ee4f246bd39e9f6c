"""``python -m motorid.cli``: the ``motorid`` command."""

from . import run

run()
