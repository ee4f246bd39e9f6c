"""Every ``motorid`` line of the documentation's shell blocks runs, in order, as printed, in an empty folder.

The user guide's pages (docs/guide, in docs/index.md's order) run in one folder, one page after the
other, as a reader who follows the guide runs them; README.md's "Model your motor" runs in a folder of
its own that holds the two wheel-motor records it reads (from ``$MOTORID_DATA/realmotors``; skipped
without them), its Python block in its place between the lines, and each line's comment quotes
(in backticks) what the line prints.
The lines run as a user runs them: the installed ``motorid`` console script in a
subprocess. ``motorid rig serve`` is started in the background and stopped after
the lines that follow it; its port (5020 in the pages) is swapped for a free one
in every line, since a test machine may have 5020 taken. The loggers' files the lines on
loggers' records read are first written by the guide's own Python block that writes them.
Nothing else is changed.
The notebooks hold no shell lines (checked here too, so a new one is not missed).
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from doc_pages import README, blocks, guide_text
from emps_fixtures import real_motor_file
from io_fixtures import wait_for

ROOT = Path(__file__).resolve().parent.parent
MOTORID = Path(sys.executable).with_name("motorid")
PAGE_PORT = "5020"


def shell_lines(text: str) -> list[str]:
    """The ``motorid ...`` lines of the ```sh blocks, their trailing comments removed."""
    lines = []
    for block in re.findall(r"```(?:sh|bash|console)\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            command = line.split(" # ")[0].strip()
            if command.startswith("motorid "):
                lines.append(command)
    return lines


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def listening(server: subprocess.Popen, port: int) -> bool:
    """True once ``server`` accepts connections on ``port``; fail the test if it exited."""
    if server.poll() is not None:
        pytest.fail(f"{server.args} exited with {server.returncode}: {server.stderr.read()}")
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_the_guide_shows_each_subcommand():
    lines = shell_lines(guide_text())
    used = {shlex.split(line)[1] for line in lines}
    assert {"demo", "simulate", "identify", "sweep", "doctor", "compare", "rig", "run", "control"} <= used


def test_notebooks_hold_no_shell_lines():
    for path in (ROOT / "notebooks").glob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"^\s*[!%]\s*motorid", text, flags=re.M), f"{path.name} runs a shell line"


def write_logger_files(folder: Path) -> dict[str, object]:
    """Run the guide's Python block that writes the loggers' files (``logger.csv`` ...) in ``folder``."""
    block = next(b for b in blocks(guide_text(), "python") if '"logger.csv"' in b)
    namespace: dict[str, object] = {}
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        exec(compile(block, "records.md", "exec"), namespace)
    finally:
        os.chdir(cwd)
    return namespace


def test_the_guide_logger_block_reads_its_files_and_finds_the_friction(tmp_path):
    namespace = write_logger_files(tmp_path)
    assert namespace["record"].attrs["dt"] == 0.01  # type: ignore[attr-defined]
    assert namespace["d"].named == ["coulomb_friction"]  # type: ignore[attr-defined]


def write_read_files(folder: Path, lines: list[str]) -> None:
    """Run, in ``folder``, each other guide Python block that writes a record a shell line reads
    (``write_record(record, "drifting.csv")``): the lines need its file."""
    for block in blocks(guide_text(), "python"):
        written = re.findall(r'write_record\([^,]+, "([^"]+)"\)', block)
        if '"logger.csv"' in block or not any(name in line for name in written for line in lines):
            continue
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            exec(compile(block, "guide", "exec"), {})
        finally:
            os.chdir(cwd)


def test_every_guide_command_runs_as_printed(tmp_path):
    lines = shell_lines(guide_text())
    write_logger_files(tmp_path)  # the files a logger wrote, which the lines on loggers' records read
    write_read_files(tmp_path, lines)
    port = str(free_port())
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    servers: list[subprocess.Popen] = []
    try:
        for line in lines:
            argv = [str(MOTORID), *shlex.split(line.replace(PAGE_PORT, port))[1:]]
            if argv[1:3] == ["rig", "serve"]:
                servers.append(
                    subprocess.Popen(argv, cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)
                )
                wait_for(lambda: listening(servers[-1], int(port)), timeout=60, what=f"{line!r} to listen")
                continue
            done = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
            assert done.returncode == 0, f"{line!r} exited with {done.returncode}:\n{done.stderr[-3000:]}"
            if "--quiet" in argv:  # as the guide says: nothing on stderr for a command that succeeds
                assert done.stderr == "", f"{line!r} printed on stderr: {done.stderr[-3000:]}"
    finally:
        for server in servers:
            server.send_signal(signal.SIGINT)
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
    for server in servers:
        assert server.returncode == 0, server.stderr.read()
    assert (tmp_path / "rec.csv").exists() and (tmp_path / "run.csv").exists()
    control_csv = pd.read_csv(tmp_path / "control.csv", comment="#")
    assert len(control_csv) == 300  # motorid control over Modbus: 12 s at 40 ms


