"""``motorid fleet doctor --per-drive`` and :func:`motorid.fleet.run` on a real dask.distributed LocalCluster.

The fleet: 3 drives x 3 days of 15 s records from :mod:`motorid.fleet.synthetic` (drive 1 wears,
drive 2 grows a dead zone on day 1), plus ``loner.csv``: a record of drive 0 with its drive id
and time taken out of its attrs, which is therefore a drive of its own (its file's stem).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from io_fixtures import wait_for

from motorid.cli import main
from motorid.fleet import DoctorJob, IdentifyJob, RecordOptions, flatten, fleet_client, load_results, run
from motorid.fleet.jobs import DRIVE_KEY_PREFIX
from motorid.fleet.synthetic import make_fleet, write_fleet
from motorid.io.records import read_record, write_record
from motorid.outputs import jsonable

BASE = ("coulomb_friction", "viscous_friction", "offset")
DOCTOR = ["--base", ",".join(BASE), "--max-steps", "1"]
DRIVES, DAYS = 3, 3
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
    drives = make_fleet(
        DRIVES, seed=1, wearing=(1,), friction_growth=0.05, dead_zone_drive=2, dead_zone_day=1
    )
    paths = write_fleet(folder, drives, DAYS, duration=15.0, seed=1)
    loner = read_record(paths[0])
    loner.attrs.pop("drive"), loner.attrs.pop("time")
    write_record(loner, folder / "loner.csv")
    return folder


@pytest.fixture(scope="module")
def per_drive_run(fleet_folder, address, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("per-drive") / "results"
    argv = ["fleet", "doctor", str(fleet_folder), "--per-drive", "--out", str(out), "--scheduler", address,
            "--no-figures", *DOCTOR]  # fmt: skip
    assert main(argv) == 0
    return out


def groups(folder: Path) -> dict[str, list[str]]:
    """Each drive's records as absolute paths in time order (the file names say the day)."""
    out: dict[str, list[str]] = {}
    for path in sorted(folder.glob("drive-*.csv")):
        out.setdefault(path.stem.rsplit("_", 1)[0], []).append(os.path.abspath(path))
    out["loner"] = [os.path.abspath(folder / "loner.csv")]
    return out


