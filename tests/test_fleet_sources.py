"""Which records a fleet run takes, their drive and time, and the synthetic fleet (no cluster here)."""

from __future__ import annotations

from datetime import datetime

import numpy as np
import pytest

from motorid.errors import DataError
from motorid.fleet import FilenamePattern, find_records, identity
from motorid.fleet.synthetic import FLEET_START, make_fleet, write_fleet
from motorid.io.records import read_record


def test_a_pattern_gives_drive_and_time_from_the_file_name():
    pattern = FilenamePattern("{drive}_{date:%Y%m%d}.csv")
    assert pattern.parse("data/axis-7_20260105.csv") == {"drive": "axis-7", "time": datetime(2026, 1, 5)}
    nested = FilenamePattern("{drive}/{site}_{time:%Y-%m-%dT%H%M}.parquet")
    assert nested.parse("/x/robot3/plantA_2026-02-01T0830.parquet") == {
        "drive": "robot3", "time": datetime(2026, 2, 1, 8, 30),
    }  # fmt: skip


@pytest.mark.parametrize(
    ("pattern", "path", "words"),
    [
        ("{drive}_{date:%Y%m%d}.csv", "axis_2026.csv", "{date} of 'axis_2026.csv'"),
        ("{drive}_{date:%Y%m%d}.csv", "axis-20260105.csv", "does not match the record 'axis-20260105.csv'"),
        ("{drive}_{date}.csv", "a_1.csv", "{date} needs a format"),
        ("record_{n}.csv", "record_1.csv", "has neither {drive} nor"),
        ("{drive}_{drive}.csv", "a_b.csv", "the field {drive} appears twice"),
    ],
)
def test_a_pattern_that_does_not_fit_is_named(pattern, path, words):
    with pytest.raises(
        DataError, match=f"pattern='{pattern}'.*" + words.replace("{", r"\{").replace("(", r"\(")
    ):
        FilenamePattern(pattern).parse(path)


def test_identity_takes_the_pattern_then_the_attrs_then_the_file_stem():
    attrs = {"drive": "from-attrs", "time": "2026-01-05T08:00:00"}
    assert identity("a/b.csv", attrs, {"drive": "from-name"}) == ("from-name", "2026-01-05T08:00:00")
    assert identity("a/b.csv", attrs, {}) == ("from-attrs", "2026-01-05T08:00:00")
    assert identity("a/b.csv", {}, {}) == ("b", None)
    with pytest.raises(DataError, match=r"a/b.csv: attrs\['time'\] = 'yesterday' is not an ISO 8601 time"):
        identity("a/b.csv", {"time": "yesterday"}, {})


def test_records_from_folders_globs_and_list_files(tmp_path):
    for name in ("a.csv", "b.parquet", "c.txt", "d.mat"):
        (tmp_path / name).write_text("x")
    (tmp_path / "sub").mkdir()
    listing = tmp_path / "list.txt"
    listing.write_text("a.csv\n# skipped\n\nd.mat  # a comment\n")
    assert [p.name for p in find_records([str(tmp_path)])] == ["a.csv", "b.parquet", "d.mat"]
    assert [p.name for p in find_records([str(tmp_path / "*.csv"), str(tmp_path / "a.csv")])] == ["a.csv"]
    assert [p.name for p in find_records([f"@{listing}"])] == ["a.csv", "d.mat"]
    with pytest.raises(DataError, match=r"'.*\*.h5' matches no file"):
        find_records([str(tmp_path / "*.h5")])
    with pytest.raises(DataError, match=r"folder .*sub holds no record file"):
        find_records([str(tmp_path / "sub")])
    with pytest.raises(DataError, match=r"list file .*nothing.txt: no such file"):
        find_records([f"@{tmp_path / 'nothing.txt'}"])


