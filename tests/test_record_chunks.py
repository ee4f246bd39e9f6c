"""iter_record: a record read in blocks equals the record read whole, its errors name the row in
the whole record, and its memory is a few blocks whatever the record's length.

The reference is :func:`motorid.io.records.read_record` on the same file; the files are written by
each format's own library (the writers of test_records_formats.py). The blocks are 997 rows:
no divisor of any record length here, so every record ends on a short block, and a Parquet
file's row groups (300 rows) never line up with them.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pcsv
import pytest
from test_records_formats import write_hdf5, write_mat

from motorid.errors import DataError
from motorid.io.records import iter_record, read_record, write_record

BLOCK = 997
ROWS = 5_000
ATTRS = {"dt": 0.001, "units": {"t": "s", "u": "V", "y": "rad/s"}, "drive": "axis-3"}


def columns_of(n: int = ROWS) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(11)
    return {
        "t": np.arange(n) * 0.001,
        "u": rng.normal(size=n) * 5.0,
        "y": rng.normal(size=n) * 100.0,
        "i_a": rng.normal(size=n),
    }


def write_csv(path, columns, attrs=None) -> None:
    frame = pd.DataFrame(columns)
    frame.attrs = dict(attrs or {})
    write_record(frame, path)


def write_parquet_groups(path, columns, attrs=None) -> None:
    """Parquet with row groups of 300 rows, as a logger flushing every 300 samples writes it."""
    import json

    import pyarrow.parquet as pq

    from motorid.io.records import ATTRS_KEY

    table = pa.table(columns)
    if attrs is not None:
        table = table.replace_schema_metadata({ATTRS_KEY: json.dumps(attrs)})
    pq.write_table(table, path, row_group_size=300)


WRITERS = {
    "csv": (".csv", write_csv),
    "parquet": (".parquet", write_parquet_groups),
    "hdf5": (".h5", write_hdf5),
    "mat": (".mat", write_mat),  # read whole, handed out in blocks
}


def write(fmt, folder, columns, attrs=None):
    suffix, writer = WRITERS[fmt]
    path = folder / f"rec{suffix}"
    writer(path, columns, attrs)
    return path


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_blocks_joined_equal_the_record_read_whole(tmp_path, fmt):
    path = write(fmt, tmp_path, columns_of(), ATTRS)
    mapping = {"t": "t", "u": "y", "y": "u"}  # swapped on purpose: the mapping is applied per block
    whole = read_record(path, columns=mapping, other_columns=False)
    blocks = list(iter_record(path, columns=mapping, chunk_rows=BLOCK))
    assert [len(b) for b in blocks] == [BLOCK] * (ROWS // BLOCK) + [ROWS % BLOCK]
    assert [b.index[0] for b in blocks] == list(range(0, ROWS, BLOCK))  # the rows' numbers in the record
    joined = pd.concat(blocks)
    pd.testing.assert_frame_equal(joined, whole, check_exact=True)
    assert all(b.attrs == whole.attrs for b in blocks)


def test_a_record_shorter_than_a_block_is_one_block_equal_to_the_record(tmp_path):
    path = write("csv", tmp_path, columns_of(300))
    (block,) = iter_record(path, chunk_rows=BLOCK, columns=("t", "u", "y"))
    whole = read_record(path, columns=("t", "u", "y"), other_columns=False)
    pd.testing.assert_frame_equal(block, whole, check_exact=True)
    assert block.attrs == whole.attrs  # dt: the median step of the record in both


def test_without_dt_in_the_file_dt_is_the_first_blocks_median_step(tmp_path):
    columns = columns_of()
    columns["t"] = columns["t"] + np.random.default_rng(0).uniform(-2e-7, 2e-7, ROWS)  # clock jitter
    path = write("csv", tmp_path, columns)
    blocks = list(iter_record(path, chunk_rows=BLOCK))
    assert blocks[0].attrs["dt"] == float(np.median(np.diff(columns["t"][:BLOCK])))
    assert blocks[0].attrs["dt"] == pytest.approx(read_record(path).attrs["dt"], rel=1e-3)


@pytest.mark.parametrize(("fmt", "place"), [("csv", r"row 1500 \(line 1503 of .*rec\.csv\)"),
                                            ("parquet", r"row 1500 of .*rec\.parquet"),
                                            ("hdf5", r"row 1500 of .*rec\.h5")])  # fmt: skip
@pytest.mark.parametrize(("value", "kind"), [(np.nan, "a NaN"), (np.inf, "an infinite")])
def test_a_bad_value_in_the_second_block_names_its_row_in_the_record(tmp_path, fmt, place, value, kind):
    columns = columns_of()
    columns["y"][1500] = value
    path = write(fmt, tmp_path, columns, ATTRS)
    blocks = iter_record(path, chunk_rows=BLOCK)
    assert len(next(blocks)) == BLOCK  # the first block is clean and comes first
    with pytest.raises(DataError, match=rf"column 'y' has {kind} value .* at {place}"):
        next(blocks)


def test_text_in_a_later_block_of_a_csv_is_named(tmp_path):
    path = tmp_path / "rec.csv"
    frame = pd.DataFrame(columns_of()).astype(object)
    frame.loc[2345, "u"] = "fast"
    frame.to_csv(path, index=False)
    with pytest.raises(
        DataError, match=r"column 'u' has a non-numeric value 'fast' at row 2345 \(line 2347 of"
    ):
        list(iter_record(path, chunk_rows=BLOCK))


@pytest.mark.parametrize("fmt", ["csv", "parquet", "hdf5"])
def test_time_checks_hold_across_a_block_boundary(tmp_path, fmt):
    """Row 997 opens the second block: its step is the one the blocks' boundary would hide."""
    columns = columns_of()
    columns["t"][BLOCK] = columns["t"][BLOCK - 2]
    path = write(fmt, tmp_path, columns)
    with pytest.raises(DataError, match=rf"column 't' is not increasing at row {BLOCK}\b"):
        list(iter_record(path, chunk_rows=BLOCK))
    columns = columns_of()
    columns["t"][BLOCK:] += 0.002  # two samples missing before row 997
    path = write(fmt, tmp_path, columns, ATTRS)
    with pytest.raises(DataError, match=rf"column 't' has a gap of 2 samples before row {BLOCK}\b"):
        list(iter_record(path, chunk_rows=BLOCK))


