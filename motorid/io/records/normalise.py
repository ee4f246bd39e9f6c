"""A record brought to motorid's names and units: time in s from 0 (numbers in s, ms, us or
ns, ISO-8601 or clock-time text, ``datetime64``), repeated stamps dropped or merged, jittered
stamps put on a uniform grid, the sign of a sign-and-magnitude input, units converted
(:func:`motorid.units.convert_record`); and the spans of a record (:func:`trim_record`) and
an encoder's speed from its position (:func:`speed_from_position`). Every format's reader
ends here, and :func:`normalise_record` applies the same to a DataFrame from the user's code.
"""

from __future__ import annotations

import logging
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError
from motorid.io.records.options import (
    DIRECTION,
    JITTER_DT_RTOL,
    JITTER_LIMIT,
    REQUIRED_COLUMNS,
    SAMPLE_TIMES,
    RecordOptions,
    column_hint,
    quoted,
    quoted_names,
)
from motorid.units import ENCODER_COUNTS, INPUT_UNITS, OUTPUT_UNIT_NAMES, TIME_UNITS

logger = logging.getLogger(__name__)


#: Rows a column's kind is judged from: a CSV's lines after the header that the separator, decimal mark and
#: time stamps as text are detected from, and a DataFrame's first time stamps.
SNIFF_LINES = 50


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


def row_place(name: str, header_line: int | None) -> Callable[[int], str]:
    """How an error names data row ``row`` of file ``name``: with its line in a CSV (whose header is
    on line ``header_line``), by the row alone in the other formats."""
    if header_line is None:
        return lambda row: f"row {row} of {name}"
    return lambda row: f"row {row} (line {header_line + 1 + row} of {name})"


def normalise_record(
    record: pd.DataFrame, options: RecordOptions | None = None, *, min_samples: int = 2, **fields: Any
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
    options : RecordOptions, optional
        How the record is read: its columns, time, units and span (``start``, ``stop``);
        the fields for files (``sep``, ``sheet`` ...) do not apply. Default: every
        field's default.
    min_samples : int
        Fewest rows accepted, >= 1.
    **fields :
        Fields of :class:`RecordOptions` given one by one (``input="pwm"``,
        ``input_unit="%"``), in place of those of ``options``.

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
    options = RecordOptions.of(options, **fields)
    mapping = options.column_map()
    present = [str(c) for c in record.columns]
    for canonical, column in mapping.items():
        if column not in present and not (canonical == "t" and options.time_optional()):
            raise DataError(
                f"column {quoted(column)} is missing from the record"
                + (f" (needed as {canonical!r})" if column != canonical else "")
                + f"; columns are {quoted_names(present)}{column_hint(canonical)}"
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
    normalised = normalised_read(
        "the record", rec, attrs, lambda row: f"sample {row}", options, min_samples, names
    )
    return as_used(normalised, options, "the record", min_samples, speed=False)


#: Time stamps a CSV's time column may hold as text: ISO-8601 dates and times and clock times.
TIME_TEXTS: dict[str, re.Pattern[str]] = {
    "iso": re.compile(r"^\s*\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}([.,]\d+)?)?\s*(Z|[+-]\d{2}:?\d{2})?\s*$"),
    "clock": re.compile(r"^\s*\d{1,2}:\d{2}:\d{2}([.,]\d+)?\s*$"),
}


def unit_cell(cell: str) -> str | None:
    """The unit a cell of a units row names (``s``, ``[ms]``, ``(%)``, ``1/min``), or None."""
    from motorid.units import RECORD_UNITS

    text = cell.strip().strip("[]()").strip()
    text = HEADER_ALIASES.get(text, text)
    return text if text in RECORD_UNITS else None


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


def normalised_read(
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


def as_used(
    record: pd.DataFrame,
    options: RecordOptions,
    source: str | os.PathLike[str],
    min_samples: int,
    speed: bool,
) -> pd.DataFrame:
    """``record`` as it is used: its output differentiated to a speed when ``speed`` asks and it is
    an encoder's position in counts (:func:`speed_from_position`), then cut to the span of
    ``options`` (:func:`trim_record`)."""
    if speed and (record.attrs.get("converted_from") or {}).get("y") == ENCODER_COUNTS:
        record = speed_from_position(record, os.fspath(source))
    return trim_record(record, options.start, options.stop, source, min_samples=min_samples)


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
