"""Running the ``motorid`` command for the CLI tests: in-process, or as a user starts it and stops it."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import time
from pathlib import Path

import pandas as pd

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


def interrupt_when_written(argv: list[str], out: Path, size: int, samples: int) -> str:
    """Start ``argv`` (a long ``motorid run`` or ``control`` writing ``out``), send it a real SIGINT
    once ``out`` holds more than ``size`` bytes, and check what a user is told: exit status 130,
    ``stopped after N of SAMPLES samples``, and exactly N rows in ``out``. Returns its stderr."""
    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (out.exists() and out.stat().st_size > size):
        assert proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline, f"{argv[1:3]} wrote nothing within 120 s"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 130, err
    stopped = re.search(rf"stopped after (\d+) of {samples} samples", err)
    assert stopped, err
    assert len(pd.read_csv(out, comment="#")) == int(stopped.group(1))
    return err
