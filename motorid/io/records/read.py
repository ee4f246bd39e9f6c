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

import bz2
import contextlib
import csv
import gzip
import io
import itertools
import json
import logging
import lzma
import math
import os
import re
import stat
import zipfile
import zlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, NoReturn

import numpy as np
import pandas as pd

from motorid.errors import DataError, UniformGridError
from motorid.json_input import parse_json
from motorid.units import ENCODER_COUNTS, INPUT_UNITS, OUTPUT_UNIT_NAMES, TIME_UNITS

logger = logging.getLogger(__name__)

#: Marker that opens the attribute line.
ATTRS_MARKER = "# motorid-record "
#: The comment prefix of the lines before a CSV's header that are its notes (an Arduino sketch's banner).
COMMENT = "#"
#: Columns a record must have, in its canonical names.
REQUIRED_COLUMNS: tuple[str, ...] = ("t", "u", "y")
#: The canonical name a direction column is read under (:class:`RecordOptions` ``direction``).
DIRECTION = "direction"
#: How rows that repeat a time stamp with other values are treated (:class:`RecordOptions`).
DUPLICATES: tuple[str, ...] = ("refuse", "first", "last", "mean")

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
            f"max_samples=...) that keeps memory bounded (about 8 bytes per sample "
            f"and column); decimate the record (low-pass filter it, then keep one row in "
            f"{math.ceil(rows / max_samples)}) or raise the limit"
        )


#: Most characters of an offending value a message quotes (a 200 MB field is not echoed).
QUOTE_LIMIT = 80