def joint_command(capsys, paths: list[str]) -> dict:
    """``motorid doctor A B C --json`` on the same records, flattened as a fleet row is."""
    assert main(["doctor", *paths, *DOCTOR, "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    payload.pop("figures")
    return payload


def row_values(row: pd.Series, keys) -> dict:
    return {k: None if not isinstance(row[k], list) and pd.isna(row[k]) else row[k] for k in keys}


def test_one_row_per_drive_equals_the_joint_doctor_command_on_its_records(
    per_drive_run, fleet_folder, capsys
):
    rows = load_results(per_drive_run).set_index("record")
    expected_groups = groups(fleet_folder)
    assert sorted(k for k in rows.index if k.startswith(DRIVE_KEY_PREFIX)) == sorted(
        DRIVE_KEY_PREFIX + d for d in expected_groups
    )
    for drive, paths in expected_groups.items():
        row = rows.loc[DRIVE_KEY_PREFIX + drive]
        assert row["status"] == "ok", row["error"]
        assert row["records"] == ",".join(paths)
        assert set(rows.loc[[DRIVE_KEY_PREFIX + drive, *paths], "command"]) == {"doctor per drive"}
        payload = joint_command(capsys, paths)
        expected = flatten(jsonable(payload))
        # the same function on the same data in another process of this machine: equal to the last bit
        assert row_values(row, expected) == expected, drive
        # each record's own row: its gaps from the joint run
        per_record = payload.get("records") or [{"samples": None, **{k: payload[k] for k in ("final_gap",)}}]
        for path, gaps in zip(paths, per_record, strict=True):
            record_row = rows.loc[path]
            assert record_row["drive"] == drive and record_row["status"] == "ok"
            assert record_row["final_gap.overall"] == gaps["final_gap"]["overall"]
            assert record_row["named"] == row["named"]
        if len(paths) > 1:
            assert [rows.loc[p, "samples"] for p in paths] == [g["samples"] for g in per_record]


def test_a_record_without_a_drive_id_is_a_drive_of_its_own(per_drive_run, fleet_folder):
    rows = load_results(per_drive_run).set_index("record")
    assert rows.loc[DRIVE_KEY_PREFIX + "loner", "records"] == os.path.abspath(fleet_folder / "loner.csv")
    assert rows.loc[os.path.abspath(fleet_folder / "loner.csv"), "drive"] == "loner"


def test_a_rerun_does_nothing_and_a_new_record_reruns_its_drive_only(
    per_drive_run, fleet_folder, client, tmp_path
):
    folder = tmp_path / "fleet"
    folder.mkdir()
    for path in fleet_folder.glob("*.csv"):
        (folder / path.name).write_bytes(path.read_bytes())
    out = tmp_path / "results"
    job = DoctorJob(base=BASE, max_steps=1)
    first = run(folder, out, job, per_drive=True, client=client, figures=False)
    assert (first.drives, first.done, first.skipped, first.failed) == (DRIVES + 1, DRIVES + 1, 0, 0)
    # every record's drive is in the results and every drive done: no record read, no cluster reached
    # (a scheduler address nothing listens on)
    again = run(folder, out, job, per_drive=True, scheduler="tcp://127.0.0.1:9", figures=False)
    assert (again.done, again.skipped, again.drives) == (0, DRIVES + 1, DRIVES + 1)
    # the Python call gives the command line's rows
    columns = [c for c in load_results(per_drive_run).columns if c not in ("run_time_s", "worker", "record")]
    got = load_results(out).drop(columns=["run_time_s", "worker"])
    want = load_results(per_drive_run).drop(columns=["run_time_s", "worker"])
    # the records' paths (in record, records, settings.records) differ by their folder only
    got, want = (
        frame.replace(str(where), "F", regex=True).sort_values("record", ignore_index=True)
        for frame, where in ((got, folder), (want, fleet_folder))
    )
    assert set(got.columns) == set(want.columns)
    pd.testing.assert_frame_equal(got[["record", *columns]], want[["record", *columns]], check_dtype=False)
    # a fourth day of drive 0: only drive 0 runs again
    drive0 = sorted(folder.glob("drive-00_*.csv"))
    extra = read_record(drive0[-1])
    write_record(extra, folder / "drive-00_99991231.csv")
    third = run(folder, out, job, per_drive=True, client=client, figures=False)
    assert (third.done, third.skipped) == (1, DRIVES)
    rows = load_results(out).set_index("record")
    assert rows.loc[DRIVE_KEY_PREFIX + "drive-00", "records"].count(",") == DAYS


def test_an_interrupted_per_drive_run_keeps_the_finished_drives_and_a_rerun_does_the_rest(
    fleet_folder, address, tmp_path, capsys
):
    out = tmp_path / "interrupted"
    argv = [str(MOTORID), "fleet", "doctor", str(fleet_folder), "--per-drive", "--out", str(out),
            "--no-figures", *DOCTOR]  # fmt: skip
    # its own cluster of one worker: the drives follow one another, so the interrupt lands while some
    # are still to do (the running scheduler's warm workers can finish them all first)
    proc = subprocess.Popen([*argv, "--workers", "1"], stderr=subprocess.PIPE, text=True)
    parts = out / "results.parquet"
    wait_for(lambda: parts.is_dir() and any(parts.glob("part-*.parquet")), timeout=120, what="a first drive")
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    kept = load_results(out)
    finished = kept[kept["record"].str.startswith(DRIVE_KEY_PREFIX) & (kept["status"] == "ok")]
    assert 1 <= len(finished) < DRIVES + 1
    # a drive's rows are stored together: every finished drive has all its record rows
    for _, drive_row in finished.iterrows():
        assert set(drive_row["records"].split(",")) <= set(kept["record"])
    assert main([*argv[1:], "--scheduler", address, "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (summary["skipped"], summary["done"], summary["failed"]) == (
        len(finished),
        DRIVES + 1 - len(finished),
        0,
    )
    rows = load_results(out)
    assert rows["record"].str.startswith(DRIVE_KEY_PREFIX).sum() == DRIVES + 1
    assert len(rows) == 2 * (DRIVES + 1) + DRIVES * (DAYS - 1)


def test_the_python_call_and_fleet_identify_with_a_span_equal_the_single_command(
    fleet_folder, client, address, tmp_path, capsys
):
    chosen = sorted(fleet_folder.glob("drive-01_*.csv"))[:2]
    options = ["--estimator", "hammerstein-rls", "--na", "2", "--nb", "2", "--degree", "3"]
    span = ["--start", "2", "--stop", "12"]
    from_python = tmp_path / "python"
    job = IdentifyJob(estimator="hammerstein-rls", na=2, nb=2, degree=3)
    done = run(
        chosen, from_python, job, read=RecordOptions(start=2.0, stop=12.0), client=client, figures=False
    )
    assert (done.done, done.failed) == (2, 0)
    from_command = tmp_path / "command"
    argv = ["fleet", "identify", *map(str, chosen), "--out", str(from_command), "--scheduler", address,
            "--no-figures", *options, *span]  # fmt: skip
    assert main(argv) == 0
    capsys.readouterr()
    for out in (from_python, from_command):
        rows = load_results(out).set_index("record")
        for path in chosen:
            assert main(["identify", str(path), *options, *span, "--json"]) == 0
            expected = flatten(jsonable(json.loads(capsys.readouterr().out)))
            expected.pop("figure"), expected.pop("model")
            assert expected["samples"] == 251  # t = 2.00 ... 12.00 s at 0.04 s
            assert row_values(rows.loc[os.path.abspath(path)], expected) == expected


def test_trend_on_per_drive_results_and_mixed_folders_are_refused_in_one_line(
    per_drive_run, fleet_folder, address, capsys
):
    assert main(["fleet", "trend", str(per_drive_run)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "run per drive" in err and "without --per-drive" in err
    parts = sorted(p.name for p in (per_drive_run / "results.parquet").iterdir())
    argv = [
        "fleet",
        "doctor",
        str(fleet_folder),
        "--out",
        str(per_drive_run),
        "--scheduler",
        address,
        *DOCTOR,
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "holds the results of a run per drive" in err
    assert sorted(p.name for p in (per_drive_run / "results.parquet").iterdir()) == parts
    with pytest.raises(Exception, match="per_drive: the doctor runs per drive"):
        run(fleet_folder, per_drive_run, IdentifyJob(), per_drive=True)


def test_drives_from_a_file_name_pattern(fleet_folder, client, tmp_path):
    """With --pattern the drive is the file name's: the records are grouped without reading them
    first, and the drives' rows equal the attrs' grouping of the same records."""
    chosen = sorted(fleet_folder.glob("drive-0[01]_*.csv"))
    out = tmp_path / "pattern"
    job = DoctorJob(base=BASE, max_steps=1)
    done = run(
        chosen, out, job, per_drive=True, pattern="{drive}_{date:%Y%m%d}.csv", client=client, figures=False
    )
    assert (done.drives, done.done, done.failed) == (2, 2, 0)
    rows = load_results(out).set_index("record")
    for drive in ("drive-00", "drive-01"):
        paths = [os.path.abspath(p) for p in chosen if p.name.startswith(drive)]
        assert rows.loc[DRIVE_KEY_PREFIX + drive, "records"] == ",".join(paths)
        assert list(rows.loc[paths, "time"]) == sorted(rows.loc[paths, "time"])


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: IdentifyJob(estimator="nope"), "unknown estimator 'nope'"),
        (lambda: DoctorJob(base=("friction",)), "base: unknown effect 'friction'"),
        (lambda: DoctorJob(base="coulomb_friction"), "base must be a sequence of effect names"),
        (lambda: DoctorJob(model=Path("m.json"), base=BASE), "base cannot be combined with model"),
        (lambda: RecordOptions(start=3.0, stop=1.0), r"stop=1 must be after start=3"),
        (lambda: RecordOptions(start=-1.0), r"start=\.\.\. must be a time >= 0"),
    ],
)
def test_the_typed_options_refuse_a_bad_value_by_name(make, message):
    from motorid.errors import DataError

    with pytest.raises(DataError, match=message):
        make()


def test_a_drive_that_changed_between_its_records_shows_as_a_gap_left_far_above_the_noise(per_drive_run):
    """Drive 2 grows a dead zone on day 1: one model for its three records fits none of them well. Its
    records' final gaps stand at 20-30 noise floors against 2-3 on the unchanged drives (10 lies far from
    both), and the stop reason says something is still missing."""
    rows = load_results(per_drive_run).set_index("record")
    records = rows[~rows.index.str.startswith(DRIVE_KEY_PREFIX)]
    floors = records.groupby("drive")["final_gap_noise_floors"]
    assert floors.min()["drive-02"] > 10.0 > floors.max()[["drive-00", "drive-01"]].max()
    assert "something is still missing" in rows.loc[DRIVE_KEY_PREFIX + "drive-02", "stop_reason"]
