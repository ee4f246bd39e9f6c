"""Records read in blocks of rows, so that a record of any length is worked on in bounded memory.

:func:`iter_record` reads what :func:`motorid.io.records.read_record` reads, with the
same options (:class:`motorid.io.records.RecordOptions`, ``sep`` and ``decimal``), the
same checks and the same numbers, but yields the record as consecutive blocks of
``chunk_rows`` rows instead of returning it whole: a CSV through pandas' C parser
in chunks (its layout, separator and decimal mark found once, from its header and
first lines: :func:`motorid.io.records.csv_layout`), Parquet in batches across its
row groups, HDF5 by slices of its datasets. Memory is then a few blocks, whatever
the length of the record: an hour at 1 kHz (3.6 M rows) or a day (86.4 M).
MATLAB and TDMS files are read whole and handed out in blocks (their formats
hold a column in one piece).

Each block is checked and converted as :func:`~motorid.io.records.read_record` checks
and converts a record, with the errors naming the row in the whole record (and its
line in a CSV): a non-numeric, NaN or infinite cell, a row with more fields than
the header, a time column that goes backwards, has a gap or is not uniformly
sampled (within a block or across two), a duty beyond 100 %. The time unit, its
origin and the sample time come from the first block (the one asked for, the one
the file says or, when neither, the median step of the first block; the
whole-record read takes the median over all steps: on a uniformly sampled record
both are within ``dt_rtol`` of each other).

A record whose time stamps jitter (or, with ``resample``, have gaps) is put on a
uniform grid by the whole-record read; that takes the record whole, so
:func:`iter_record` refuses it with :class:`UniformGridError`, naming the row,
and a caller that can hold the record reads it with ``read_record`` instead
(``motorid identify`` does, within ``--max-samples``).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError, UniformGridError
from motorid.io.records.columns import Blocks
from motorid.io.records.files import record_format
from motorid.io.records.hdf5 import hdf5_blocks
from motorid.io.records.normalise import (
    InputSignCheck,
    as_used,
    check_increasing,
    named_attrs,
    row_place,
    signed_by_direction,
    steps_off_grid,
    time_base,
    untimed_dt,
)
from motorid.io.records.options import DIRECTION, REQUIRED_COLUMNS, RecordOptions, quoted
from motorid.io.records.parquet import parquet_blocks
from motorid.io.records.read import read_binary, read_record
from motorid.io.records.text import csv_blocks
from motorid.units import ENCODER_COUNTS

#: Rows per block by default: 65,536 rows of three float64 columns are 1.5 MB, and what an
#: estimator's ``batch_filter`` returns per block (estimate and covariance diagonal per sample,
#: 19 parameters) 20 MB.
CHUNK_ROWS = 1 << 16


def iter_record(
    path: str | os.PathLike[str],
    options: RecordOptions | None = None,
    *,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    chunk_rows: int = CHUNK_ROWS,
    speed: bool = False,
    **fields: Any,
) -> Iterator[pd.DataFrame]:
    """The record of :func:`motorid.io.records.read_record`, as consecutive blocks of rows.

    Parameters
    ----------
    path : str or path-like
        The record file, in any format :func:`~motorid.io.records.read_record` reads. Only
        the record's columns are read (its ``other_columns=False``); there is no
        ``max_samples``, since memory does not grow with the record.
    options : RecordOptions, optional
        How the record is read, as for ``read_record``; ``max_samples`` does not apply,
        since memory does not grow with the record, and a span (``start``, ``stop``) is
        cut from the record read whole (a :class:`UniformGridError`). As in
        ``read_record``, ``dt`` given and a file or time column that says otherwise is a
        DataError; without it, the sample time is the file's, else the median step of
        the first block.
    **fields :
        Fields of :class:`RecordOptions` given one by one, in place of those of ``options``.
    columns : sequence of str or mapping, optional
        Columns that must be present (default ``("t", "u", "y")``), or a mapping
        ``{canonical: name_in_file}`` that renames them, as for ``read_record``.
    min_samples : int
        Fewest rows accepted, >= 1.
    chunk_rows : int
        Rows per block (the last one may be shorter), >= ``max(2, min_samples)``.
    speed : bool
        Refuse an encoder's position (``output_unit="counts"``) with a :class:`UniformGridError`:
        a command that needs a speed differentiates it, which ``read_record`` does whole.

    Yields
    ------
    pandas.DataFrame
        One block: float64 columns ``t`` [s, from 0], ``u``, ``y`` in motorid's
        units, the index the rows' numbers in the whole record (0-based),
        ``attrs`` as the whole record's (``dt`` set). Concatenated, the blocks
        equal the record :func:`~motorid.io.records.read_record` returns, bit for bit.

    Raises
    ------
    DataError
        As :func:`~motorid.io.records.read_record`, naming the row in the whole
        record; an error in a later block is raised when that block is reached.
    UniformGridError
        (a DataError) The time stamps jitter, or have gaps and ``resample`` is
        set: ``read_record`` puts such a record on a uniform grid, whole; a span is
        asked for, or a speed from an encoder's counts.
    """
    if not isinstance(min_samples, int) or min_samples < 1:
        raise ValueError(f"min_samples must be an integer >= 1, got {min_samples!r}")
    if not isinstance(chunk_rows, int) or chunk_rows < max(2, min_samples):
        raise ValueError(f"chunk_rows must be an integer >= max(2, min_samples), got {chunk_rows!r}")
    options = RecordOptions.of(options, **fields)
    name = os.fspath(path)
    if options.spanned:
        raise UniformGridError(
            f"{name}: a span (start, stop) is cut from the record read whole (read_record)"
        )
    if speed and options.output_unit == ENCODER_COUNTS:
        raise UniformGridError(
            f"{name}: an encoder's counts are differentiated to a speed when the record is read whole (read_record)"
        )
    mapping = options.column_map(columns)
    optional = {"t"} if options.time_optional(columns) else set()
    kind = record_format(name)
    if kind == "CSV":
        source = csv_blocks(
            name,
            mapping,
            optional,
            chunk_rows,
            options.sep,
            options.decimal,
            options.thousands,
            options.comment,
        )
    elif kind in ("Parquet", "HDF5"):
        readers = {"Parquet": parquet_blocks, "HDF5": hdf5_blocks}
        source = readers[kind](name, kind, mapping, optional, chunk_rows)
    else:
        source = _whole_blocks(name, kind, mapping, optional, chunk_rows, options.sheet)
    with contextlib.closing(source) as blocks:
        attrs = dict(next(blocks))
        where = row_place(name, next(blocks))
        names = {canonical: mapping[canonical] for canonical in REQUIRED_COLUMNS if canonical in mapping}
        named_attrs(name, attrs, options, names)
        clock = _BlockClock(name, attrs, where, options, names)
        signs = InputSignCheck(name, options, names)
        first_row = 0
        for block in _exact_blocks(blocks, chunk_rows):
            rows = len(next(iter(block.values())))
            if first_row == 0 and rows < min_samples:
                plural = "" if rows == 1 else "s"
                raise DataError(f"{name} has {rows} sample{plural}; at least {min_samples} are needed")
            times = clock.seconds(block.get("t"), first_row, rows)
            block = {**block, "t": times} if "t" in block else {"t": times, **block}  # the whole read's order
            chunk = pd.DataFrame(block, index=pd.RangeIndex(first_row, first_row + rows))
            chunk.attrs = dict(attrs)
            at = lambda row, start=first_row: where(start + row)  # noqa: E731
            if DIRECTION in chunk.columns:
                chunk["u"] = signed_by_direction(chunk, at, options, names.get("u", "u"))[:, 0]
                chunk = chunk.drop(columns=DIRECTION)
            chunk = _converted(chunk, options, at, names.get("u", "u"))
            if "u" in chunk.columns and "y" in chunk.columns:
                signs.update(
                    chunk["u"].to_numpy(), chunk["y"].to_numpy(), (chunk.attrs.get("units") or {}).get("y")
                )
            yield chunk
            first_row += rows
        signs.finish()


class _BlockClock:
    """The time column of a record read in blocks, in s from 0: the unit, origin and sample time
    from the first block (:func:`motorid.io.records.time_base`, which also sets ``attrs``), each
    later block checked against them and across the boundary with the block before."""

    def __init__(
        self, name: str, attrs: dict[str, Any], where: Callable[[int], str], options: RecordOptions,
        names: dict[str, str],
    ) -> None:  # fmt: skip
        self.name, self.attrs, self.where, self.options = name, attrs, where, options
        self.names = names
        self.column = names.get("t", "t")
        self.origin: Any = None
        self.scale = self.dt = 1.0
        self.last_raw: Any = None
        self.last_t = 0.0

    def seconds(self, raw: np.ndarray | None, first_row: int, rows: int) -> np.ndarray:
        """The times [s] of the block of ``rows`` rows from ``first_row`` (``raw``: its stamps, None
        when the record has no time column); a DataError naming the row of a bad stamp."""
        if raw is None:
            if first_row == 0:
                self.dt = untimed_dt(self.name, self.attrs, self.options, self.names)
                self.attrs.setdefault("units", {})["t"] = "s"
            return np.arange(first_row, first_row + rows) * self.dt  # as the whole read: same bits
        repeats = np.flatnonzero(raw[1:] == raw[:-1])
        if self.last_raw is not None and raw.size and raw[0] == self.last_raw:
            repeats = np.concatenate(([-1], repeats))
        if repeats.size:
            row = first_row + int(repeats[0]) + 1
            raise UniformGridError(
                f"{self.name}: column {quoted(self.column)} repeats a time stamp at {self.where(row)}: rows that "
                "repeat a stamp are dropped or merged when the record is read whole (read_record), not in blocks"
            )
        if self.origin is None:
            t, self.dt, self.scale = time_base(
                self.name, raw, self.attrs, self.where, self.options, self.column
            )
            self.origin = raw[0]
            steps, where = np.diff(t), self.where
        else:  # with the last stamp of the block before, whose row is first_row - 1
            where = lambda row, start=first_row - 1: self.where(start + row)  # noqa: E731
            check_increasing(np.concatenate(([self.last_raw], raw)), where, self.column)
            t = (raw - self.origin).astype(np.float64) * self.scale  # as the whole read: same bits
            steps = np.diff(np.concatenate(([self.last_t], t)))
        off_grid = steps_off_grid(steps, self.dt, where, self.options, self.column)
        if off_grid is not None:
            row = int(np.argmax(off_grid[0] > self.options.dt_rtol * self.dt)) + 1
            raise UniformGridError(
                f"{self.name}: the time stamps of column {self.column!r} are off the uniform {self.dt:.6g} s grid "
                f"from {where(row)} on: such a record is put on a uniform grid, which reads it whole "
                "(read_record), not in blocks"
            )
        self.last_raw, self.last_t = raw[-1], float(t[-1])
        return t


def _converted(
    chunk: pd.DataFrame, options: RecordOptions, where: Callable[[int], str], column: str
) -> pd.DataFrame:
    """A block in motorid's units, as :func:`motorid.units.convert_record` converts a whole record."""
    from motorid.units import convert_record

    return convert_record(
        chunk, options.input_unit, options.output_unit, options.supply_voltage,
        input_full_scale=options.input_full_scale, counts_per_rev=options.counts_per_rev, where=where,
        column=column,
    )  # fmt: skip


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


