"""One form for warnings, once per cause: a cause met at many samples is said once (and its total once).

From the command line every warning is one line ``motorid: warning: ...`` on stderr, also with
``--quiet``; in Python the same warnings are log records of the ``motorid`` loggers. The causes
here come up at many samples of one run: a client too slow for a real-time rig, commands beyond
the drive's rating, a free run that diverges.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file
from io_fixtures import SlowUpdatesARX

from motorid.drive import paper_rig
from motorid.io import ModbusDAQ, RigServer, SimulatedDAQ, run_online


def warnings_of(caplog: pytest.LogCaptureFixture, words: str) -> list[str]:
    return [
        r.getMessage() for r in caplog.records if r.levelno == logging.WARNING and words in r.getMessage()
    ]


def test_a_client_too_slow_for_a_real_time_rig_is_said_at_its_first_miss_and_at_close(caplog, tmp_path):
    """The review's run logged 286 lines "client too slow"; a slow client is said twice: the first
    samples it missed, and how many in all when the link closes."""
    caplog.set_level(logging.WARNING, logger="motorid")
    with RigServer(paper_rig(), port=0, seed=1, lockstep=False, watchdog_periods=None) as server:
        daq = ModbusDAQ("127.0.0.1", server.port, dt=server.dt, timeout=2.0)
        record = run_online(
            daq,
            {"arx": SlowUpdatesARX(0.1, lambda n: n % 5 == 0)},
            [1.0] * 40,
            None,
            out=tmp_path / "run.csv",
        )
    gaps = int(record["seq"].iloc[-1]) - len(record)  # the rig's samples since the link opened, not rows
    assert daq.missed_samples == gaps >= 4  # 8 late updates of 2.5 periods each: at least one miss in two
    said = warnings_of(caplog, "were not read")
    assert len(said) == 2, said
    assert "client too slow for dt = 0.04 s" in said[0] and "said when the link closes" in said[0]
    assert said[1].startswith(
        f"Modbus TCP 127.0.0.1:{server.port}: {gaps} sample(s) of the rig were not read"
    )


def test_clamped_commands_are_said_at_the_first_clamp_and_counted_at_close(caplog):
    caplog.set_level(logging.WARNING, logger="motorid")
    daq = SimulatedDAQ(paper_rig(), seed=0, u_max=2.0)
    with daq:
        for k in range(60):  # 3 V for 5 samples, 0 V for 5: six separate stretches of clamping
            daq.write(3.0 if k % 10 < 5 else 0.0)
            daq.read()
    said = warnings_of(caplog, "clamped")
    assert len(said) == 2, said
    assert said[0].startswith("command 3 V clamped to 2 V (rating +/-2 V)")
    assert said[1] == "30 command(s) clamped to the rating +/-2 V while the DAQ was open"
    assert daq.clamp_count == 30


def test_the_command_line_says_each_cause_once_in_one_form_also_with_quiet(tmp_path):
    """``motorid run`` clamping at every peak of its steps: two lines, each ``motorid: warning: ...``,
    and the total they say is the rows the run's CSV marks clamped."""
    argv = [sys.executable, "-m", "motorid.cli", "run", "--estimator", "arx-rls", "--signal", "steps",
            "--amplitude", "6", "--u-max", "2", "--duration", "20", "--out", "run.csv", "-q"]  # fmt: skip
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    done = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    clamped = int(pd.read_csv(tmp_path / "run.csv", comment="#")["clamped"].sum())
    lines = done.stderr.splitlines()
    assert len(lines) == 2 and clamped > 10, done.stderr
    assert lines[0].startswith("motorid: warning: command ") and "V (rating +/-2 V)" in lines[0]
    assert (
        lines[1]
        == f"motorid: warning: {clamped} command(s) clamped to the rating +/-2 V while the DAQ was open"
    )


def test_a_diverging_free_run_is_one_warning_line_in_the_command_line_form_also_with_quiet(capsys):
    """The paper's cubic on a duty record (its free run diverges from sample 257 on): said as every
    warning is, and --quiet, which keeps errors and warnings, keeps it."""
    path = real_motor_file("kit_chirp_run1.csv")
    if not path.is_file():
        pytest.skip(f"real motor data not found at {path} (set MOTORID_DATA)")
    code, _, err = run(
        capsys, "identify", str(path), "--input-unit", "%", "--output-unit", "rad/s", "--degree", "3", "-q"
    )
    assert code == 0, err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("motorid: warning: hammerstein-rls: the free run diverges from sample ")
