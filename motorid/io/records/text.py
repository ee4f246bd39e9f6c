"""CSV and other text records: written with the record's attributes in a commented first line
(:func:`write_record`); read as loggers write them (any separator, a decimal comma, a
thousands separator, comment lines before the header, a row of units under it, time as
text), whole (:func:`read_csv_record`) or in blocks of rows through pandas' C parser
(:func:`csv_blocks`), both from one layout (:func:`csv_layout`).
"""

from __future__ import annotations

import csv
import json
import logging
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, NoReturn

import numpy as np
import pandas as pd

from motorid.errors import DataError, UniformGridError
from motorid.io.records.columns import Blocks
from motorid.io.records.files import (
    attrs_from_json,
    not_text_hint,
    open_record_bytes,
    open_record_text,
    regular_file_size,
)
from motorid.io.records.normalise import (
    HEADER_UNITS,
    SNIFF_LINES,
    TIME_TEXTS,
    row_place,
    stamped_in_ns,
    text_times,
    unit_cell,
)
from motorid.io.records.options import (
    COMMENT,
    TIME_ATTR,
    check_row_limit,
    column_hint,
    quoted,
    quoted_names,
)

logger = logging.getLogger(__name__)


#: Marker that opens the attribute line.
ATTRS_MARKER = "# motorid-record "


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


def attrs_line(attrs: Mapping[str, Any]) -> str:
    """A record's attributes as the first line of its CSV: :data:`ATTRS_MARKER` and compact JSON
    (numpy scalars converted, non-finite numbers as null), the line every record reader takes back
    as ``attrs`` (:func:`write_record`, and the runs that write their CSV row by row).

    Parameters
    ----------
    attrs : mapping
        JSON-serialisable attributes (``dt`` [s], ``units``, ``timing``, ...).

    Raises
    ------
    ValueError
        A value holds a line break (the line would end early).
    """
    line = ATTRS_MARKER + json.dumps(_jsonable(dict(attrs)), separators=(",", ":"), allow_nan=False)
    if "\n" in line or "\r" in line:
        raise ValueError("attrs must not contain line breaks")
    return line


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

    header = attrs_line(df.attrs)

    def write(fh: Any) -> None:
        fh.write(header + "\n")
        df.to_csv(fh, index=False, float_format=None, lineterminator="\n")

    write_file(path, write, overwrite=overwrite)
    logger.debug("wrote record %s: %d rows, columns %s", path, len(df), list(df.columns))


#: pandas < 3 parses floats exactly only when asked to; pandas 3 always does and deprecates the option.
_EXACT_FLOATS: dict[str, str] = (
    {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
)


def _open_checked(path: str | os.PathLike[str]) -> str:
    """The first line of ``path`` (a UTF-8 BOM left out), or a DataError naming what keeps it from being a record."""
    name = os.fspath(path)
    size = regular_file_size(name)
    try:
        with open_record_text(name) as fh:
            first = fh.readline()
    except UnicodeDecodeError as exc:
        raise DataError(
            f"{name} is not a text CSV file (byte {exc.start} of its first line is not UTF-8){not_text_hint(name)}"
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


def csv_data_options(layout: CsvLayout, names: list[str]) -> dict[str, Any]:
    """The options of :func:`pandas.read_csv` that parse the data rows of a CSV record of ``layout``
    (the lines before the header and a units row under it skipped, the columns ``names``, the
    separator, decimal mark and thousands separator): one place for the whole-record read and
    the read in blocks (:mod:`motorid.io.records.blocks`); a compressed file is decompressed by
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


def _is_number(cell: str, decimal: str, thousands: str | None) -> bool:
    text = cell.strip()
    if thousands:
        text = text.replace(thousands, "")
    try:
        float(text.replace(",", ".") if decimal == "," else text)
    except ValueError:
        return False
    return True


def _units_row(
    name: str, line: str, present: list[str], sep: str, mapping: dict[str, str]
) -> dict[str, str] | None:
    """The units of a row of units under the header (column -> unit), or None when ``line`` is no
    such row (it holds a number, or no cell names a unit). A named column's unit that is none of
    its kind's is refused, naming the option that gives it."""
    cells = [cell.strip() for cell in _fields(line, sep)]
    if len(cells) != len(present) or not any(unit_cell(c) for c in cells):
        return None
    if any(_is_number(c, ".", None) or _is_number(c, ",", None) for c in cells if c):
        return None
    units = {column: unit for column, cell in zip(present, cells, strict=True) if (unit := unit_cell(cell))}
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
    (:mod:`motorid.io.records.blocks`).

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
        attrs = attrs_from_json(first[len(ATTRS_MARKER) :], name, "the attribute line (line 1)")
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
                + f"; columns are {quoted_names(present)}{hint or column_hint(canonical)}"
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


def read_csv_record(
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


def csv_blocks(
    name: str,
    mapping: dict[str, str],
    optional: set[str],
    chunk_rows: int,
    sep: str | None,
    decimal: str | None,
    thousands: str | None = None,
    comment: str | None = COMMENT,
) -> Blocks:
    """A CSV record by pandas' C parser in chunks, with the whole-record read's layout and options; a
    chunk that does not parse as finite numbers is named by :func:`~motorid.io.records.raise_bad_cell`.

    A time column whose first lines are integers is read as int64, exactly, as the whole read
    reads it; should a later chunk hold a fraction there, the rest is read as float64 (the whole
    read then reads the column as float64: the same numbers below 2**53).
    """
    layout = csv_layout(name, mapping, optional, sep, decimal, comment=comment, thousands=thousands)
    if layout.time_text:
        raise UniformGridError(
            f"{name}: the time column {quoted(layout.time_column)} holds {layout.time_text} stamps as text, which "
            "are read when the record is read whole (read_record), not in blocks"
        )
    yield layout.attrs
    yield layout.data_line
    names = [column for column in layout.present if column in mapping.values()]
    canonical = {column: key for key, column in mapping.items()}
    integers = list(layout.integers)
    rows_read = 0
    reader = _csv_reader(name, layout, names, integers, chunk_rows, rows_read)
    try:
        while True:
            try:
                data = next(reader)
            except StopIteration:
                return
            except (ValueError, OverflowError):  # a cell that is not a number, or a fraction in an int column
                if not integers:
                    raise_bad_cell(name, layout, names)
                integers = []  # this chunk again, as floats: a bad cell is then named above
                reader.close()
                reader = _csv_reader(name, layout, names, integers, chunk_rows, rows_read)
                continue
            arrays = {canonical[c]: data[c].to_numpy() for c in names}
            if not all(np.isfinite(values).all() for values in arrays.values()):
                raise_bad_cell(name, layout, names)
            rows_read += len(data)
            yield arrays
    finally:
        reader.close()


def _csv_reader(
    name: str, layout: CsvLayout, names: list[str], integers: list[str], chunk_rows: int, start: int
) -> Any:
    """pandas' chunked reader of the columns ``names`` of a CSV record from data row ``start`` on."""
    options = csv_data_options(layout, names)
    if start:  # the header (and a units row) is skipped with the rows read before: the columns are named
        options.update(skiprows=layout.data_line + start, header=None, names=layout.present)
    dtypes = {column: np.int64 if column in integers else np.float64 for column in names}
    return pd.read_csv(name, dtype=dtypes, chunksize=chunk_rows, **options)
