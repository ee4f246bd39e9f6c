"""The ``motorid`` console script (:func:`motorid.cli.run`): the exit status and the output are
:func:`~motorid.cli.main`'s; the files a command writes are whole when the process has ended
without the collector's last pass; :func:`~motorid.cli.main` leaves the collector alone."""

from __future__ import annotations

import gc
import subprocess
import sys
from pathlib import Path

import pytest

from motorid.cli import main, run
from motorid.io.records import read_record

MOTORID = Path(sys.executable).with_name("motorid")


@pytest.mark.parametrize("command", [[str(MOTORID)], [sys.executable, "-m", "motorid.cli"]],
                         ids=["console script", "python -m motorid.cli"])  # fmt: skip
def test_the_command_writes_a_whole_record_and_exits_with_the_status_of_main(tmp_path, command):
    """A record written by ``simulate`` in a process that ends with its objects frozen is whole (every
    sample of the 4 s at the paper's 40 ms, the header with dt and units read back), status 0; a
    missing record is status 2 with one line naming it, as :func:`main` returns."""
    out = tmp_path / "rec.csv"
    done = subprocess.run([*command, "simulate", "--duration", "4", "--out", str(out), "--quiet"],
                          capture_output=True, text=True, timeout=300)  # fmt: skip
    assert done.returncode == 0, done.stderr
    record = read_record(out)
    assert len(record) == 100 and record.attrs["dt"] == 0.04
    assert list(record.columns[:3]) == ["t", "u", "y"]

    missing = tmp_path / "nothing.csv"
    done = subprocess.run([*command, "doctor", str(missing)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1 and "nothing.csv" in done.stderr
    assert main(["doctor", str(missing)]) == 2


def test_run_freezes_the_objects_only_once_the_command_has_returned(monkeypatch, capsys):
    """:func:`main` leaves the collector as it found it (a caller may run it many times in one
    process); :func:`run` exits with main's status and the objects frozen (no last pass at exit)."""
    frozen = gc.get_freeze_count()
    assert main(["--help"]) == 0
    assert gc.get_freeze_count() == frozen
    monkeypatch.setattr(sys, "argv", ["motorid", "doctor", "--no-such-option"])
    try:
        with pytest.raises(SystemExit) as done:
            run()
        assert done.value.code == 2
        assert gc.get_freeze_count() > frozen
    finally:
        gc.unfreeze()  # this test process goes on
    assert "motorid doctor: error: " in capsys.readouterr().err
