"""``motorid fleet`` on a real dask.distributed LocalCluster (2 worker processes) and a generated fleet.

One cluster serves the whole module (started once, closed at the end); the commands
reach it with ``--scheduler``. The fleet: 5 drives x 5 days of 30 s records (25
records) from :mod:`motorid.fleet.synthetic` (drives 1 and 2 wear by 8 % a day, drive 3
grows a 0.8 V dead zone on day 2, drives 0 and 4 are healthy), plus one bad record.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pandas as pd
import pytest
from io_fixtures import wait_for

from motorid.cli import main
from motorid.cli.report import jsonable
from motorid.fleet import ResultsStore, flatten, fleet_client, load_results, run_fleet
from motorid.fleet.synthetic import FLEET_START, make_fleet, write_fleet
from motorid.fleet.trend import flag_drives, friction_trends

DOCTOR = ["--base", "coulomb_friction,viscous_friction,offset"]
IDENTIFY = ["--estimator", "hammerstein-rls", "--na", "2", "--nb", "2", "--degree", "3"]
DRIVES, DAYS, DEAD_ZONE_DAY = 5, 5, 2
MOTORID = Path(sys.executable).with_name("motorid")


@pytest.fixture(scope="module")
def client():
    with fleet_client(workers=2) as c:
        yield c


@pytest.fixture(scope="module")
def address(client) -> str:
    return client.scheduler.address


@pytest.fixture(scope="module")
def fleet_folder(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("fleet")
    drives = make_fleet(DRIVES, seed=0, wearing=(1, 2), friction_growth=0.08, dead_zone_drive=3,
                        dead_zone_day=DEAD_ZONE_DAY)  # fmt: skip
    write_fleet(folder, drives, DAYS, duration=30.0)
    (folder / "bad.csv").write_text("t,u,y\n0,1,2\n0.04,1,nan\n", encoding="utf-8")
    return folder


@pytest.fixture(scope="module")
def doctor_run(fleet_folder, address, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("doctor") / "results"
    code = main(["fleet", "doctor", str(fleet_folder), "--out", str(out), "--scheduler", address, "--no-figures",
                 *DOCTOR])  # fmt: skip
    assert code == 0
    return out


def records(folder: Path) -> list[Path]:
    return sorted(p for p in folder.glob("drive-*.csv"))


def single_command_row(capsys, argv: list[str]) -> dict:
    """The single-record command's --json output, flattened as a fleet row is."""
    assert main([*argv, "--json"]) == 0
    return flatten(jsonable(json.loads(capsys.readouterr().out)))


def test_doctor_rows_equal_the_single_doctor_command(doctor_run, fleet_folder, capsys):
    rows = load_results(doctor_run).set_index("record")
    assert len(rows) == DRIVES * DAYS + 1
    for path in records(fleet_folder):
        row = rows.loc[os.path.abspath(path)]
        assert row["status"] == "ok", row["error"]
        expected = single_command_row(capsys, ["doctor", str(path), *DOCTOR])
        expected.pop("figures", None)
        got = {
            k: (None if pd.isna(row[k]) else row[k]) if not isinstance(row[k], list) else row[k]
            for k in expected
        }
        # the same function on the same data in another process of this machine: equal to the last bit
        assert got == expected, path.name


