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
same checks and the same errors as a CSV.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import os
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError

logger = logging.getLogger(__name__)

#: Marker that opens the attribute line.
ATTRS_MARKER = "# motorid-record "
#: Columns a record must have, in its canonical names.
REQUIRED_COLUMNS: tuple[str, ...] = ("t", "u", "y")

#: The keys of ``attrs`` naming the drive a record comes from and when it was taken (ISO 8601 text):
#: written by :mod:`motorid.plants.fleet`, read by ``motorid fleet``.
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
    if value not in TIMINGS:
        raise DataError(f"attrs['timing'] must be one of {sorted(TIMINGS)}, got {value!r}")
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


def write_record(df: pd.DataFrame, path: str | os.PathLike[str]) -> None:
    """Write a record as CSV with its ``attrs`` as JSON in a commented first line.

    Floats are written with full precision (``repr``), so a record read back
    equals the one written.

    Parameters
    ----------
    df : pandas.DataFrame
        The record; its ``attrs`` must be JSON-serialisable (numpy scalars are
        converted).
    path : str or path-like
        Destination file.
    """
    attrs = _jsonable(dict(df.attrs))
    header = ATTRS_MARKER + json.dumps(attrs, separators=(",", ":"), allow_nan=False)
    if "\n" in header:
        raise ValueError("attrs must not contain line breaks")
    with open(path, "w", newline="", encoding="utf-8") as fh:
        fh.write(header + "\n")
        df.to_csv(fh, index=False, float_format=None, lineterminator="\n")
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
    """
    count = 0
    last = b"\n"
    with open(path, "rb") as fh:
        while chunk := fh.read(chunk_bytes):
            count += chunk.count(b"\n")
            last = chunk[-1:]
    return count + (last != b"\n")


def _open_checked(path: str | os.PathLike[str]) -> str:
    """The first line of ``path``, or a DataError naming what keeps it from being a record file."""
    name = os.fspath(path)
    if os.path.isdir(name):
        raise DataError(f"{name} is a folder, not a record file")
    try:
        with open(name, encoding="utf-8") as fh:
            first = fh.readline()
    except FileNotFoundError:
        raise DataError(f"{name}: no such file") from None
    except UnicodeDecodeError as exc:
        raise DataError(
            f"{name} is not a text CSV file (byte {exc.start} of its first line is not UTF-8)"
        ) from None
    if not first.strip():
        raise DataError(f"{name} is empty" if os.path.getsize(name) == 0 else f"{name}: line 1 is blank")
    return first


def _header(path: str, line: str, line_number: int) -> list[str]:
    """The column names of a header line; a DataError on a blank, empty or repeated name."""
    names = [name.strip() for name in next(csv.reader([line]))]
    for position, name in enumerate(names):
        if not name:
            raise DataError(f"{path}: line {line_number}: column {position + 1} of the header has no name")
        if names.index(name) != position:
            raise DataError(f"{path}: line {line_number}: column name {name!r} appears twice in the header")
    return names


def _parse_columns(path: str, skip: int, names: list[str], chunk_rows: int = 1_000_000) -> pd.DataFrame:
    """The data rows of ``names`` as float64, naming the first non-numeric, NaN or infinite cell.

    The fast path parses floats directly, exactly (so a record written with
    :func:`write_record` reads back bit for bit); only when it fails
    are the cells read as text, in chunks of ``chunk_rows`` rows (bounded memory),
    to find and name the first bad one.
    """
    try:
        data = pd.read_csv(path, **csv_data_options(skip, names), dtype=np.float64)
        if all(np.isfinite(data[name].to_numpy()).all() for name in names):
            return data[names]
    except ValueError:
        pass  # a cell that is not a number: find and name it below
    raise_bad_cell(path, skip, names, chunk_rows)


def csv_data_options(skip: int, names: list[str]) -> dict[str, Any]:
    """The options of :func:`pandas.read_csv` that parse the data rows of a CSV record (the
    ``skip`` lines before the header, the columns ``names``): one place for the whole-record read
    and the read in blocks (:mod:`motorid.record_chunks`)."""
    return {"skiprows": skip, "usecols": names, **_EXACT_FLOATS}


def raise_bad_cell(path: str, skip: int, names: list[str], chunk_rows: int = 1_000_000) -> None:
    """Raise a DataError naming the first non-numeric, NaN or infinite cell of the columns ``names``
    of a CSV record, read as text from the start in chunks of ``chunk_rows`` rows (bounded memory)."""
    with pd.read_csv(
        path, **csv_data_options(skip, names), dtype=str, keep_default_na=False, chunksize=chunk_rows
    ) as reader:  # closed when a bad cell is raised
        _name_bad_cell(path, reader, names, skip + 1)
    raise DataError(f"{path}: the columns {names} do not parse as numbers")  # the fast path failed on a quirk


def _name_bad_cell(path: str, reader: Any, names: list[str], header_line: int) -> None:
    """Raise a DataError naming the first non-numeric, NaN or infinite cell of the chunks of ``reader``."""
    for chunk in reader:
        for name in names:
            text = chunk[name].str.strip()
            values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
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
                raise DataError(
                    f"column {name!r} has {kind} value {raw!r} at row {row} (line {header_line + 1 + row} of {path})"
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
    """The format :func:`read_record` reads ``path`` as: a value of :data:`RECORD_FORMATS`, else ``"CSV"``."""
    return RECORD_FORMATS.get(os.path.splitext(os.fspath(path))[1].lower(), "CSV")


def _attrs_from_json(text: Any, name: str, where: str) -> dict[str, Any]:
    """The attributes stored as JSON text (str or bytes) at ``where`` in file ``name``; {} when absent."""
    if text is None:
        return {}
    if isinstance(text, np.ndarray):  # a MATLAB char variable reads as an array of one string
        text = "".join(str(v) for v in text.ravel())
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="replace")
    try:
        attrs = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataError(f"{name}: the record attributes in {where} are not valid JSON: {exc}") from None
    if not isinstance(attrs, dict):
        raise DataError(f"{name}: the record attributes in {where} are not a JSON object")
    return attrs


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
        raise DataError(f"{name} is not a readable Parquet file: {exc}") from None
    metadata = parquet.schema_arrow.metadata or {}
    return parquet, _attrs_from_json(metadata.get(ATTRS_KEY.encode()), name, "the schema metadata")


def _read_parquet(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    parquet, attrs = _parquet_file(name)
    schema = parquet.schema_arrow
    rows = parquet.metadata.num_rows
    chosen = choose({column: (rows,) for column in schema.names})
    table = parquet.read(columns=chosen)
    return {column: table.column(column).to_numpy() for column in chosen}, attrs


def _read_mat(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    import scipy.io

    try:
        listing = scipy.io.whosmat(name)
    except NotImplementedError:  # a MATLAB v7.3 file is an HDF5 file
        return _read_hdf5(name, choose)
    except Exception as exc:  # scipy raises many kinds on a file that is not MATLAB's
        raise DataError(f"{name} is not a readable MATLAB file: {type(exc).__name__}: {exc}") from None
    shapes = {var: tuple(shape) for var, shape, _ in listing if var != MAT_ATTRS_VARIABLE}
    chosen = choose(shapes)
    extra = [MAT_ATTRS_VARIABLE] if len(shapes) < len(listing) else []
    mat = scipy.io.loadmat(name, variable_names=chosen + extra)
    attrs = _attrs_from_json(mat.get(MAT_ATTRS_VARIABLE), name, f"the variable {MAT_ATTRS_VARIABLE}")
    return {var: np.asarray(mat[var]).reshape(-1) for var in chosen}, attrs


def _hdf5_file(name: str) -> tuple[Any, dict[str, tuple[int, ...]], dict[str, Any]]:
    """An HDF5 file opened (an ``h5py.File``), the shape of each of its datasets by path, and its
    record attributes."""
    import h5py

    try:
        handle = h5py.File(name, "r")
    except OSError as exc:
        raise DataError(f"{name} is not a readable HDF5 file: {exc}") from None
    shapes: dict[str, tuple[int, ...]] = {}

    def visit(key: str, item: Any) -> None:
        if isinstance(item, h5py.Dataset) and not key.startswith("#"):  # '#refs#': MATLAB's own
            shapes[key] = tuple(item.shape)

    try:
        handle.visititems(visit)
        attrs = _attrs_from_json(handle.attrs.get(ATTRS_KEY), name, f"the root attribute {ATTRS_KEY!r}")
    except BaseException:
        handle.close()
        raise
    return handle, shapes, attrs


def _read_hdf5(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    handle, shapes, attrs = _hdf5_file(name)
    with handle:
        chosen = choose(shapes)
        return {key: np.asarray(handle[key][()]).reshape(-1) for key in chosen}, attrs


def _read_tdms(name: str, choose: Choose) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Columns ``group/channel``; ``dt`` from the channels' ``wf_increment`` when the file has no attrs' dt."""
    from nptdms import TdmsFile

    try:
        tdms = TdmsFile.open(name)
    except Exception as exc:  # npTDMS raises ValueError, KeyError, struct errors ... on a foreign file
        raise DataError(f"{name} is not a readable TDMS file: {type(exc).__name__}: {exc}") from None
    with tdms:
        channels = {f"{g.name}/{c.name}": c for g in tdms.groups() for c in g.channels()}
        attrs = _attrs_from_json(tdms.properties.get(ATTRS_KEY), name, f"the file property {ATTRS_KEY!r}")
        chosen = choose({key: (len(channel),) for key, channel in channels.items()})
        increments = {channels[key].properties.get("wf_increment") for key in chosen}
        if "dt" not in attrs and len(increments) == 1 and None not in increments:
            attrs["dt"] = float(increments.pop())
        return {key: np.asarray(channels[key][:]) for key in chosen}, attrs


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
    name: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None, found: dict[str, str]
) -> Choose:
    """The ``choose`` of a binary reader: it checks the columns of ``mapping`` against the shapes the
    file holds, records each one's key in ``found`` (key in the file -> canonical name) and returns
    the keys to load (with the other columns of the same length when ``other_columns``)."""

    def choose(shapes: dict[str, tuple[int, ...]]) -> list[str]:
        present = list(shapes)
        for canonical, column in mapping.items():
            key = _find_column(name, column, present)
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
        others = (
            [k for k in present if k not in found and _samples(shapes[k]) == rows] if other_columns else []
        )
        return [k for k in present if k in found or k in others]

    return choose


