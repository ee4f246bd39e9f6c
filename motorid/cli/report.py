"""What a command prints: human text on stderr, one JSON object on stdout.

:func:`configure` is called by :func:`motorid.cli.main` for each command with its
``--quiet`` and ``--json``: with ``--quiet``, :func:`say` prints nothing and no
progress bar shows; errors (:func:`say_error`) always print.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import numpy as np
import pandas as pd

from motorid.outputs import jsonable


def emit_json(payload: dict[str, Any]) -> None:
    """Print ``payload`` as one JSON object on stdout."""
    sys.stdout.write(json.dumps(jsonable(payload), indent=2) + "\n")


#: The running command's --quiet and --json (set by :func:`configure`).
_settings = {"quiet": False, "json": False}
#: The warnings said so far by the running command, as their one-line text: each is said once, whether
#: it comes from the command itself (:func:`say_warning`), through :mod:`warnings` or through :mod:`logging`.
_said: set[str] = set()


def configure(*, quiet: bool, json: bool) -> None:
    """Set what the command about to run prints: ``quiet`` silences :func:`say` and
    the progress bars; ``json`` is whether it prints its result on stdout. No warning is said yet."""
    _settings.update(quiet=quiet, json=json)
    _said.clear()


def first_time(text: str) -> bool:
    """True the first time the running command says the warning ``text`` (one line)."""
    if text in _said:
        return False
    _said.add(text)
    return True


def warning_line(text: str) -> str | None:
    """``motorid: warning: <text>`` on one line, the first time the running command says it; else None."""
    text = " ".join(str(text).split())
    return f"motorid: warning: {text}" if first_time(text) else None


def say_warning(text: str) -> None:
    """Print a warning on stderr as every warning of a command is: ``motorid: warning: <text>``, one
    line, once per cause, also with ``--quiet`` (which keeps errors and warnings); the fields a
    library warning names said as their flags (:func:`~motorid.cli.options.with_flags`)."""
    from .options import with_flags

    line = warning_line(with_flags(text))
    if line is not None:
        sys.stderr.write(line + "\n")


def say(text: str = "") -> None:
    """Print a line of human text on stderr (nothing with ``--quiet``)."""
    if not _settings["quiet"]:
        sys.stderr.write(text + "\n")


def say_error(text: str) -> None:
    """Print a line on stderr that says why a command failed or stopped (also with ``--quiet``)."""
    sys.stderr.write(text + "\n")


def show_progress() -> bool:
    """Whether the running command shows progress bars on stderr.

    Only on a terminal: a bar redraws its line with carriage returns and cursor
    codes, which a log file or a pipe would keep. Never with ``--quiet``, and never with
    ``--json`` when stdout is not a terminal (the output is read by a program).
    ``TQDM_DISABLE`` turns them off in any case (:func:`motorid.progress.progress_bar`).
    """
    if _settings["quiet"] or not sys.stderr.isatty():
        return False
    return not (_settings["json"] and not sys.stdout.isatty())


def frame_records(df: pd.DataFrame) -> list[dict[str, Any]]:
    """A DataFrame's rows as dicts, its index as a named field."""
    return [
        {df.index.name or "index": idx, **row}
        for idx, row in zip(df.index, df.to_dict("records"), strict=True)
    ]


def say_params(prefix: str, params: dict[str, Any]) -> None:
    """One line per estimated parameter."""
    for key, value in params.items():
        say(f"  {prefix}{key} = {np.array2string(np.asarray(value), precision=5)}")
