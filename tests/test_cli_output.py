"""What the command prints fits a terminal and a log: progress bars only on a terminal,
``--quiet`` on every command, ``TQDM_DISABLE`` honoured.

The bars are checked where they are drawn: the command runs in a subprocess with
stderr on a pipe (as a log or ``2> file`` is) and on a pseudo-terminal (as a user's
shell is), and its bytes are read as they arrive.
"""

from __future__ import annotations

import argparse
import fcntl
import os
import pty
import re
import select
import struct
import subprocess
import sys
import termios
from pathlib import Path

import pandas as pd
import pytest
from cli_fixtures import run

from motorid.cli import build_parser, main
from motorid.fleet import ResultsStore
from motorid.progress import bars_disabled_by_environment, progress_bar

MOTORID = Path(sys.executable).with_name("motorid")
#: What a redrawn bar leaves in a file: a carriage return or an ANSI control sequence (ESC [).
BAR_CODES = re.compile(r"\r|\x1b\[")
#: A short sweep: four models, a few seconds, with a bar of the models done.
SWEEP = ["sweep", "--orders", "1-2", "--degrees", "2-3"]


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("output") / "rec.csv"
    assert main(["simulate", "--out", str(path), "--duration", "20", "--seed", "2", "-q"]) == 0
    return path


def environment(**extra: str) -> dict[str, str]:
    """This process's environment without TQDM_DISABLE, plus ``extra``."""
    env = {k: v for k, v in os.environ.items() if k != "TQDM_DISABLE"}
    return {**env, **extra}


def on_terminal(argv: list[str], *, stdout_on_terminal: bool = False, **env: str) -> tuple[int, str]:
    """Run ``motorid ARGV`` with stderr (and optionally stdout) on a pseudo-terminal.

    Returns the exit status and everything the terminal received.
    """
    leader, follower = pty.openpty()
    # a terminal of 24 rows and 100 columns (a new pseudo-terminal has none: a bar would have no room)
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    # the bytes as the program wrote them: no output processing (which turns each \n into \r\n)
    mode = termios.tcgetattr(follower)
    mode[1] &= ~termios.OPOST
    termios.tcsetattr(follower, termios.TCSANOW, mode)
    process = subprocess.Popen(
        [str(MOTORID), *argv],
        stdin=subprocess.DEVNULL,
        stdout=follower if stdout_on_terminal else subprocess.DEVNULL,
        stderr=follower,
        env=environment(**env),
    )
    os.close(follower)  # the child holds the only copy: reading ends when it exits
    received = bytearray()
    while True:
        ready, _, _ = select.select([leader], [], [], 120.0)
        if not ready:
            process.kill()
            raise AssertionError(f"motorid {' '.join(argv)}: no output for 120 s")
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # EIO: the terminal's other end is closed
            break
        if not chunk:
            break
        received += chunk
    os.close(leader)
    return process.wait(timeout=60), received.decode("utf-8", "replace")


def piped(argv: list[str], **env: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(MOTORID), *argv], capture_output=True, text=True, env=environment(**env),
                          timeout=300, check=False)  # fmt: skip


# --------------------------------------------------------------------------- bars on a terminal only
@pytest.mark.parametrize("argv", [SWEEP, ["doctor"]], ids=["sweep", "doctor"])
def test_stderr_on_a_pipe_gets_report_lines_and_no_bar(record_csv, argv):
    done = piped([argv[0], str(record_csv), *argv[1:]])
    assert done.returncode == 0, done.stderr
    assert done.stderr.strip(), "the report is missing"
    assert not BAR_CODES.search(done.stderr), repr(done.stderr[:300])
    assert "order sweep" not in done.stderr and "stage" not in done.stderr


def test_a_terminal_shows_the_bar(record_csv):
    code, screen = on_terminal([SWEEP[0], str(record_csv), *SWEEP[1:]])
    assert code == 0
    assert "order sweep" in screen and "\r" in screen
    assert "4/4" in screen  # the bar counts the four models of the sweep to the end
    assert "Table 1" in screen  # the report follows on the same terminal


def test_the_doctors_bar_runs_through_its_last_stage_on_a_terminal(record_csv):
    code, screen = on_terminal(["doctor", str(record_csv), "--json"], stdout_on_terminal=True)
    assert code == 0
    last = screen.rsplit("\rdoctor:", 1)[1]  # the bar's last drawing
    assert "100%" in last and "final gaps" in last
    assert '"final_gap"' in screen  # the JSON on the same terminal


@pytest.mark.parametrize(
    "how",
    [{"argv": ["--quiet"]}, {"argv": ["-q"]}, {"env": {"TQDM_DISABLE": "1"}}, {"env": {"TQDM_DISABLE": "true"}},
     {"argv": ["--json"]}],
    ids=["--quiet", "-q", "TQDM_DISABLE=1", "TQDM_DISABLE=true", "--json into a pipe"],
)  # fmt: skip
def test_no_bar_on_a_terminal_when_told_or_when_json_goes_to_a_program(record_csv, how):
    code, screen = on_terminal(
        [SWEEP[0], str(record_csv), *SWEEP[1:], *how.get("argv", [])], **how.get("env", {})
    )
    assert code == 0
    assert "order sweep" not in screen and not BAR_CODES.search(screen), repr(screen[:300])


