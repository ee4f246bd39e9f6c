"""The vocabulary of a record and how it is read: :class:`RecordOptions`, the one object
that carries the reading options whole, from the command line through ``motorid.app`` into
the readers; the canonical column names, the attribute keys and the timings; the quoting of
offending values in messages. Messages name fields (``time_unit=...``), never command-line
flags.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from motorid.errors import DataError
from motorid.units import ENCODER_COUNTS, TIME_UNITS

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


def _column_map(columns: Sequence[str] | Mapping[str, str] | None) -> dict[str, str]:
    """Canonical name -> name in the file."""
    if columns is None:
        return {c: c for c in REQUIRED_COLUMNS}
    if isinstance(columns, Mapping):
        mapping = {c: c for c in REQUIRED_COLUMNS}
        mapping.update({str(k): str(v) for k, v in columns.items()})
        return mapping
    return {str(c): str(c) for c in columns}


#: The option that names each column a record is read with.
_COLUMN_OPTIONS = {"t": "time", "u": "input", "y": "output", DIRECTION: "direction"}


def column_hint(canonical: str) -> str:
    """The end of a missing column's message: the option that names the column (none for others)."""
    option = _COLUMN_OPTIONS.get(canonical)
    return f"; name the {option} column with {option}=..." if option else ""


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


#: Thousands separators a CSV may use (``thousands``).
THOUSANDS: tuple[str, ...] = (",", ".", "'", " ")


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


#: The most rows the commands (and a fleet's records) hold whole unless told otherwise (``max_samples``):
#: 2 M rows of three float64 columns are 48 MB, and what the doctor builds on them about 0.9 GB.
COMMAND_MAX_SAMPLES = 2_000_000


@dataclass(frozen=True)
class RecordOptions:
    """How a record is read: one object, passed whole from the command line through
    :mod:`motorid.app` to :func:`~motorid.io.records.read_record`,
    :func:`~motorid.io.records.iter_record`, :func:`~motorid.io.records.normalise_record` and
    :func:`motorid.diagnose.diagnose`, each of which also takes its fields as keyword arguments
    (:meth:`of`). The command line says each field as its flag (``time_unit`` as ``--time-unit``).

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
    sep : str, optional
        Separator of a CSV (one character). Default: detected from the header and the
        first lines among :data:`~motorid.io.records.text.SEPARATORS`.
    decimal : {".", ","}, optional
        Decimal mark of a CSV. Default: ``,`` when the separator is not a comma and the
        first lines hold numbers written with one.
    thousands : str, optional
        Thousands separator of a CSV (one of :data:`THOUSANDS`). Default: detected with
        the decimal mark from a number written with both (``-1,035.7``, ``-1.035,7``) or
        with two groups of three digits; else none.
    comment : str, optional
        Prefix of the comment lines before a CSV's header (default ``#``), kept as
        ``attrs["notes"]``; None or ``""``: none.
    sheet : str, optional
        The sheet of an Excel workbook (default: its first).
    max_samples : int, optional
        Most rows a record read whole may have, counted before anything is parsed (a
        record takes about 8 bytes per row and column once read); a longer one is refused
        naming the limit and how to decimate. :func:`~motorid.io.records.read_head` reads
        the first ``max_samples`` rows instead; a record read in blocks has no limit.
        Default: none.
    start, stop : float, optional
        The span kept, ``start <= t <= stop`` [s], ``t`` from 0 at the first sample (without
        a time column, ``k dt``); None leaves that end as it is.
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
    sep: str | None = None
    decimal: str | None = None
    thousands: str | None = None
    comment: str | None = COMMENT
    sheet: str | None = None
    max_samples: int | None = None
    start: float | None = None
    stop: float | None = None

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
        check_dialect(self.sep, self.decimal, self.thousands)
        if self.comment is not None and (
            not isinstance(self.comment, str) or "\n" in self.comment or "\r" in self.comment
        ):
            raise DataError(
                f"comment=... must be the text comment lines begin with, got {quoted(self.comment)}"
            )
        if self.sheet is not None and not isinstance(self.sheet, str):
            raise DataError(f"sheet=... must name a sheet (a text), got {quoted(self.sheet)}")
        if self.max_samples is not None and (
            isinstance(self.max_samples, bool)
            or not isinstance(self.max_samples, int)
            or self.max_samples < 1
        ):
            raise DataError(f"max_samples=... must be an integer >= 1, got {quoted(self.max_samples)}")
        for key in ("start", "stop"):
            value = getattr(self, key)
            if value is not None and (
                isinstance(value, bool) or not isinstance(value, int | float) or not 0.0 <= value < math.inf
            ):
                raise DataError(f"{key}=... must be a time >= 0 [s], got {quoted(value)}")
        if self.start is not None and self.stop is not None and self.stop <= self.start:
            raise DataError(f"stop={self.stop:g} must be after start={self.start:g} [s]")

    @classmethod
    def of(cls, options: RecordOptions | None = None, **fields: Any) -> RecordOptions:
        """``options`` (default: every field's default) with the ``fields`` given as keyword
        arguments in their place: how the functions that take a ``RecordOptions`` also take its
        fields, ``read_record(path, input="pwm", input_unit="%")``.

        Raises
        ------
        DataError
            ``options`` is no RecordOptions, or a keyword is no field of it (naming the fields).
        """
        if options is not None and not isinstance(options, RecordOptions):
            raise DataError(f"options must be a RecordOptions, got {type(options).__name__}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(fields) - known)
        if unknown:
            raise DataError(
                f"{unknown[0]!r} is no record option; the record options are {', '.join(sorted(known))}"
            )
        if options is None:
            return cls(**fields)
        return dataclasses.replace(options, **fields) if fields else options

    @classmethod
    def split(
        cls, options: RecordOptions | None, keywords: Mapping[str, Any]
    ) -> tuple[RecordOptions, dict[str, Any]]:
        """``options`` with the ``keywords`` that are its fields in their place (:meth:`of`), and the
        other keywords: how a function that takes a record and options of its own
        (``identify(df, input="pwm", na=2)``) tells the record's from its own."""
        names = {f.name for f in dataclasses.fields(cls)}
        mine = {key: value for key, value in keywords.items() if key in names}
        return cls.of(options, **mine), {key: value for key, value in keywords.items() if key not in names}

    def normalising(self) -> dict[str, Any]:
        """The fields :func:`~motorid.io.records.normalise_record` reads besides the columns' names:
        the sample time and units always, the others where they are not their defaults."""
        always = (
            "dt",
            "time_unit",
            "input_unit",
            "output_unit",
            "supply_voltage",
            "input_full_scale",
            "resample",
        )
        unread = ("time", "input", "output", "sep", "decimal", "thousands", "comment", "sheet", "max_samples")
        defaults = RecordOptions()
        return {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if f.name in always
            or (f.name not in unread and getattr(self, f.name) != getattr(defaults, f.name))
        }

    @property
    def spanned(self) -> bool:
        """Whether a span is kept (``start`` or ``stop`` given)."""
        return self.start is not None or self.stop is not None

    def whole(self) -> RecordOptions:
        """These options without the span: the record as a whole."""
        return dataclasses.replace(self, start=None, stop=None) if self.spanned else self

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
