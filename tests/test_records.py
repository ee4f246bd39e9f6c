"""Record CSV round trip and the checks on reading."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from conftest import examples
from hypothesis import given
from hypothesis import strategies as st

from motorid.drive import TwoMassRig, paper_rig
from motorid.errors import DataError
from motorid.io.records import ATTRS_MARKER, count_data_lines, read_record, write_record
from motorid.signals import two_sine_signal


@pytest.fixture(scope="module")
def record() -> pd.DataFrame:
    rig = paper_rig()
    _, u = two_sine_signal(duration=4.0, dt=rig.dt, seed=2)
    return rig.simulate(u, seed=5)


def test_round_trip_keeps_values_and_attrs(tmp_path, record):
    path = tmp_path / "rec.csv"
    write_record(record, path)
    assert path.read_text().startswith(ATTRS_MARKER)
    back = read_record(path, min_samples=10)
    pd.testing.assert_frame_equal(back, record, check_exact=True)
    assert back.attrs["dt"] == record.attrs["dt"]
    assert back.attrs["units"] == record.attrs["units"]
    assert TwoMassRig.from_dict(back.attrs["rig"]) == TwoMassRig.from_dict(record.attrs["rig"])
    # plain pandas reads the same data
    plain = pd.read_csv(path, comment="#")
    np.testing.assert_array_equal(plain["y"].to_numpy(), record["y"].to_numpy())


@examples(20)
@given(
    values=st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=2, max_size=30),
    dt=st.sampled_from([0.001, 0.01, 0.04, 0.1]),
)
def test_round_trip_is_exact_for_any_floats(tmp_path_factory, values, dt):
    n = len(values)
    df = pd.DataFrame({"t": np.arange(n) * dt, "u": values, "y": values[::-1]})
    df.attrs["dt"] = dt
    path = tmp_path_factory.mktemp("r") / "r.csv"
    write_record(df, path)
    back = read_record(path)
    pd.testing.assert_frame_equal(back, df, check_exact=True)


def test_foreign_csv_without_attrs_and_renamed_columns(tmp_path):
    path = tmp_path / "daq.csv"
    t = np.arange(20) * 0.04
    pd.DataFrame({"time": t, "volts": np.sin(t), "speed": np.cos(t)}).to_csv(path, index=False)
    rec = read_record(path, columns={"t": "time", "u": "volts", "y": "speed"})
    assert list(rec.columns) == ["t", "u", "y"]
    assert rec.attrs["dt"] == pytest.approx(0.04)
    with pytest.raises(ValueError, match=r"dt = 0.05"):
        write_record(rec, tmp_path / "again.csv")
        read_record(tmp_path / "again.csv", dt=0.05)


def write_lines(tmp_path, lines):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_missing_column_is_named(tmp_path):
    path = write_lines(tmp_path, ["t,u", "0,1", "0.04,2"])
    with pytest.raises(ValueError, match=r"column 'y' is missing"):
        read_record(path)
    with pytest.raises(ValueError, match=r"column 'speed' is missing.*'y'"):
        read_record(path, columns={"y": "speed"})


@pytest.mark.parametrize(
    "cell, kind",
    [
        ("abc", "a non-numeric"),
        ("nan", "a NaN"),
        ("", "a NaN"),
        ("1.2.3", "a non-numeric"),
        ("inf", "an infinite"),
    ],
)
def test_bad_value_names_column_and_row(tmp_path, cell, kind):
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", f"0.08,1,{cell}", "0.12,1,0"])
    with pytest.raises(ValueError, match=rf"column 'y' has {kind} value .* row 2 \(line 4"):
        read_record(path)


def test_time_not_increasing_names_row(tmp_path):
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", "0.04,2,0", "0.12,1,0"])  # a stamp repeated
    with pytest.raises(ValueError, match=r"column 't' repeats the time stamp 0.04 at row 2 .*duplicates="):
        read_record(path)
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", "0.02,1,0"])
    with pytest.raises(ValueError, match=r"not increasing at row 2"):
        read_record(path)


def test_time_not_uniform_names_row(tmp_path):
    # a step of 1.45 dt is neither jitter (up to 40 % of dt) nor a whole missing sample
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", "0.08,1,0", "0.138,1,0", "0.17,1,0"])
    with pytest.raises(ValueError, match=r"column 't' is not uniformly sampled at row 3"):
        read_record(path)


def test_too_few_samples(tmp_path, record):
    path = tmp_path / "short.csv"
    write_record(record.iloc[:5], path)
    with pytest.raises(ValueError, match=r"5 samples; at least 10 are needed"):
        read_record(path, min_samples=10)
    assert len(read_record(path, min_samples=5)) == 5


def test_dt_mismatch_with_file(tmp_path, record):
    path = tmp_path / "rec.csv"
    write_record(record, path)
    with pytest.raises(ValueError, match="dt"):
        read_record(path, dt=0.01)
    assert read_record(path, dt=0.04).attrs["dt"] == 0.04


GOOD = "t,u,y\n" + "".join(f"{k * 0.04!r},{np.sin(k):.6f},{np.cos(k):.6f}\n" for k in range(10))


@pytest.mark.parametrize(
    ("case", "content", "words"),
    [
        ("missing file", None, ["no such file"]),
        ("a folder", "folder", ["is a folder"]),
        ("empty", b"", ["is empty"]),
        ("binary", b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe", ["not a text CSV"]),
        ("header only", b"t,u,y\n", ["no data"]),
        ("attribute line only", (ATTRS_MARKER + '{"dt": 0.04}\n').encode(), ["no header line"]),
        ("repeated column", b"t,u,y,y\n0,1,2,3\n0.04,1,2,3\n", ["'y' appears twice"]),
        ("unnamed column", b"t,u,,y\n0,1,2,3\n0.04,1,2,3\n", ["column 3 of the header has no name"]),
        ("single row", b"t,u,y\n0,1,2\n", ["1 sample;", "at least 2"]),
        ("text in the time column", GOOD.replace("0.16", "skip").encode(), ["'t'", "'skip'", "row 4"]),
        (
            "three rows missing",
            "".join(GOOD.splitlines(True)[i] for i in (0, 1, 2, 6, 7, 8)).encode(),
            ["gap of 3 samples before row 2", "line 4"],
        ),
        (
            "infinite value",
            GOOD.replace("0.04,", "0.04,inf,", 1).replace(",inf,0.841471", ",inf").encode(),
            ["'u' has an infinite value 'inf' at row 1"],
        ),
    ],
)
def test_a_file_that_is_not_a_record_is_a_data_error_naming_it(tmp_path, case, content, words):
    path = tmp_path / "rec.csv"
    if content == "folder":
        path.mkdir()
    elif content is not None:
        path.write_bytes(content)
    before = path.read_bytes() if path.is_file() else None
    with pytest.raises(DataError) as err:
        read_record(path)
    assert all(w in str(err.value) for w in words), f"{case}: {err.value}"
    assert str(path) in str(err.value) or "column" in str(err.value)
    assert (path.read_bytes() if path.is_file() else None) == before


def test_max_samples_refuses_a_long_record_before_parsing_it(tmp_path):
    path = tmp_path / "long.csv"
    path.write_text(GOOD)
    assert len(read_record(path, max_samples=10)) == 10
    with pytest.raises(
        DataError, match=r"10 rows, more than the limit of 9 samples.*decimate.*keep one row in 2\)"
    ):
        read_record(path, max_samples=9)
    assert count_data_lines(path) == 11
    path.write_text(GOOD.rstrip("\n"))  # no line break after the last row
    assert count_data_lines(path) == 11


def test_only_the_named_columns_are_read_when_asked(tmp_path, record):
    path = tmp_path / "rec.csv"
    write_record(record, path)
    narrow = read_record(path, other_columns=False)
    assert list(narrow.columns) == ["t", "u", "y"]
    pd.testing.assert_frame_equal(narrow, record[["t", "u", "y"]], check_exact=True, check_like=False)
