"""Record CSV round trip and the checks on reading."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from motorid.plants import TwoMassRig, paper_rig
from motorid.plants.signals import two_sine_signal
from motorid.records import ATTRS_MARKER, read_record, write_record


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


@settings(max_examples=20, deadline=None)
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
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", "0.04,1,0", "0.12,1,0"])
    with pytest.raises(ValueError, match=r"column 't' is not increasing at row 2"):
        read_record(path)
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", "0.02,1,0"])
    with pytest.raises(ValueError, match=r"not increasing at row 2"):
        read_record(path)


def test_time_not_uniform_names_row(tmp_path):
    path = write_lines(tmp_path, ["t,u,y", "0,1,0", "0.04,1,0", "0.08,1,0", "0.13,1,0", "0.17,1,0"])
    with pytest.raises(ValueError, match=r"column 't' is not uniformly sampled at row 3"):
        read_record(path)


def test_too_few_samples(tmp_path, record):
    path = tmp_path / "short.csv"
    write_record(record.iloc[:5], path)
    with pytest.raises(ValueError, match=r"5 samples, fewer than min_samples = 10"):
        read_record(path, min_samples=10)
    assert len(read_record(path, min_samples=5)) == 5


def test_dt_mismatch_with_file(tmp_path, record):
    path = tmp_path / "rec.csv"
    write_record(record, path)
    with pytest.raises(ValueError, match="dt"):
        read_record(path, dt=0.01)
    assert read_record(path, dt=0.04).attrs["dt"] == 0.04