def test_the_guide_two_mass_doctor_block_names_stribeck_and_improves_the_rig(tmp_path):
    """The doctor page's block on the doctor from a two-mass rig, its lines run as printed: the doctor
    names Stribeck friction, writes a two-mass rig that simulate runs, and compare shows the
    low-speed RMSE the page quotes."""
    import json

    block = next(b for b in blocks(guide_text(), "sh") if "--model sheet.json" in b)
    lines = shell_lines(f"```sh\n{block}```")
    assert [shlex.split(line)[1] for line in lines] == [
        "simulate", "simulate", "doctor", "simulate", "simulate", "compare",
    ]  # fmt: skip
    err = {}
    for line in lines:
        done = subprocess.run([str(MOTORID), *shlex.split(line)[1:]], cwd=tmp_path, capture_output=True,
                              text=True, timeout=600)  # fmt: skip
        assert done.returncode == 0, f"{line!r} exited with {done.returncode}:\n{done.stderr[-3000:]}"
        err[shlex.split(line)[1]] = done.stderr
    assert "+ stribeck_friction" in err["doctor"] and "searched on the rigid equivalent" in err["doctor"]
    assert json.loads((tmp_path / "better.json").read_text())["kind"] == "two-mass-rig"
    assert len(pd.read_csv(tmp_path / "better_rec.csv", comment="#")) == 500
    low = {m: float(re.search(rf"^{m}\s+two-mass rig\s+\S+\s+\S+\s+(\S+)", err["compare"], flags=re.M).group(1))
           for m in ("sheet.json", "better.json")}  # fmt: skip
    quoted = re.search(r"low-speed RMSE (\S+) \(sheet.json\) -> (\S+) rad/s", block)
    assert (f"{low['sheet.json']:.2f}", f"{low['better.json']:.2f}") == quoted.groups()


WHEEL_RECORDS = ("wheel_free_train_motor1.csv", "wheel_free_validation_motor1.csv")


@pytest.mark.skipif(
    not all(real_motor_file(name).is_file() for name in WHEEL_RECORDS),
    reason=f"real motor data not found at {real_motor_file(WHEEL_RECORDS[0]).parent} (set MOTORID_DATA)",
)
def test_readme_model_your_motor_runs_as_printed_and_prints_what_it_says(tmp_path, capsys):
    """README.md's blocks, shell and Python, in their order, in a folder holding the wheel motor's two
    records: each line exits 0 and prints every fragment its comment quotes in backticks, the Python
    block prints what its ``# shown`` comment shows."""
    text = README.read_text(encoding="utf-8")
    for name in WHEEL_RECORDS:
        (tmp_path / name).write_bytes(real_motor_file(name).read_bytes())
    port = str(free_port())
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    servers: list[subprocess.Popen] = []
    steps = re.findall(r"```(sh|python)\n(.*?)```", text, flags=re.S)
    ran = []
    try:
        for language, block in steps:
            if language == "python":
                cwd = os.getcwd()
                os.chdir(tmp_path)
                try:
                    exec(compile(block, "README.md", "exec"), {"__name__": "__main__"})
                finally:
                    os.chdir(cwd)
                shown = [
                    line.split("#", 1)[1].strip() for line in block.splitlines() if line.startswith("print(")
                ]
                assert capsys.readouterr().out.splitlines()[-len(shown) :] == shown
                continue
            for raw in block.splitlines():
                line, _, comment = raw.partition(" # ")
                if not line.startswith("motorid "):
                    continue
                ran.append(shlex.split(line)[1])
                argv = [str(MOTORID), *shlex.split(line.strip().replace(PAGE_PORT, port))[1:]]
                if argv[1:3] == ["rig", "serve"]:
                    servers.append(
                        subprocess.Popen(argv, cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)
                    )
                    wait_for(
                        lambda: listening(servers[-1], int(port)), timeout=60, what=f"{line!r} to listen"
                    )
                    continue
                done = subprocess.run(
                    argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
                )
                assert done.returncode == 0, f"{line!r} exited with {done.returncode}:\n{done.stderr[-3000:]}"
                for fragment in re.findall(r"`([^`]+)`", comment):
                    assert fragment in done.stdout + done.stderr, f"{line!r} did not print {fragment!r}"
    finally:
        for server in servers:
            server.send_signal(signal.SIGINT)
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
    assert ran == ["doctor", "compare", "control", "control", "rig", "control", "control"]
    assert len(pd.read_csv(tmp_path / "loop.csv", comment="#")) == 1200  # the loop over Modbus: 12 s at 10 ms
    header = (tmp_path / "wheel_ctrl" / "motorid_speed.h").read_text(encoding="utf-8")
    assert "MOTORID_SPEED_DT" in header  # the exported controller's sample time, for the sketch