def _read_binary(
    name: str, kind: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The columns of a Parquet, MATLAB, HDF5 or TDMS record as float64, checked as a CSV's are.

    Other columns (``other_columns``) are those of the same length that are numbers, named as in
    the file (a nested one by its last part when that is unique); the rest of the file (scalars,
    matrices, text) is left out.
    """
    if os.path.isdir(name):
        raise DataError(f"{name} is a folder, not a record file")
    if not os.path.exists(name):
        raise DataError(f"{name}: no such file")
    if os.path.getsize(name) == 0:
        raise DataError(f"{name} is empty")
    found: dict[str, str] = {}
    choose = _column_chooser(name, mapping, other_columns, max_samples, found)
    arrays, attrs = _READERS[kind](name, choose)
    columns: dict[str, np.ndarray] = {}
    for key, values in arrays.items():
        if values.dtype.kind not in "fiub" and key not in found:
            continue
        values = _finite_floats(name, key, values)
        columns[found[key] if key in found else _short_name(key, list(arrays))] = values
    return pd.DataFrame(columns), attrs


def _finite_floats(name: str, key: str, values: np.ndarray, first_row: int = 0) -> np.ndarray:
    """A column of file ``name`` as float64, or a DataError naming it when it is not numeric, or
    its first NaN or infinite value by row (``first_row`` is the row of ``values[0]`` in the file)."""
    if values.dtype.kind not in "fiub":
        raise DataError(f"column {key!r} of {name} is not numeric (its values are {values.dtype})")
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


def read_record(
    path: str | os.PathLike[str],
    dt: float | None = None,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    dt_rtol: float = 1e-3,
    max_samples: int | None = None,
    other_columns: bool = True,
) -> pd.DataFrame:
    """Read and check a record: CSV (as :func:`write_record` writes it, or any CSV) or a DAQ's file.

    The format comes from the extension (:func:`record_format`): ``.parquet``/``.pq``
    (Parquet), ``.mat`` (MATLAB: one variable per column, a row or column vector,
    as EMPS; v7.3 files too), ``.tdms`` (NI TDMS: a column per channel, named
    ``group/channel`` or by the channel's name alone when no other group has one
    of that name), ``.h5``/``.hdf5`` (HDF5: a column per one-dimensional dataset,
    named by its path), anything else CSV. The attributes come from the CSV
    attribute line or the format's place for them (:data:`ATTRS_KEY`); a TDMS
    waveform's ``wf_increment`` gives ``dt``. Every format is checked the same way.

    Parameters
    ----------
    path : str or path-like
        The record file.
    dt : float, optional
        Expected sample time [s]. Default: ``attrs["dt"]`` from the file, else
        the median spacing of the time column. If given and the file says
        otherwise, DataError.
    columns : sequence of str or mapping, optional
        Columns that must be present. A sequence lists them by name (default
        ``("t", "u", "y")``); a mapping ``{canonical: name_in_file}``, e.g.
        ``{"t": "time", "y": "speed_rad_s"}``, renames them to ``t``, ``u``,
        ``y`` (unmapped ones keep their canonical name).
    min_samples : int
        Fewest rows accepted (what the model needs), >= 1.
    dt_rtol : float
        Relative tolerance on the uniformity of the time steps (default 0.1 %: a
        measured time column carries clock jitter, e.g. 2e-5 relative in EMPS).
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

    Returns
    -------
    pandas.DataFrame
        The record with float64 columns and ``attrs`` (``dt`` always set).

    Raises
    ------
    DataError
        (a ValueError) On a missing file, a folder, an empty, binary or
        header-only file, a file that is not of the format its extension says, a
        blank or repeated column name, a missing or ambiguous column, a column
        that is not one column of numbers or is shorter than another, a NaN or
        infinite value, a time column that is not increasing, has a gap or is
        not uniformly sampled, fewer than ``min_samples`` or more than
        ``max_samples`` rows; the message names the file, the column and the row
        (0-based data row, and in a CSV the line in the file).
    """
    if not isinstance(min_samples, int) or min_samples < 1:
        raise ValueError(f"min_samples must be an integer >= 1, got {min_samples!r}")
    if max_samples is not None and (not isinstance(max_samples, int) or max_samples < min_samples):
        raise ValueError(
            f"max_samples must be an integer >= min_samples = {min_samples}, got {max_samples!r}"
        )
    if dt is not None and (not math.isfinite(dt) or dt <= 0.0):
        raise DataError(f"dt must be finite and > 0, got {dt!r}")
    name = os.fspath(path)
    mapping = _column_map(columns)
    kind = record_format(name)
    if kind == "CSV":
        rec, attrs, header_line = _read_csv(name, mapping, other_columns, max_samples)
        where = _row_place(name, header_line)
    else:
        rec, attrs = _read_binary(name, kind, mapping, other_columns, max_samples)
        where = _row_place(name, None)
    return _checked(name, rec, attrs, where, dt, dt_rtol, min_samples)


def _row_place(name: str, header_line: int | None) -> Callable[[int], str]:
    """How an error names data row ``row`` of file ``name``: with its line in a CSV (whose header is
    on line ``header_line``), by the row alone in the other formats."""
    if header_line is None:
        return lambda row: f"row {row} of {name}"
    return lambda row: f"row {row} (line {header_line + 1 + row} of {name})"


def _read_csv(
    name: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None
) -> tuple[pd.DataFrame, dict[str, Any], int]:
    """The columns of a CSV record, its attrs and the line number of its header."""
    attrs, skip, present = _csv_layout(name, mapping)
    rows = count_data_lines(name) - skip - 1
    if rows <= 0:
        raise DataError(f"{name} has a header but no data rows")
    check_row_limit(name, rows, max_samples)
    wanted = present if other_columns else [c for c in present if c in mapping.values()]
    rec = _parse_columns(name, skip, wanted).rename(columns={v: k for k, v in mapping.items() if v != k})
    return rec.reset_index(drop=True), attrs, skip + 1


def _csv_layout(name: str, mapping: dict[str, str]) -> tuple[dict[str, Any], int, list[str]]:
    """A CSV record's attrs, the number of lines before its header and its column names, once the
    columns of ``mapping`` are found in the header."""
    first = _open_checked(name)
    attrs: dict[str, Any] = {}
    skip = 0
    if first.startswith(ATTRS_MARKER):
        try:
            attrs = json.loads(first[len(ATTRS_MARKER) :])
        except json.JSONDecodeError as exc:
            raise DataError(f"{name}: line 1: the attribute line is not valid JSON: {exc}") from exc
        skip = 1
    with open(name, encoding="utf-8") as fh:
        header_text = [fh.readline() for _ in range(skip + 1)][-1]
    if not header_text.strip():
        raise DataError(f"{name} has no header line (line {skip + 1} is empty)")
    present = _header(name, header_text, skip + 1)
    for canonical, column in mapping.items():
        if column not in present:
            raise DataError(
                f"column {column!r} is missing from {name}"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {present}"
            )
    return attrs, skip, present


def _checked(
    name: str,
    rec: pd.DataFrame,
    attrs: dict[str, Any],
    where: Callable[[int], str],
    dt: float | None,
    dt_rtol: float,
    min_samples: int,
) -> pd.DataFrame:
    """The record with ``attrs["dt"]`` set, once its length and time column pass the checks."""
    if len(rec) < min_samples:
        plural = "" if len(rec) == 1 else "s"
        raise DataError(f"{name} has {len(rec)} sample{plural}; at least {min_samples} are needed")
    if "t" in rec.columns:
        t = rec["t"].to_numpy()
        steps = np.diff(t)
        nonpos = np.flatnonzero(steps <= 0.0)
        if nonpos.size:
            row = int(nonpos[0]) + 1
            raise DataError(
                f"column 't' is not increasing at {where(row)}: {float(t[row])!r} after {float(t[row - 1])!r}"
            )
        file_dt = attrs.get("dt")
        if dt is not None and file_dt is not None and not math.isclose(dt, file_dt, rel_tol=dt_rtol):
            raise DataError(f"dt = {dt!r} was asked for but {name} says dt = {file_dt!r}")
        expected = dt if dt is not None else file_dt
        if expected is None and steps.size:
            expected = float(np.median(steps))
        if steps.size and expected is not None:
            off = np.flatnonzero(np.abs(steps - expected) > dt_rtol * expected)
            if off.size:
                row = int(off[0]) + 1
                step = float(steps[row - 1])
                missing = round(step / expected) - 1
                if missing >= 1 and abs(step - (missing + 1) * expected) <= dt_rtol * expected * (
                    missing + 1
                ):
                    raise DataError(
                        f"column 't' has a gap of {missing} sample{'s' if missing > 1 else ''} before {where(row)}: "
                        f"step {step:.6g} s, expected dt = {float(expected):.6g} s"
                    )
                raise DataError(
                    f"column 't' is not uniformly sampled at {where(row)}: step "
                    f"{step:.6g} s, expected dt = {float(expected):.6g} s"
                )
        if expected is not None:
            attrs["dt"] = float(expected)
    elif dt is not None:
        attrs["dt"] = float(dt)
    if "dt" not in attrs:
        raise DataError(f"{name}: no time column 't' and no dt given")
    rec.attrs.update(attrs)
    return rec


__all__ = [
    "ATTRS_KEY",
    "ATTRS_MARKER",
    "DRIVE_ATTR",
    "MAT_ATTRS_VARIABLE",
    "RECORD_FORMATS",
    "REQUIRED_COLUMNS",
    "TIME_ATTR",
    "TIMINGS",
    "count_data_lines",
    "read_record",
    "record_format",
    "record_timing",
    "write_record",
]
