"""Record files on disk, whatever their format: what a file is (:func:`record_format`, by its
extension), its bytes decompressed as they are read (:func:`open_record_bytes`), the checks
before a file is opened (a regular file, not empty), and the record's attributes where each
format keeps them (:data:`ATTRS_KEY`), checked (:func:`check_attrs`).
"""

from __future__ import annotations

import bz2
import contextlib
import gzip
import io
import lzma
import math
import os
import stat
import zipfile
import zlib
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.options import DRIVE_ATTR, TIME_ATTR, quoted, quoted_names, record_timing
from motorid.json_input import parse_json

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
        raise DataError(
            f"{name}: its {kind} data cannot be read (cut or corrupt?): {one_line_reason(exc)}"
        ) from None


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


def regular_file_size(name: str) -> int:
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


def not_text_hint(name: str) -> str:
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


def attrs_from_json(text: Any, name: str, where: str) -> dict[str, Any]:
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


def one_line_reason(exc: BaseException) -> str:
    """An exception of a format library as one line: its kind and the first line of its message."""
    lines = str(exc).strip().splitlines()
    text = lines[0] if lines else ""
    return f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__
