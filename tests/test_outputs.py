"""One writer per output, a full disk, names from data: motorid.outputs and the commands that write."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from motorid.errors import OutputError
from motorid.outputs import MAX_NAME_BYTES, FolderLock, safe_file_name, write_file


def motorid_process(*argv: str, cwd: Path) -> subprocess.Popen:
    """A real ``python -m motorid.cli ARGV`` process in ``cwd`` (stdout and stderr piped)."""
    return subprocess.Popen(
        [sys.executable, "-m", "motorid.cli", *argv],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def finish(proc: subprocess.Popen, timeout: float = 300) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out, err


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# -- write_file: one step from check to create ------------------------------------------------
def test_write_file_refuses_a_name_another_writer_took_meanwhile(tmp_path):
    target = tmp_path / "x.csv"

    def write(fh):
        fh.write("ours\n")
        target.write_text("theirs\n")  # another process creates the file while ours is written

    with pytest.raises(OutputError, match=r"x\.csv: the file exists .*nothing was written"):
        write_file(target, write)
    assert target.read_text() == "theirs\n"
    assert leftovers(tmp_path) == ["x.csv"]  # no temporary file left behind


def test_write_file_replaces_whole_with_overwrite_and_keeps_the_old_file_on_error(tmp_path):
    target = tmp_path / "x.json"
    target.write_text("old\n")
    write_file(target, lambda fh: fh.write("new\n"), overwrite=True)
    assert target.read_text() == "new\n"

    def fail(fh):
        fh.write("half")
        raise ValueError("not serialisable")

    with pytest.raises(ValueError, match="not serialisable"):
        write_file(target, fail, overwrite=True)
    assert target.read_text() == "new\n"
    assert leftovers(tmp_path) == ["x.json"]


def test_without_hard_links_the_name_is_still_claimed_in_one_step(tmp_path, monkeypatch):
    """A file system without hard links (some network and FUSE ones): the name is taken with O_EXCL."""
    import errno

    def no_link(src, dst):
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_link)
    target = tmp_path / "x.csv"
    write_file(target, lambda fh: fh.write("first\n"))
    assert target.read_text() == "first\n"
    with pytest.raises(OutputError, match="the file exists"):
        write_file(target, lambda fh: fh.write("second\n"))
    assert target.read_text() == "first\n"
    assert leftovers(tmp_path) == ["x.csv"]


def test_write_file_gives_a_normal_file_mode(tmp_path):
    """The temporary file is created as open() creates a file (0666 less the umask), not 0600."""
    mask = os.umask(0o022)
    os.umask(mask)
    path = write_file(tmp_path / "m.txt", lambda fh: fh.write("x"))
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask


def test_two_simulate_runs_into_one_out_exactly_one_wins(tmp_path):
    argv = ("simulate", "--out", "race.csv", "--duration", "5")
    procs = [motorid_process(*argv, cwd=tmp_path) for _ in range(2)]
    results = sorted(finish(p) for p in procs)
    (ok, _, ok_err), (refused, _, refused_err) = results
    assert (ok, refused) == (0, 2), results
    assert "wrote race.csv" in ok_err
    assert len(refused_err.strip().splitlines()) == 1 and "race.csv" in refused_err
    assert "the file exists" in refused_err
    assert leftovers(tmp_path) == ["race.csv"]
    from motorid.io.records import read_record

    assert len(read_record(tmp_path / "race.csv")) == 125  # 5 s at 40 ms: one whole record


def test_two_simulate_runs_with_overwrite_leave_one_whole_record(tmp_path):
    from motorid.io.records import read_record

    (tmp_path / "race.csv").write_text("an old record\n")
    argv = ("simulate", "--out", "race.csv", "--overwrite", "--duration", "5", "--seed")
    procs = [motorid_process(*argv, str(seed), cwd=tmp_path) for seed in (1, 2)]
    assert [finish(p)[0] for p in procs] == [0, 0]
    assert leftovers(tmp_path) == ["race.csv"]
    record = read_record(tmp_path / "race.csv")
    assert len(record) == 125  # one of the two records, whole, not a mix or a part


# -- a full disk ----------------------------------------------------------------------------------
def test_simulate_on_a_full_disk_leaves_no_file(small_disk):
    code, _, err = finish(
        motorid_process("simulate", "--out", "big.csv", "--duration", "120", cwd=small_disk)
    )
    assert code == 2
    assert err.strip().splitlines() == [
        "motorid simulate: error: big.csv: the disk is full (No space left on device); nothing was written"
    ]
    assert leftovers(small_disk) == []


def test_simulate_refused_for_its_record_leaves_no_model_file(small_disk, tmp_path):
    """The record does not fit: the model file written a moment before (on another disk) goes too."""
    model = tmp_path / "rig.json"
    argv = ("simulate", "--out", "big.csv", "--save-model", str(model), "--duration", "120")
    code, _, err = finish(motorid_process(*argv, cwd=small_disk))
    assert code == 2 and "big.csv: the disk is full" in err
    assert not model.exists() and leftovers(small_disk) == []


def test_simulate_overwrite_on_a_full_disk_keeps_the_old_file(small_disk):
    old = small_disk / "big.csv"
    old.write_text("an old record\n")
    argv = ("simulate", "--out", "big.csv", "--duration", "120", "--overwrite")
    code, _, err = finish(motorid_process(*argv, cwd=small_disk))
    assert code == 2
    assert "big.csv: the disk is full" in err and "big.csv is as it was" in err
    assert old.read_text() == "an old record\n"
    assert leftovers(small_disk) == ["big.csv"]


def test_run_on_a_full_disk_ends_on_a_whole_row_and_says_how_many(small_disk):
    argv = ("run", "--estimator", "arx-rls", "--duration", "600", "--out", "run.csv")
    code, _, err = finish(motorid_process(*argv, cwd=small_disk))
    assert code == 2
    lines = err.strip().splitlines()
    assert lines[-1].startswith("motorid run: error: run.csv: the disk is full (No space left on device): ")
    rows = int(lines[-1].split("the file holds the first ")[1].split(" of ")[0])
    data = (small_disk / "run.csv").read_bytes()
    assert data.endswith(b"\n")
    import pandas as pd

    table = pd.read_csv(small_disk / "run.csv", comment="#")
    assert len(table) == rows > 0
    assert table["seq"].tolist() == list(range(1, rows + 1))  # every row whole, none lost before the cut
    assert not table.isna().any().any()
    assert leftovers(small_disk) == ["run.csv"]


def test_run_without_a_server_says_nothing_was_written(tmp_path, capsys):
    from cli_fixtures import run
    from io_fixtures import free_port

    out = tmp_path / "run_noserver.csv"
    argv = ("run", "--daq", f"modbus://127.0.0.1:{free_port()}", "--estimator", "arx-rls",
            "--duration", "1", "--out", str(out), "--timeout", "0.5")  # fmt: skip
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert "cannot connect" in err and f"nothing written to {out}" in err
    assert "recorded" not in err and "rows in" not in err
    assert not out.exists()


class StallingARX:
    """An ARX-RLS estimator whose 10th update stalls for 1 s, as a machine that hangs a moment."""

    def __init__(self, **kw):
        from motorid.estimators import create

        self.inner = create("arx-rls", na=2, nb=2)
        self.updates = 0
        self.params = self.inner.params

    def predict(self, u):
        return self.inner.predict(u)

    def update(self, y):
        import time

        self.updates += 1
        if self.updates == 10:
            time.sleep(1.0)  # 25 sample periods of 40 ms: the rig's watchdog (3 periods) trips
        self.inner.update(y)
        self.params = self.inner.params


def test_run_stopped_by_the_watchdog_tells_what_to_type(tmp_path, capsys):
    from cli_fixtures import run

    from motorid.drive import paper_rig
    from motorid.estimators import register, unregister
    from motorid.io import RigServer

    register("stalling-arx", StallingARX)
    out = tmp_path / "run.csv"
    try:
        # real time: the rig's clock goes on while the estimator stalls (a lock-step rig waits for it)
        with RigServer(paper_rig(), port=0, seed=1, watchdog_periods=3.0, lockstep=False) as server:
            argv = ("run", "--daq", server.url, "--estimator", "stalling-arx", "--duration", "2",
                    "--out", str(out), "--timeout", "2")  # fmt: skip
            code, _, err = run(capsys, *argv)
    finally:
        unregister("stalling-arx")
    assert code == 2
    last = err.strip().splitlines()[-1].split("\r")[-1]  # after the progress bar
    assert last.startswith("motorid run: error: run stopped: the rig at modbus://")
    assert "reports fault watchdog" in last and "start motorid run again" in last
    assert "reset_faults" not in err
    rows = int(last.split(" rows in ")[0].rsplit("(", 1)[1])
    import pandas as pd

    assert rows >= 9 and len(pd.read_csv(out, comment="#")) == rows  # the stall came after the 10th sample


# -- names from data -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "name", ["../../x", "/etc/passwd", "a\x00b", "d" * 10_000, ".", "..", "", " .hidden"]
)
def test_a_hostile_name_becomes_one_file_name_in_its_folder(tmp_path, name):
    safe = safe_file_name(name)
    assert safe not in ("", ".", "..") and not safe.startswith(".")
    assert "/" not in safe and "\x00" not in safe and len(safe.encode()) <= MAX_NAME_BYTES
    path = tmp_path / safe
    path.write_text("x")  # the file system takes it, in this folder
    assert path.resolve().parent == tmp_path.resolve()


def test_safe_names_keep_plain_ids_and_tell_changed_ids_apart():
    assert safe_file_name("drive-01") == "drive-01"
    assert safe_file_name("Motor 3_ü.v2") == "Motor 3_ü.v2"
    assert safe_file_name("../../x") == "_.._x-9cdf6a50"  # the README's example
    # unsafe characters all become "_", so the hash keeps these three apart
    assert len({safe_file_name("a/b"), safe_file_name("a\\b"), safe_file_name("a_b")}) == 3


@given(st.text(min_size=0, max_size=300), st.text(min_size=0, max_size=300))
def test_every_text_gives_a_safe_name_and_two_texts_two_names(text, other):
    safe = safe_file_name(text)
    assert safe and not safe.startswith((".", " ")) and not safe.endswith(" ")
    assert all(c.isalnum() or c in "-_.+=@ " for c in safe)
    assert len(safe.encode("utf-8")) <= MAX_NAME_BYTES
    assert safe_file_name(safe) == safe  # a safe name is kept as it is
    if other != text:
        assert safe_file_name(other) != safe


# -- a folder's lock ---------------------------------------------------------------------------------
def hold_lock(folder: Path) -> subprocess.Popen:
    """Another process holding the folder's lock, returned once it holds it."""
    code = "import sys, time\nfrom motorid.outputs import FolderLock\nFolderLock(sys.argv[1]).acquire()\nprint('held', flush=True)\ntime.sleep(600)\n"
    proc = subprocess.Popen([sys.executable, "-c", code, str(folder)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_lock_names_its_holder_and_is_taken_over_when_the_holder_dies(tmp_path):
    holder = hold_lock(tmp_path)
    try:
        with pytest.raises(
            OutputError, match=rf"process {holder.pid} on \S+ holds its lock file .*\.motorid\.lock"
        ):
            FolderLock(tmp_path).acquire()
    finally:
        holder.kill()  # SIGKILL: the holder cannot clean up; the kernel releases its lock
        holder.wait(30)
    with FolderLock(tmp_path) as lock:
        assert lock.held and lock.holder() == f"process {os.getpid()} on {socket.gethostname()}"
    assert not lock.held
    with FolderLock(tmp_path):  # released: taken again at once
        pass


def test_wait_takes_the_lock_once_the_holder_lets_it_go(tmp_path):
    holder = hold_lock(tmp_path)
    released = threading.Timer(0.5, holder.kill)
    released.start()
    try:
        with FolderLock(tmp_path, wait=True) as lock:
            assert lock.held
            assert holder.wait(30) is not None  # it only came once the holder was gone
    finally:
        released.cancel()
        holder.kill()
        holder.wait(30)


def test_identify_into_a_locked_folder_is_refused_and_changes_nothing(tmp_path, capsys):
    from cli_fixtures import run

    record = tmp_path / "rec.csv"
    assert run(capsys, "simulate", "--out", str(record), "--duration", "10")[0] == 0
    out = tmp_path / "figures"
    out.mkdir()
    holder = hold_lock(out)
    argv = ("identify", str(record), "--estimator", "arx-rls", "--out", str(out))
    try:
        code, _, err = run(capsys, *argv)
    finally:
        holder.kill()
        holder.wait(30)
    assert code == 2
    assert err.strip().splitlines() == [
        f"motorid identify: error: --out {out}: another run writes this folder: process {holder.pid} on "
        f"{socket.gethostname()} holds its lock file {out / '.motorid.lock'}; pass --wait to wait for it, "
        "or choose another folder"
    ]
    assert leftovers(out) == [".motorid.lock"]
    assert run(capsys, *argv)[0] == 0  # the dead holder's lock is taken over
    assert run(capsys, *argv)[0] == 0  # and released when the command returned
    assert (out / "residual_tests.png").stat().st_size > 0


# -- the run's recorder --------------------------------------------------------------------------------
@pytest.mark.parametrize("flush_every", [1, 7])
def test_a_recorder_on_a_full_disk_keeps_whole_rows_and_counts_them(small_disk, flush_every):
    from motorid.io.online import RunRecorder

    recorder = RunRecorder(small_disk / "run.csv", flush_every=flush_every)
    with pytest.raises(
        OutputError, match=r"run\.csv: the disk is full .*: the file holds the first \d+ of"
    ) as info:
        for k in range(100_000):
            recorder.append({"t": k * 0.04, "seq": k + 1, "u": 1.0 / 3.0, "y": float(k) / 7.0})
    recorder.close()
    import pandas as pd

    table = pd.read_csv(small_disk / "run.csv")
    assert len(table) == recorder.on_disk == int(str(info.value).split("first ")[1].split(" of")[0])
    assert table["seq"].tolist() == list(range(1, len(table) + 1))
    assert (small_disk / "run.csv").read_bytes().endswith(b"\n")
    assert 1 <= recorder.count - recorder.on_disk <= flush_every  # only rows of the write the disk refused


def test_a_recorder_refuses_a_file_another_writer_created_after_its_check(tmp_path):
    from motorid.io.online import RunRecorder

    out = tmp_path / "run.csv"
    recorder = RunRecorder(out)  # checks: no file yet
    out.write_text("the other run's rows\n")  # another run creates it before our first sample
    with pytest.raises(OutputError, match=r"run\.csv: the file exists .*nothing was written"):
        recorder.append({"t": 0.0, "seq": 1, "u": 0.0, "y": 0.0})
    assert out.read_text() == "the other run's rows\n" and not recorder.created


def test_two_recorders_with_overwrite_never_write_one_file(tmp_path):
    from motorid.io.online import RunRecorder

    out = tmp_path / "run.csv"
    out.write_text("an old run\n")
    first, second = RunRecorder(out, overwrite=True), RunRecorder(out, overwrite=True)
    first.append({"t": 0.0, "seq": 1, "u": 0.0, "y": 0.0})
    with pytest.raises(OutputError, match=r"run\.csv: another run is writing this file"):
        second.append({"t": 0.0, "seq": 1, "u": 5.0, "y": 5.0})
    first.append({"t": 0.04, "seq": 2, "u": 0.0, "y": 0.0})
    first.close()
    assert out.read_text() == "t,seq,u,y\n0.0,1,0.0,0.0\n0.04,2,0.0,0.0\n"
    third = RunRecorder(out, overwrite=True)  # the first let go of it when it closed
    third.append({"t": 0.0, "seq": 1, "u": 1.0, "y": 2.0})
    third.close()
    assert out.read_text() == "t,seq,u,y\n0.0,1,1.0,2.0\n"