def quoted(value: Any, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` cut to about ``limit`` characters, saying how long the whole is when it is cut.

    Parameters
    ----------
    value : Any
        The value a message names (a cell, a column name, a unit).
    limit : int
        Most characters of its ``repr`` kept.
    """
    text = repr(value)
    if len(text) <= limit:
        return text
    size = f"{len(value)} characters" if isinstance(value, str | bytes) else f"{len(text)} characters shown"
    return f"{text[:limit]}... ({size})"


def quoted_names(names: Sequence[str], most: int = 12) -> str:
    """A list of column names for a message: each quoted (:func:`quoted`), at most ``most`` of them."""
    shown = ", ".join(quoted(str(n), 40) for n in names[:most])
    more = f", ... ({len(names)} columns)" if len(names) > most else ""
    return f"[{shown}{more}]"


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


#: Compressed record files, by their last extension: a CSV inside (``log.csv.gz``, or a ``.zip``
#: holding one CSV) is read as it is decompressed, never unpacked on disk.
COMPRESSIONS: dict[str, str] = {".gz": "gzip", ".bz2": "bzip2", ".xz": "xz", ".zip": "zip"}
#: What the decompressors raise on a cut or corrupt stream.
_COMPRESSION_ERRORS = (OSError, EOFError, zlib.error, lzma.LZMAError, zipfile.BadZipFile)


def compression(path: str | os.PathLike[str]) -> str | None:
    """The compression of a record file by its last extension (a value of :data:`COMPRESSIONS`), else None.

    Parameters
    ----------
    path : str or PathLike
        The record file; only its name is looked at.
    """
    return COMPRESSIONS.get(os.path.splitext(os.fspath(path))[1].lower())


def _zip_member(name: str, archive: zipfile.ZipFile) -> zipfile.ZipInfo:
    """The one record a ``.zip`` holds (folders and macOS's ``__MACOSX/`` entries left aside)."""
    members = [m for m in archive.infolist() if not m.is_dir() and not m.filename.startswith("__MACOSX/")]
    if len(members) != 1:
        listed = quoted_names([m.filename for m in members])
        raise DataError(f"{name} holds {len(members)} files {listed}, not one record: unzip the one to read")
    inner = record_format(members[0].filename)
    if inner != "CSV":
        raise DataError(
            f"{name} holds {quoted(members[0].filename)}, a {inner} file: compressed records are read when "
            "they are CSV; unzip it and read the file itself"
        )
    return members[0]


@contextlib.contextmanager
def open_record_bytes(path: str | os.PathLike[str]) -> Iterator[io.BufferedIOBase]:
    """The bytes of a record file, decompressed as they are read when it is compressed
    (:func:`compression`); a cut or corrupt stream is a DataError naming the file.

    Parameters
    ----------
    path : str or PathLike
        The record file.
    """
    name = os.fspath(path)
    kind = compression(name)
    try:
        if kind == "zip":
            with zipfile.ZipFile(name) as archive, archive.open(_zip_member(name, archive)) as fh:
                yield fh
        else:
            opener = {"gzip": gzip.open, "bzip2": bz2.open, "xz": lzma.open}.get(kind or "", open)
            with opener(name, "rb") as fh:
                yield fh
    except _COMPRESSION_ERRORS as exc:
        if kind is None:
            raise
        raise DataError(f"{name}: its {kind} data cannot be read (cut or corrupt?): {_reason(exc)}") from None


@contextlib.contextmanager
def open_record_text(path: str | os.PathLike[str], newline: str | None = None) -> Iterator[io.TextIOBase]:
    """The text of a CSV record (UTF-8, a BOM left out), decompressed as it is read (:func:`open_record_bytes`).

    Parameters
    ----------
    path : str or PathLike
        The record file.
    newline : str, optional
        As :func:`open`'s (``""`` for the csv module).
    """
    with open_record_bytes(path) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig", newline=newline) as fh:
        yield fh


def count_data_lines(path: str | os.PathLike[str], chunk_bytes: int = 1 << 24) -> int:
    """Number of line breaks in a file, counted in fixed-size binary chunks (bounded memory).

    A file whose last line has no line break counts one more. Used to refuse a
    record too long to hold in memory before it is parsed. A compressed file
    (:func:`compression`) is counted as it is decompressed.

    Parameters
    ----------
    path : str or PathLike
        The file.
    chunk_bytes : int
        Bytes read at a time (the memory it takes).
    """
    count = 0
    last = b"\n"
    with open_record_bytes(path) as fh:
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
        with open_record_text(name) as fh:
            first = fh.readline()
    except UnicodeDecodeError as exc:
        raise DataError(
            f"{name} is not a text CSV file (byte {exc.start} of its first line is not UTF-8){_not_text_hint(name)}"
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
            raise DataError(
                f"{path}: line {line_number}: column name {quoted(name)} appears twice in the header"
            )
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


#: Numbers written with a thousands separator, by (thousands, decimal) mark: one with both marks
#: (``-1,035.7``, ``-1.035,7``) or with two groups of three digits (``1,035,000``) says both.
_GROUPED: dict[tuple[str, str], re.Pattern[str]] = {
    (",", "."): re.compile(r"^\s*[+-]?\d{1,3}(?:(?:,\d{3})+\.\d*|(?:,\d{3}){2,})\s*$"),
    (".", ","): re.compile(r"^\s*[+-]?\d{1,3}(?:(?:\.\d{3})+,\d*|(?:\.\d{3}){2,})\s*$"),
    ("'", "."): re.compile(r"^\s*[+-]?\d{1,3}(?:'\d{3})+(?:\.\d*)?\s*$"),
}
#: Thousands separators a CSV may use (``thousands``).
THOUSANDS: tuple[str, ...] = (",", ".", "'", " ")


def _dialect(
    name: str,
    header: str,
    lines: list[str],
    sep: str | None,
    decimal: str | None,
    thousands: str | None = None,
) -> tuple[str, str, str | None]:
    """The separator, decimal mark and thousands separator of a CSV: as given, else detected from
    its header and first lines.

    A decimal comma is detected when the separator is not a comma and a cell of
    the first lines is a number written with one (``1,25``); a thousands separator
    when a cell is a number written with one (:data:`_GROUPED`: ``-1,035.7``,
    ``-1.035,7``, ``1'035.7``), which also says the decimal mark.
    """
    given = (sep, decimal, thousands)
    if sep is None:
        best = (1, ",")
        for candidate in SEPARATORS:
            counts = [len(_fields(line, candidate)) for line in [header, *lines]]
            if counts[0] > best[0] and all(c == counts[0] for c in counts[1:]):
                best = (counts[0], candidate)
        sep = best[1]
    cells = [cell for line in lines for cell in _fields(line, sep)]
    if thousands is None:
        for (mark, point), pattern in _GROUPED.items():
            if decimal in (None, point) and any(pattern.match(cell) for cell in cells):
                thousands, decimal = mark, point
                break
    if decimal is None:
        decimal = "," if sep != "," and any(_DECIMAL_COMMA.match(cell) for cell in cells) else "."
    said = ["detected" if value is None else "given" for value in given]
    logger.info("%s: separator %r (%s), decimal mark %r (%s)%s", name, sep, said[0], decimal, said[1],
                "" if thousands is None else f", thousands separator {thousands!r} ({said[2]})")  # fmt: skip
    return sep, decimal, thousands


def check_dialect(sep: str | None, decimal: str | None, thousands: str | None = None) -> None:
    """Refuse a CSV separator, decimal mark or thousands separator the reader cannot use (one
    character each, none the same as another)."""
    if sep is not None and (not isinstance(sep, str) or len(sep) != 1 or sep in '\r\n".'):
        raise DataError(f"sep=... must be one character such as ',', ';' or a tab, got {sep!r}")
    if decimal is not None and decimal not in (".", ","):
        raise DataError(f"decimal=... must be '.' or ',', got {decimal!r}")
    if sep is not None and sep == decimal:
        raise DataError(f"sep=... and decimal=... are both {sep!r}: a CSV cannot use one for both")
    if thousands is not None:
        if thousands not in THOUSANDS:
            raise DataError(
                f"thousands=... must be one of {', '.join(map(repr, THOUSANDS))}, got {quoted(thousands)}"
            )
        if thousands == decimal:
            raise DataError(
                f"thousands={thousands!r} is also the decimal mark: a CSV cannot use one mark for both"
            )


def _count_lines_and(path: str, sep: str, chunk_bytes: int = 1 << 20) -> tuple[int, int]:
    """Line breaks (one more when the last line has none) and separators in a file, in bounded memory."""
    lines = seps = 0
    last = b"\n"
    mark = sep.encode()
    with open_record_bytes(path) as fh:
        while chunk := fh.read(chunk_bytes):
            lines += chunk.count(b"\n")
            seps += chunk.count(mark)
            last = chunk[-1:]
    return lines + (last != b"\n"), seps


def _check_fields(name: str, data_line: int, sep: str, width: int) -> None:
    """Raise a DataError naming the first data row (after line ``data_line``) whose number of fields
    is not the header's ``width``."""
    with open_record_text(name, newline="") as fh:
        for _ in range(data_line):
            fh.readline()
        for row, fields in enumerate(csv.reader(fh, delimiter=sep)):
            if fields and len(fields) != width:
                raise DataError(
                    f"row {row} (line {data_line + 1 + row} of {name}) has {len(fields)} fields, the header "
                    f"has {width}" + ("; is the separator right? (sep)" if len(fields) > width else "")
                )


def _parse_columns(
    path: str, layout: CsvLayout, names: list[str], chunk_rows: int = 1_000_000
) -> pd.DataFrame:
    """The data rows of ``names`` as float64 (the time column of ``layout.integers`` as int64, one of
    text stamps as int64 ns: :func:`text_times`), naming the first bad cell.

    The fast path parses floats directly, exactly (so a record written with
    :func:`write_record` reads back bit for bit); a time column of integers
    (``millis()``, nanoseconds since 1970) is kept as int64, exactly. Only when
    this fails are the cells read as text, in chunks of ``chunk_rows`` rows
    (bounded memory), to find and name the first non-numeric, NaN or infinite one.
    """
    options = csv_data_options(layout, names)
    texts = [n for n in names if layout.time_text and n == layout.time_column]
    numbers = [n for n in names if n not in texts]
    integers = [n for n in layout.integers if n in numbers]
    for ints in (integers, []) if integers else ([],):
        dtypes = {name: str if name in texts else np.int64 if name in ints else np.float64 for name in names}
        try:
            data = pd.read_csv(path, dtype=dtypes, **options)
            if all(np.isfinite(data[name].to_numpy()).all() for name in numbers if name not in ints):
                for name in texts:
                    data[name] = text_times(
                        path, data[name], str(layout.time_text), row_place(path, layout.data_line)
                    )
                return data[names]
            break
        except (ValueError, OverflowError):
            pass  # an integer column holds a fraction, or a cell is not a number: found and named below
    marked = thousands_past_the_head(path, layout, numbers)
    if marked is not None:  # a number with a thousands separator past the first lines: read again with it
        return _parse_columns(path, marked, names, chunk_rows)
    raise_bad_cell(path, layout, numbers, chunk_rows)


def text_times(name: str, stamps: pd.Series, kind: str, where: Callable[[int], str]) -> np.ndarray:
    """Time stamps written as text, as int64 nanoseconds: ISO-8601 dates and times
    (``2026-11-28T10:00:00.123``, an offset or ``Z`` taken into account) since 1970, or clock
    times (``10:00:00.123``) since midnight, a day added each time the clock passes midnight.

    Parameters
    ----------
    name : str
        The record, for the messages.
    stamps : pandas.Series
        The time column's cells as text.
    kind : {"iso", "clock"}
        What they are (:data:`TIME_TEXTS`).
    where : callable
        Data row -> its place in the file, for the messages.

    Raises
    ------
    DataError
        Naming the first cell that is not a stamp of that kind, and its row.
    """
    text = stamps.astype(str).str.strip().str.replace(",", ".", regex=False)
    if kind == "iso":
        zoned = text.str.contains(r"(?:Z|[+-]\d{2}:?\d{2})$", regex=True)
        parsed = pd.to_datetime(text, format="ISO8601", errors="coerce", utc=bool(zoned.any()))
        values = parsed.to_numpy().astype("datetime64[ns]").astype(np.int64)
        bad = np.flatnonzero(parsed.isna().to_numpy())
    else:
        parsed = pd.to_timedelta(text.where(text.str.match(TIME_TEXTS["clock"])), errors="coerce")
        bad = np.flatnonzero(parsed.isna().to_numpy())
        values = parsed.to_numpy().astype("timedelta64[ns]").astype(np.int64)
        day = 86_400 * 10**9
        values = values + day * np.concatenate(([0], np.cumsum(np.diff(values) < -day // 2)))  # past midnight
    if bad.size:
        row = int(bad[0])
        what = "an ISO-8601 date and time" if kind == "iso" else "a clock time (hh:mm:ss.fff)"
        raise DataError(
            f"the time column of {name} holds {quoted(stamps.iloc[row])} at {where(row)}, not {what} as its first "
            "rows are"
        )
    return values


def csv_data_options(layout: CsvLayout, names: list[str]) -> dict[str, Any]:
    """The options of :func:`pandas.read_csv` that parse the data rows of a CSV record of ``layout``
    (the lines before the header and a units row under it skipped, the columns ``names``, the
    separator, decimal mark and thousands separator): one place for the whole-record read and
    the read in blocks (:mod:`motorid.record_chunks`); a compressed file is decompressed by
    pandas as it is read (the same compressions, by extension: :data:`COMPRESSIONS`)."""
    skiprows: int | list[int] = layout.skip
    if layout.units_row:
        skiprows = [*range(layout.skip), layout.skip + 1]
    return {"skiprows": skiprows, "usecols": names, "sep": layout.sep, "decimal": layout.decimal,
            "thousands": layout.thousands, "encoding": "utf-8-sig", **_EXACT_FLOATS}  # fmt: skip


def raise_bad_cell(path: str, layout: CsvLayout, names: list[str], chunk_rows: int = 1_000_000) -> NoReturn:
    """Raise a DataError naming the first non-numeric, NaN or infinite cell of the columns ``names``
    of a CSV record, read as text from the start in chunks of ``chunk_rows`` rows (bounded memory).

    A number written with a thousands separator (``-1,035.7``) past the first lines the marks
    were detected from, when no thousands separator is known, is a :class:`UniformGridError`:
    the whole-record read reads the record again with the marks it shows (:func:`thousands_past_the_head`).
    """
    bad = _first_bad_cell(path, layout, names, chunk_rows)
    if bad is None:
        raise DataError(f"{path}: the columns {quoted_names(names)} do not parse as numbers")  # a quirk
    name, row, raw, value = bad
    place = f"row {row} (line {layout.data_line + 1 + row} of {path})"
    marks = _grouped(raw, layout)
    if marks is not None:
        raise UniformGridError(
            f"column {quoted(name)} has the number {quoted(raw)} at {place}, written with a thousands separator: "
            f"the record is read whole, with thousands={marks[0]!r} and decimal={marks[1]!r}"
        )
    if raw.lower() in ("", "nan", "na", "null", "none"):
        kind = "a NaN"
    elif np.isinf(value):
        kind = "an infinite"
    else:
        kind = "a non-numeric"
    hint = ""
    if layout.decimal == "." and _DECIMAL_COMMA.match(raw):
        hint = "; is it a decimal comma? (decimal=',')"
    elif TIME_TEXTS["iso"].match(raw) or TIME_TEXTS["clock"].match(raw):
        hint = "; time stamps as text are read in the time column only (time=...)"
    raise DataError(f"column {quoted(name)} has {kind} value {quoted(raw)} at {place}" + hint)


def thousands_past_the_head(path: str, layout: CsvLayout, names: list[str]) -> CsvLayout | None:
    """The layout with the thousands separator and decimal mark that the first bad cell of a CSV
    record shows (a number written with one, past the first lines they were detected from), or
    None when it shows none or one is known."""
    bad = _first_bad_cell(path, layout, names)
    marks = _grouped(bad[2], layout) if bad is not None else None
    if marks is None:
        return None
    logger.info("%s: thousands separator %r, decimal mark %r (detected at row %d)", path, *marks, bad[1])
    return replace(layout, thousands=marks[0], decimal=marks[1])


def _grouped(raw: str, layout: CsvLayout) -> tuple[str, str] | None:
    """The (thousands, decimal) marks of a number written with a thousands separator, when the
    layout knows none; else None."""
    if layout.thousands is not None:
        return None
    return next((marks for marks, pattern in _GROUPED.items() if pattern.match(raw)), None)


def _first_bad_cell(
    path: str, layout: CsvLayout, names: list[str], chunk_rows: int = 1_000_000
) -> tuple[str, int, str, float] | None:
    """The first non-numeric, NaN or infinite cell of the columns ``names`` of a CSV record (its
    column, row, text and value as parsed), read as text in chunks (bounded memory); None if none."""
    options = {key: value for key, value in csv_data_options(layout, names).items()
               if key not in _EXACT_FLOATS and key != "thousands"}  # fmt: skip
    with pd.read_csv(path, dtype=str, keep_default_na=False, chunksize=chunk_rows, **options) as reader:
        for chunk in reader:
            for name in names:
                text = chunk[name].str.strip()
                numbers = text.str.replace(layout.thousands, "", regex=False) if layout.thousands else text
                numbers = numbers.str.replace(",", ".", regex=False) if layout.decimal == "," else numbers
                values = pd.to_numeric(numbers, errors="coerce").to_numpy(dtype=float)
                bad = np.flatnonzero(~np.isfinite(values))
                if bad.size:
                    return name, int(chunk.index[bad[0]]), str(text.iloc[bad[0]]), float(values[bad[0]])
    return None


#: Formats :func:`read_record` reads besides CSV, by file-name extension (any other extension is CSV).
RECORD_FORMATS: dict[str, str] = {
    ".parquet": "Parquet",
    ".pq": "Parquet",
    ".mat": "MATLAB",
    ".tdms": "TDMS",
    ".h5": "HDF5",
    ".hdf5": "HDF5",
    ".xlsx": "Excel",
    ".xlsm": "Excel",
}
#: Where a record's attributes (the JSON of the CSV attribute line) sit in the other formats: a key of
#: a Parquet file's schema metadata, a root property of a TDMS file, a root attribute of an HDF5 file.
ATTRS_KEY = "motorid-record"
#: The same JSON in a MATLAB file: a char variable (MATLAB names take no hyphen).
MAT_ATTRS_VARIABLE = "motorid_record"
#: Files of other programs that :func:`read_record` does not read, by extension: refused, saying which are.
UNREAD_FORMATS: dict[str, str] = {
    ".xls": "an Excel 97-2003 workbook (.xls)",
    ".xlsb": "an Excel binary workbook (.xlsb)",
    ".ods": "an OpenDocument spreadsheet (.ods)",
    ".numbers": "a Numbers spreadsheet (.numbers)",
    ".json": "JSON",
    ".7z": "a 7-Zip archive",
    ".rar": "a RAR archive",
    ".tar": "a tar archive",
    ".zst": "Zstandard data",
}
#: What :func:`read_record` reads, in a message that refuses a file.
FORMATS_READ = (
    "motorid reads CSV and other text (any other extension; also compressed as .gz, .bz2, .xz or a .zip "
    "holding one), Parquet (.parquet, .pq), MATLAB (.mat), NI TDMS (.tdms), HDF5 (.h5, .hdf5) and Excel "
    "(.xlsx, .xlsm)"
)
#: The first bytes of binary files, for the message that a file named like a CSV is not text.
_SIGNATURES: dict[bytes, str] = {
    b"PK\x03\x04": "a ZIP archive (an .xlsx workbook is one): name it .xlsx, or .zip when it holds one CSV",
    b"\x1f\x8b": "gzip data: name it .gz",
    b"BZh": "bzip2 data: name it .bz2",
    b"\xfd7zXZ\x00": "xz data: name it .xz",
    b"\x89HDF\r\n\x1a\n": "an HDF5 file: name it .h5",
    b"PAR1": "a Parquet file: name it .parquet",
    b"MATLAB": "a MATLAB file: name it .mat",
    b"TDSm": "a TDMS file: name it .tdms",
    b"\xd0\xcf\x11\xe0": "an OLE2 document (an Excel 97-2003 .xls?), which is not read: save it as .xlsx or CSV",
}


def record_format(path: str | os.PathLike[str]) -> str:
    """The format :func:`read_record` reads ``path`` as: a value of :data:`RECORD_FORMATS`, else ``"CSV"``.

    A compressed file (:func:`compression`) is named by the extension before the
    compression's (``log.csv.gz`` is CSV; ``log.zip`` holds one CSV).

    Parameters
    ----------
    path : str or PathLike
        The record file; only its name is looked at.

    Raises
    ------
    DataError
        A file of :data:`UNREAD_FORMATS`, or another format than CSV compressed, naming
        what is read.
    """
    name = os.fspath(path)
    stem, extension = os.path.splitext(name)
    extension = extension.lower()
    if extension in COMPRESSIONS:
        inner = os.path.splitext(stem)[1].lower()
        if RECORD_FORMATS.get(inner, "CSV") != "CSV" or inner in UNREAD_FORMATS:
            raise DataError(
                f"{name} is a compressed {RECORD_FORMATS.get(inner) or UNREAD_FORMATS[inner]} file: compressed "
                "records are read when they are CSV; decompress it and read the file itself"
            )
        return "CSV"
    if extension in UNREAD_FORMATS:
        raise DataError(f"{name} is {UNREAD_FORMATS[extension]}, which is not read: {FORMATS_READ}")
    return RECORD_FORMATS.get(extension, "CSV")


def _not_text_hint(name: str) -> str:
    """What a file that is not text seems to be, by its first bytes, and what is read."""
    try:
        with open(name, "rb") as fh:
            start = fh.read(8)
    except OSError:
        return ""
    seen = (
        None
        if compression(name)
        else next((w for magic, w in _SIGNATURES.items() if start.startswith(magic)), None)
    )
    return (f": it looks like {seen}" if seen else "") + f"; {FORMATS_READ}"


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
    return f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__


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


#: MATLAB classes of the objects Simulink logs (``sim``'s ``logsout``, ``timeseries``): stored in
#: MATLAB's own object format, which is not read.
SIMULINK_OBJECTS = ("Simulink.SimulationData.Dataset", "Simulink.SimulationData.Signal", "timeseries")


def _hdf5_file(name: str) -> tuple[Any, dict[str, tuple[int, ...]], dict[str, Any], dict[str, str]]:
    """An HDF5 file opened (an ``h5py.File``, to be closed by the caller), the shape of each of
    its columns, its record attributes, and each column's dataset path.

    A column is a dataset, named by its path; a MATLAB v7.3 structure that Simulink logs
    ("structure with time": ``sig.time``, ``sig.signals.values``, ``sig.signals.label``) is
    also the column ``sig`` (and its label), and its time the column ``t`` when the file has
    none and every such structure has as many samples. A Simulink object (:data:`SIMULINK_OBJECTS`)
    is refused when it is all the file holds, saying how to save its signals.
    """
    import h5py

    try:
        handle = h5py.File(name, "r")
    except OSError as exc:
        raise DataError(f"{name} is not a readable HDF5 file: {_reason(exc)}") from None
    shapes: dict[str, tuple[int, ...]] = {}
    elsewhere: list[
        str
    ] = []  # what keeps data in other files (raised after the visit: h5py's callbacks must return)

    def visit(key: str, item: Any) -> None:
        if isinstance(item, h5py.Dataset) and not key.startswith("#"):  # '#refs#': MATLAB's own
            if item.external or item.is_virtual:
                elsewhere.append(
                    f"the dataset {quoted(key)} keeps its data in other files "
                    f"({'virtual' if item.is_virtual else 'external storage'})"
                )
            shapes[key] = tuple(item.shape)

    def visit_link(key: str, link: Any) -> None:
        if isinstance(link, h5py.ExternalLink):
            elsewhere.append(f"{quoted(key)} is a link to {quoted(link.filename)}")

    try:
        try:
            handle.visititems_links(visit_link)
            if not elsewhere:  # an external link is not followed
                handle.visititems(visit)
            text = handle.attrs.get(ATTRS_KEY)
        except HDF5_ERRORS as exc:  # a damaged file
            raise DataError(f"{name}: its HDF5 structure cannot be read (corrupt?): {_reason(exc)}") from None
        if elsewhere:
            raise DataError(
                f"{name}: {elsewhere[0]}: a record is read from its own file only; copy the data into it"
            )
        attrs = _attrs_from_json(text, name, f"the root attribute {ATTRS_KEY!r}")
        objects = {key: kind for key in handle if (kind := _matlab_class(handle[key])) in SIMULINK_OBJECTS}
        paths = {key: key for key in shapes}
        signals = _simulink_structures(handle, shapes)
        for signal, (values, _) in signals.items():
            if signal not in shapes:
                shapes[signal], paths[signal] = shapes[values], values
        times = {shapes[time] for _, time in signals.values()}
        if signals and "t" not in shapes and len(times) == 1:
            first = next(iter(signals.values()))[1]
            shapes["t"], paths["t"] = shapes[first], first
        if objects and not signals and all(key in objects for key in shapes):
            variable, kind = next(iter(objects.items()))
            raise DataError(
                f"{name} holds {quoted(variable)}, a Simulink {kind} object, in MATLAB's object format, which is not "
                "read: log the signals as 'Structure With Time' (a To Workspace block's Save format, or the model's "
                "Data Import/Export), or save their Time and Data as variables (y = ts.Data; t = ts.Time)"
            )
    except BaseException:
        handle.close()
        raise
    return handle, shapes, attrs, paths


def _matlab_class(item: Any) -> str:
    """The ``MATLAB_class`` attribute of an HDF5 item of a v7.3 MAT-file ('' when it has none)."""
    value = item.attrs.get("MATLAB_class", b"")
    return value.decode("ascii", "replace") if isinstance(value, bytes) else str(value)


def _simulink_structures(handle: Any, shapes: dict[str, tuple[int, ...]]) -> dict[str, tuple[str, str]]:
    """Signal name -> (values path, time path) of the structures with time that Simulink logs in a
    v7.3 MAT-file (a top-level group ``sig`` holding ``time`` and ``signals/values``); a
    structure whose ``signals/label`` names it (MATLAB char, UTF-16 codes) is named by that too."""
    signals: dict[str, tuple[str, str]] = {}
    for key in handle:
        values, time = f"{key}/signals/values", f"{key}/time"
        if values not in shapes or time not in shapes or _samples(shapes[values]) != _samples(shapes[time]):
            continue
        signals[key] = (values, time)
        label = f"{key}/signals/label"
        if label in shapes and shapes[label] and 0 < math.prod(shapes[label]) <= 200:
            text = "".join(map(chr, np.asarray(handle[label][()]).reshape(-1))).strip()
            if text and text not in signals:
                signals[text] = (values, time)
    return signals


def _read_hdf5(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    handle, shapes, attrs, paths = _hdf5_file(name)
    with handle:
        chosen = choose(shapes)
        try:
            return {key: np.asarray(handle[paths[key]][()]).reshape(-1) for key in chosen}, attrs
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
        raise DataError(
            f"column {quoted(column)} is ambiguous in {name}: {quoted_names(nested)}; name one of them"
        )
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
                    f"column {quoted(column)} is missing from {name}"
                    + (f" (needed as {canonical!r})" if column != canonical else "")
                    + f"; columns are {quoted_names(present)}{_name_it(canonical)}"
                )
            if _samples(shapes[key]) is None:
                raise DataError(
                    f"column {quoted(column)} of {name} is not one column of samples (shape {shapes[key]})"
                )
            found[key] = canonical
        first = next(iter(found))
        rows = _samples(shapes[first])
        for key in found:
            if _samples(shapes[key]) != rows:
                raise DataError(
                    f"column {quoted(key)} of {name} has {_samples(shapes[key])} samples, column {quoted(first)} has {rows}"
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


def _read_excel(name: str, choose: Choose, sheet: str | None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The columns of a sheet of an Excel workbook (openpyxl, read-only: row by row), named by the
    cells of its first row; a second row that names units (``s``, ``%``, ``rpm``) gives theirs.

    A cell that is a date and time (or a time of day) makes its column datetime64 (timedelta64);
    an empty cell is NaN, text a non-numeric value, both refused by row where they are read."""
    import openpyxl

    try:
        workbook = openpyxl.load_workbook(name, read_only=True, data_only=True)
    except Exception as exc:  # zipfile, KeyError, XML errors ... on a file that is not a workbook
        raise DataError(f"{name} is not a readable Excel workbook: {_reason(exc)}") from None
    try:
        if sheet is not None and sheet not in workbook.sheetnames:
            raise DataError(
                f"{name} has no sheet {quoted(sheet)}; its sheets are {quoted_names(workbook.sheetnames)} (sheet=...)"
            )
        worksheet = workbook[sheet] if sheet is not None else workbook.worksheets[0]
        rows = worksheet.iter_rows(values_only=True)
        header = next(rows, None)
        if header is None or all(cell is None for cell in header):
            raise DataError(f"{name}: sheet {quoted(worksheet.title)} has no header in its first row")
        width = max(i for i, cell in enumerate(header) if cell is not None) + 1
        names = [str(cell).strip() if cell is not None else "" for cell in header[:width]]
        for position, column in enumerate(names):
            if not column:
                raise DataError(f"{name}: column {position + 1} of the header of sheet {quoted(worksheet.title)} "
                                "has no name")  # fmt: skip
        attrs: dict[str, Any] = {}
        second = next(rows, None)
        units = None
        if second is not None and all(isinstance(c, str | type(None)) for c in second[:width]):
            cells = ["" if c is None else c for c in second[:width]]
            if any(_unit_cell(c) for c in cells):
                units = {
                    column: unit for column, c in zip(names, cells, strict=True) if (unit := _unit_cell(c))
                }
        pending = [] if second is None or units else [second]
        stored = worksheet.max_row  # the sheet's stored dimension; None when it stores none
        if stored is None:  # counted as read
            body = [*pending, *rows]
            count, source = len(body), iter(body)
        else:
            count, source = stored - 1 - (units is not None), itertools.chain(pending, rows)
        chosen = choose({column: (max(count, 0),) for column in names})
        positions = [names.index(column) for column in chosen]
        cells_by_column: list[list[Any]] = [[] for _ in chosen]
        for row in source:
            if all(cell is None for cell in row):
                continue  # a blank row (openpyxl's dimension may count trailing ones)
            for slot, position in enumerate(positions):
                cells_by_column[slot].append(row[position] if position < len(row) else None)
    finally:
        workbook.close()
    if units:
        attrs["units"] = units
    return {column: _excel_column(name, column, cells) for column, cells in zip(chosen, cells_by_column,
                                                                                 strict=True)}, attrs  # fmt: skip


def _excel_column(name: str, column: str, cells: list[Any]) -> np.ndarray:
    """The cells of an Excel column as an array: float64, or datetime64/timedelta64 when they are
    dates and times; an empty cell is NaN and text is refused, naming the row."""
    import datetime

    kinds = {type(cell) for cell in cells}
    if kinds and kinds <= {datetime.datetime, datetime.date}:
        return np.array(cells, dtype="datetime64[ns]")
    if kinds and kinds <= {datetime.time, datetime.timedelta}:
        return np.array([
            cell if isinstance(cell, datetime.timedelta) else datetime.timedelta(
                hours=cell.hour, minutes=cell.minute, seconds=cell.second, microseconds=cell.microsecond)
            for cell in cells
        ], dtype="timedelta64[ns]")  # fmt: skip
    values = np.empty(len(cells))
    for row, cell in enumerate(cells):
        if cell is None:
            values[row] = np.nan
        elif isinstance(cell, bool) or not isinstance(cell, int | float):
            raise DataError(
                f"column {quoted(column)} has a non-numeric value {quoted(cell)} at row {row} of {name}"
            )
        else:
            values[row] = cell
    return values


def binary_column(name: str, key: str, values: np.ndarray, time: bool, first_row: int = 0) -> np.ndarray:
    """Column ``key`` of the binary record ``name`` as float64 (a time column of integers as int64,
    exactly: nanoseconds since 1970 exceed float64's digits), or a DataError naming it when it is
    not numeric, or its first NaN or infinite value by row (``first_row`` is the row of
    ``values[0]`` in the file: one place for the whole-record read and the read in blocks)."""
    if time and values.dtype.kind in "mM":  # datetime64 or timedelta64: int64 ns, exactly
        if np.isnat(values).any():
            raise DataError(f"column {quoted(key)} has a missing time at row {first_row + int(np.isnat(values).argmax())} "
                            f"of {name}")  # fmt: skip
        return values.astype("datetime64[ns]" if values.dtype.kind == "M" else "timedelta64[ns]").astype(
            np.int64
        )
    if values.dtype.kind not in "fiub":
        raise DataError(f"column {quoted(key)} of {name} is not numeric (its values are {values.dtype})")
    if time and values.dtype.kind in "iu":
        return values.astype(np.int64)
    values = values.astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        kind_of = "a NaN" if np.isnan(values[bad[0]]) else "an infinite"
        raise DataError(
            f"column {quoted(key)} has {kind_of} value {values[bad[0]]!r} at row {first_row + int(bad[0])} of {name}"
        )
    return values


#: The option that names each column a record is read with.
_COLUMN_OPTIONS = {"t": "time", "u": "input", "y": "output", DIRECTION: "direction"}


def _name_it(canonical: str) -> str:
    """The end of a missing column's message: the option that names the column (none for others)."""
    option = _COLUMN_OPTIONS.get(canonical)
    return f"; name the {option} column with {option}=..." if option else ""


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
    counts_per_rev : float, optional
        Counts per revolution of an encoder, for ``output_unit="counts"``: a position
        of ``n`` counts is ``2 pi n / counts_per_rev`` rad.
    direction : str, optional
        Name of a direction column that gives an unsigned input (a PWM's magnitude
        in sign-and-magnitude drive) its sign: ``u = |u|`` where the column equals
        ``direction_forward``, ``-|u|`` where it holds the other value.
    direction_forward : float
        The direction column's value for forward (positive input), default 1; the
        column may hold one other value.
    duplicates : {"refuse", "first", "last", "mean"}
        What becomes of rows that repeat the time stamp of the row before with
        other values: refused naming the row (default), or merged into one row
        (the first, the last, or the mean of each column). Repeated rows with the
        same values are always dropped, and one line says how many.
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
    counts_per_rev: float | None = None
    direction: str | None = None
    direction_forward: float = 1.0
    duplicates: str = "refuse"

    def __post_init__(self) -> None:
        for key in ("time", "input", "output", "direction"):
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
                        f"{key}=... {column!r} is the same column as {other}=... {first!r}: "
                        "each must name its own column"
                    )
        if self.dt is not None and (isinstance(self.dt, bool) or not isinstance(self.dt, int | float)
                                    or not math.isfinite(self.dt) or self.dt <= 0.0):  # fmt: skip
            raise DataError(f"dt must be finite and > 0, got {self.dt!r}")
        if self.time_unit is not None and self.time_unit not in TIME_UNITS:
            raise DataError(f"time_unit=... must be one of {', '.join(TIME_UNITS)}, got {self.time_unit!r}")
        if not isinstance(self.resample, bool):
            raise DataError(f"resample must be True or False, got {self.resample!r}")
        if self.duplicates not in DUPLICATES:
            raise DataError(
                f"duplicates=... must be one of {', '.join(DUPLICATES)}, got {quoted(self.duplicates)}"
            )
        if self.counts_per_rev is not None:
            value = self.counts_per_rev
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or not (math.isfinite(value) and value > 0)
            ):
                raise DataError(
                    f"counts_per_rev=... must be a positive number of counts, got {quoted(value)}"
                )
            if self.output_unit not in (None, ENCODER_COUNTS):
                raise DataError(
                    f"counts_per_rev=... goes with output_unit='counts' (an encoder's position), not with "
                    f"output_unit={self.output_unit!r}"
                )
        elif self.output_unit == ENCODER_COUNTS:
            raise DataError(
                "output_unit='counts' needs the encoder's counts per revolution: counts_per_rev=... "
                "(e.g. 2048; four times the lines of a quadrature encoder)"
            )
        forward = self.direction_forward
        if isinstance(forward, bool) or not isinstance(forward, int | float) or not math.isfinite(forward):
            raise DataError(f"direction_forward=... must be a number (the direction column's value for forward), "
                            f"got {quoted(forward)}")  # fmt: skip
        if self.direction is not None and self.direction in (
            self.time or "t",
            self.input or "u",
            self.output or "y",
        ):
            raise DataError(
                f"direction={self.direction!r} is the time, input or output column: it must name its own"
            )

    def column_map(self, columns: Sequence[str] | Mapping[str, str] | None = None) -> dict[str, str]:
        """Canonical name -> name in the file: ``columns`` (as :func:`read_record` takes it) and the names."""
        mapping = _column_map(columns)
        for canonical, given in zip(REQUIRED_COLUMNS, (self.time, self.input, self.output), strict=True):
            if given is not None:
                mapping[canonical] = given
        if self.direction is not None:
            mapping[DIRECTION] = self.direction
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
    counts_per_rev: float | None = None,
    direction: str | None = None,
    direction_forward: float = 1.0,
    duplicates: str = "refuse",
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
    counts_per_rev, direction, direction_forward, duplicates : optional
        As :class:`RecordOptions`.

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
        resample=resample, dt_rtol=dt_rtol, counts_per_rev=counts_per_rev, direction=direction,
        direction_forward=direction_forward, duplicates=duplicates,
    )  # fmt: skip
    mapping = options.column_map()
    present = [str(c) for c in record.columns]
    for canonical, column in mapping.items():
        if column not in present and not (canonical == "t" and options.time_optional()):
            raise DataError(
                f"column {quoted(column)} is missing from the record"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {quoted_names(present)}{_name_it(canonical)}"
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
        stamps = series.astype(str).head(SNIFF_LINES) if key == "t" and series.dtype == object else None
        text = next((kind for kind, pattern in TIME_TEXTS.items()
                     if stamps is not None and len(stamps) and stamps.str.match(pattern).all()), None)  # fmt: skip
        if key == "t" and pd.api.types.is_datetime64_any_dtype(series):
            if getattr(series.dt, "tz", None) is not None:  # an instant: counted in UTC
                series = series.dt.tz_convert("UTC").dt.tz_localize(None)
            values = series.to_numpy().astype("datetime64[ns]").astype(np.int64)
            time_unit_of_dates = "ns"
        elif key == "t" and pd.api.types.is_timedelta64_dtype(series):
            values = series.to_numpy().astype("timedelta64[ns]").astype(np.int64)
            time_unit_of_dates = "ns"
        elif text is not None:
            values = text_times("the record", series, text, lambda row: f"sample {row}")
            time_unit_of_dates = "ns"
        elif key == "t" and pd.api.types.is_integer_dtype(series):
            values = series.to_numpy(dtype=np.int64)
        else:
            numbers = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)
            bad = np.flatnonzero(~np.isfinite(numbers))
            if bad.size:
                if key in mapping:
                    raise DataError(f"column {quoted(str(column))} is not a finite number at sample {int(bad[0])}: "
                                    f"{quoted(series.iloc[int(bad[0])])}")  # fmt: skip
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
    """What a CSV record's first lines say.

    Attributes
    ----------
    attrs : dict
        Its attributes: the attribute line's, ``notes`` (the comment lines before the header)
        and ``units`` from a row of units under the header.
    skip : int
        The lines before its header (the attribute line, comment lines).
    present : list of str
        Its column names.
    sep, decimal : str
        Its separator and decimal mark (as given or detected).
    thousands : str or None
        Its thousands separator (as given or detected), None when it has none.
    integers : list of str
        The time column when its first lines are integers (``millis()``, ns since 1970),
        read as int64; else empty.
    time_column : str or None
        The time column's name in the file (None: the record has none).
    time_text : {"iso", "clock"} or None
        The time column's stamps when they are text: ISO-8601 dates and times, or clock times.
    units_row : bool
        Whether a row of units sits under the header.
    rows : int
        The number of data rows.
    """

    attrs: dict[str, Any]
    skip: int
    present: list[str]
    sep: str
    decimal: str
    thousands: str | None
    integers: list[str]
    time_column: str | None
    time_text: str | None
    units_row: bool
    rows: int

    @property
    def data_line(self) -> int:
        """The line (from 1) after which the data rows start: the header's, or the units row's."""
        return self.skip + 1 + self.units_row


#: Time stamps a CSV's time column may hold as text: ISO-8601 dates and times and clock times.
TIME_TEXTS: dict[str, re.Pattern[str]] = {
    "iso": re.compile(r"^\s*\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}([.,]\d+)?)?\s*(Z|[+-]\d{2}:?\d{2})?\s*$"),
    "clock": re.compile(r"^\s*\d{1,2}:\d{2}:\d{2}([.,]\d+)?\s*$"),
}


def _is_number(cell: str, decimal: str, thousands: str | None) -> bool:
    text = cell.strip()
    if thousands:
        text = text.replace(thousands, "")
    try:
        float(text.replace(",", ".") if decimal == "," else text)
    except ValueError:
        return False
    return True


def _unit_cell(cell: str) -> str | None:
    """The unit a cell of a units row names (``s``, ``[ms]``, ``(%)``, ``1/min``), or None."""
    from motorid.units import RECORD_UNITS

    text = cell.strip().strip("[]()").strip()
    text = HEADER_ALIASES.get(text, text)
    return text if text in RECORD_UNITS else None


def _units_row(
    name: str, line: str, present: list[str], sep: str, mapping: dict[str, str]
) -> dict[str, str] | None:
    """The units of a row of units under the header (column -> unit), or None when ``line`` is no
    such row (it holds a number, or no cell names a unit). A named column's unit that is none of
    its kind's is refused, naming the option that gives it."""
    cells = [cell.strip() for cell in _fields(line, sep)]
    if len(cells) != len(present) or not any(_unit_cell(c) for c in cells):
        return None
    if any(_is_number(c, ".", None) or _is_number(c, ",", None) for c in cells if c):
        return None
    units = {column: unit for column, cell in zip(present, cells, strict=True) if (unit := _unit_cell(cell))}
    options = {"t": "time_unit", "u": "input_unit", "y": "output_unit"}
    for canonical, column in mapping.items():
        cell = cells[present.index(column)] if column in present else ""
        if cell and units.get(column) not in HEADER_UNITS.get(canonical, (units.get(column),)):
            raise DataError(
                f"{name}: the units row under the header gives column {quoted(column)} the unit {quoted(cell)}, "
                f"which is no unit of its kind ({', '.join(HEADER_UNITS[canonical])}): name its unit with "
                f"{options[canonical]}"
            )
    return units


def csv_layout(
    name: str, mapping: dict[str, str], optional: set[str], sep: str | None, decimal: str | None,
    *, comment: str | None = COMMENT, thousands: str | None = None,
) -> CsvLayout:  # fmt: skip
    """The layout of a CSV record, once the columns of ``mapping`` are found in its header and
    every data row has the header's number of fields (checked in one pass over the file in
    bounded memory): one place for the whole-record read and the read in blocks
    (:mod:`motorid.record_chunks`).

    Lines before the header that begin with ``comment`` are the record's notes
    (``attrs["notes"]``); a row under the header whose cells name units (``s``, ``%``,
    ``rev/s``, ``[ms]``) and hold no number gives the columns' units.

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
    comment : str, optional
        The prefix of comment lines before the header (default ``#``); None: none.
    thousands : str, optional
        The thousands separator; None: detected from the first lines with the decimal mark.
    """
    if comment is not None and (not isinstance(comment, str) or "\n" in comment or "\r" in comment):
        raise DataError(f"comment=... must be the text comment lines begin with, got {quoted(comment)}")
    comment = comment or None  # an empty prefix: no comment lines
    first = _open_checked(name)
    attrs: dict[str, Any] = {}
    skip = 0
    if first.startswith(ATTRS_MARKER):
        attrs = _attrs_from_json(first[len(ATTRS_MARKER) :], name, "the attribute line (line 1)")
        skip = 1
    notes: list[str] = []
    head: list[str] = []
    with open_record_text(name) as fh:
        head = [fh.readline() for _ in range(skip)]
        while (line := fh.readline()) and comment and line.startswith(comment):
            notes.append(line[len(comment) :].strip())
            head.append(line)
        header_text = line
        sample = [line for _ in range(SNIFF_LINES) if (line := fh.readline()).strip()]
    skip = len(head)
    if notes:
        attrs.setdefault("notes", notes)
    if not header_text.strip():
        raise DataError(f"{name} has no header line (line {skip + 1} is empty)")
    sep, decimal, thousands = _dialect(name, header_text, sample, sep, decimal, thousands)
    present = _header(name, header_text, skip + 1, sep)
    for canonical, column in list(mapping.items()):
        if column not in present:
            if canonical in optional:
                del mapping[canonical]
                continue
            hint = ""
            if not notes and header_text[:1] in "#;/%!*" and header_text[:1] != sep:
                hint = "; is the header a comment line? name the comment lines' prefix with comment=..."
            elif len(present) == 1:
                hint = (f"; the header splits into one column with the separator {sep!r}: "
                        "name the file's separator with sep=...")  # fmt: skip
            raise DataError(
                f"column {quoted(column)} is missing from {name}"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {quoted_names(present)}{hint or _name_it(canonical)}"
            )
    units = _units_row(name, sample[0], present, sep, mapping) if sample else None
    if units is not None:
        head.append(sample.pop(0))
        attrs["units"] = {**units, **(attrs.get("units") or {})}
    lines, separators = _count_lines_and(name, sep)
    data_line = skip + 1 + (units is not None)
    rows = lines - data_line
    if rows <= 0:
        raise DataError(f"{name} has a header but no data rows")
    head_separators = sum(line.count(sep) for line in [*head, header_text])
    if separators - head_separators != rows * (len(present) - 1):
        _check_fields(name, data_line, sep, len(present))  # names the row; quoted separators pass
    integers = []
    time_text = None
    if "t" in mapping:
        position = present.index(mapping["t"])
        cells = [_fields(line, sep) for line in sample]
        stamps = [c[position] for c in cells if len(c) > position]
        bare = [stamp.replace(thousands, "") if thousands else stamp for stamp in stamps]
        if stamps and all(_INTEGER.match(stamp) for stamp in bare):
            integers = [mapping["t"]]
        for kind, pattern in TIME_TEXTS.items():
            if stamps and all(pattern.match(stamp) for stamp in stamps):
                time_text = kind
    return CsvLayout(attrs, skip, present, sep, decimal, thousands, integers, mapping.get("t"), time_text,
                     units is not None, rows)  # fmt: skip


def _read_csv(
    name: str,
    mapping: dict[str, str],
    optional: set[str],
    other_columns: bool,
    max_samples: int | None,
    sep: str | None,
    decimal: str | None,
    thousands: str | None = None,
    comment: str | None = COMMENT,
) -> tuple[pd.DataFrame, dict[str, Any], int]:
    """The columns of a CSV record, its attrs and the line after which its data start."""
    layout = csv_layout(name, mapping, optional, sep, decimal, comment=comment, thousands=thousands)
    check_row_limit(name, layout.rows, max_samples)
    replaced = {k for k, v in mapping.items() if v != k}  # a column of a canonical name a named one takes
    wanted = [c for c in layout.present if c in mapping.values() or (other_columns and c not in replaced)]
    rec = _parse_columns(name, layout, wanted)
    rec = rec.rename(columns={v: k for k, v in mapping.items() if v != k})
    attrs = layout.attrs
    if layout.time_text:
        attrs = stamped_in_ns(name, attrs, layout.time_column or "t", layout.time_text)
    if layout.time_text == "iso":
        attrs.setdefault(TIME_ATTR, pd.Timestamp(int(rec["t"].iloc[0])).isoformat())
    return rec.reset_index(drop=True), attrs, layout.data_line


def stamped_in_ns(name: str, attrs: dict[str, Any], column: str, what: str) -> dict[str, Any]:
    """``attrs`` saying that the time column holds int64 ns (it held dates, clock times or
    datetime64 values, read as such); a ``time_unit`` the attrs give it otherwise is refused."""
    units = dict(attrs.get("units") or {})
    if units.get(column, "ns") != "ns":
        raise DataError(
            f"{name}: the time column {quoted(column)} holds {what} stamps, not numbers in {units[column]}"
        )
    units[column] = "ns"
    return {**attrs, "units": units, "time_stamps": what}


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
        rec, where = without_repeated_stamps(name, rec, where, options, names.get("t", "t"))
    if DIRECTION in rec.columns:
        rec[["u", DIRECTION]] = signed_by_direction(rec, where, options, names.get("u", "u"))
        rec = rec.drop(columns=DIRECTION)
    if "t" in rec.columns:
        rec = _on_uniform_time(name, rec, attrs, where, options, names.get("t", "t"))
    else:
        untimed_dt(name, attrs, options, names)
    if "t" not in rec.columns and len(rec.columns):
        rec.insert(0, "t", np.arange(len(rec)) * float(attrs["dt"]))  # the time the sample time gives
        attrs.setdefault("units", {})["t"] = "s"
    rec.attrs.update(attrs)
    rec = convert_record(
        rec, options.input_unit, options.output_unit, options.supply_voltage,
        input_full_scale=options.input_full_scale, counts_per_rev=options.counts_per_rev, where=where,
        column=names.get("u", "u"),
    )  # fmt: skip
    if "u" in rec.columns and "y" in rec.columns:
        check = InputSignCheck(name, options, names)
        check.update(rec["u"].to_numpy(), rec["y"].to_numpy(), (rec.attrs.get("units") or {}).get("y"))
        check.finish()
    return rec


def without_repeated_stamps(
    name: str, rec: pd.DataFrame, where: Callable[[int], str], options: RecordOptions, column: str
) -> tuple[pd.DataFrame, Callable[[int], str]]:
    """``rec`` without the rows that repeat the time stamp of the row before (a logger that wrote a
    sample twice), and how an error names a row of what is left (by its row in the file).

    Repeated rows with the same values are dropped and a warning says how many. Rows whose stamp
    repeats with other values are refused, naming the first and the column that differs, unless
    ``options.duplicates`` says how to merge each stamp's rows: ``first``, ``last`` or ``mean``.
    """
    t = rec["t"].to_numpy()
    repeats = np.flatnonzero(t[1:] == t[:-1]) + 1
    if not repeats.size:
        return rec, where
    others = [c for c in rec.columns if c != "t"]
    values = rec[others].to_numpy(dtype=np.float64)
    differ = repeats[np.any(values[repeats] != values[repeats - 1], axis=1)]
    if differ.size and options.duplicates == "refuse":
        row = int(differ[0])
        which = next(c for k, c in enumerate(others) if values[row, k] != values[row - 1, k])
        raise DataError(
            f"column {quoted(column)} repeats the time stamp {quoted(t[row].item())} at {where(row)} with another "
            f"value of column {quoted(which)} ({rec[which].iloc[row - 1]!r} then {rec[which].iloc[row]!r}): say how "
            "to merge the rows of one stamp with duplicates=first|last|mean"
        )
    group = np.cumsum(np.concatenate(([True], t[1:] != t[:-1])))
    kept = np.flatnonzero(np.concatenate(([True], t[1:] != t[:-1])))
    if differ.size:
        how = {c: options.duplicates for c in others}
        merged = rec.groupby(group, sort=False).agg({"t": "first", **how}).reset_index(drop=True)
    else:
        merged = rec.iloc[kept].reset_index(drop=True)
    merged.attrs = dict(rec.attrs)
    said = f"{name}: {repeats.size} row{'s' if repeats.size > 1 else ''} repeated the time stamp of the row before"
    if differ.size:
        said += f" ({differ.size} with other values), merged by the {options.duplicates} as duplicates asks"
    else:
        said += " with the same values; dropped"
    logger.warning(said + f" (the first at {where(int(repeats[0]))})")
    return merged, lambda row: where(int(kept[row]))


def signed_by_direction(
    rec: pd.DataFrame, where: Callable[[int], str], options: RecordOptions, column: str
) -> np.ndarray:
    """The input ``u`` given its sign by the direction column (sign and magnitude): ``|u|`` where
    the column equals ``options.direction_forward``, ``-|u|`` where it holds its one other value;
    returned with the direction column beside it, as two columns.

    Raises
    ------
    DataError
        A negative input (it must be a magnitude), or a direction column holding a third value,
        naming the row.
    """
    u = rec["u"].to_numpy(dtype=np.float64)
    direction = rec[DIRECTION].to_numpy(dtype=np.float64)
    negative = np.flatnonzero(u < 0)
    if negative.size:
        row = int(negative[0])
        raise DataError(
            f"input column {quoted(column)} is {u[row]:g} at {where(row)}: with direction=... giving the sign, "
            "the input must be a magnitude (>= 0)"
        )
    forward = options.direction_forward
    backward = direction[direction != forward]
    third = np.flatnonzero((direction != forward) & (direction != backward[0])) if backward.size else backward
    if third.size:
        row = int(third[0])
        raise DataError(
            f"direction column {quoted(options.direction)} holds {direction[row]:g} at {where(row)}, a third value "
            f"besides {forward:g} (forward: direction_forward=...) and {backward[0]:g} (backward)"
        )
    return np.column_stack((np.where(direction == forward, u, -u), direction))


class InputSignCheck:
    """Refuses a record whose input never changes sign while its output reverses: a sign-and-magnitude
    drive's unsigned PWM read without its direction column (``direction``), which would give a
    wrong model. Fed a whole record, or its blocks in turn (:meth:`update`), then :meth:`finish`.

    The output reverses when its speed (the output, or the steps of a position) reaches more than
    :attr:`REVERSAL` of its largest magnitude both ways.
    """

    #: Share of the largest speed that the speed must reach both ways to be a reversal.
    REVERSAL = 0.1

    def __init__(self, name: str, options: RecordOptions, names: Mapping[str, str]) -> None:
        self.name, self.options, self.names = name, options, names
        self.input_low = self.input_high = 0.0
        self.speed_low = self.speed_high = 0.0
        self.last: float | None = None
        self.unit: str | None = None

    def update(self, u: np.ndarray, y: np.ndarray, unit: str | None) -> None:
        """Take the next samples of the input ``u`` and the output ``y`` (in ``unit``)."""
        if not u.size:
            return
        self.unit = unit
        self.input_low = min(self.input_low, float(u.min()))
        self.input_high = max(self.input_high, float(u.max()))
        speed = y
        if unit in ("rad", "m"):  # a position: its steps are the speed's sign and size
            speed = np.diff(y if self.last is None else np.concatenate(([self.last], y)))
            self.last = float(y[-1])
        if speed.size:
            self.speed_low = min(self.speed_low, float(speed.min()))
            self.speed_high = max(self.speed_high, float(speed.max()))

    def finish(self) -> None:
        """Raise a DataError naming ``direction`` when the input never changed sign and the output reversed."""
        if self.options.direction is not None or (self.input_low < 0.0 < self.input_high):
            return
        if self.input_low == self.input_high == 0.0:
            return
        largest = max(-self.speed_low, self.speed_high)
        if largest > 0 and min(-self.speed_low, self.speed_high) > self.REVERSAL * largest:
            sign = ">= 0" if self.input_low >= 0.0 else "<= 0"
            what = "position turns back" if self.unit in ("rad", "m") else "output reverses"
            raise DataError(
                f"{self.name}: the input {quoted(self.names.get('u', 'u'))} never changes sign ({sign}) while the "
                f"{what}: a drive with sign and magnitude logs the sign in a direction column; name it "
                "with direction=... (and its value for forward with direction_forward=...)"
            )


def check_increasing(raw: np.ndarray, where: Callable[[int], str], column: str) -> None:
    """Refuse time stamps ``raw`` that do not increase, naming the row (``where(k)`` names ``raw[k]``)."""
    nonpos = np.flatnonzero(np.diff(raw) <= 0)
    if nonpos.size:
        row = int(nonpos[0]) + 1
        raise DataError(
            f"column {quoted(column)} is not increasing at {where(row)}: {quoted(raw[row].item())} after {quoted(raw[row - 1].item())}"
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
    stamps = attrs.pop("time_stamps", None)
    if stamps is not None and options.time_unit not in (None, "ns"):
        raise DataError(
            f"time_unit={options.time_unit!r} was given, but the time column {quoted(column)} of {name} holds "
            f"{stamps} stamps, read as such: leave time_unit out"
        )
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
            f"column {quoted(column)} of {name} steps by {median_raw:g} per sample: read in {unit or 's'} that is a "
            f"sample time of {median_raw * scale:g} s; loggers stamp in s, ms, us or ns: say which with "
            "time_unit=..., or give the sample time with dt=..."
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
                f"dt = {_seconds(dt)} (dt=...) contradicts the time column {quoted(column)} of {name}, which steps "
                f"by {_seconds(median)}; leave it out or correct it"
                + ("" if options.time_unit else " (or give the time column's unit with time_unit=...)")
            )
    expected = dt if dt is not None else file_dt if file_dt is not None else median
    if expected is None:  # one sample and no dt
        raise DataError(f"{name}: one sample and no dt given: the sample time is unknown (dt=...)")
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
                f"column {quoted(column)} has a gap of {missing} sample{'s' if missing > 1 else ''} before {where(row)}: "
                f"step {steps[row - 1]:.6g} s, expected dt = {expected:.6g} s (resample=True puts the record on a "
                "uniform grid across it)"
            )
        if odd.size:
            row = int(odd[0]) + 1
            raise DataError(
                f"column {quoted(column)} is not uniformly sampled at {where(row)}: step {steps[row - 1]:.6g} s, "
                f"expected dt = {expected:.6g} s (jitter up to {JITTER_LIMIT:.0%} of it is resampled; "
                "resample=True resamples any)"
            )
    return deviation, jittered, gaps, odd


#: The units a named column's header may end with, in brackets, by canonical column.
HEADER_UNITS: dict[str, tuple[str, ...]] = {
    "t": tuple(TIME_UNITS),
    "u": tuple(INPUT_UNITS),
    "y": OUTPUT_UNIT_NAMES,
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
            f"{name}: no time column {names.get('t', 't')!r} and no dt given: name the time column with time=... "
            "or give the sample time with dt=..."
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
        message += " as resample=True asks"
    logger.warning(message + f": input held, output interpolated ({len(rec)} -> {len(out)} samples)")
    return out


def speed_from_position(record: pd.DataFrame, source: str | os.PathLike[str] = "the record") -> pd.DataFrame:
    """The speed of a record whose output is a position (an encoder's, read in counts): backward
    differences over one sample,

        omega[k] = (theta[k] - theta[k-1]) / dt    [rad/s from rad, m/s from m],

    the mean speed over the sample before ``t[k]``. The first sample, which has no difference,
    is left out; the position is kept as the column ``position``, and ``t`` starts at 0 again
    (``attrs["time_origin"]`` moves on by ``dt``). A position in counts is quantised, so the
    speed is too, in steps of ``2 pi / (N dt)``: a warning says the step.

    Parameters
    ----------
    record : pandas.DataFrame
        A record (as :func:`read_record` gives it) whose ``attrs["units"]["y"]`` is ``rad`` or ``m``.
    source : str or path-like
        The record's name in the messages.

    Returns
    -------
    pandas.DataFrame
        The record with ``y`` the speed, ``attrs["units"]["y"]`` its unit and
        ``attrs["speed_step"]`` [rad/s] the step a speed from counts is quantised in.

    Raises
    ------
    DataError
        The output is no position, or the record has fewer than 2 samples.
    """
    units = dict(record.attrs.get("units") or {})
    unit = units.get("y")
    if unit not in ("rad", "m"):
        raise DataError(f"{source}: the output is in {unit or 'no named unit'}, not a position (rad or m)")
    if len(record) < 2:
        raise DataError(f"{source}: a speed from positions needs at least 2 samples, got {len(record)}")
    dt = float(record.attrs["dt"])
    theta = record["y"].to_numpy(dtype=np.float64)
    out = record.iloc[1:].reset_index(drop=True)
    out["y"] = np.diff(theta) / dt
    out["position"] = theta[1:]
    if "t" in out.columns:
        out["t"] = record["t"].to_numpy()[:-1]  # the same grid from 0: k dt
    out.attrs = dict(record.attrs)
    out.attrs["time_origin"] = float(record.attrs.get("time_origin", 0.0)) + dt
    out.attrs["units"] = {**units, "y": f"{unit}/s", "position": unit}
    counts = (record.attrs.get("converted_from") or {}).get("y") == ENCODER_COUNTS
    if counts and record.attrs.get("counts_per_rev"):
        step = 2.0 * math.pi / float(record.attrs["counts_per_rev"]) / dt
        out.attrs["speed_step"] = step
        logger.warning(
            "%s: the speed is differentiated from the encoder's position (%g counts/rev, dt %s): it is "
            "quantised in steps of %.4g rad/s (%.4g rpm)", source, record.attrs["counts_per_rev"], _seconds(dt),
            step, step * 60.0 / (2.0 * math.pi),
        )  # fmt: skip
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
        raise DataError(f"stop={stop:g} must be after start={start:g} [s]")
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
            f"{option}={value:g} s"
            for option, value in (("start", start), ("stop", stop))
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
    "COMMENT",
    "COMPRESSIONS",
    "DRIVE_ATTR",
    "DUPLICATES",
    "FORMATS_READ",
    "JITTER_LIMIT",
    "MAT_ATTRS_VARIABLE",
    "RECORD_FORMATS",
    "REQUIRED_COLUMNS",
    "SEPARATORS",
    "THOUSANDS",
    "TIME_ATTR",
    "TIME_UNITS",
    "TIMINGS",
    "UNREAD_FORMATS",
    "RecordOptions",
    "check_attrs",
    "compression",
    "count_data_lines",
    "csv_layout",
    "normalise_record",
    "read_record",
    "record_format",
    "record_timing",
    "speed_from_position",
    "trim_record",
    "write_record",
]
