"""Everything bounded: files that never end, durations no machine holds, a run of a month in flat memory."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from cli_fixtures import run
from io_fixtures import free_port

from motorid.errors import DataError
from motorid.inputs import read_small_file
from motorid.io import RegisterMap


def motorid(*argv: str, cwd: Path, timeout: float = 120) -> tuple[int, str]:
    """Exit status and stderr of a real ``motorid ARGV`` process (it must end within ``timeout``)."""
    proc = subprocess.run(
        [sys.executable, "-m", "motorid.cli", *argv], cwd=cwd, capture_output=True, text=True, timeout=timeout
    )
    return proc.returncode, proc.stderr


@pytest.fixture
def fifo(tmp_path):
    path = tmp_path / "pipe"
    os.mkfifo(path)
    return path


def test_read_small_file_refuses_a_fifo_a_device_a_folder_and_a_large_file(tmp_path, fifo):
    with pytest.raises(DataError, match=r"^map .*pipe: is a FIFO, not a regular file$"):
        read_small_file(fifo, "map", 100)
    with pytest.raises(DataError, match=r"^map /dev/zero: is a device or socket, not a regular file$"):
        read_small_file("/dev/zero", "map", 100)
    with pytest.raises(DataError, match="is a folder"):
        read_small_file(tmp_path, "map", 100)
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * 101)
    with pytest.raises(DataError, match=r"is 101 bytes, more than the 100 accepted"):
        read_small_file(big, "map", 100)
    assert read_small_file(big, "map", 101) == b"#" * 101


@pytest.mark.parametrize("which", ["fifo", "/dev/zero", "large"])
def test_run_with_a_map_that_never_ends_is_refused_in_one_line(tmp_path, fifo, which):
    path = {"fifo": str(fifo), "/dev/zero": "/dev/zero", "large": str(tmp_path / "large.toml")}[which]
    if which == "large":
        Path(path).write_text(RegisterMap.default().to_toml() + "#" * (2 << 20))
    argv = ("run", "--daq", f"modbus://127.0.0.1:{free_port()}", "--map", path, "--estimator", "arx-rls",
            "--duration", "1", "--out", "run.csv")  # fmt: skip
    code, err = motorid(*argv, cwd=tmp_path, timeout=60)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"motorid run: error: register map {path}: "), err
    assert not (tmp_path / "run.csv").exists()


@pytest.mark.parametrize("which", ["fifo", "/dev/zero"])
def test_control_with_a_reference_that_never_ends_is_refused_in_one_line(tmp_path, fifo, which):
    from motorid.diagnose import diagnose
    from motorid.drive import paper_rig
    from motorid.signals import two_sine_signal

    rig = paper_rig()
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=0)
    design = tmp_path / "drive.json"
    diagnose(rig.simulate(u, seed=1)).model.save(design)
    path = str(fifo) if which == "fifo" else "/dev/zero"
    code, err = motorid("control", "--design", str(design), "--reference", path, cwd=tmp_path, timeout=60)
    assert code == 2
    lines = err.strip().splitlines()
    assert lines[-1].startswith(f"motorid control: error: --reference {path}: is a "), err
    assert "not a regular file" in lines[-1]


def test_an_impossible_duration_is_refused_in_one_line(tmp_path, capsys):
    code, _, err = run(
        capsys, "run", "--estimator", "arx-rls", "--duration", "1e12", "--out", str(tmp_path / "r.csv")
    )
    assert code == 2
    assert err.strip().splitlines() == [
        "motorid run: error: --duration 1e+12 s is longer than a year (3.16224e+07 s), the longest a command "
        "plans; run it in parts"
    ]
    code, _, err = run(capsys, "simulate", "--duration", "3e7", "--out", str(tmp_path / "s.csv"))
    assert code == 2
    (line,) = err.strip().splitlines()
    assert line.startswith("motorid simulate: error: --duration 3e+07 s is 750,000,000 samples at dt = 0.04 s: "
                           "the record would need about 225 GB in memory, more than this machine's ")  # fmt: skip
    assert not any(tmp_path.iterdir())


def resident_megabytes(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmRSS")


def rss_while_running(duration: str, cwd: Path) -> float:
    """Resident memory [MB] of ``motorid run --duration DURATION`` once it has written 2000 rows."""
    out = cwd / f"run-{duration}.csv"
    argv = [sys.executable, "-m", "motorid.cli", "run", "--estimator", "arx-rls", "--duration", duration,
            "--out", str(out), "--quiet"]  # fmt: skip
    proc = subprocess.Popen(argv, cwd=cwd, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 240
        while not (out.exists() and out.read_bytes().count(b"\n") > 2000):
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline, "the run wrote 2000 rows within 240 s"
            time.sleep(0.1)
        return resident_megabytes(proc.pid)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs /proc to read a process's memory")
def test_a_run_planned_for_30_days_holds_what_a_run_of_a_minute_holds(tmp_path):
    # ten minutes planned (15,000 rows at 40 ms): a simulated run writes its first 2000 rows in
    # seconds, and one of 100 s (2,500 rows) could end before its memory was read
    minute = rss_while_running("600", tmp_path)
    month = rss_while_running(str(30 * 86400), tmp_path)
    # before, the month's excitation alone took 2.9 GB; 50 MB covers the allocator's noise
    assert month < minute + 50, (minute, month)