def _whole_blocks(
    name: str,
    kind: str,
    mapping: dict[str, str],
    optional: set[str],
    chunk_rows: int,
    sheet: str | None = None,
) -> Blocks:
    """A MATLAB, TDMS or Excel record read whole (its format holds a column in one piece), in blocks."""
    record, attrs = read_binary(name, kind, mapping, False, None, optional, sheet)
    yield attrs
    yield None
    arrays = {column: record[column].to_numpy() for column in record.columns}
    for first_row in range(0, len(record), chunk_rows):
        yield {column: values[first_row : first_row + chunk_rows] for column, values in arrays.items()}


def read_head(
    path: str | os.PathLike[str],
    options: RecordOptions | None = None,
    *,
    min_samples: int = 2,
    speed: bool = False,
    **fields: Any,
) -> tuple[pd.DataFrame, bool]:
    """The record ``path`` when it has at most ``max_samples`` rows, else its first ``max_samples``
    rows (a segment, as ``motorid doctor`` reads a record); and whether it is a segment.

    Read in blocks of ``max_samples`` rows (:func:`iter_record`): the first block is the record
    or the segment, checked as a whole record is, and the start of a second one tells that there
    is more, so no more than about ``max_samples`` rows are ever held (the rows after the segment
    are not checked). A record whose time stamps jitter is put on a uniform grid, which takes it
    whole: it is read by :func:`~motorid.io.records.read_record` (which then refuses a longer
    one). The output is then differentiated to a speed when ``speed`` asks, and the span of the
    options cut, as :func:`~motorid.io.records.read_record` does.

    Parameters
    ----------
    path : str or path-like
        The record file.
    options : RecordOptions, optional
        How the record is read; its ``max_samples`` is the length of a segment (None: the
        record is read whole).
    min_samples : int
        Fewest rows accepted, >= 1.
    speed : bool
        As for :func:`~motorid.io.records.read_record`.
    **fields :
        Fields of :class:`RecordOptions` given one by one, in place of those of ``options``.
    """
    options = RecordOptions.of(options, **fields)
    whole = options.whole()
    rows = options.max_samples
    if rows is None or rows < max(2, min_samples):  # the whole-record read says what is wrong
        record, more = read_record(path, whole, min_samples=min_samples, other_columns=False), False
    else:
        blocks = iter_record(path, replace(whole, max_samples=None), min_samples=min_samples, chunk_rows=rows)
        with contextlib.closing(blocks):
            try:
                record = next(blocks)
            except UniformGridError:
                record = read_record(path, whole, min_samples=min_samples, other_columns=False)
                blocks.close()
                return as_used(record, options, path, min_samples, speed), False
            try:
                more = next(blocks, None) is not None
            except DataError:  # a bad row after the segment (or stamps off the grid): there are rows after it
                more = True
    return as_used(record, options, path, min_samples, speed), more


__all__ = ["CHUNK_ROWS", "iter_record", "read_head"]