def test_json_shown_on_the_terminal_keeps_the_bar(record_csv):
    code, screen = on_terminal([SWEEP[0], str(record_csv), *SWEEP[1:], "--json"], stdout_on_terminal=True)
    assert code == 0
    assert "order sweep" in screen and '"table1"' in screen


def test_tqdm_disable_set_to_zero_leaves_the_bar_on(record_csv):
    code, screen = on_terminal([SWEEP[0], str(record_csv), *SWEEP[1:]], TQDM_DISABLE="0")
    assert code == 0 and "order sweep" in screen


# --------------------------------------------------------------------------- the library's one place
@pytest.mark.parametrize(
    ("value", "disabled"),
    [(None, False), ("", False), ("0", False), ("false", False), ("Off", False), ("1", True), ("True", True),
     ("yes", True)],
)  # fmt: skip
def test_tqdm_disable_turns_off_a_bar_the_caller_asked_for(monkeypatch, capsys, value, disabled):
    if value is None:
        monkeypatch.delenv("TQDM_DISABLE", raising=False)
    else:
        monkeypatch.setenv("TQDM_DISABLE", value)
    assert bars_disabled_by_environment() is disabled
    assert list(progress_bar(range(3), show=True, desc="counting")) == [0, 1, 2]
    err = capsys.readouterr().err
    assert ("counting" in err) is not disabled
    assert list(progress_bar(range(3), show=False, desc="hidden")) == [0, 1, 2]
    assert capsys.readouterr().err == ""


def test_the_library_functions_bar_follows_progress_and_tqdm_disable(monkeypatch, capsys):
    import numpy as np

    from motorid.validation import order_sweep

    rng = np.random.default_rng(0)
    u = rng.standard_normal(400)
    y = np.convolve(u, [0.0, 0.5, 0.25])[:400]
    monkeypatch.delenv("TQDM_DISABLE", raising=False)
    order_sweep(u, y, orders=[1], degrees=[2], order=1, progress=True)
    assert "order sweep" in capsys.readouterr().err
    order_sweep(u, y, orders=[1], degrees=[2], order=1, progress=False)
    assert capsys.readouterr().err == ""
    monkeypatch.setenv("TQDM_DISABLE", "1")
    order_sweep(u, y, orders=[1], degrees=[2], order=1, progress=True)
    assert capsys.readouterr().err == ""


def test_every_progress_bar_is_made_in_motorid_progress():
    """tqdm is imported in one module only, so every bar honours TQDM_DISABLE and the caller."""
    root = Path(__file__).resolve().parents[1] / "motorid"
    importing = sorted(
        str(p.relative_to(root))
        for p in root.rglob("*.py")
        if re.search(r"^\s*(from tqdm|import tqdm)", p.read_text(encoding="utf-8"), re.MULTILINE)
    )
    assert importing == ["progress.py"]


