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

import json
import logging
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

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
        raise ValueError(f"attrs['timing'] must be one of {sorted(TIMINGS)}, got {value!r}")
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


def read_record(
    path: str | os.PathLike[str],
    dt: float | None = None,
    columns: Sequence[str] | Mapping[str, str] | None = None,
    min_samples: int = 2,
    dt_rtol: float = 1e-3,
) -> pd.DataFrame:
    """Read and check a record written by :func:`write_record` (or any CSV).

    Parameters
    ----------
    path : str or path-like
        CSV file, with or without the ``# motorid-record`` attribute line.
    dt : float, optional
        Expected sample time [s]. Default: ``attrs["dt"]`` from the file, else
        the spacing of the time column. If given and the file says otherwise,
        ValueError.
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

    Returns
    -------
    pandas.DataFrame
        The record with float64 columns and ``attrs`` (``dt`` always set).

    Raises
    ------
    ValueError
        On a missing column, a non-numeric or NaN value, a time column that is
        not increasing or not uniformly sampled, or fewer than ``min_samples``
        rows; the message names the column and the row (0-based data row and
        the line in the file).
    """
    if not isinstance(min_samples, int) or min_samples < 1:
        raise ValueError(f"min_samples must be an integer >= 1, got {min_samples!r}")
    if dt is not None and (not math.isfinite(dt) or dt <= 0.0):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    with open(path, encoding="utf-8") as fh:
        first = fh.readline()
    attrs: dict[str, Any] = {}
    skip = 0
    if first.startswith(ATTRS_MARKER):
        try:
            attrs = json.loads(first[len(ATTRS_MARKER) :])
        except json.JSONDecodeError as exc:
            raise ValueError(f"{path}: line 1: the attribute line is not valid JSON: {exc}") from exc
        skip = 1
    df = pd.read_csv(path, skiprows=skip, dtype=str, keep_default_na=False)
    header_line = skip + 1

    def where(row: int) -> str:
        return f"row {row} (line {header_line + 1 + row} of {os.fspath(path)})"

    mapping = _column_map(columns)
    for canonical, name in mapping.items():
        if name not in df.columns:
            raise ValueError(
                f"column {name!r} is missing from {os.fspath(path)}"
                + (f" (needed as {canonical!r})" if name != canonical else "")
                + f"; columns are {list(df.columns)}"
            )
    df = df.rename(columns={v: k for k, v in mapping.items() if v != k})

    out = {}
    for col in df.columns:
        text = df[col].str.strip()
        values = pd.to_numeric(text, errors="coerce")
        bad = ~np.isfinite(values.to_numpy(dtype=float))
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raw = df[col].iloc[row]
            if raw.strip().lower() in ("", "nan", "na", "null", "none"):
                kind = "a NaN"
            elif np.isinf(values.iloc[row]):
                kind = "an infinite"
            else:
                kind = "a non-numeric"
            raise ValueError(f"column {col!r} has {kind} value {raw!r} at {where(row)}")
        out[col] = values.to_numpy(dtype=float)
    rec = pd.DataFrame(out)

    if len(rec) < min_samples:
        raise ValueError(
            f"{os.fspath(path)} has {len(rec)} samples, fewer than min_samples = {min_samples} "
            f"(column 't', rows 0..{len(rec) - 1})"
        )
    if "t" in rec.columns:
        t = rec["t"].to_numpy()
        steps = np.diff(t)
        nonpos = np.flatnonzero(steps <= 0.0)
        if nonpos.size:
            row = int(nonpos[0]) + 1
            raise ValueError(
                f"column 't' is not increasing at {where(row)}: {float(t[row])!r} after {float(t[row - 1])!r}"
            )
        file_dt = attrs.get("dt")
        if dt is not None and file_dt is not None and not math.isclose(dt, file_dt, rel_tol=dt_rtol):
            raise ValueError(f"dt = {dt!r} was asked for but {os.fspath(path)} says dt = {file_dt!r}")
        expected = dt if dt is not None else file_dt
        if expected is None and steps.size:
            expected = float(np.median(steps))
        if steps.size and expected is not None:
            off = np.flatnonzero(np.abs(steps - expected) > dt_rtol * expected)
            if off.size:
                row = int(off[0]) + 1
                raise ValueError(
                    f"column 't' is not uniformly sampled at {where(row)}: step "
                    f"{float(steps[row - 1])!r} s, expected dt = {float(expected)!r} s"
                )
        if expected is not None:
            attrs["dt"] = float(expected)
    elif dt is not None:
        attrs["dt"] = float(dt)
    if "dt" not in attrs:
        raise ValueError(f"{os.fspath(path)}: no time column 't' and no dt given")
    rec.attrs.update(attrs)
    return rec


__all__ = ["ATTRS_MARKER", "REQUIRED_COLUMNS", "TIMINGS", "read_record", "record_timing", "write_record"]
