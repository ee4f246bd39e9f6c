"""Records read in blocks of rows, so that a record of any length is worked on in bounded memory.

:func:`iter_record` reads what :func:`motorid.records.read_record` reads, with the
same options, the same checks and the same numbers, but yields the record as
consecutive blocks of ``chunk_rows`` rows instead of returning it whole: a CSV
through pandas' C parser in chunks (the options of the whole-record read, from
:func:`motorid.records.csv_data_options`), Parquet in batches across its row
groups, HDF5 by slices of its datasets. Memory is then a few blocks, whatever
the length of the record: an hour at 1 kHz (3.6 M rows) or a day (86.4 M).
MATLAB and TDMS files are read whole and handed out in blocks (their formats
hold a column in one piece).

Each block is checked as :func:`~motorid.records.read_record` checks a record,
with the errors naming the row in the whole record (and its line in a CSV): a
non-numeric, NaN or infinite cell, a time column that goes backwards, has a gap
or is not uniformly sampled, within a block or across two. The sample time is
the one asked for, the one the file says or, when neither, the median step of
the first block (the whole-record read takes the median over all steps; on a
uniformly sampled record both are within ``dt_rtol`` of each other).
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError
from motorid.records import (
    _checked,
    _column_chooser,
    _column_map,
    _csv_layout,
    _finite_floats,
    _hdf5_file,
    _parquet_file,
    _read_binary,
    _row_place,
    _samples,
    csv_data_options,
    raise_bad_cell,
    record_format,
)

#: Rows per block by default: 65,536 rows of three float64 columns are 1.5 MB, and what an
#: estimator's ``batch_filter`` returns per block (estimate and covariance diagonal per sample,
#: 19 parameters) 20 MB.
CHUNK_ROWS = 1 << 16

# A source of blocks: a generator that yields the record's attrs, then the line number of a CSV's
# header (None in the other formats), then each block as {canonical name: float64 array}.
Blocks = Iterator[Any]


def iter_record(
    path: str | os.PathLike[str],
    dt: float | None = None,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    dt_rtol: float = 1e-3,
    chunk_rows: int = CHUNK_ROWS,
) -> Iterator[pd.DataFrame]:
    """The record of :func:`motorid.records.read_record`, as consecutive blocks of rows.

    Parameters
    ----------
    path, dt, columns, min_samples, dt_rtol
        As for :func:`~motorid.records.read_record`. Only the columns named by
        ``columns`` are read (its ``other_columns=False``); there is no
        ``max_samples``, since memory does not grow with the record.
    chunk_rows : int
        Rows per block (the last one may be shorter), >= ``max(2, min_samples)``.

    Yields
    ------
    pandas.DataFrame
        One block: float64 columns in their canonical names, the index the rows'
        numbers in the whole record (0-based), ``attrs`` as the whole record's
        (``dt`` set). Concatenated, the blocks equal the record
        :func:`~motorid.records.read_record` returns, bit for bit.

    Raises
    ------
    DataError
        As :func:`~motorid.records.read_record`, naming the row in the whole
        record; an error in a later block is raised when that block is reached.
    """
    if not isinstance(min_samples, int) or min_samples < 1:
        raise ValueError(f"min_samples must be an integer >= 1, got {min_samples!r}")
    if not isinstance(chunk_rows, int) or chunk_rows < max(2, min_samples):
        raise ValueError(f"chunk_rows must be an integer >= max(2, min_samples), got {chunk_rows!r}")
    if dt is not None and (not math.isfinite(dt) or dt <= 0.0):
        raise DataError(f"dt must be finite and > 0, got {dt!r}")
    name = os.fspath(path)
    mapping = _column_map(columns)
    kind = record_format(name)
    source = {"CSV": _csv_blocks, "Parquet": _parquet_blocks, "HDF5": _hdf5_blocks}.get(kind, _whole_blocks)
    with contextlib.closing(source(name, kind, mapping, chunk_rows)) as blocks:
        attrs = dict(next(blocks))
        where = _row_place(name, next(blocks))
        first_row = 0
        last_t: float | None = None
        for block in _exact_blocks(blocks, chunk_rows):
            rows = len(next(iter(block.values())))
            # the time checks of the whole-record read, on this block and the last row before it
            times: dict[str, np.ndarray] = {}
            if "t" in block:
                times["t"] = block["t"] if last_t is None else np.concatenate(([last_t], block["t"]))
            overlap = 0 if last_t is None else 1
            timed = _checked(
                name, pd.DataFrame(times, index=pd.RangeIndex(rows + overlap)), dict(attrs),
                lambda row, start=first_row - overlap: where(start + row),
                dt, dt_rtol, min_samples if first_row == 0 else 1,
            )  # fmt: skip
            dt = attrs["dt"] = timed.attrs["dt"]
            chunk = pd.DataFrame(block, index=pd.RangeIndex(first_row, first_row + rows))
            chunk.attrs = dict(attrs)
            yield chunk
            first_row += rows
            last_t = float(block["t"][-1]) if "t" in block else None
        if first_row == 0:
            raise DataError(f"{name} has a header but no data rows")


def _exact_blocks(
    blocks: Iterator[dict[str, np.ndarray]], chunk_rows: int
) -> Iterator[dict[str, np.ndarray]]:
    """The rows of ``blocks`` regrouped into blocks of exactly ``chunk_rows`` rows (the last one
    shorter); a block that already has that many passes through uncopied."""
    pending: list[dict[str, np.ndarray]] = []
    held = 0
    for block in blocks:
        rows = len(next(iter(block.values())))
        start = 0
        while start < rows:
            take = min(rows - start, chunk_rows - held)
            pending.append(
                block
                if (start, take) == (0, rows)
                else {k: v[start : start + take] for k, v in block.items()}
            )
            held += take
            start += take
            if held == chunk_rows:
                yield _joined(pending)
                pending, held = [], 0
    if held:
        yield _joined(pending)


def _joined(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    if len(parts) == 1:
        return parts[0]
    return {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}


def _csv_blocks(name: str, kind: str, mapping: dict[str, str], chunk_rows: int) -> Blocks:
    """A CSV record by pandas' C parser in chunks, with the whole-record read's options; a chunk that
    does not parse as finite numbers is named by :func:`~motorid.records.raise_bad_cell`."""
    attrs, skip, present = _csv_layout(name, mapping)
    yield attrs
    yield skip + 1
    names = [column for column in present if column in mapping.values()]
    canonical = {column: key for key, column in mapping.items()}
    with pd.read_csv(name, **csv_data_options(skip, names), dtype=np.float64, chunksize=chunk_rows) as reader:
        while True:
            try:
                data = next(reader)
            except StopIteration:
                return
            except ValueError:  # a cell that is not a number: named from the text below
                data = None
            arrays = {} if data is None else {canonical[c]: data[c].to_numpy() for c in names}
            if data is None or not all(np.isfinite(values).all() for values in arrays.values()):
                raise_bad_cell(name, skip, names)
            yield arrays


def _checked_binary(name: str) -> None:
    """The file checks of :func:`~motorid.records.read_record` before a binary format is opened."""
    if os.path.isdir(name):
        raise DataError(f"{name} is a folder, not a record file")
    if not os.path.exists(name):
        raise DataError(f"{name}: no such file")
    if os.path.getsize(name) == 0:
        raise DataError(f"{name} is empty")


def _parquet_blocks(name: str, kind: str, mapping: dict[str, str], chunk_rows: int) -> Blocks:
    """A Parquet record in batches of at most ``chunk_rows`` rows (pyarrow reads them across row groups)."""
    _checked_binary(name)
    parquet, attrs = _parquet_file(name)
    with parquet:
        found: dict[str, str] = {}
        rows = parquet.metadata.num_rows
        chosen = _column_chooser(name, mapping, False, None, found)(
            {column: (rows,) for column in parquet.schema_arrow.names}
        )
        yield attrs
        yield None
        first_row = 0
        for batch in parquet.iter_batches(batch_size=chunk_rows, columns=chosen):
            yield {
                found[key]: _finite_floats(
                    name, key, batch.column(key).to_numpy(zero_copy_only=False), first_row
                )
                for key in chosen
            }
            first_row += batch.num_rows


def _hdf5_blocks(name: str, kind: str, mapping: dict[str, str], chunk_rows: int) -> Blocks:
    """An HDF5 record by slices of ``chunk_rows`` samples of its datasets."""
    _checked_binary(name)
    handle, shapes, attrs = _hdf5_file(name)
    with handle:
        found: dict[str, str] = {}
        chosen = _column_chooser(name, mapping, False, None, found)(shapes)
        yield attrs
        yield None
        rows = _samples(shapes[chosen[0]]) or 0
        for first_row in range(0, rows, chunk_rows):
            block = {}
            for key in chosen:
                shape = shapes[key]
                axis = next((i for i, n in enumerate(shape) if n > 1), 0)  # the one axis along the samples
                where = tuple(
                    slice(first_row, first_row + chunk_rows) if i == axis else 0 for i in range(len(shape))
                )
                block[found[key]] = _finite_floats(
                    name, key, np.asarray(handle[key][where]).reshape(-1), first_row
                )
            yield block


def _whole_blocks(name: str, kind: str, mapping: dict[str, str], chunk_rows: int) -> Blocks:
    """A MATLAB or TDMS record read whole (its format holds a column in one piece), in blocks."""
    record, attrs = _read_binary(name, kind, mapping, False, None)
    yield attrs
    yield None
    arrays = {column: record[column].to_numpy() for column in record.columns}
    for first_row in range(0, len(record), chunk_rows):
        yield {column: values[first_row : first_row + chunk_rows] for column, values in arrays.items()}


__all__ = ["CHUNK_ROWS", "iter_record"]