def test_fleet_doctor_starts_from_a_two_mass_rig_as_the_single_command_does(
    fleet_folder, address, tmp_path, capsys
):
    """``motorid fleet doctor --model rig.json``: each row is the single doctor's from that rig, the
    search on its rigid equivalent and the improved rig in the row; a bad --model stops the run
    before any work, the folder not made."""
    from motorid.drive import paper_rig

    paper_rig().save(tmp_path / "sheet.json")
    two = records(fleet_folder)[:2]
    out = tmp_path / "results"
    argv = ["--model", str(tmp_path / "sheet.json"), "--max-steps", "1"]
    assert main(["fleet", "doctor", *map(str, two), "--out", str(out), "--scheduler", address, "--no-figures",
                 *argv]) == 0  # fmt: skip
    rows = load_results(out).set_index("record")
    for path in two:
        row = rows.loc[os.path.abspath(path)]
        assert row["status"] == "ok", row["error"]
        expected = single_command_row(capsys, ["doctor", str(path), *argv])
        expected.pop("figures", None)
        assert "searched on the rigid equivalent of the two-mass rig" in expected["notes"]
        assert (
            expected["two_mass_rig.searched_on"] == "rigid equivalent"
            and "two_mass_rig.improved.J_m" in expected
        )
        got = {k: (None if pd.isna(row[k]) else row[k]) for k in expected}
        assert got == expected, path.name
    (tmp_path / "est.json").write_text('{"format": "motorid-model"}', encoding="utf-8")
    code = main(["fleet", "doctor", *map(str, two), "--out", str(tmp_path / "never"), "--scheduler", address,
                 "--model", str(tmp_path / "est.json")])  # fmt: skip
    assert code == 2 and "est.json" in capsys.readouterr().err and not (tmp_path / "never").exists()


def test_identify_rows_equal_the_single_identify_command(fleet_folder, address, tmp_path, capsys):
    chosen = records(fleet_folder)[::6]
    listing = tmp_path / "some.txt"
    listing.write_text("\n".join(str(p) for p in chosen) + "\n# a comment line\n", encoding="utf-8")
    out = tmp_path / "identify"
    assert (
        main(["fleet", "identify", f"@{listing}", "--out", str(out), "--scheduler", address, *IDENTIFY]) == 0
    )
    capsys.readouterr()
    rows = load_results(out).set_index("record")
    assert sorted(rows.index) == sorted(os.path.abspath(p) for p in chosen)
    for path in chosen:
        row = rows.loc[os.path.abspath(path)]
        expected = single_command_row(capsys, ["identify", str(path), *IDENTIFY])
        expected.pop("figure"), expected.pop("model")  # single-record outputs, not fleet columns
        assert {k: row[k] for k in expected} == expected, path.name
        # the figure per record under <drive>/<record>/
        assert (out / row["drive"] / path.stem / "residual_tests.png").is_file()
    csv = pd.read_csv(out / "results.csv")
    assert sorted(csv["record"]) == sorted(rows.index)


def test_a_failing_record_is_a_row_with_its_error_and_the_others_go_on(doctor_run, fleet_folder):
    rows = load_results(doctor_run).set_index("record")
    bad = rows.loc[os.path.abspath(fleet_folder / "bad.csv")]
    assert bad["status"] == "failed"
    assert "column 'y' has a NaN value 'nan' at row 1" in bad["error"]
    assert bad["drive"] == "bad"
    assert (rows["status"] == "ok").sum() == DRIVES * DAYS


def test_drive_and_time_come_from_the_attrs(doctor_run):
    rows = load_results(doctor_run)
    ok = rows[rows["status"] == "ok"]
    assert sorted(ok["drive"].unique()) == [f"drive-{i:02d}" for i in range(DRIVES)]
    assert sorted(ok["time"].unique()) == [
        pd.Timestamp(FLEET_START) + pd.Timedelta(days=d) for d in range(DAYS)
    ]


