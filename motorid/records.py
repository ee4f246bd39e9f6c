"""Records on disk: CSV with the record's attributes in a commented first line.

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
"""

from __future__ import annotations

import csv
import json
import logging
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError

logger = logging.getLogger(__name__)

#: Marker that opens the attribute line.
ATTRS_MARKER = "# motorid-record "
#: Columns a record must have, in its canonical names.
REQUIRED_COLUMNS: tuple[str, ...] = ("t", "u", "y")

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
    header_line = skip + 1
    try:
        data = pd.read_csv(path, skiprows=skip, usecols=names, dtype=np.float64, **_EXACT_FLOATS)
        if all(np.isfinite(data[name].to_numpy()).all() for name in names):
            return data[names]
    except ValueError:
        pass  # a cell that is not a number: find and name it below
    reader = pd.read_csv(
        path, skiprows=skip, usecols=names, dtype=str, keep_default_na=False, chunksize=chunk_rows
    )
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
    raise DataError(f"{path}: the columns {names} do not parse as numbers")  # the fast path failed on a quirk


def read_record(
    path: str | os.PathLike[str],
    dt: float | None = None,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    dt_rtol: float = 1e-3,
    max_samples: int | None = None,
    other_columns: bool = True,
) -> pd.DataFrame:
    """Read and check a record written by :func:`write_record` (or any CSV).

    Parameters
    ----------
    path : str or path-like
        CSV file, with or without the ``# motorid-record`` attribute line.
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
        Most rows accepted. The lines of the file are counted (in bounded
        memory) before anything is parsed, so a record too long for memory is
        refused at once, by a DataError naming the limit and how to decimate.
        A record takes about 8 bytes per row and column once read.
    other_columns : bool
        Keep the file's other columns too (default); False reads only ``columns``
        (less memory and time on a wide file).

    Returns
    -------
    pandas.DataFrame
        The record with float64 columns and ``attrs`` (``dt`` always set).

    Raises
    ------
    DataError
        (a ValueError) On a missing file, a folder, an empty, binary or
        header-only file, a blank or repeated column name, a missing column, a
        non-numeric, NaN or infinite value, a time column that is not increasing,
        has a gap or is not uniformly sampled, fewer than ``min_samples`` or more
        than ``max_samples`` rows; the message names the file, the column and
        the row (0-based data row and the line in the file).
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
    mapping = _column_map(columns)
    for canonical, column in mapping.items():
        if column not in present:
            raise DataError(
                f"column {column!r} is missing from {name}"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {present}"
            )
    rows = count_data_lines(name) - skip - 1
    if rows <= 0:
        raise DataError(f"{name} has a header but no data rows")
    if max_samples is not None and rows > max_samples:
        raise DataError(
            f"{name} has {rows} rows, more than the limit of {max_samples} samples (max_samples, "
            f"--max-samples on the command line) that keeps memory bounded (about 8 bytes per sample "
            f"and column); decimate the record (low-pass filter it, then keep one row in "
            f"{math.ceil(rows / max_samples)}) or raise the limit"
        )
    wanted = present if other_columns else [c for c in present if c in mapping.values()]
    rec = _parse_columns(name, skip, wanted).rename(columns={v: k for k, v in mapping.items() if v != k})
    rec = rec.reset_index(drop=True)
    header_line = skip + 1

    def where(row: int) -> str:
        return f"row {row} (line {header_line + 1 + row} of {name})"

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
    "ATTRS_MARKER",
    "REQUIRED_COLUMNS",
    "TIMINGS",
    "count_data_lines",
    "read_record",
    "record_timing",
    "write_record",
]