def test_too_few_rows_and_a_header_only_file_are_refused_as_read_record_refuses_them(tmp_path):
    path = write("csv", tmp_path, columns_of(5))
    with pytest.raises(DataError, match=r"has 5 samples; at least 20 are needed"):
        next(iter_record(path, min_samples=20, chunk_rows=BLOCK))
    empty = tmp_path / "header.csv"
    empty.write_text("t,u,y\n")
    with pytest.raises(DataError, match=r"has a header but no data rows"):
        next(iter_record(empty))
    with pytest.raises(ValueError, match="chunk_rows"):
        next(iter_record(path, min_samples=20, chunk_rows=10))


def test_memory_is_a_few_blocks_however_long_the_record(tmp_path):
    """2,000,000 rows (48 MB as float64) read in blocks of 65,536 rows (1.5 MB): the peak of the
    memory Python and NumPy allocate while the blocks are read and dropped stays under 7 blocks'
    worth (11 MB; measured 6.6 MB: the parser's block and its DataFrame, the block handed out, the
    time column with the row before it, its steps and their checks, each about a third of a block
    to a block), less than a quarter of the record (12 MB)."""
    rows, block = 2_000_000, 1 << 16
    path = tmp_path / "long.csv"
    k = np.arange(rows)
    table = pa.table(
        {"t": k / 1000.0, "u": np.round(np.sin(k * 1e-3), 4), "y": np.round(np.cos(k * 1e-3), 4)}
    )
    pcsv.write_csv(table, path, pcsv.WriteOptions(quoting_style="none"))
    del table, k
    block_bytes = block * 3 * 8
    tracemalloc.start()
    try:
        seen = 0
        for chunk in iter_record(path, chunk_rows=block):
            seen += len(chunk)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert seen == rows
    assert peak < 7 * block_bytes < rows * 3 * 8 / 4, f"peak {peak / 1e6:.1f} MB"