def test_a_rerun_skips_what_is_done_and_retries_failed_ones_on_request(
    doctor_run, fleet_folder, address, capsys
):
    parts = sorted(p.name for p in (doctor_run / "results.parquet").iterdir())
    before = load_results(doctor_run)
    argv = ["fleet", "doctor", str(fleet_folder), "--out", str(doctor_run), "--scheduler", address, "--no-figures",
            *DOCTOR, "--json"]  # fmt: skip
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["skipped"], summary["done"], summary["failed"]) == (DRIVES * DAYS + 1, 0, 0)
    assert sorted(p.name for p in (doctor_run / "results.parquet").iterdir()) == parts
    assert main([*argv, "--retry-failed"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["skipped"], summary["done"], summary["failed"]) == (DRIVES * DAYS, 0, 1)
    # the same rows and values; a column of only empty values may come back as text or as objects
    pd.testing.assert_frame_equal(
        load_results(doctor_run).drop(columns=["run_time_s", "worker"]),
        before.drop(columns=["run_time_s", "worker"]),
        check_dtype=False,
    )


def test_a_worker_killed_mid_run_loses_no_result(client, fleet_folder, tmp_path):
    from motorid.fleet.jobs import DoctorJob, RecordOptions, RecordTask

    task = RecordTask(DoctorJob(base=tuple(DOCTOR[1].split(","))), RecordOptions(), figures=None)
    paths = records(fleet_folder)
    out = tmp_path / "killed"
    pids = client.run(os.getpid)
    runs = []
    runner = threading.Thread(target=lambda: runs.append(run_fleet(paths, task, out, client, progress=False)))
    runner.start()
    parts = out / "results.parquet"
    wait_for(lambda: parts.is_dir() and any(parts.glob("part-*.parquet")), timeout=120, what="a first result")
    victim = next(iter(pids.values()))
    os.kill(victim, signal.SIGKILL)
    runner.join(timeout=300)
    assert not runner.is_alive()
    rows = load_results(out)
    assert runs[0].done == len(paths) and runs[0].failed == 0
    assert sorted(rows["record"]) == sorted(os.path.abspath(p) for p in paths)
    assert (rows["status"] == "ok").all()
    workers_after = set(client.run(os.getpid).values())
    assert victim not in workers_after  # the killed process is gone; its tasks ran elsewhere


def test_an_interrupted_command_keeps_every_finished_row_and_a_rerun_completes(
    fleet_folder, address, tmp_path
):
    out = tmp_path / "interrupted"
    argv = [str(MOTORID), "fleet", "doctor", str(fleet_folder), "--out", str(out), *DOCTOR]
    # its own cluster of one worker: the records follow one another, so the interrupt lands while
    # most are still to do (on the running scheduler's warm workers, the whole run can finish
    # between the first part file and the signal)
    proc = subprocess.Popen([*argv, "--workers", "1"], stderr=subprocess.PIPE, text=True)
    parts = out / "results.parquet"
    wait_for(lambda: parts.is_dir() and any(parts.glob("part-*.parquet")), timeout=120, what="a first result")
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    kept = load_results(out)
    assert 1 <= len(kept) <= DRIVES * DAYS + 1
    csv = pd.read_csv(out / "results.csv")
    assert sorted(csv["record"]) == sorted(kept["record"])  # the CSV was rewritten on the way out
    assert main([*argv[1:], "--scheduler", address, "--no-figures"]) == 0
    assert len(load_results(out)) == DRIVES * DAYS + 1


# --------------------------------------------------------------------------- trends
def test_trend_finds_the_wearing_drives_and_the_dead_zone_day_and_no_healthy_drive(doctor_run):
    results = load_results(doctor_run)
    flags = flag_drives(friction_trends(results), results).set_index("drive")
    assert set(flags.index[flags["flagged"]]) == {"drive-01", "drive-02", "drive-03"}
    # truth: +8 % a day on the Coulomb levels, +32 % over the 4 days; the estimate carries a few %
    # of record-to-record scatter, so it is held to 20-45 %
    for drive in ("drive-01", "drive-02"):
        assert 0.20 < flags.loc[drive, "coulomb_rise"] < 0.45
    day = (FLEET_START + pd.Timedelta(days=DEAD_ZONE_DAY)).strftime("%Y-%m-%d")
    assert flags.loc["drive-03", "appeared"] == f"input_dead_zone from {day}"
    for healthy in ("drive-00", "drive-04"):
        assert not flags.loc[healthy, "flagged"] and abs(flags.loc[healthy, "coulomb_rise"]) < 0.1
    # every doctor result carries the standard errors of its levels into the trends
    coulomb = friction_trends(results).query("parameter == 'coulomb'")
    assert coulomb["std"].notna().all() and (coulomb["std"] > 0).all()
    assert (coulomb["std"] < 0.2 * coulomb["value"]).all()  # a level known to better than 20 %


def test_trend_command_prints_the_flagged_table_and_writes_figures(doctor_run, tmp_path, capsys):
    out = tmp_path / "trend"
    assert main(["fleet", "trend", str(doctor_run), "--out", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    payload = json.loads(captured.out)
    assert [row["drive"] for row in payload["flagged"]] == ["drive-01", "drive-02", "drive-03"]
    assert captured.err.index("flagged drives") < captured.err.index("wrote flags.csv")
    assert sorted(p.name for p in out.glob("*.png")) == [f"drive-{i:02d}.png" for i in range(DRIVES)]
    assert main(["fleet", "trend", str(doctor_run), "--threshold", "0.5", "--out", str(out), "--json"]) == 0
    assert [row["drive"] for row in json.loads(capsys.readouterr().out)["flagged"]] == ["drive-03"]


def test_trend_on_a_folder_without_results_is_a_clear_error(tmp_path, capsys):
    assert main(["fleet", "trend", str(tmp_path)]) == 2
    assert "holds no fleet results" in capsys.readouterr().err


# --------------------------------------------------------------------------- the store
def test_the_store_keeps_the_last_row_per_record_and_compacts_without_loss(tmp_path):
    store = ResultsStore(tmp_path)
    store.append(
        [{"record": "a", "status": "failed", "error": "x"}, {"record": "b", "status": "ok", "v": 1.5}]
    )
    store.append([{"record": "a", "status": "ok", "v": 2.0}])
    store.compact()
    rows = ResultsStore(tmp_path).rows().set_index("record")
    assert list(rows.index) == ["a", "b"] and rows.loc["a", "status"] == "ok" and rows.loc["a", "v"] == 2.0
    assert len(list((tmp_path / "results.parquet").glob("part-*.parquet"))) == 1
    assert len(pd.read_parquet(tmp_path / "results.parquet")) == 2  # pandas reads the folder as one table


def test_drive_and_time_from_the_file_name_pattern_on_parquet_records(
    fleet_folder, address, tmp_path, capsys
):
    """Records without attrs (Parquet written by pyarrow) get drive and time from --pattern."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from motorid.io.records import read_record

    folder = tmp_path / "daq"
    folder.mkdir()
    for i, path in enumerate(records(fleet_folder)[:2]):
        record = read_record(path)
        pq.write_table(
            pa.table({c: record[c].to_numpy() for c in ("t", "u", "y")}),
            folder / f"axis{i}_2026030{i + 1}.parquet",
        )
    out = tmp_path / "out"
    argv = ["fleet", "identify", str(folder / "*.parquet"), "--out", str(out), "--scheduler", address, "--no-figures",
            "--pattern", "{drive}_{date:%Y%m%d}.parquet", *IDENTIFY]  # fmt: skip
    assert main(argv) == 0
    rows = load_results(out)
    assert list(rows["drive"]) == ["axis0", "axis1"] and (rows["status"] == "ok").all()
    assert list(rows["time"]) == [pd.Timestamp("2026-03-01"), pd.Timestamp("2026-03-02")]
    capsys.readouterr()
    argv[argv.index("--pattern") + 1] = "{drive}-{date:%Y%m%d}.parquet"
    assert main(argv) == 2
    assert "--pattern '{drive}-{date:%Y%m%d}.parquet' does not match the record 'axis0_20260301.parquet'" in (
        capsys.readouterr().err
    )


def test_a_records_warnings_are_in_its_row(fleet_folder):
    """The friction EKF's model (the paper's rig, with its 0.6 V dead zone) does not fit these drives:
    it warns that it diverged, and the row says so instead of the worker's stderr."""
    from motorid.fleet.jobs import IdentifyJob, RecordOptions, RecordTask

    task = RecordTask(IdentifyJob(estimator="friction-ekf"), RecordOptions(), figures=None)
    row = task(str(records(fleet_folder)[0]), {})
    assert row["status"] == "ok" and "friction-ekf diverged at sample" in row["warnings"]


# --------------------------------------------------------------------------- one run per folder
def test_a_store_compacts_only_the_parts_it_merged(tmp_path):
    """Another writer's part that came after this store read the folder survives its compaction."""
    ours, theirs = ResultsStore(tmp_path), ResultsStore(tmp_path)
    ours.append([{"record": "a", "status": "ok"}])
    ours.append([{"record": "b", "status": "ok"}])
    ours.rows()  # the folder as this store knows it: parts of a and b
    theirs.append([{"record": "c", "status": "ok"}])  # a part name of its own, not one of ours replaced
    ours.compact()
    assert sorted(load_results(tmp_path)["record"]) == ["a", "b", "c"]
    assert len(list((tmp_path / "results.parquet").glob("part-*.parquet"))) == 2  # merged a+b, and c
    assert not list((tmp_path / "results.parquet").glob(".*"))  # no temporary file left


def lock_holder(folder: Path) -> subprocess.Popen:
    """A process that takes the folder's lock as a run does and sleeps, returned once it holds it."""
    code = (
        "import sys, time\nfrom motorid.outputs import FolderLock\n"
        "FolderLock(sys.argv[1]).acquire()\nprint('held', flush=True)\ntime.sleep(600)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", code, str(folder)], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_run_into_a_locked_folder_is_refused_and_a_dead_holder_is_taken_over(
    fleet_folder, address, tmp_path, capsys
):
    out = tmp_path / "locked"
    out.mkdir()
    holder = lock_holder(out)
    argv = ["fleet", "doctor", *map(str, records(fleet_folder)[:2]), "--out", str(out), "--scheduler", address,
            "--no-figures", *DOCTOR]  # fmt: skip
    try:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.strip().splitlines() == [
            f"motorid fleet doctor: error: --out {out}: another run writes this folder: process {holder.pid} "
            f"on {socket.gethostname()} holds its lock file {out / '.motorid.lock'}; pass --wait to wait for "
            "it, or choose another folder"
        ]
        assert not (out / "results.parquet").exists()  # the refused run wrote nothing
    finally:
        holder.kill()  # SIGKILL: no clean-up of its own; the kernel lets the lock go
        holder.wait(30)
    assert main(argv) == 0
    assert len(load_results(out)) == 2


def test_two_runs_into_one_folder_with_wait_keep_every_row(fleet_folder, address, tmp_path):
    out = tmp_path / "shared"
    paths = records(fleet_folder)
    halves = [paths[:3], paths[3:6]]
    argv = ["fleet", "doctor", "--out", str(out), "--wait", "--scheduler", address, "--no-figures", *DOCTOR]
    procs = [
        subprocess.Popen([str(MOTORID), *argv, *map(str, half)], stderr=subprocess.PIPE, text=True)
        for half in halves
    ]
    for proc in procs:
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
        assert "3 done, 0 failed" in err
    rows = load_results(out)
    assert sorted(rows["record"]) == sorted(os.path.abspath(p) for p in paths[:6])
    assert (rows["status"] == "ok").all()
    assert sorted(pd.read_csv(out / "results.csv")["record"]) == sorted(rows["record"])


def test_two_runs_into_one_folder_started_together_lose_no_row(fleet_folder, address, tmp_path):
    """Without --wait, a run that finds the folder locked refuses in one line naming the holder's pid."""
    out = tmp_path / "raced"
    paths = records(fleet_folder)
    halves = [paths[6:8], paths[8:10]]
    argv = ["fleet", "doctor", "--out", str(out), "--scheduler", address, "--no-figures", *DOCTOR]
    procs = [
        subprocess.Popen([str(MOTORID), *argv, *map(str, half)], stderr=subprocess.PIPE, text=True)
        for half in halves
    ]
    errs = [proc.communicate(timeout=600)[1] for proc in procs]
    done = []
    for proc, other, err, half in zip(procs, reversed(procs), errs, halves, strict=True):
        if proc.returncode == 0:
            done += half
            continue
        assert proc.returncode == 2, err
        refusal = err.strip().splitlines()[-1]
        assert refusal.startswith(f"motorid fleet doctor: error: --out {out}: another run writes this folder")
        assert f"process {other.pid} " in refusal and str(out / ".motorid.lock") in refusal
    assert done  # the first run got the lock
    assert sorted(load_results(out)["record"]) == sorted(os.path.abspath(p) for p in done)


def test_a_full_disk_stops_the_run_saying_what_is_kept(fleet_folder, address, small_disk, capsys):
    out = small_disk / "results"
    argv = ["fleet", "doctor", *map(str, records(fleet_folder)[:12]), "--out", str(out), "--scheduler", address,
            "--no-figures", *DOCTOR]  # fmt: skip
    assert main(argv) == 2  # a part holds at least 27 kB (its schema): 64 kB hold two
    line = capsys.readouterr().err.strip().splitlines()[-1].split("\r")[-1]
    assert line.startswith(f"motorid fleet doctor: error: {out}/")  # a part, or results.csv
    assert "the disk is full (No space left on device); " in line
    stored = int(line.split("; the ")[1].split(" rows")[0])
    assert stored >= 1 and f"are in {out / 'results.parquet'}/" in line
    assert len(load_results(out)) == stored  # every row it says is stored is whole and readable
    assert not [p.name for p in (out / "results.parquet").iterdir() if p.name.startswith(".")]


# --------------------------------------------------------------------------- names from data
def test_drive_ids_from_attrs_never_leave_the_out_folder(fleet_folder, address, tmp_path, capsys):
    from motorid.io.records import read_record, write_record

    outside = tmp_path / "outside"
    hostile = ["../../x", str(outside), "a\x00b", "d" * 10_000]
    data = tmp_path / "records"
    data.mkdir()
    for i, (drive, source) in enumerate(zip(hostile, records(fleet_folder), strict=False)):
        record = read_record(source)
        record.attrs["drive"] = drive
        write_record(record, data / f"r{i}.csv")
    (data / "...csv").write_bytes((data / "r0.csv").read_bytes())  # a record whose file stem is '..'
    out = tmp_path / "run" / "out"
    out.parent.mkdir()  # --out/../../x is tmp_path/x
    before = sorted(p for p in tmp_path.rglob("*") if not p.is_relative_to(out))
    argv = ["fleet", "doctor", str(data), "--out", str(out), "--scheduler", address, *DOCTOR]
    assert main(argv) == 0, capsys.readouterr().err
    rows = load_results(out)
    assert (rows["status"] == "ok").all() and len(rows) == 5
    assert sorted(rows["drive"]) == sorted([*hostile, "../../x"])  # the ids themselves are kept as data
    assert sorted(p for p in tmp_path.rglob("*") if not p.is_relative_to(out)) == before
    figures = [p for p in out.rglob("*.png")]
    assert len(figures) >= 5
    for figure in figures:
        assert figure.resolve().is_relative_to(out.resolve())
        assert len(figure.relative_to(out).parts) == 3  # <drive>/<record>/<figure>.png
    assert not outside.exists() and not (tmp_path / "x").exists()
    assert main(["fleet", "trend", str(out)]) == 0
    trend_figures = list((out / "trend").glob("*.png"))
    assert len(trend_figures) == len(set(rows["drive"])) == 4


def test_trend_and_generate_refuse_a_folder_another_run_holds(tmp_path, capsys):
    """fleet trend reads a results folder only when no run writes it; fleet generate writes its
    records only into a folder no other run holds (one line naming the holder, exit 2)."""
    out = tmp_path / "held"
    out.mkdir()
    holder = lock_holder(out)
    try:
        for argv, option in ((["fleet", "trend", str(out)], "results"),
                             (["fleet", "generate", "--out", str(out), "--drives", "1", "--days", "1"], "--out")):  # fmt: skip
            assert main(argv) == 2
            err = capsys.readouterr().err.strip().splitlines()
            assert (
                len(err) == 1
                and f"{option} {out}: another run writes this folder: process {holder.pid}" in err[0]
            )
        assert sorted(p.name for p in out.iterdir()) == [".motorid.lock"]  # nothing written
    finally:
        holder.kill()
        holder.wait(30)