# --------------------------------------------------------------------------- the synthetic fleet
def test_a_wearing_drive_grows_its_friction_and_the_dead_zone_appears_on_its_day():
    drives = make_fleet(5, seed=3, wearing=(1,), friction_growth=0.05, dead_zone_drive=2, dead_zone_day=4)
    assert [d.healthy for d in drives] == [True, False, False, True, True]
    wearing = drives[1]
    day0, day10 = wearing.rig_on(0), wearing.rig_on(10)
    coulomb0 = [f.params["coulomb"] for f in day0.friction]
    coulomb10 = [f.params["coulomb"] for f in day10.friction]
    np.testing.assert_allclose(coulomb10, np.array(coulomb0) * 1.5, rtol=1e-15)  # 1 + 0.05 * 10, exactly
    assert day10.B_m == pytest.approx(day0.B_m * 1.5, rel=1e-15) and day10.amplifier.dead_zone == 0.0
    dz = drives[2]
    assert [dz.rig_on(day).amplifier.dead_zone for day in (0, 3, 4, 9)] == [0.0, 0.0, 0.8, 0.8]
    assert drives[0].rig_on(7) == drives[0].rig  # a healthy drive does not change
    # the spread: every drive differs from the others, within ±5 % of the design
    k_m = np.array([d.rig.K_m for d in drives])
    assert len(set(k_m)) == 5 and np.all(np.abs(k_m / 0.04284 - 1) <= 0.05)


def test_make_fleet_refuses_bad_arguments_by_name():
    with pytest.raises(ValueError, match="n_drives"):
        make_fleet(0)
    with pytest.raises(ValueError, match="spread"):
        make_fleet(3, spread=0.9)
    with pytest.raises(ValueError, match="both wearing and growing"):
        make_fleet(4, wearing=(3,), dead_zone_drive=3)


def test_written_records_carry_drive_and_time_in_attrs_and_name(tmp_path):
    drives = make_fleet(2, seed=1, wearing=(), dead_zone_drive=None)
    paths = write_fleet(tmp_path, drives, 2, duration=4.0)
    assert [p.name for p in paths] == ["drive-00_20260105.csv", "drive-00_20260106.csv",
                                       "drive-01_20260105.csv", "drive-01_20260106.csv"]  # fmt: skip
    pattern = FilenamePattern("{drive}_{date:%Y%m%d}.csv")
    for path in paths:
        record = read_record(path)
        from_name = pattern.parse(path)
        assert record.attrs["drive"] == from_name["drive"]
        assert datetime.fromisoformat(record.attrs["time"]).date() == from_name["time"].date()
    first, second = (read_record(p)["y"].to_numpy() for p in paths[:2])
    assert not np.array_equal(first, second)  # each day a new record
    assert datetime.fromisoformat(read_record(paths[0]).attrs["time"]) == FLEET_START
    every_third = write_fleet(tmp_path / "sparse", drives[:1], [0, 3, 6], duration=4.0)
    assert [p.name for p in every_third] == [
        "drive-00_20260105.csv",
        "drive-00_20260108.csv",
        "drive-00_20260111.csv",
    ]
    with pytest.raises(ValueError, match="days"):
        write_fleet(tmp_path, drives, 0)


def test_the_results_table_does_not_depend_on_how_rows_were_batched(tmp_path):
    """Rows written one part each, or all in one part, read back as the same table (values and dtypes)."""
    import pandas as pd

    from motorid.fleet import ResultsStore

    rows = [
        {"record": "/r/a.csv", "status": "ok", "warnings": None, "final_gap.overall": 0.5},
        {"record": "/r/b.csv", "status": "ok", "warnings": "filter diverged at sample 3",
         "final_gap.overall": 0.7, "model.params.dead_zone": 0.82},
        {"record": "/r/c.csv", "status": "failed", "error": "column 'y' has a NaN value", "warnings": None},
    ]  # fmt: skip
    one_by_one, together = ResultsStore(tmp_path / "parts"), ResultsStore(tmp_path / "one")
    for row in rows:
        one_by_one.append([row])
    together.append(rows)
    table = ResultsStore(tmp_path / "parts").rows()  # read back from disk
    pd.testing.assert_frame_equal(table, together.rows())
    pd.testing.assert_frame_equal(one_by_one.rows(), together.rows())
    assert table.set_index("record").loc["/r/b.csv", "model.params.dead_zone"] == 0.82
    assert pd.isna(table.set_index("record").loc["/r/a.csv", "model.params.dead_zone"])
