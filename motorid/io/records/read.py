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
from motorid.io.records.columns import Choose, _column_chooser, _short_name, binary_column
from motorid.io.records.excel import _read_excel
from motorid.io.records.files import _regular_file, record_format
from motorid.io.records.hdf5 import _read_hdf5
from motorid.io.records.matlab import _read_mat
from motorid.io.records.normalise import _normalised, row_place, stamped_in_ns
from motorid.io.records.options import COMMENT, REQUIRED_COLUMNS, RecordOptions, quoted
from motorid.io.records.parquet import _read_parquet
from motorid.io.records.tdms import _read_tdms
from motorid.io.records.text import _read_csv, check_dialect

_READERS: dict[str, Callable[[str, Choose], tuple[dict[str, np.ndarray], dict[str, Any]]]] = {
    "Parquet": _read_parquet,
    "MATLAB": _read_mat,
    "HDF5": _read_hdf5,
    "TDMS": _read_tdms,
}


def _read_binary(
    name: str, kind: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None,
    optional: set[str] = frozenset(),  # type: ignore[assignment]
    sheet: str | None = None,
) -> tuple[pd.DataFrame, dict[str, Any]]:  # fmt: skip
    """The columns of a Parquet, MATLAB, HDF5, TDMS or Excel record as float64, checked as a CSV's are.

    Other columns (``other_columns``) are those of the same length that are numbers, named as in
    the file (a nested one by its last part when that is unique); the rest of the file (scalars,
    matrices, text) is left out. A time column of dates and times (datetime64) is read in ns.
    """
    if _regular_file(name) == 0:
        raise DataError(f"{name} is empty")
    if sheet is not None and kind != "Excel":
        raise DataError(f"sheet={quoted(sheet)} names a sheet of an Excel workbook; {name} is a {kind} file")
    found: dict[str, str] = {}
    choose = _column_chooser(name, mapping, other_columns, max_samples, found, optional)
    arrays, attrs = _read_excel(name, choose, sheet) if kind == "Excel" else _READERS[kind](name, choose)
    columns: dict[str, np.ndarray] = {}
    for key, values in arrays.items():
        if values.dtype.kind not in "fiub" and key not in found:
            continue
        if found.get(key) == "t" and values.dtype.kind in "mM":
            attrs = stamped_in_ns(name, attrs, mapping["t"], "date and time")
        columns[found[key] if key in found else _short_name(key, list(arrays))] = binary_column(
            name, key, values, found.get(key) == "t"
        )
    return pd.DataFrame(columns), attrs


def read_record(
    path: str | os.PathLike[str],
    dt: float | None = None,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    dt_rtol: float = 1e-3,
    max_samples: int | None = None,
    other_columns: bool = True,
    *,
    time: str | None = None,
    input: str | None = None,
    output: str | None = None,
    time_unit: str | None = None,
    input_unit: str | None = None,
    output_unit: str | None = None,
    supply_voltage: float | None = None,
    input_full_scale: float | None = None,
    resample: bool = False,
    counts_per_rev: float | None = None,
    direction: str | None = None,
    direction_forward: float = 1.0,
    duplicates: str = "refuse",
    sep: str | None = None,
    decimal: str | None = None,
    thousands: str | None = None,
    comment: str | None = COMMENT,
    sheet: str | None = None,
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
    converted). ``read_record(path, **options)`` takes the command line's record
    options by the same names (:class:`RecordOptions`).

    Parameters
    ----------
    path : str or path-like
        The record file (a regular file: a FIFO or a device is refused before it
        is opened).
    dt : float, optional
        Expected sample time [s]. Default: ``attrs["dt"]`` from the file, else
        the median spacing of the time column. If given and the file or its time
        column says otherwise, DataError.
    columns : sequence of str or mapping, optional
        Columns that must be present. A sequence lists them by name (default
        ``("t", "u", "y")``); a mapping ``{canonical: name_in_file}``, e.g.
        ``{"t": "time", "y": "speed_rad_s"}``, renames them to ``t``, ``u``,
        ``y`` (unmapped ones keep their canonical name).
    min_samples : int
        Fewest rows accepted (what the model needs), >= 1.
    dt_rtol : float
        Relative tolerance on the uniformity of the time steps (:class:`RecordOptions`).
    max_samples : int, optional
        Most rows accepted. The rows are counted before anything is parsed (the
        lines of a CSV in bounded memory, the others from their metadata), so a
        record too long for memory is refused at once, by a DataError naming
        the limit and how to decimate. A record takes about 8 bytes per row and
        column once read.
    other_columns : bool
        Keep the file's other columns too (default; in the binary formats those
        of the same length that hold numbers); False reads only ``columns``
        (less memory and time on a wide file).
    time, input, output, time_unit, input_unit, output_unit, supply_voltage, input_full_scale, resample : optional
        As :class:`RecordOptions` (``--time``, ``--input`` ... on the command line).
    counts_per_rev, direction, direction_forward, duplicates : optional
        As :class:`RecordOptions`.
    sep : str, optional
        Separator of a CSV (one character; ``--sep``). Default: detected from the
        header and the first lines among :data:`SEPARATORS` (logged at INFO, ``-v``).
    decimal : {".", ","}, optional
        Decimal mark of a CSV (``--decimal``). Default: ``,`` when the separator is
        not a comma and the first lines hold numbers written with one.
    thousands : str, optional
        Thousands separator of a CSV (one of :data:`THOUSANDS`). Default: detected
        with the decimal mark from a number written with both (``-1,035.7``,
        ``-1.035,7``) or with two groups of three digits; else none.
    comment : str, optional
        Prefix of the comment lines before a CSV's header (default ``#``), kept as
        ``attrs["notes"]``; None: none.
    sheet : str, optional
        The sheet of an Excel workbook (default: its first).

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
        ``max_samples`` rows; the message names the file, the column and the row
        (0-based data row, and in a CSV the line in the file).
    """
    if not isinstance(min_samples, int) or min_samples < 1:
        raise ValueError(f"min_samples must be an integer >= 1, got {min_samples!r}")
    if max_samples is not None and (not isinstance(max_samples, int) or max_samples < min_samples):
        raise ValueError(
            f"max_samples must be an integer >= min_samples = {min_samples}, got {max_samples!r}"
        )
    options = RecordOptions(
        time=time, input=input, output=output, dt=dt, time_unit=time_unit, input_unit=input_unit,
        output_unit=output_unit, supply_voltage=supply_voltage, input_full_scale=input_full_scale,
        resample=resample, dt_rtol=dt_rtol, counts_per_rev=counts_per_rev, direction=direction,
        direction_forward=direction_forward, duplicates=duplicates,
    )  # fmt: skip
    check_dialect(sep, decimal, thousands)
    name = os.fspath(path)
    mapping = options.column_map(columns)
    optional = {"t"} if options.time_optional(columns) else set()
    kind = record_format(name)
    if kind == "CSV":
        rec, attrs, header_line = _read_csv(
            name, mapping, optional, other_columns, max_samples, sep, decimal, thousands, comment
        )
        where = row_place(name, header_line)
    else:
        rec, attrs = _read_binary(name, kind, mapping, other_columns, max_samples, optional, sheet)
        where = row_place(name, None)
    names = {canonical: mapping[canonical] for canonical in REQUIRED_COLUMNS if canonical in mapping}
    return _normalised(name, rec, attrs, where, options, min_samples, names)
