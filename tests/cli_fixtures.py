"""Running the ``motorid`` command in-process for the CLI tests."""

from __future__ import annotations

import json

from motorid.cli import main


def run(capsys, *argv: str) -> tuple[int, dict | str, str]:
    """Exit code, stdout (parsed when it is JSON) and stderr of ``motorid ARGV``."""
    code = main(list(argv))
    captured = capsys.readouterr()
    try:
        out = json.loads(captured.out)
    except json.JSONDecodeError:
        out = captured.out
    return code, out, captured.err