# --------------------------------------------------------------------------- --quiet
def _commands(parser: argparse.ArgumentParser, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """Every command of the command line, as the words that name it."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                found += _commands(child, (*prefix, name)) or [(*prefix, name)]
    return found


@pytest.mark.parametrize("command", _commands(build_parser()), ids=" ".join)
def test_every_command_takes_quiet(capsys, command):
    assert main([*command, "--help"]) == 0
    assert "--quiet" in capsys.readouterr().out


@pytest.fixture(scope="module")
def results_folder(tmp_path_factory) -> Path:
    """A fleet's results as ``motorid fleet doctor`` stores them: one drive, four days."""
    folder = tmp_path_factory.mktemp("results")
    ResultsStore(folder).append([
        {"record": f"/r/drive-00_2025010{day}.csv", "drive": "drive-00", "time": f"2025-01-0{day}T00:00:00",
         "command": "doctor", "status": "ok", "model.params.coulomb": 0.5 + 0.1 * day,
         "model.params_std.coulomb": 0.01, "units.params.coulomb": "V", "named": ""}
        for day in range(1, 5)
    ])  # fmt: skip
    return folder


def quiet_commands(record: Path, work: Path, results: Path) -> dict[str, list[str]]:
    """A successful run of each command that ends on its own, small enough to run in a test."""
    return {
        "demo": ["demo", "--duration", "10", "--out", str(work / "demo")],
        "simulate": ["simulate", "--duration", "2", "--out", str(work / "sim.csv")],
        # ARX: the default Hammerstein model's free run fits the rig's dead zone below 80 %, which is
        # warned of, and a warning passes --quiet (test_quiet_keeps_warnings)
        "identify": ["identify", str(record), "--estimator", "arx-rls", "--out", str(work / "identify"),
                     "--save-model", str(work / "m.json")],
        "sweep": [*SWEEP[:1], str(record), *SWEEP[1:]],
        "doctor": ["doctor", str(record), "--out", str(work / "doctor")],
        "run": ["run", "--daq", "sim", "--estimator", "arx-rls", "--duration", "2", "--out", str(work / "run.csv")],
        "fleet generate": ["fleet", "generate", "--drives", "1", "--days", "1", "--duration", "5",
                           "--out", str(work / "fleet")],
        "fleet trend": ["fleet", "trend", str(results), "--out", str(work / "trend")],
    }  # fmt: skip


@pytest.mark.parametrize("name", list(quiet_commands(Path(), Path(), Path())))
@pytest.mark.parametrize("where", ["before", "after"])
def test_quiet_prints_nothing_on_stderr_for_a_successful_command(
    capsys, record_csv, results_folder, tmp_path, name, where
):
    argv = quiet_commands(record_csv, tmp_path, results_folder)[name]
    code, out, err = run(capsys, *(["--quiet", *argv] if where == "before" else [*argv, "--quiet"]))
    assert code == 0
    assert err == "" and out == ""  # without --json nothing goes to stdout either
    assert any(tmp_path.iterdir()) or name == "sweep"  # it did its work: files are written


def test_quiet_keeps_the_json_on_stdout(capsys, record_csv):
    code, out, err = run(capsys, "identify", str(record_csv), "--estimator", "arx-rls", "--json", "--quiet")
    assert code == 0 and err == ""
    assert out["scores"]["one_step"]["fit_percent"] > 90  # the simulated rig's model fits (as test_cli)


def test_quiet_keeps_warnings(capsys, record_csv):
    """--quiet prints only errors and warnings: the default model's poor free run is still said."""
    code, out, err = run(capsys, "identify", str(record_csv), "--quiet")
    assert code == 0 and out == ""
    assert err.startswith("motorid: warning: hammerstein-rls: its free run fits") and err.count("\n") == 1


def test_quiet_still_prints_an_error(capsys, tmp_path):
    code, out, err = run(capsys, "--quiet", "identify", str(tmp_path / "missing.csv"))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "missing.csv" in err and err.startswith("motorid identify: error:")


def test_rig_serve_with_quiet_serves_and_stops_without_a_word(tmp_path):
    """The long-running command: no banner with --quiet, the Modbus server still answers."""
    import signal
    import socket

    from io_fixtures import wait_for

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([str(MOTORID), "rig", "serve", "--port", str(port), "--quiet"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment())  # fmt: skip
    try:

        def listening() -> bool:
            assert server.poll() is None, server.stderr.read()
            with socket.socket() as probe:
                return probe.connect_ex(("127.0.0.1", port)) == 0

        wait_for(listening, timeout=60, what="motorid rig serve --quiet to listen")
        done = piped(["run", "--daq", f"modbus://127.0.0.1:{port}", "--estimator", "arx-rls", "--duration", "1",
                      "--out", str(tmp_path / "run.csv"), "-q"])  # fmt: skip
        assert done.returncode == 0 and done.stderr == "", done.stderr
    finally:
        server.send_signal(signal.SIGINT)
        try:  # the server's own stop is bounded (10 s for its loop, 10 s for its thread); 120 s for a busy machine
            out, err = server.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            server.kill()
            out, err = server.communicate()
            pytest.fail(
                f"motorid rig serve --quiet did not stop within 120 s of SIGINT; its stderr: {err[-2000:]}"
            )
    assert server.returncode == 0 and err == "" and out == ""
    assert len(pd.read_csv(tmp_path / "run.csv", comment="#")) == 25  # 1 s at the rig's 40 ms


def test_fleet_identify_with_quiet_prints_nothing_but_the_records_that_failed(tmp_path, capsys):
    """A fleet run on its own local cluster of one worker: nothing on stderr when every record
    is done; a line saying how many failed when some did (their rows say why)."""
    assert main(["fleet", "generate", "--drives", "1", "--days", "2", "--duration", "5", "--out",
                 str(tmp_path / "fleet"), "-q"]) == 0  # fmt: skip
    fleet = [
        "fleet",
        "identify",
        str(tmp_path / "fleet"),
        "--workers",
        "1",
        "--estimator",
        "arx-rls",
        "--quiet",
    ]
    code, out, err = run(capsys, *fleet, "--max-lag", "5", "--out", str(tmp_path / "done"))
    assert code == 0 and err == "" and out == ""
    rows = pd.read_csv(tmp_path / "done" / "results.csv")
    assert len(rows) == 2 and (rows["status"] == "ok").all()
    # 5 s at 40 ms is 125 samples: --skip 110 leaves fewer than 20 to score, both records fail
    code, out, err = run(capsys, *fleet, "--skip", "110", "--out", str(tmp_path / "failed"))
    assert code == 0 and out == ""
    assert err.count("\n") == 1
    assert err.startswith("motorid fleet identify: 2 records failed: their errors are in the 'error' column")
