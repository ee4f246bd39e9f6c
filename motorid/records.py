"""Records on disk: CSV with the record's attributes in a commented first line; the files DAQs write.

A record is a pandas DataFrame with columns ``t`` [s], ``u`` [V], ``y`` [rad/s]
(and any extra signals) and ``attrs`` holding at least ``dt`` [s] and ``units``
(column -> unit). On disk it is one CSV file whose first line is a comment
carrying the attributes as JSON::

    # motorid-record {"dt": 0.04, "units": {"t": "s", ...}, "rig": {...}}
    t,u,y,...
    0.0,1.2,0.0,...

pandas reads such a file with ``pd.read_csv(path, comment="#")`` and most CSV
tools skip the comment line, so the data stay readable without motorid;
:func:`read_record` restores the attributes and checks the data. A CSV without
the comment line (a measurement from elsewhere) reads too: ``dt`` then comes
from the argument or from the time column.

:func:`read_record` also reads the files DAQs and analysis tools write, by
extension (:data:`RECORD_FORMATS`): Parquet, MATLAB ``.mat`` (a variable per
column), NI TDMS (a channel per column) and HDF5 (a dataset per column), with the
same checks and the same errors as a CSV, and CSV as loggers write it (any
separator, decimal commas, a BOM).

Every reader ends in one place, which brings the columns to motorid's names and
units with the options of :class:`RecordOptions` (the command line's ``--time``,
``--time-unit``, ``--input-unit`` ...): time in s from 0, jittered stamps put on a
uniform grid, units converted. :func:`normalise_record` applies the same to a
DataFrame from the user's own code (:func:`motorid.diagnose.diagnose` calls it).
"""

from __future__ import annotations

import csv
import json
import logging
import math
import os
import re
import stat
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError
from motorid.json_input import parse_json
from motorid.units import INPUT_UNITS, OUTPUT_UNITS, TIME_UNITS

logger = logging.getLogger(__name__)

#: Marker that opens the attribute line.
ATTRS_MARKER = "# motorid-record "
#: Columns a record must have, in its canonical names.
REQUIRED_COLUMNS: tuple[str, ...] = ("t", "u", "y")

#: The keys of ``attrs`` naming the drive a record comes from and when it was taken (ISO 8601 text):
#: written by :mod:`motorid.fleet.synthetic`, read by ``motorid fleet``.
DRIVE_ATTR = "drive"
TIME_ATTR = "time"
#: The keywords ``attrs["timing"]`` takes: how input and output samples line up in time.
TIMINGS: dict[str, str] = {
    "hold": "u[k] is held over [t[k], t[k]+dt); y[k] is measured at t[k]+dt (a simulator, a DAQ loop)",
    "sampled": "y[k] is read at t[k], then u[k] is held over [t[k], t[k]+dt) (a controller's loop)",
}
#: Descriptive sentences earlier motorid versions wrote as ``attrs["timing"]``; each means "hold".
_LEGACY_TIMINGS = (
    "u[k] is held over [t[k], t[k]+dt); y and the true states are at t[k]+dt",
    "u[k] is held over [t[k], t[k]+dt); y is measured at t[k]+dt",
)


def check_row_limit(name: str, rows: int, max_samples: int | None) -> None:
    """Refuse, before it is loaded, a record of more than ``max_samples`` rows (how to decimate it named)."""
    if max_samples is not None and rows > max_samples:
        raise DataError(
            f"{name} has {rows} rows, more than the limit of {max_samples} samples (max_samples, "
            f"--max-samples on the command line) that keeps memory bounded (about 8 bytes per sample "
            f"and column); decimate the record (low-pass filter it, then keep one row in "
            f"{math.ceil(rows / max_samples)}) or raise the limit"
        )


