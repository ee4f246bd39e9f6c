"""A whole record read from any file: :func:`read_record` finds the format by the extension,
has that format's reader load the columns (:mod:`~motorid.io.records.text`,
:mod:`~motorid.io.records.parquet`, :mod:`~motorid.io.records.matlab`,
:mod:`~motorid.io.records.tdms`, :mod:`~motorid.io.records.hdf5`,
:mod:`~motorid.io.records.excel`) and brings them to motorid's names and units
(:mod:`~motorid.io.records.normalise`).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError
from motorid.io.records.columns import Choose, binary_column, column_chooser, short_name
from motorid.io.records.excel import read_excel
from motorid.io.records.files import record_format, regular_file_size
from motorid.io.records.hdf5 import read_hdf5
from motorid.io.records.matlab import read_mat
from motorid.io.records.normalise import as_used, normalised_read, row_place, stamped_in_ns
from motorid.io.records.options import REQUIRED_COLUMNS, RecordOptions, quoted
from motorid.io.records.parquet import read_parquet
from motorid.io.records.tdms import read_tdms
from motorid.io.records.text import read_csv_record

_READERS: dict[str, Callable[[str, Choose], tuple[dict[str, np.ndarray], dict[str, Any]]]] = {
    "Parquet": read_parquet,
    "MATLAB": read_mat,
    "HDF5": read_hdf5,
    "TDMS": read_tdms,
}


def read_binary(
    name: str, kind: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None,
    optional: set[str] = frozenset(),  # type: ignore[assignment]
    sheet: str | None = None,
) -> tuple[pd.DataFrame, dict[str, Any]]:  # fmt: skip
    """The columns of a Parquet, MATLAB, HDF5, TDMS or Excel record as float64, checked as a CSV's are.

    Other columns (``other_columns``) are those of the same length that are numbers, named as in
    the file (a nested one by its last part when that is unique); the rest of the file (scalars,
    matrices, text) is left out. A time column of dates and times (datetime64) is read in ns.
    """
    if regular_file_size(name) == 0:
        raise DataError(f"{name} is empty")
    if sheet is not None and kind != "Excel":
        raise DataError(f"sheet={quoted(sheet)} names a sheet of an Excel workbook; {name} is a {kind} file")
    found: dict[str, str] = {}
    choose = column_chooser(name, mapping, other_columns, max_samples, found, optional)
    arrays, attrs = read_excel(name, choose, sheet) if kind == "Excel" else _READERS[kind](name, choose)
    columns: dict[str, np.ndarray] = {}
    for key, values in arrays.items():
        if values.dtype.kind not in "fiub" and key not in found:
            continue
        if found.get(key) == "t" and values.dtype.kind in "mM":
            attrs = stamped_in_ns(name, attrs, mapping["t"], "date and time")
        columns[found[key] if key in found else short_name(key, list(arrays))] = binary_column(
            name, key, values, found.get(key) == "t"
        )
    return pd.DataFrame(columns), attrs


def read_record(
    path: str | os.PathLike[str],
    options: RecordOptions | None = None,
    *,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    other_columns: bool = True,
    speed: bool = False,
    **fields: Any,
) -> pd.DataFrame:
    """Read and check a record: CSV (as :func:`write_record` writes it, or any CSV) or a DAQ's file.

    The format comes from the extension (:func:`record_format`): ``.parquet``/``.pq``
    (Parquet), ``.mat`` (MATLAB: one variable per column, a row or column vector,
    as EMPS; v7.3 files too), ``.tdms`` (NI TDMS: a column per channel, named
    ``group/channel`` or by the channel's name alone when no other group has one
    of that name), ``.h5``/``.hdf5`` (HDF5: a column per one-dimensional dataset,
    named by its path), ``.xlsx``/``.xlsm`` (Excel: a column per header cell of the
    first row of ``sheet``), anything else CSV (any separator, a decimal comma, a
    thousands separator, a UTF-8 BOM, comment lines before the header, a row of
    units under it, time stamps as ISO-8601 dates or clock times; compressed as
    ``.gz``, ``.bz2``, ``.xz`` or a ``.zip`` of one CSV). The attributes come from the CSV attribute line or the format's place for
    them (:data:`ATTRS_KEY`); a TDMS waveform's ``wf_increment`` gives ``dt`` (and
    the time, when the file has no time column). Every format is checked the same
    way, and the columns are then brought to motorid's names and units by
    :func:`normalise_record`'s rules (time in s from 0, jitter resampled, units
    converted), and the span of ``options`` is kept.

    Parameters
    ----------
    path : str or path-like
        The record file (a regular file: a FIFO or a device is refused before it
        is opened).
    options : RecordOptions, optional
        How the record is read: its columns, time, units, CSV dialect, size limit
        (``max_samples``) and span (``start``, ``stop``). Default: every field's default.
    **fields :
        Fields of :class:`RecordOptions` given one by one (``time="Zeit [s]"``,
        ``input_unit="%"``, ``dt=0.01``), in place of those of ``options``.
    columns : sequence of str or mapping, optional
        Columns that must be present. A sequence lists them by name (default
        ``("t", "u", "y")``); a mapping ``{canonical: name_in_file}``, e.g.
        ``{"t": "time", "y": "speed_rad_s"}``, renames them to ``t``, ``u``,
        ``y`` (unmapped ones keep their canonical name).
    min_samples : int
        Fewest rows accepted (what the model needs), >= 1.
    other_columns : bool
        Keep the file's other columns too (default; in the binary formats those
        of the same length that hold numbers); False reads only ``columns``
        (less memory and time on a wide file).
    speed : bool
        Differentiate an encoder's position (``output_unit="counts"``) to a speed
        (:func:`speed_from_position`) before the span is cut, as the commands that
        need a speed do; a warning says the speed's quantisation step.

    Returns
    -------
    pandas.DataFrame
        The record with float64 columns ``t`` [s, from 0], ``u``, ``y`` (and the
        others) and ``attrs`` (``dt`` always set).

    Raises
    ------
    DataError
        (a ValueError) On a missing file, a folder, a FIFO or device, an empty,
        binary or header-only file, a file that is not of the format its
        extension says (or is cut or corrupt), a blank or repeated column name, a
        row with more or fewer fields than the header, a missing or ambiguous
        column, a column that is not one column of numbers or is shorter than
        another, a NaN or infinite value, a time column that is not increasing,
        has a gap or is not uniformly sampled, that looks like ms or µs read as
        seconds, or contradicts ``dt``, fewer than ``min_samples`` or more than
        ``max_samples`` rows, no sample in the span; the message names the file, the column and the row
        (0-based data row, and in a CSV the line in the file).
    """
    if not isinstance(min_samples, int) or min_samples < 1:
        raise ValueError(f"min_samples must be an integer >= 1, got {min_samples!r}")
    options = RecordOptions.of(options, **fields)
    max_samples = options.max_samples
    if max_samples is not None and max_samples < min_samples:
        raise DataError(f"max_samples={max_samples} is below min_samples = {min_samples}")
    name = os.fspath(path)
    mapping = options.column_map(columns)
    optional = {"t"} if options.time_optional(columns) else set()
    kind = record_format(name)
    if kind == "CSV":
        rec, attrs, header_line = read_csv_record(
            name, mapping, optional, other_columns, max_samples, options.sep, options.decimal, options.thousands,
            options.comment,
        )  # fmt: skip
        where = row_place(name, header_line)
    else:
        rec, attrs = read_binary(name, kind, mapping, other_columns, max_samples, optional, options.sheet)
        where = row_place(name, None)
    names = {canonical: mapping[canonical] for canonical in REQUIRED_COLUMNS if canonical in mapping}
    record = normalised_read(name, rec, attrs, where, options, min_samples, names)
    return as_used(record, options, name, min_samples, speed)
