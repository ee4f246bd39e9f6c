"""read_record on the files DAQs write: each format written by its own library and read back.

Parquet by pyarrow, MATLAB by scipy.io.savemat (and a v7.3 file, which is HDF5 with
MATLAB's 128-byte header, by h5py), TDMS by npTDMS's writer, HDF5 by h5py. The
reference is the DataFrame written; the checks are those a CSV gets, with the
same messages.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import scipy.io
from emps_fixtures import requires_emps
from nptdms import ChannelObject, RootObject, TdmsWriter

from motorid.cli import main
from motorid.errors import DataError
from motorid.io.records import (
    ATTRS_KEY,
    MAT_ATTRS_VARIABLE,
    read_record,
    record_format,
    write_record,
)


def write_parquet(path: Path, columns: dict[str, np.ndarray], attrs: dict | None = None) -> None:
    table = pa.table(columns)
    if attrs is not None:
        table = table.replace_schema_metadata({ATTRS_KEY: json.dumps(attrs)})
    pq.write_table(table, path)


def write_mat(path: Path, columns: dict[str, np.ndarray], attrs: dict | None = None) -> None:
    # savemat stores a 1-D array as a 1 x n row vector, as MATLAB does; EMPS holds n x 1 columns
    variables: dict = {name: values.reshape(-1, 1) for name, values in columns.items()}
    if attrs is not None:
        variables[MAT_ATTRS_VARIABLE] = json.dumps(attrs)
    scipy.io.savemat(path, variables)


def write_tdms(path: Path, columns: dict[str, np.ndarray], attrs: dict | None = None) -> None:
    objects: list = [RootObject(properties={ATTRS_KEY: json.dumps(attrs)} if attrs else {})]
    objects += [ChannelObject("daq", name, values) for name, values in columns.items()]
    with TdmsWriter(path) as writer:
        writer.write_segment(objects)


def write_hdf5(path: Path, columns: dict[str, np.ndarray], attrs: dict | None = None) -> None:
    with h5py.File(path, "w") as fh:
        for name, values in columns.items():
            fh.create_dataset(name, data=values)
        if attrs is not None:
            fh.attrs[ATTRS_KEY] = json.dumps(attrs)


WRITERS: dict[str, tuple[str, Callable[..., None]]] = {
    "parquet": (".parquet", write_parquet),
    "mat": (".mat", write_mat),
    "tdms": (".tdms", write_tdms),
    "hdf5": (".h5", write_hdf5),
}
FORMATS = list(WRITERS)


def columns_of(n: int = 50, dt: float = 0.04) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(3)
    return {
        "t": np.arange(n) * dt,
        "u": rng.normal(size=n) * 5.0,
        "y": rng.normal(size=n) * 100.0,
        "i_a": rng.normal(size=n),
    }


def write(fmt: str, folder: Path, columns: dict[str, np.ndarray], attrs: dict | None = None) -> Path:
    suffix, writer = WRITERS[fmt]
    path = folder / f"rec{suffix}"
    writer(path, columns, attrs)
    return path


@pytest.mark.parametrize("fmt", FORMATS)
def test_each_format_reads_back_the_values_and_attrs_written(tmp_path, fmt):
    columns = columns_of()
    attrs = {"dt": 0.04, "drive": "axis-7", "units": {"t": "s", "u": "V", "y": "rad/s"}}
    path = write(fmt, tmp_path, columns, attrs)
    rec = read_record(path)
    expected = pd.DataFrame(columns)
    pd.testing.assert_frame_equal(rec[list(columns)], expected, check_exact=True)
    assert rec.attrs["drive"] == "axis-7" and rec.attrs["units"]["y"] == "rad/s"
    assert rec.attrs["dt"] == 0.04


@pytest.mark.parametrize("fmt", FORMATS)
def test_each_format_reads_as_the_same_record_as_its_csv(tmp_path, fmt):
    """One check for every format: the record equals the one read from the CSV of the same data."""
    columns = columns_of()
    csv = tmp_path / "rec.csv"
    write_record(pd.DataFrame(columns), csv)
    path = write(fmt, tmp_path, columns)
    mapping = {"t": "t", "u": "y", "y": "u"}  # swapped on purpose: the mapping is applied, not assumed
    from_csv = read_record(csv, columns=mapping, other_columns=False)
    from_file = read_record(path, columns=mapping, other_columns=False)
    pd.testing.assert_frame_equal(from_file, from_csv, check_exact=True)
    assert from_file.attrs == from_csv.attrs
    np.testing.assert_array_equal(from_file["u"], columns["y"])


def test_the_format_comes_from_the_extension():
    assert [record_format(f"a{s}") for s in (".csv", ".parquet", ".PQ", ".mat", ".tdms", ".h5", ".hdf5", ".txt")] == [
        "CSV", "Parquet", "Parquet", "MATLAB", "TDMS", "HDF5", "HDF5", "CSV",
    ]  # fmt: skip


def test_tdms_columns_are_group_and_channel_and_wf_increment_gives_dt(tmp_path):
    path = tmp_path / "rec.tdms"
    n = 30
    with TdmsWriter(path) as writer:
        writer.write_segment(
            [
                RootObject(),
                ChannelObject("command", "voltage", np.linspace(-1, 1, n), properties={"wf_increment": 0.01}),
                ChannelObject("speed", "tacho", np.linspace(0, 3, n), properties={"wf_increment": 0.01}),
                ChannelObject("speed", "voltage", np.zeros(n), properties={"wf_increment": 0.01}),
            ]
        )
    rec = read_record(path, columns=["command/voltage", "tacho"])  # no time column: dt from the file
    assert list(rec.columns) == ["t", "command/voltage", "tacho", "speed/voltage"] and rec.attrs["dt"] == 0.01
    np.testing.assert_array_equal(rec["t"], np.arange(n) * 0.01)  # the time the increment gives
    np.testing.assert_array_equal(rec["tacho"], np.linspace(0, 3, n))
    with pytest.raises(DataError, match=r"column 'voltage' is ambiguous in .*rec.tdms.*command/voltage"):
        read_record(path, columns=["voltage", "tacho"])


def test_a_matlab_file_like_emps_reads_its_vectors_and_leaves_out_scalars(tmp_path):
    path = tmp_path / "emps_like.mat"
    n = 40
    scipy.io.savemat(
        path,
        {"t": np.arange(n).reshape(-1, 1) * 1e-3, "vir": np.ones((n, 1)), "qm": np.arange(n) * 1e-4,
         "gtau": 35.15, "M": np.eye(3)},
    )  # fmt: skip
    rec = read_record(path, columns={"t": "t", "u": "vir", "y": "qm"})
    assert list(rec.columns) == ["t", "u", "y"]
    assert rec.attrs["dt"] == pytest.approx(1e-3)
    with pytest.raises(DataError, match=r"column 'M' of .* is not one column of samples \(shape \(3, 3\)\)"):
        read_record(path, columns={"t": "t", "u": "M", "y": "qm"})


def test_a_matlab_v73_file_reads_through_hdf5(tmp_path):
    """MATLAB v7.3 writes HDF5 behind a 512-byte user block opening with its 128-byte header."""
    path = tmp_path / "v73.mat"
    columns = columns_of(20)
    with h5py.File(path, "w", userblock_size=512) as fh:
        for name, values in columns.items():
            fh.create_dataset(name, data=values.reshape(1, -1))  # MATLAB stores a column transposed
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64".ljust(116) + bytes(8) + b"\x00\x02IM"
    with open(path, "r+b") as fh:
        fh.write(header)
    rec = read_record(path)
    pd.testing.assert_frame_equal(rec[list(columns)], pd.DataFrame(columns), check_exact=True)


@requires_emps
def test_the_emps_mat_file_reads_as_load_emps_reads_it():
    from emps_fixtures import emps_folder

    from motorid.datasets import load_emps

    folder = emps_folder()
    reference = load_emps(folder)
    rec = read_record(folder / "DATA_EMPS.mat", columns={"t": "t", "u": "vir", "y": "qm"}, dt_rtol=1e-2)
    np.testing.assert_array_equal(rec["u"], reference["u"])
    np.testing.assert_array_equal(rec["y"], reference["y"])


# --------------------------------------------------------------------------- bad files
@pytest.mark.parametrize("fmt", FORMATS)
def test_a_missing_column_is_named_with_the_columns_there(tmp_path, fmt):
    columns = columns_of()
    path = write(fmt, tmp_path, {k: v for k, v in columns.items() if k != "y"})
    with pytest.raises(
        DataError, match=r"column 'speed' is missing from .*rec\.\w+ \(needed as 'y'\); columns are \["
    ):
        read_record(path, columns={"y": "speed"})


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(("value", "kind"), [(np.nan, "a NaN"), (np.inf, "an infinite")])
def test_a_nan_or_inf_is_named_with_column_and_row(tmp_path, fmt, value, kind):
    columns = columns_of()
    columns["y"][17] = value
    path = write(fmt, tmp_path, columns)
    with pytest.raises(DataError, match=rf"column '(daq/)?y' has {kind} value .* at row 17 of .*rec"):
        read_record(path)


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_gap_in_time_names_the_row(tmp_path, fmt):
    columns = columns_of()
    columns["t"][30:] += 0.04  # one sample missing before row 30
    path = write(fmt, tmp_path, columns)
    with pytest.raises(DataError, match=r"column 't' has a gap of 1 sample before row 30 of .*rec"):
        read_record(path)


# a Parquet table cannot hold columns of different lengths: the other formats can
@pytest.mark.parametrize("fmt", [f for f in FORMATS if f != "parquet"])
def test_columns_of_different_lengths_are_refused(tmp_path, fmt):
    columns = columns_of()
    columns["y"] = columns["y"][:-3]
    path = write(fmt, tmp_path, columns)
    with pytest.raises(DataError, match=r"column '(daq/)?y' of .* has 47 samples, column '(daq/)?t' has 50"):
        read_record(path)


@pytest.mark.parametrize("fmt", FORMATS)
def test_too_many_samples_are_refused_before_reading(tmp_path, fmt):
    path = write(fmt, tmp_path, columns_of())
    with pytest.raises(DataError, match=r"50 rows, more than the limit of 20 samples.*keep one row in 3\)"):
        read_record(path, max_samples=20)


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_file_that_is_not_of_its_format_is_named(tmp_path, fmt):
    suffix, _ = WRITERS[fmt]
    path = tmp_path / f"bad{suffix}"
    path.write_bytes(b"t,u,y\n0,1,2\n" * 20)
    name = {"parquet": "Parquet", "mat": "MATLAB", "tdms": "TDMS", "hdf5": "HDF5"}[fmt]
    with pytest.raises(DataError, match=rf"bad{suffix} is not a readable {name} file"):
        read_record(path)


@pytest.mark.parametrize("fmt", FORMATS)
def test_missing_empty_and_folder_are_named(tmp_path, fmt):
    suffix, _ = WRITERS[fmt]
    with pytest.raises(DataError, match=r"no such file"):
        read_record(tmp_path / f"nothing{suffix}")
    (tmp_path / f"empty{suffix}").write_bytes(b"")
    with pytest.raises(DataError, match=r"is empty"):
        read_record(tmp_path / f"empty{suffix}")
    (tmp_path / f"dir{suffix}").mkdir()
    with pytest.raises(DataError, match=r"is a folder"):
        read_record(tmp_path / f"dir{suffix}")


def test_a_text_column_is_refused_by_name(tmp_path):
    path = tmp_path / "rec.parquet"
    columns = columns_of(10)
    pq.write_table(pa.table({**columns, "u": pa.array([f"v{i}" for i in range(10)])}), path)
    with pytest.raises(DataError, match=r"column 'u' of .*rec.parquet is not numeric"):
        read_record(path)


def test_bad_attribute_json_is_named(tmp_path):
    path = tmp_path / "rec.h5"
    write_hdf5(path, columns_of(10))
    with h5py.File(path, "a") as fh:
        fh.attrs[ATTRS_KEY] = "{not json"
    with pytest.raises(
        DataError,
        match=rf"rec.h5: the record attributes in the root attribute '{ATTRS_KEY}': invalid JSON",
    ):
        read_record(path)


# --------------------------------------------------------------------------- every command
def test_identify_reads_a_parquet_record_as_its_csv(tmp_path, capsys):
    from motorid.drive import paper_rig
    from motorid.signals import two_sine_signal

    _, u = two_sine_signal(duration=20.0, seed=4)
    record = paper_rig().simulate(u, seed=4)[["t", "u", "y"]]
    write_record(record, tmp_path / "rec.csv")
    write_parquet(tmp_path / "rec.parquet", {c: record[c].to_numpy() for c in record.columns})
    outputs = []
    for name in ("rec.csv", "rec.parquet"):
        assert main(["identify", str(tmp_path / name), "--estimator", "arx-rls", "--json"]) == 0
        outputs.append(json.loads(capsys.readouterr().out))
    assert outputs[0]["params"] == outputs[1]["params"]
    assert main(["identify", str(tmp_path / "rec.parquet"), "--output", "speed"]) == 2
    assert "column 'speed' is missing from" in capsys.readouterr().err


def test_a_bad_csv_cell_leaves_no_file_open(tmp_path):
    import gc
    import warnings

    path = tmp_path / "bad.csv"
    path.write_text("t,u,y\n0,1,2\n0.04,1,nan\n", encoding="utf-8")
    gc.collect()  # what other tests left behind goes now, not below
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(DataError, match=r"column 'y' has a NaN value 'nan' at row 1"):
            read_record(path)
        gc.collect()
    assert not [w for w in caught if issubclass(w.category, ResourceWarning) and str(path) in str(w.message)]