def record_timing(attrs: Mapping[str, Any], default: str = "hold") -> str:
    """The timing keyword of a record's ``attrs`` (one of :data:`TIMINGS`).

    Parameters
    ----------
    attrs : mapping
        The record's attributes; ``attrs["timing"]`` may be absent (``default``
        is returned) or a sentence an earlier motorid version wrote (read as
        ``"hold"``, so recordings already on disk stay readable).
    default : str
        Timing of a record that does not say.

    Raises
    ------
    ValueError
        On a value that is not a known keyword, naming it and the keywords.
    """
    value = attrs.get("timing", default)
    if value in _LEGACY_TIMINGS:
        return "hold"
    if not isinstance(value, str) or value not in TIMINGS:
        raise DataError(f"attrs['timing'] must be one of {sorted(TIMINGS)}, got {value!r:.60}")
    return str(value)


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_record(df: pd.DataFrame, path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
    """Write a record as CSV with its ``attrs`` as JSON in a commented first line.

    Floats are written with full precision (``repr``), so a record read back
    equals the one written. The file is written whole
    (:func:`motorid.outputs.write_file`): a reader never sees part of it.

    Parameters
    ----------
    df : pandas.DataFrame
        The record; its ``attrs`` must be JSON-serialisable (numpy scalars are
        converted).
    path : str or path-like
        Destination file.
    overwrite : bool
        Replace an existing file (the default); False refuses one, also one
        another process created meanwhile.

    Raises
    ------
    motorid.errors.OutputError
        The file exists (without ``overwrite``) or the disk is full; ``path`` is
        as it was.
    """
    from motorid.outputs import write_file

    attrs = _jsonable(dict(df.attrs))
    header = ATTRS_MARKER + json.dumps(attrs, separators=(",", ":"), allow_nan=False)
    if "\n" in header:
        raise ValueError("attrs must not contain line breaks")

    def write(fh: Any) -> None:
        fh.write(header + "\n")
        df.to_csv(fh, index=False, float_format=None, lineterminator="\n")

    write_file(path, write, overwrite=overwrite)
    logger.debug("wrote record %s: %d rows, columns %s", path, len(df), list(df.columns))


def _column_map(columns: Sequence[str] | Mapping[str, str] | None) -> dict[str, str]:
    """Canonical name -> name in the file."""
    if columns is None:
        return {c: c for c in REQUIRED_COLUMNS}
    if isinstance(columns, Mapping):
        mapping = {c: c for c in REQUIRED_COLUMNS}
        mapping.update({str(k): str(v) for k, v in columns.items()})
        return mapping
    return {str(c): str(c) for c in columns}


#: pandas < 3 parses floats exactly only when asked to; pandas 3 always does and deprecates the option.
_EXACT_FLOATS: dict[str, str] = (
    {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
)


def count_data_lines(path: str | os.PathLike[str], chunk_bytes: int = 1 << 24) -> int:
    """Number of line breaks in a file, counted in fixed-size binary chunks (bounded memory).

    A file whose last line has no line break counts one more. Used to refuse a
    record too long to hold in memory before it is parsed.

    Parameters
    ----------
    path : str or PathLike
        The file.
    chunk_bytes : int
        Bytes read at a time (the memory it takes).
    """
    count = 0
    last = b"\n"
    with open(path, "rb") as fh:
        while chunk := fh.read(chunk_bytes):
            count += chunk.count(b"\n")
            last = chunk[-1:]
    return count + (last != b"\n")


def _regular_file(name: str) -> int:
    """The size of ``name``; a DataError when it is missing, a folder or not a regular file.

    Checked with ``os.stat`` before the file is opened, so a FIFO or a device named
    like a record is refused at once instead of blocking the read.
    """
    try:
        info = os.stat(name)
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    if stat.S_ISDIR(info.st_mode):
        raise DataError(f"{name} is a folder, not a record file")
    if not stat.S_ISREG(info.st_mode):
        kind = "a FIFO" if stat.S_ISFIFO(info.st_mode) else "a device or socket"
        raise DataError(f"{name} is {kind}, not a regular file: a record is read from a file")
    return info.st_size


def _open_checked(path: str | os.PathLike[str]) -> str:
    """The first line of ``path`` (a UTF-8 BOM left out), or a DataError naming what keeps it from being a record."""
    name = os.fspath(path)
    size = _regular_file(name)
    try:
        with open(name, encoding="utf-8-sig") as fh:
            first = fh.readline()
    except UnicodeDecodeError as exc:
        raise DataError(
            f"{name} is not a text CSV file (byte {exc.start} of its first line is not UTF-8)"
        ) from None
    if not first.strip():
        raise DataError(f"{name} is empty" if size == 0 else f"{name}: line 1 is blank")
    return first


def _header(path: str, line: str, line_number: int, sep: str = ",") -> list[str]:
    """The column names of a header line; a DataError on a blank, empty or repeated name.

    Linear in the number of columns (a set of the names seen), so a header of a
    million columns is checked at once.
    """
    try:
        names = [name.strip() for name in next(csv.reader([line], delimiter=sep))]
    except csv.Error as exc:  # e.g. a field beyond the csv module's limit: a line with no separator
        raise DataError(f"{path}: line {line_number} is not a CSV header ({exc})") from None
    seen: set[str] = set()
    for position, name in enumerate(names):
        if not name:
            raise DataError(f"{path}: line {line_number}: column {position + 1} of the header has no name")
        if name in seen:
            raise DataError(f"{path}: line {line_number}: column name {name!r} appears twice in the header")
        seen.add(name)
    return names


#: Separators tried, in this order, when a CSV's is not given: the one that splits the header and
#: the first lines into the same number (at least 2) of fields, the most fields winning.
SEPARATORS: tuple[str, ...] = (",", ";", "\t", "|")
#: Lines after the header that the separator and decimal mark are detected from.
SNIFF_LINES = 50
_DECIMAL_COMMA = re.compile(r"^\s*[+-]?\d*,\d+(?:[eE][+-]?\d+)?\s*$")
_INTEGER = re.compile(r"^\s*[+-]?\d+\s*$")


def _fields(line: str, sep: str) -> list[str]:
    try:
        return next(csv.reader([line], delimiter=sep))
    except (csv.Error, StopIteration):  # a field beyond the csv module's limit: no such separator here
        return [line]


def _dialect(
    name: str, header: str, lines: list[str], sep: str | None, decimal: str | None
) -> tuple[str, str]:
    """The separator and decimal mark of a CSV: as given, else detected from its header and first lines.

    A decimal comma is detected when the separator is not a comma and a cell of
    the first lines is a number written with one (``1,25``).
    """
    given = (sep, decimal)
    if sep is None:
        best = (1, ",")
        for candidate in SEPARATORS:
            counts = [len(_fields(line, candidate)) for line in [header, *lines]]
            if counts[0] > best[0] and all(c == counts[0] for c in counts[1:]):
                best = (counts[0], candidate)
        sep = best[1]
    if decimal is None:
        cells = (cell for line in lines for cell in _fields(line, sep))
        decimal = "," if sep != "," and any(_DECIMAL_COMMA.match(cell) for cell in cells) else "."
    logger.info("%s: separator %r (%s), decimal mark %r (%s)", name, sep, "detected" if given[0] is None else "given",
                decimal, "detected" if given[1] is None else "given")  # fmt: skip
    return sep, decimal


def check_dialect(sep: str | None, decimal: str | None) -> None:
    """Refuse a CSV separator or decimal mark the reader cannot use (one character each, not the same)."""
    if sep is not None and (not isinstance(sep, str) or len(sep) != 1 or sep in '\r\n".'):
        raise DataError(f"sep (--sep) must be one character such as ',', ';' or a tab, got {sep!r}")
    if decimal is not None and decimal not in (".", ","):
        raise DataError(f"decimal (--decimal) must be '.' or ',', got {decimal!r}")
    if sep is not None and sep == decimal:
        raise DataError(
            f"sep (--sep) and decimal (--decimal) are both {sep!r}: a CSV cannot use one for both"
        )


def _count_lines_and(path: str, sep: str, chunk_bytes: int = 1 << 20) -> tuple[int, int]:
    """Line breaks (one more when the last line has none) and separators in a file, in bounded memory."""
    lines = seps = 0
    last = b"\n"
    mark = sep.encode()
    with open(path, "rb") as fh:
        while chunk := fh.read(chunk_bytes):
            lines += chunk.count(b"\n")
            seps += chunk.count(mark)
            last = chunk[-1:]
    return lines + (last != b"\n"), seps


def _check_fields(name: str, skip: int, sep: str, width: int) -> None:
    """Raise a DataError naming the first data row whose number of fields is not the header's ``width``."""
    with open(name, encoding="utf-8-sig", newline="") as fh:
        for _ in range(skip + 1):
            fh.readline()
        for row, fields in enumerate(csv.reader(fh, delimiter=sep)):
            if fields and len(fields) != width:
                raise DataError(
                    f"row {row} (line {skip + 2 + row} of {name}) has {len(fields)} fields, the header "
                    f"has {width}" + ("; is the separator right? (--sep)" if len(fields) > width else "")
                )


def _parse_columns(
    path: str, skip: int, names: list[str], sep: str = ",", decimal: str = ".",
    integers: Sequence[str] = (), chunk_rows: int = 1_000_000,
) -> pd.DataFrame:  # fmt: skip
    """The data rows of ``names`` as float64 (``integers`` as int64), naming the first bad cell.

    The fast path parses floats directly, exactly (so a record written with
    :func:`write_record` reads back bit for bit); a time column of integers
    (``millis()``, nanoseconds since 1970) is kept as int64, exactly. Only when
    this fails are the cells read as text, in chunks of ``chunk_rows`` rows
    (bounded memory), to find and name the first non-numeric, NaN or infinite one.
    """
    options = csv_data_options(skip, names, sep, decimal)
    for ints in (list(integers), []) if integers else ([],):
        dtypes = {name: np.int64 if name in ints else np.float64 for name in names}
        try:
            data = pd.read_csv(path, dtype=dtypes, **options)
            if all(np.isfinite(data[name].to_numpy()).all() for name in names if name not in ints):
                return data[names]
            break
        except (ValueError, OverflowError):
            pass  # an integer column holds a fraction, or a cell is not a number: found and named below
    raise_bad_cell(path, skip, names, sep, decimal, chunk_rows)


def csv_data_options(skip: int, names: list[str], sep: str = ",", decimal: str = ".") -> dict[str, Any]:
    """The options of :func:`pandas.read_csv` that parse the data rows of a CSV record (the
    ``skip`` lines before the header, the columns ``names``, the separator and decimal mark):
    one place for the whole-record read and the read in blocks (:mod:`motorid.record_chunks`)."""
    return {"skiprows": skip, "usecols": names, "sep": sep, "decimal": decimal, "encoding": "utf-8-sig",
            **_EXACT_FLOATS}  # fmt: skip


def raise_bad_cell(
    path: str, skip: int, names: list[str], sep: str = ",", decimal: str = ".", chunk_rows: int = 1_000_000
) -> None:
    """Raise a DataError naming the first non-numeric, NaN or infinite cell of the columns ``names``
    of a CSV record, read as text from the start in chunks of ``chunk_rows`` rows (bounded memory)."""
    options = {key: value for key, value in csv_data_options(skip, names, sep, decimal).items()
               if key not in _EXACT_FLOATS}  # fmt: skip
    with pd.read_csv(
        path, dtype=str, keep_default_na=False, chunksize=chunk_rows, **options
    ) as reader:  # closed when a bad cell is raised
        _name_bad_cell(path, reader, names, skip + 1, decimal)
    raise DataError(f"{path}: the columns {names} do not parse as numbers")  # the fast path failed on a quirk


def _name_bad_cell(path: str, reader: Any, names: list[str], header_line: int, decimal: str = ".") -> None:
    """Raise a DataError naming the first non-numeric, NaN or infinite cell of the chunks of ``reader``."""
    for chunk in reader:
        for name in names:
            text = chunk[name].str.strip()
            numbers = text.str.replace(",", ".", regex=False) if decimal == "," else text
            values = pd.to_numeric(numbers, errors="coerce").to_numpy(dtype=float)
            bad = np.flatnonzero(~np.isfinite(values))
            if bad.size:
                row = int(chunk.index[bad[0]])
                raw = text.iloc[bad[0]]
                if raw.lower() in ("", "nan", "na", "null", "none"):
                    kind = "a NaN"
                elif np.isinf(values[bad[0]]):
                    kind = "an infinite"
                else:
                    kind = "a non-numeric"
                hint = (
                    "; is it a decimal comma? (--decimal ,)"
                    if decimal == "." and _DECIMAL_COMMA.match(raw)
                    else ""
                )
                raise DataError(
                    f"column {name!r} has {kind} value {raw!r} at row {row} (line {header_line + 1 + row} of {path})"
                    + hint
                )


#: Formats :func:`read_record` reads besides CSV, by file-name extension (any other extension is CSV).
RECORD_FORMATS: dict[str, str] = {
    ".parquet": "Parquet",
    ".pq": "Parquet",
    ".mat": "MATLAB",
    ".tdms": "TDMS",
    ".h5": "HDF5",
    ".hdf5": "HDF5",
}
#: Where a record's attributes (the JSON of the CSV attribute line) sit in the other formats: a key of
#: a Parquet file's schema metadata, a root property of a TDMS file, a root attribute of an HDF5 file.
ATTRS_KEY = "motorid-record"
#: The same JSON in a MATLAB file: a char variable (MATLAB names take no hyphen).
MAT_ATTRS_VARIABLE = "motorid_record"


def record_format(path: str | os.PathLike[str]) -> str:
    """The format :func:`read_record` reads ``path`` as: a value of :data:`RECORD_FORMATS`, else ``"CSV"``.

    Parameters
    ----------
    path : str or PathLike
        The record file; only its extension is looked at.
    """
    return RECORD_FORMATS.get(os.path.splitext(os.fspath(path))[1].lower(), "CSV")


def _attrs_from_json(text: Any, name: str, where: str) -> dict[str, Any]:
    """The attributes stored as JSON text (str or bytes) at ``where`` in file ``name``; {} when absent.

    Parsed within bounds (:func:`motorid.json_input.parse_json`) and checked by :func:`check_attrs`.
    """
    if text is None:
        return {}
    if isinstance(text, np.ndarray):  # a MATLAB char variable reads as an array of one string
        text = "".join(str(v) for v in text.ravel())
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    if not isinstance(text, str):
        raise DataError(f"{name}: the record attributes in {where} are not text but {type(text).__name__}")
    source = f"{name}: the record attributes in {where}"
    attrs = parse_json(text, source, "attrs")
    if not isinstance(attrs, dict):
        raise DataError(f"{source} are not a JSON object")
    check_attrs(attrs, source)
    return attrs


def check_attrs(attrs: Mapping[str, Any], source: str) -> None:
    """Check the attributes motorid reads back for type and range (others are kept unread).

    ``dt`` a sample time [s] in :data:`~motorid.drive.ranges.SAMPLE_TIME`; ``units`` and
    ``converted_from`` objects of column -> unit, each unit one of
    :data:`motorid.units.RECORD_UNITS`; ``timing`` a keyword of :data:`TIMINGS`;
    ``drive``, ``time`` and ``integrator`` text; ``samples`` an integer >= 0 and
    ``seed`` one or null; ``rig`` and ``model`` objects.

    Parameters
    ----------
    attrs : Mapping
        The record's attributes, as read from its file.
    source : str
        Names the file (and where in it the attributes are) in the error.

    Raises
    ------
    DataError
        ``{source}: attrs.dt must be ..., got "abc"``, naming the key.
    """
    from motorid.drive.ranges import SAMPLE_TIME
    from motorid.units import check_unit

    def shown(value: Any) -> str:
        return f"{value!r:.60}"

    if "dt" in attrs:
        dt = attrs["dt"]
        low, high = SAMPLE_TIME
        if isinstance(dt, bool) or not isinstance(dt, int | float) or not low <= dt <= high:
            raise DataError(
                f"{source}: attrs.dt must be a sample time in [{low:g}, {high:g}] s, got {shown(dt)}"
            )
    for key in ("units", "converted_from"):
        if key in attrs:
            if not isinstance(attrs[key], dict):
                raise DataError(
                    f"{source}: attrs.{key} must be an object of column: unit, got {shown(attrs[key])}"
                )
            for column, unit in attrs[key].items():
                check_unit(unit, column, f"{source}: attrs.{key}")
    if "timing" in attrs:
        try:
            record_timing(attrs)
        except DataError as exc:
            raise DataError(f"{source}: {exc}") from None
    if "time_origin" in attrs:
        origin = attrs["time_origin"]
        if isinstance(origin, bool) or not isinstance(origin, int | float) or not math.isfinite(origin):
            raise DataError(f"{source}: attrs.time_origin must be a time in s, got {shown(origin)}")
    for key in (DRIVE_ATTR, TIME_ATTR, "integrator"):
        if key in attrs and not isinstance(attrs[key], str):
            raise DataError(f"{source}: attrs.{key} must be text, got {shown(attrs[key])}")
    for key, nullable in (("samples", False), ("seed", True)):
        value = attrs.get(key, 0)
        if not (value is None and nullable) and (
            isinstance(value, bool) or not isinstance(value, int) or value < 0
        ):
            raise DataError(f"{source}: attrs.{key} must be an integer >= 0, got {shown(value)}")
    for key in ("rig", "model"):
        if key in attrs and not isinstance(attrs[key], dict):
            raise DataError(f"{source}: attrs.{key} must be an object, got {shown(attrs[key])}")


def _reason(exc: BaseException) -> str:
    """An exception of a format library as one line: its kind and the first line of its message."""
    lines = str(exc).strip().splitlines()
    text = lines[0] if lines else ""
    return f"{type(exc).__name__}: {text[:300]}" if text else type(exc).__name__


# A reader of a binary format: (file name, choose) -> (arrays by column name, attrs). ``choose`` is
# given the shape of every column the file holds and returns the names to load (it raises on a
# missing, ambiguous, misshapen or too long column), so nothing is loaded before it is checked.
Choose = Callable[[dict[str, tuple[int, ...]]], list[str]]


def _parquet_file(name: str) -> tuple[Any, dict[str, Any]]:
    """A Parquet file opened (a ``pyarrow.parquet.ParquetFile``) and its record attributes."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        parquet = pq.ParquetFile(name)
    except (pa.ArrowException, OSError) as exc:
        raise DataError(f"{name} is not a readable Parquet file: {_reason(exc)}") from None
    metadata = parquet.schema_arrow.metadata or {}
    return parquet, _attrs_from_json(metadata.get(ATTRS_KEY.encode()), name, "the schema metadata")


def _read_parquet(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    import pyarrow as pa

    parquet, attrs = _parquet_file(name)
    schema = parquet.schema_arrow
    rows = parquet.metadata.num_rows
    chosen = choose({column: (rows,) for column in schema.names})
    try:
        table = parquet.read(columns=chosen)
    except (pa.ArrowException, OSError) as exc:  # a corrupt page or a cut file
        raise DataError(
            f"{name}: its Parquet data cannot be read (corrupt or cut?): {_reason(exc)}"
        ) from None
    return {column: table.column(column).to_numpy() for column in chosen}, attrs


def _read_mat(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    import scipy.io

    try:
        listing = scipy.io.whosmat(name)
    except NotImplementedError:  # a MATLAB v7.3 file is an HDF5 file
        return _read_hdf5(name, choose)
    except Exception as exc:  # scipy raises many kinds on a file that is not MATLAB's
        raise DataError(f"{name} is not a readable MATLAB file: {_reason(exc)}") from None
    shapes = {var: tuple(shape) for var, shape, _ in listing if var != MAT_ATTRS_VARIABLE}
    chosen = choose(shapes)
    extra = [MAT_ATTRS_VARIABLE] if len(shapes) < len(listing) else []
    try:
        mat = scipy.io.loadmat(name, variable_names=chosen + extra)
    except Exception as exc:  # a cut or corrupt file: zlib, struct, OSError ... depending on where
        raise DataError(f"{name}: its MATLAB data cannot be read (cut or corrupt?): {_reason(exc)}") from None
    attrs = _attrs_from_json(mat.get(MAT_ATTRS_VARIABLE), name, f"the variable {MAT_ATTRS_VARIABLE}")
    return {var: np.asarray(mat[var]).reshape(-1) for var in chosen}, attrs


#: What h5py raises on a damaged HDF5 file.
HDF5_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError)


def _hdf5_file(name: str) -> tuple[Any, dict[str, tuple[int, ...]], dict[str, Any]]:
    """An HDF5 file opened (an ``h5py.File``, to be closed by the caller), the shape of each of
    its datasets by path, and its record attributes."""
    import h5py

    try:
        handle = h5py.File(name, "r")
    except OSError as exc:
        raise DataError(f"{name} is not a readable HDF5 file: {_reason(exc)}") from None
    shapes: dict[str, tuple[int, ...]] = {}

    def visit(key: str, item: Any) -> None:
        if isinstance(item, h5py.Dataset) and not key.startswith("#"):  # '#refs#': MATLAB's own
            shapes[key] = tuple(item.shape)

    try:
        try:
            handle.visititems(visit)
            text = handle.attrs.get(ATTRS_KEY)
        except HDF5_ERRORS as exc:  # a damaged file
            raise DataError(f"{name}: its HDF5 structure cannot be read (corrupt?): {_reason(exc)}") from None
        attrs = _attrs_from_json(text, name, f"the root attribute {ATTRS_KEY!r}")
    except BaseException:
        handle.close()
        raise
    return handle, shapes, attrs


def _read_hdf5(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    handle, shapes, attrs = _hdf5_file(name)
    with handle:
        chosen = choose(shapes)
        try:
            return {key: np.asarray(handle[key][()]).reshape(-1) for key in chosen}, attrs
        except HDF5_ERRORS as exc:
            raise DataError(f"{name}: its HDF5 data cannot be read (corrupt?): {_reason(exc)}") from None


class _Collected(logging.Handler):
    """The distinct messages a library logs while a file is read (to be said once, with the file's name)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        text = text if len(text) <= 200 else text[:200] + " ..."
        if text not in self.messages:
            self.messages.append(text)


def _read_tdms(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Columns ``group/channel``; ``dt`` from the channels' ``wf_increment`` when the file has no attrs' dt.

    npTDMS's own warnings (printed by its handler and again through the root logger) are
    collected while the file is read and logged once each, naming the file, when it is read.
    """
    from nptdms import TdmsFile
    from nptdms.log import log_manager

    collected = _Collected()
    loggers = [(log, log.propagate, list(log.handlers)) for log in log_manager.loggers.values()]
    for log, _, _ in loggers:
        log.propagate, log.handlers = False, [collected]
    try:
        columns = _tdms_columns(name, choose, TdmsFile)
    finally:
        for log, propagate, handlers in loggers:
            log.propagate, log.handlers = propagate, handlers
    for message in collected.messages:  # a refused file says only why it is refused
        logger.warning("%s: %s", name, message)
    return columns


def _tdms_columns(name: str, choose: Choose, tdms_file: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    try:
        tdms = tdms_file.open(name)
    except Exception as exc:  # npTDMS raises ValueError, KeyError, struct errors ... on a foreign file
        raise DataError(f"{name} is not a readable TDMS file: {_reason(exc)}") from None
    with tdms:
        channels = {f"{g.name}/{c.name}": c for g in tdms.groups() for c in g.channels()}
        if not channels:  # a header and then bytes that hold no channel
            raise DataError(f"{name} is not a readable TDMS file: it holds no channel")
        attrs = _attrs_from_json(tdms.properties.get(ATTRS_KEY), name, f"the file property {ATTRS_KEY!r}")
        chosen = choose({key: (len(channel),) for key, channel in channels.items()})
        increments = {channels[key].properties.get("wf_increment") for key in chosen}
        if "dt" not in attrs and len(increments) == 1 and None not in increments:
            attrs["dt"] = float(increments.pop())
        try:
            return {key: np.asarray(channels[key][:]) for key in chosen}, attrs
        except Exception as exc:  # a damaged data segment
            raise DataError(
                f"{name}: its TDMS data cannot be read (corrupt or cut?): {_reason(exc)}"
            ) from None


_READERS: dict[str, Callable[[str, Choose], tuple[dict[str, np.ndarray], dict[str, Any]]]] = {
    "Parquet": _read_parquet,
    "MATLAB": _read_mat,
    "HDF5": _read_hdf5,
    "TDMS": _read_tdms,
}


def _find_column(name: str, column: str, present: list[str]) -> str | None:
    """The name in the file of ``column``: itself, or the one ``group/column`` of a TDMS or HDF5 file."""
    if column in present:
        return column
    nested = [key for key in present if key.rsplit("/", 1)[-1] == column]
    if len(nested) > 1:
        raise DataError(f"column {column!r} is ambiguous in {name}: {nested}; name one of them")
    return nested[0] if nested else None


def _samples(shape: tuple[int, ...]) -> int | None:
    """Number of samples of an array that is one column (at most one axis longer than 1), else None."""
    return math.prod(shape) if sum(n > 1 for n in shape) <= 1 else None


def _column_chooser(
    name: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None, found: dict[str, str],
    optional: set[str] = frozenset(),  # type: ignore[assignment]
) -> Choose:  # fmt: skip
    """The ``choose`` of a binary reader: it checks the columns of ``mapping`` against the shapes the
    file holds (``optional`` ones may be absent), records each one's key in ``found`` (key in the
    file -> canonical name) and returns the keys to load (with the other columns of the same
    length when ``other_columns``)."""

    def choose(shapes: dict[str, tuple[int, ...]]) -> list[str]:
        present = list(shapes)
        for canonical, column in mapping.items():
            key = _find_column(name, column, present)
            if key is None and canonical in optional:
                continue
            if key is None:
                raise DataError(
                    f"column {column!r} is missing from {name}"
                    + (f" (needed as {canonical!r})" if column != canonical else "")
                    + f"; columns are {present}"
                )
            if _samples(shapes[key]) is None:
                raise DataError(
                    f"column {column!r} of {name} is not one column of samples (shape {shapes[key]})"
                )
            found[key] = canonical
        first = next(iter(found))
        rows = _samples(shapes[first])
        for key in found:
            if _samples(shapes[key]) != rows:
                raise DataError(
                    f"column {key!r} of {name} has {_samples(shapes[key])} samples, column {first!r} has {rows}"
                )
        if not rows:
            raise DataError(f"{name} has columns but no samples")
        check_row_limit(name, rows, max_samples)
        replaced = {k for k, v in mapping.items() if v != k}  # a canonical name that a named column takes
        others = [
            k for k in present
            if k not in found and _samples(shapes[k]) == rows and _short_name(k, present) not in replaced
        ] if other_columns else []  # fmt: skip
        return [k for k in present if k in found or k in others]

    return choose


def _read_binary(
    name: str, kind: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None,
    optional: set[str] = frozenset(),  # type: ignore[assignment]
) -> tuple[pd.DataFrame, dict[str, Any]]:  # fmt: skip
    """The columns of a Parquet, MATLAB, HDF5 or TDMS record as float64, checked as a CSV's are.

    Other columns (``other_columns``) are those of the same length that are numbers, named as in
    the file (a nested one by its last part when that is unique); the rest of the file (scalars,
    matrices, text) is left out.
    """
    if _regular_file(name) == 0:
        raise DataError(f"{name} is empty")
    found: dict[str, str] = {}
    choose = _column_chooser(name, mapping, other_columns, max_samples, found, optional)
    arrays, attrs = _READERS[kind](name, choose)
    columns: dict[str, np.ndarray] = {}
    for key, values in arrays.items():
        if values.dtype.kind not in "fiub" and key not in found:
            continue
        columns[found[key] if key in found else _short_name(key, list(arrays))] = binary_column(
            name, key, values, found.get(key) == "t"
        )
    return pd.DataFrame(columns), attrs


def binary_column(name: str, key: str, values: np.ndarray, time: bool, first_row: int = 0) -> np.ndarray:
    """Column ``key`` of the binary record ``name`` as float64 (a time column of integers as int64,
    exactly: nanoseconds since 1970 exceed float64's digits), or a DataError naming it when it is
    not numeric, or its first NaN or infinite value by row (``first_row`` is the row of
    ``values[0]`` in the file: one place for the whole-record read and the read in blocks)."""
    if values.dtype.kind not in "fiub":
        raise DataError(f"column {key!r} of {name} is not numeric (its values are {values.dtype})")
    if time and values.dtype.kind in "iu":
        return values.astype(np.int64)
    values = values.astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        kind_of = "a NaN" if np.isnan(values[bad[0]]) else "an infinite"
        raise DataError(
            f"column {key!r} has {kind_of} value {values[bad[0]]!r} at row {first_row + int(bad[0])} of {name}"
        )
    return values


def _short_name(key: str, keys: list[str]) -> str:
    """``group/name`` as ``name`` when no other of ``keys`` ends in that name."""
    last = key.rsplit("/", 1)[-1]
    return last if sum(k.rsplit("/", 1)[-1] == last for k in keys) == 1 else key


#: Units a time column may be in, with their factor to seconds.
#: Largest deviation of a time step from the sample time, as a share of it, that is taken for a
#: logger's jitter (``millis()`` stamps a 10 ms loop 9, 10 or 11 ms apart) rather than a fault:
#: such a record is put on a uniform grid. A step of 1.5 sample times or more is a gap.
JITTER_LIMIT = 0.4
#: Sample times [s] a time column may give without a stated ``dt``: a median step outside them is a
#: time column read in the wrong unit (``millis()`` read as seconds gives 10 s; ms read as ns, 10 ns).
SAMPLE_TIMES = (1e-6, 1.0)
#: How far the mean step of a jittered record may be from a ``dt`` given for it (relative).
JITTER_DT_RTOL = 0.02


@dataclass(frozen=True)
class RecordOptions:
    """How a record is read: the options of :func:`read_record` and :func:`normalise_record`,
    the same as the command line's (``--time``, ``--time-unit``, ``--input-unit`` ...).

    Attributes
    ----------
    time, input, output : str, optional
        Names of the time, input and output columns (default ``t``, ``u``,
        ``y``); any text, ``"Zeit [s]"`` too. They are renamed to ``t``, ``u``,
        ``y``. A time column not named explicitly may be absent when ``dt`` is known
        (given, or from the file).
    dt : float, optional
        Sample time [s]; a time column that says otherwise is refused.
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the time column (default: the record's ``attrs["units"]["t"]``,
        else seconds). Unless ``dt`` is given or in the file, a column whose median
        step is outside :data:`SAMPLE_TIMES` in this unit (``millis()`` read as
        seconds: 10 s) is refused with a message naming the option.
    input_unit, output_unit : str, optional
        Units of the input and output columns (:data:`motorid.units.INPUT_UNITS`,
        :data:`motorid.units.OUTPUT_UNITS`), converted as they are read
        (:func:`motorid.units.convert_record`).
    supply_voltage : float, optional
        Supply voltage [V] of a PWM drive: duty in % (or counts) becomes volts.
    input_full_scale : float, optional
        The count of full duty, for ``input_unit="counts"`` (255 for an 8-bit PWM).
    resample : bool
        Put a record with gaps (missing samples) on the uniform grid too, instead
        of refusing it.
    dt_rtol : float
        Relative tolerance on the uniformity of the time steps (default 0.1 %: a
        measured time column carries clock jitter, e.g. 2e-5 relative in EMPS).
    """

    time: str | None = None
    input: str | None = None
    output: str | None = None
    dt: float | None = None
    time_unit: str | None = None
    input_unit: str | None = None
    output_unit: str | None = None
    supply_voltage: float | None = None
    input_full_scale: float | None = None
    resample: bool = False
    dt_rtol: float = 1e-3

    def __post_init__(self) -> None:
        for key in ("time", "input", "output"):
            value = getattr(self, key)
            if value is not None and (not isinstance(value, str) or not value.strip()):
                raise DataError(f"{key} must name a column (a non-empty text), got {value!r}")
        named = [
            (key, getattr(self, key) or canonical)
            for key, canonical in zip(("time", "input", "output"), REQUIRED_COLUMNS, strict=True)
        ]
        for position, (key, column) in enumerate(named):
            for other, first in named[:position]:
                if first == column:
                    raise DataError(
                        f"{key} (--{key}) {column!r} is the same column as {other} (--{other}): "
                        "each must name its own column"
                    )
        if self.dt is not None and (isinstance(self.dt, bool) or not isinstance(self.dt, int | float)
                                    or not math.isfinite(self.dt) or self.dt <= 0.0):  # fmt: skip
            raise DataError(f"dt must be finite and > 0, got {self.dt!r}")
        if self.time_unit is not None and self.time_unit not in TIME_UNITS:
            raise DataError(
                f"time_unit (--time-unit) must be one of {', '.join(TIME_UNITS)}, got {self.time_unit!r}"
            )
        if not isinstance(self.resample, bool):
            raise DataError(f"resample must be True or False, got {self.resample!r}")

    def column_map(self, columns: Sequence[str] | Mapping[str, str] | None = None) -> dict[str, str]:
        """Canonical name -> name in the file: ``columns`` (as :func:`read_record` takes it) and the names."""
        mapping = _column_map(columns)
        for canonical, given in zip(REQUIRED_COLUMNS, (self.time, self.input, self.output), strict=True):
            if given is not None:
                mapping[canonical] = given
        return mapping

    def time_optional(self, columns: Sequence[str] | Mapping[str, str] | None = None) -> bool:
        """Whether the time column may be missing: it was not named (``time`` or in ``columns``)."""
        return self.time is None and not (columns is not None and "t" in columns)


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
    sep: str | None = None,
    decimal: str | None = None,
) -> pd.DataFrame:
    """Read and check a record: CSV (as :func:`write_record` writes it, or any CSV) or a DAQ's file.

    The format comes from the extension (:func:`record_format`): ``.parquet``/``.pq``
    (Parquet), ``.mat`` (MATLAB: one variable per column, a row or column vector,
    as EMPS; v7.3 files too), ``.tdms`` (NI TDMS: a column per channel, named
    ``group/channel`` or by the channel's name alone when no other group has one
    of that name), ``.h5``/``.hdf5`` (HDF5: a column per one-dimensional dataset,
    named by its path), anything else CSV (any separator, a decimal comma, a UTF-8
    BOM). The attributes come from the CSV attribute line or the format's place for
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
    sep : str, optional
        Separator of a CSV (one character; ``--sep``). Default: detected from the
        header and the first lines among :data:`SEPARATORS` (logged at INFO, ``-v``).
    decimal : {".", ","}, optional
        Decimal mark of a CSV (``--decimal``). Default: ``,`` when the separator is
        not a comma and the first lines hold numbers written with one.

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
        resample=resample, dt_rtol=dt_rtol,
    )  # fmt: skip
    check_dialect(sep, decimal)
    name = os.fspath(path)
    mapping = options.column_map(columns)
    optional = {"t"} if options.time_optional(columns) else set()
    kind = record_format(name)
    if kind == "CSV":
        rec, attrs, header_line = _read_csv(name, mapping, optional, other_columns, max_samples, sep, decimal)
        where = row_place(name, header_line)
    else:
        rec, attrs = _read_binary(name, kind, mapping, other_columns, max_samples, optional)
        where = row_place(name, None)
    names = {canonical: mapping[canonical] for canonical in REQUIRED_COLUMNS if canonical in mapping}
    return _normalised(name, rec, attrs, where, options, min_samples, names)


def row_place(name: str, header_line: int | None) -> Callable[[int], str]:
    """How an error names data row ``row`` of file ``name``: with its line in a CSV (whose header is
    on line ``header_line``), by the row alone in the other formats."""
    if header_line is None:
        return lambda row: f"row {row} of {name}"
    return lambda row: f"row {row} (line {header_line + 1 + row} of {name})"


def normalise_record(
    record: pd.DataFrame,
    *,
    time: str | None = None,
    input: str | None = None,
    output: str | None = None,
    dt: float | None = None,
    time_unit: str | None = None,
    input_unit: str | None = None,
    output_unit: str | None = None,
    supply_voltage: float | None = None,
    input_full_scale: float | None = None,
    resample: bool = False,
    dt_rtol: float = 1e-3,
    min_samples: int = 2,
) -> pd.DataFrame:
    """A DataFrame from the user's own code as a motorid record, with the options :func:`read_record` takes.

    The named columns become ``t`` [s], ``u`` and ``y``, converted to motorid's
    units; the time column (seconds, or ``time_unit``; a ``datetime64`` column
    too) is checked and shifted to start at 0 (its first stamp is kept in
    ``attrs["time_origin"]`` [s]), so ``millis()`` since boot or Unix time in ns
    read alike, without losing precision. Time stamps that jitter around a
    uniform step by up to :data:`JITTER_LIMIT` of it, with no sample missing, are
    put on the uniform grid of the sample time (``dt`` if given, else the
    record's ``attrs["dt"]``, else the median step): the input is held from each
    stamp to the next (zero-order hold, as a drive holds its command), the output
    and any other column are interpolated linearly; a warning states the jitter
    once. Gaps of missing samples are refused naming the row, unless
    ``resample`` (then the grid spans them too, and the warning says so).

    Parameters
    ----------
    record : pandas.DataFrame
        The measurement; ``attrs`` may hold ``dt`` and ``units``.
    time, input, output, dt, time_unit, input_unit, output_unit, supply_voltage, input_full_scale, resample, dt_rtol : optional
        As :class:`RecordOptions`.
    min_samples : int
        Fewest rows accepted, >= 1.

    Returns
    -------
    pandas.DataFrame
        A new record: float64 columns ``t`` (when there is a time column), ``u``,
        ``y`` and the others; ``attrs["dt"]`` set and ``attrs["units"]`` naming
        what is known.

    Raises
    ------
    DataError
        The checks of :func:`read_record`, naming the column and the row.
    """
    if not isinstance(record, pd.DataFrame):
        raise DataError(f"record must be a pandas DataFrame, got {type(record).__name__}")
    options = RecordOptions(
        time=time, input=input, output=output, dt=dt, time_unit=time_unit, input_unit=input_unit,
        output_unit=output_unit, supply_voltage=supply_voltage, input_full_scale=input_full_scale,
        resample=resample, dt_rtol=dt_rtol,
    )  # fmt: skip
    mapping = options.column_map()
    present = [str(c) for c in record.columns]
    for canonical, column in mapping.items():
        if column not in present and not (canonical == "t" and options.time_optional()):
            raise DataError(
                f"column {column!r} is missing from the record"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {present}"
            )
    mapping = {k: v for k, v in mapping.items() if v in present}
    renamed = {v: k for k, v in mapping.items()}
    attrs = dict(record.attrs)
    time_unit_of_dates = None
    columns: dict[str, np.ndarray] = {}
    for column in record.columns:
        key = renamed.get(str(column), str(column))
        if key in columns or (key in mapping and str(column) != mapping[key]):
            continue  # a column of the canonical name that a named column replaces
        series = record[column]
        if key == "t" and pd.api.types.is_datetime64_any_dtype(series):
            values = series.to_numpy().astype("datetime64[ns]").astype(np.int64)
            time_unit_of_dates = "ns"
        elif key == "t" and pd.api.types.is_integer_dtype(series):
            values = series.to_numpy(dtype=np.int64)
        else:
            numbers = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)
            bad = np.flatnonzero(~np.isfinite(numbers))
            if bad.size:
                if key in mapping:
                    raise DataError(f"column {str(column)!r} is not a finite number at sample {int(bad[0])}: "
                                    f"{series.iloc[int(bad[0])]!r}")  # fmt: skip
                continue  # another column that is not numbers is left out, as the readers do
            values = numbers
        columns[key] = values
    rec = pd.DataFrame(columns)
    if time_unit_of_dates is not None:
        options = replace(options, time_unit=time_unit_of_dates)
    names = {canonical: mapping[canonical] for canonical in REQUIRED_COLUMNS if canonical in mapping}
    return _normalised("the record", rec, attrs, lambda row: f"sample {row}", options, min_samples, names)


@dataclass(frozen=True)
class CsvLayout:
    """What a CSV record's first lines say: its attrs, the lines before its header (``skip``), its
    column names, separator and decimal mark (as given or detected), the time column read as
    integers (``millis()``, ns since 1970; none when its first lines are not integers) and the
    number of data rows."""

    attrs: dict[str, Any]
    skip: int
    present: list[str]
    sep: str
    decimal: str
    integers: list[str]
    rows: int


def csv_layout(name: str, mapping: dict[str, str], optional: set[str], sep: str | None,
               decimal: str | None) -> CsvLayout:  # fmt: skip
    """The layout of a CSV record, once the columns of ``mapping`` are found in its header and
    every data row has the header's number of fields (checked in one pass over the file in
    bounded memory): one place for the whole-record read and the read in blocks
    (:mod:`motorid.record_chunks`).

    Parameters
    ----------
    name : str
        The CSV file; the messages name it.
    mapping : dict of str to str
        Canonical name -> the column's name in the file; a column missing from the header is a
        DataError. Changed in place: an ``optional`` column that is absent is taken out.
    optional : set of str
        The canonical names that may be absent (``{"t"}`` when the sample time is known).
    sep : str, optional
        The separator (one character); None: detected from the header and the first lines.
    decimal : {".", ","}, optional
        The decimal mark; None: detected from the first lines.
    """
    first = _open_checked(name)
    attrs: dict[str, Any] = {}
    skip = 0
    if first.startswith(ATTRS_MARKER):
        attrs = _attrs_from_json(first[len(ATTRS_MARKER) :], name, "the attribute line (line 1)")
        skip = 1
    with open(name, encoding="utf-8-sig") as fh:
        header_text = [fh.readline() for _ in range(skip + 1)][-1]
        sample = [line for _ in range(SNIFF_LINES) if (line := fh.readline()).strip()]
    if not header_text.strip():
        raise DataError(f"{name} has no header line (line {skip + 1} is empty)")
    sep, decimal = _dialect(name, header_text, sample, sep, decimal)
    present = _header(name, header_text, skip + 1, sep)
    for canonical, column in list(mapping.items()):
        if column not in present:
            if canonical in optional:
                del mapping[canonical]
                continue
            hint = ""
            if len(present) == 1:
                hint = (f"; the header splits into one column with the separator {sep!r}: "
                        "name the file's separator with --sep (sep=...)")  # fmt: skip
            raise DataError(
                f"column {column!r} is missing from {name}"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {present}{hint}"
            )
    lines, separators = _count_lines_and(name, sep)
    rows = lines - skip - 1
    if rows <= 0:
        raise DataError(f"{name} has a header but no data rows")
    head_separators = sum(line.count(sep) for line in ([first] if skip else []) + [header_text])
    if separators - head_separators != rows * (len(present) - 1):
        _check_fields(name, skip, sep, len(present))  # names the row; quoted separators pass
    integers = []
    if "t" in mapping:
        position = present.index(mapping["t"])
        cells = [_fields(line, sep) for line in sample]
        if cells and all(len(c) > position and _INTEGER.match(c[position]) for c in cells):
            integers = [mapping["t"]]
    return CsvLayout(attrs, skip, present, sep, decimal, integers, rows)


def _read_csv(
    name: str,
    mapping: dict[str, str],
    optional: set[str],
    other_columns: bool,
    max_samples: int | None,
    sep: str | None,
    decimal: str | None,
) -> tuple[pd.DataFrame, dict[str, Any], int]:
    """The columns of a CSV record, its attrs and the line number of its header."""
    layout = csv_layout(name, mapping, optional, sep, decimal)
    check_row_limit(name, layout.rows, max_samples)
    replaced = {k for k, v in mapping.items() if v != k}  # a column of a canonical name a named one takes
    wanted = [c for c in layout.present if c in mapping.values() or (other_columns and c not in replaced)]
    rec = _parse_columns(name, layout.skip, wanted, layout.sep, layout.decimal, layout.integers)
    rec = rec.rename(columns={v: k for k, v in mapping.items() if v != k})
    return rec.reset_index(drop=True), layout.attrs, layout.skip + 1


def _seconds(value: float) -> str:
    """A duration for a message: ``10 ms``, ``1.2 ms``, ``250 us``, ``0.5 s``."""
    for unit, factor in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if abs(value) >= factor or unit == "us":
            return f"{value / factor:.3g} {unit}"
    return f"{value:.3g} s"  # pragma: no cover (the loop always returns)


def _normalised(
    name: str,
    rec: pd.DataFrame,
    attrs: dict[str, Any],
    where: Callable[[int], str],
    options: RecordOptions,
    min_samples: int,
    names: dict[str, str],
) -> pd.DataFrame:
    """The record in motorid's names and units, ``attrs["dt"]`` set, once its length and time pass the checks.

    ``names`` maps ``t``, ``u``, ``y`` to their names in the file, for the messages.
    """
    from motorid.units import convert_record

    if len(rec) < min_samples:
        plural = "" if len(rec) == 1 else "s"
        raise DataError(f"{name} has {len(rec)} sample{plural}; at least {min_samples} are needed")
    named_attrs(name, attrs, options, names)
    if "t" in rec.columns:
        rec = _on_uniform_time(name, rec, attrs, where, options, names.get("t", "t"))
    else:
        untimed_dt(name, attrs, options, names)
    if "t" not in rec.columns and len(rec.columns):
        rec.insert(0, "t", np.arange(len(rec)) * float(attrs["dt"]))  # the time the sample time gives
        attrs.setdefault("units", {})["t"] = "s"
    rec.attrs.update(attrs)
    return convert_record(
        rec, options.input_unit, options.output_unit, options.supply_voltage,
        input_full_scale=options.input_full_scale, where=where, column=names.get("u", "u"),
    )  # fmt: skip


def check_increasing(raw: np.ndarray, where: Callable[[int], str], column: str) -> None:
    """Refuse time stamps ``raw`` that do not increase, naming the row (``where(k)`` names ``raw[k]``)."""
    nonpos = np.flatnonzero(np.diff(raw) <= 0)
    if nonpos.size:
        row = int(nonpos[0]) + 1
        raise DataError(
            f"column {column!r} is not increasing at {where(row)}: {raw[row].item()!r} after {raw[row - 1].item()!r}"
        )


def time_base(
    name: str,
    raw: np.ndarray,
    attrs: dict[str, Any],
    where: Callable[[int], str],
    options: RecordOptions,
    column: str,
) -> tuple[np.ndarray, float, float]:
    """The time stamps ``raw`` of a record (or of its first block) in s from 0, its sample time [s]
    and the factor from the stamps' unit to seconds.

    Checks that they increase, finds their unit (``time_unit``, else the attrs', else s;
    a median step outside :data:`SAMPLE_TIMES` is refused unless a ``dt`` is known) and
    the sample time (``dt``, else the file's, else the median step; a ``dt`` the stamps
    contradict is refused), and sets ``attrs`` (``dt``, ``time_origin``, the unit of ``t``).
    A later block's stamps are ``(raw - raw[0]) * factor`` in seconds, with the first block's ``raw[0]``.
    """
    check_increasing(raw, where, column)
    steps_raw = np.diff(raw)
    declared = (attrs.get("units") or {}).get("t")
    unit = options.time_unit or (declared if declared in TIME_UNITS else None)
    dt, file_dt = options.dt, attrs.get("dt")
    median_raw = float(np.median(steps_raw)) if steps_raw.size else 0.0
    scale = TIME_UNITS[unit or "s"]
    if (
        steps_raw.size
        and dt is None
        and file_dt is None
        and not SAMPLE_TIMES[0] <= median_raw * scale < SAMPLE_TIMES[1]
    ):
        raise DataError(
            f"column {column!r} of {name} steps by {median_raw:g} per sample: read in {unit or 's'} that is a "
            f"sample time of {median_raw * scale:g} s; loggers stamp in s, ms, us or ns: say which with "
            "--time-unit (time_unit=...), or give the sample time with --dt"
        )
    t = (raw - raw[0]).astype(np.float64) * scale  # the origin off first, in the file's numbers: exact
    if raw[0] != 0:
        attrs["time_origin"] = float(raw[0]) * scale
    steps = np.diff(t)
    median = float(np.median(steps_raw)) * scale if steps.size else None  # from the file's numbers: exact
    if dt is not None and median is not None and not math.isclose(dt, median, rel_tol=options.dt_rtol):
        within = np.abs(steps - median) <= JITTER_LIMIT * median
        mean = float(np.mean(steps[within])) if within.any() else median
        if not math.isclose(dt, mean, rel_tol=JITTER_DT_RTOL):
            raise DataError(
                f"dt = {_seconds(dt)} (--dt) contradicts the time column {column!r} of {name}, which steps "
                f"by {_seconds(median)}; leave --dt out or correct it"
                + ("" if options.time_unit else " (or give the time column's unit with --time-unit)")
            )
    expected = dt if dt is not None else file_dt if file_dt is not None else median
    if expected is None:  # one sample and no dt
        raise DataError(f"{name}: one sample and no dt given: the sample time is unknown (--dt)")
    expected = float(expected)
    attrs["dt"] = expected
    units = attrs.setdefault("units", {})
    units["t"] = "s"
    if unit not in (None, "s"):
        attrs.setdefault("converted_from", {})["t"] = unit
    return t, expected, scale


def steps_off_grid(
    steps: np.ndarray, expected: float, where: Callable[[int], str], options: RecordOptions, column: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """None when every time step [s] is within ``dt_rtol`` of the sample time ``expected``; else
    the steps' deviations, which of them are jitter (within :data:`JITTER_LIMIT`), and the
    positions of the gaps (missing samples) and of the other odd steps, to be resampled.

    Without ``resample``, the first gap or odd step is refused, naming its row (``where(k + 1)``
    names the row after ``steps[k]``).
    """
    deviation = np.abs(steps - expected)
    if not np.any(deviation > options.dt_rtol * expected):
        return None
    ratio = steps / expected
    jittered = np.abs(ratio - 1.0) <= JITTER_LIMIT
    missing_samples = (ratio > 1.0 + JITTER_LIMIT) & (np.rint(ratio) >= 2)  # about a whole sample or more
    gaps = np.flatnonzero(missing_samples)
    odd = np.flatnonzero(~jittered & ~missing_samples)
    if not options.resample:
        if gaps.size and (not odd.size or gaps[0] < odd[0]):
            row = int(gaps[0]) + 1
            missing = int(np.rint(ratio[row - 1])) - 1
            raise DataError(
                f"column {column!r} has a gap of {missing} sample{'s' if missing > 1 else ''} before {where(row)}: "
                f"step {steps[row - 1]:.6g} s, expected dt = {expected:.6g} s (--resample puts the record on a "
                "uniform grid across it)"
            )
        if odd.size:
            row = int(odd[0]) + 1
            raise DataError(
                f"column {column!r} is not uniformly sampled at {where(row)}: step {steps[row - 1]:.6g} s, "
                f"expected dt = {expected:.6g} s (jitter up to {JITTER_LIMIT:.0%} of it is resampled; "
                "--resample resamples any)"
            )
    return deviation, jittered, gaps, odd


#: The units a named column's header may end with, in brackets, by canonical column.
HEADER_UNITS: dict[str, tuple[str, ...]] = {
    "t": tuple(TIME_UNITS),
    "u": tuple(INPUT_UNITS),
    "y": tuple(OUTPUT_UNITS),
}
#: How headers also write some of them: ``µs``, and revolutions per minute as ``1/min`` or ``U/min``.
HEADER_ALIASES: dict[str, str] = {"µs": "us", "μs": "us", "1/min": "rpm", "U/min": "rpm"}


def header_unit(column: str, canonical: str) -> str | None:
    """The unit a column's header ends with, ``Zeit [ms]`` or ``speed (rpm)``, when it is one of
    :data:`HEADER_UNITS` for the ``canonical`` column (or a :data:`HEADER_ALIASES` of one); None
    otherwise.

    Parameters
    ----------
    column : str
        The column's name in the file.
    canonical : {"t", "u", "y"}
        What it is read as.
    """
    found = re.search(r"[\[(]\s*([^\[\]()]+?)\s*[\])]\s*$", column)
    if found is None:
        return None
    unit = HEADER_ALIASES.get(found.group(1), found.group(1))
    return unit if unit in HEADER_UNITS.get(canonical, ()) else None


def named_attrs(name: str, attrs: dict[str, Any], options: RecordOptions, names: dict[str, str]) -> None:
    """``attrs`` with the units of the named columns under their canonical names (``names``:
    ``t``, ``u``, ``y`` -> the name in the file), a unit the file does not give taken from the
    column's header where it ends with one (:func:`header_unit`); a ``dt`` asked for that the file
    contradicts is refused. The options (``time_unit`` ...) override either."""
    units = attrs.get("units")
    if isinstance(units, dict):  # the units of the named columns follow them to their new names
        renamed = {v: k for k, v in names.items()}
        attrs["units"] = {k: v for k, v in units.items() if k not in renamed}
        attrs["units"].update({renamed[k]: v for k, v in units.items() if k in renamed})
    from_headers = {
        canonical: unit
        for canonical, column in names.items()
        if (unit := header_unit(column, canonical)) is not None
        and canonical not in (attrs.get("units") or {})
    }
    if from_headers:
        attrs["units"] = {**(attrs.get("units") or {}), **from_headers}
    dt, file_dt = options.dt, attrs.get("dt")
    if dt is not None and file_dt is not None and not math.isclose(dt, file_dt, rel_tol=options.dt_rtol):
        raise DataError(f"dt = {dt!r} was asked for but {name} says dt = {file_dt!r}")


def untimed_dt(name: str, attrs: dict[str, Any], options: RecordOptions, names: dict[str, str]) -> float:
    """The sample time of a record without a time column (``dt`` given, else the file's), set in
    ``attrs``; a DataError naming ``--time`` and ``--dt`` when neither says."""
    if options.dt is not None:
        attrs["dt"] = float(options.dt)
    if "dt" not in attrs:
        raise DataError(
            f"{name}: no time column {names.get('t', 't')!r} and no dt given: name the time column with --time "
            "(time=...) or give the sample time with --dt"
        )
    return float(attrs["dt"])


def _on_uniform_time(
    name: str,
    rec: pd.DataFrame,
    attrs: dict[str, Any],
    where: Callable[[int], str],
    options: RecordOptions,
    column: str,
) -> pd.DataFrame:
    """The record with ``t`` in s from 0 on a uniform grid (resampled when it jitters), ``attrs["dt"]`` set."""
    t, expected, _ = time_base(name, rec["t"].to_numpy(), attrs, where, options, column)
    off_grid = steps_off_grid(np.diff(t), expected, where, options, column)
    if off_grid is None:
        rec["t"] = t
        return rec
    deviation, jittered, gaps, odd = off_grid
    jitter = float(np.max(deviation[jittered], initial=0.0))
    grid = np.arange(int(np.floor(t[-1] / expected * (1.0 + 1e-12))) + 1) * expected
    held = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 1)
    out = pd.DataFrame(
        {key: grid if key == "t" else rec[key].to_numpy()[held] if key == "u" else
         np.interp(grid, t, rec[key].to_numpy(dtype=np.float64)) for key in rec.columns}
    )  # fmt: skip
    message = f"{name}: "
    if jitter > options.dt_rtol * expected:
        message += f"time stamps jitter by up to {_seconds(jitter)} ({100 * jitter / expected:.0f} % of dt {_seconds(expected)}); "
    message += f"resampled to a uniform {_seconds(expected)} grid"
    if gaps.size:
        message += (f", across {gaps.size} gap{'s' if gaps.size > 1 else ''} of missing samples (the first "
                    f"before {where(int(gaps[0]) + 1)})")  # fmt: skip
    if odd.size:
        message += (f", across {odd.size} step{'s' if odd.size > 1 else ''} beyond the jitter limit (the first "
                    f"before {where(int(odd[0]) + 1)})")  # fmt: skip
    if gaps.size or odd.size:
        message += " as --resample asks"
    logger.warning(message + f": input held, output interpolated ({len(rec)} -> {len(out)} samples)")
    return out


def trim_record(
    record: pd.DataFrame,
    start: float | None = None,
    stop: float | None = None,
    source: str | os.PathLike[str] = "record",
    min_samples: int = 2,
) -> pd.DataFrame:
    """The samples of ``record`` with ``start <= t <= stop`` [s], ``attrs`` kept (the command
    line's ``--start`` and ``--stop``, which the messages name).

    Parameters
    ----------
    record : pandas.DataFrame
        The record; ``t`` is its time column [s] (as :func:`read_record` gives it: from 0 at
        the first sample), else ``k dt`` from its first sample (``attrs["dt"]`` [s]).
    start, stop : float, optional
        The ends of the span kept [s]; None leaves that end as it is (both None: ``record``
        itself is returned).
    source : str or path-like
        What the record is (its file), for the messages.
    min_samples : int
        Fewest samples the span must hold.

    Returns
    -------
    pandas.DataFrame
        The samples in the span, indexed from 0, with ``record``'s attrs.

    Raises
    ------
    motorid.errors.DataError
        When ``stop <= start``, or fewer than ``min_samples`` samples lie in the span;
        the message names the option, ``source`` and the span the record covers.
    """
    if start is None and stop is None:
        return record
    if start is not None and stop is not None and stop <= start:
        raise DataError(f"--stop {stop:g} must be after --start {start:g} [s]")
    if "t" in record.columns:
        t = pd.to_numeric(record["t"], errors="coerce").to_numpy(dtype=float)
    else:
        t = np.arange(len(record)) * float(record.attrs["dt"])
    keep = np.ones(len(record), dtype=bool)
    if start is not None:
        keep &= t >= start
    if stop is not None:
        keep &= t <= stop
    kept = int(keep.sum())
    if kept < max(min_samples, 1):
        span = " and ".join(
            f"{option} {value:g} s"
            for option, value in (("--start", start), ("--stop", stop))
            if value is not None
        )
        what = "no sample" if kept == 0 else f"only {kept} samples (at least {min_samples} needed)"
        raise DataError(f"{source}: {what} within {span}; the record runs from {t[0]:g} to {t[-1]:g} s")
    trimmed = record.loc[keep].reset_index(drop=True)
    trimmed.attrs = dict(record.attrs)
    return trimmed


__all__ = [
    "ATTRS_KEY",
    "ATTRS_MARKER",
    "DRIVE_ATTR",
    "JITTER_LIMIT",
    "MAT_ATTRS_VARIABLE",
    "RECORD_FORMATS",
    "REQUIRED_COLUMNS",
    "SEPARATORS",
    "TIME_ATTR",
    "TIME_UNITS",
    "TIMINGS",
    "RecordOptions",
    "check_attrs",
    "count_data_lines",
    "csv_layout",
    "normalise_record",
    "read_record",
    "record_format",
    "record_timing",
    "trim_record",
    "write_record",
]
