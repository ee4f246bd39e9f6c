"""How a record file is read, as typed options: the record options identify, doctor and compare share.

:class:`ReadOptions` holds the command line's record options by their names (``--time``,
``--input-unit``, ``--start`` ...) and reads a record with them: whole, its first
``max_samples`` rows (the doctor's segment), or in blocks (compare).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import asdict, dataclass
from typing import Any

import pandas as pd

from motorid.errors import DataError


@dataclass(frozen=True)
class ReadOptions:
    """How a record is read: :func:`motorid.io.records.read_record`'s options, then the span
    ``start <= t <= stop`` [s] (:func:`motorid.io.records.trim_record`).

    The names are the command line's record options (``--time``, ``--input-unit``,
    ``--start`` ...).

    Attributes
    ----------
    time : str, optional
        Name of the time column (default ``t``; none needed when ``dt`` is known).
    input, output : str
        Names of the columns that become ``u`` and ``y`` (default ``u``, ``y``).
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the time column (default: the record's ``attrs["units"]["t"]``, else seconds).
    dt : float, optional
        Sample time [s]; a time column that says otherwise is refused.
    resample : bool
        Put a record with gaps on the uniform grid instead of refusing it.
    sep : str, optional
        Separator of a CSV record (one character); default: detected from its first lines.
    decimal : {".", ","}, optional
        Decimal mark of a CSV record; default: detected from its first lines.
    input_unit, output_unit : str, optional
        Units of the input and output columns, converted to motorid's as they are read
        (:data:`motorid.units.INPUT_UNITS`, :data:`motorid.units.OUTPUT_UNITS`).
    input_full_scale : float, optional
        The count of full duty, for ``input_unit="counts"`` (255 for an 8-bit PWM).
    supply_voltage : float, optional
        Supply voltage [V] of a PWM drive: a duty in % (or counts) becomes volts.
    counts_per_rev : float, optional
        Counts per revolution of an encoder whose position is the output
        (``output_unit="counts"``): the commands get its speed, differentiated
        (:func:`motorid.io.records.speed_from_position`), and a warning says the speed's
        quantisation step.
    direction : str, optional
        A direction column that gives the unsigned input its sign (sign and magnitude).
    direction_forward : float
        The direction column's value for forward (default 1).
    duplicates : {"refuse", "first", "last", "mean"}
        How rows that repeat a time stamp with other values are merged (default: refused).
    thousands : str, optional
        Thousands separator of a CSV record; default: detected from its first lines.
    comment : str, optional
        Prefix of the comment lines before a CSV record's header (default ``#``).
    sheet : str, optional
        The sheet of an Excel record (default: its first).
    max_samples : int
        Most rows read: :meth:`read` refuses a longer record, :meth:`read_segment` takes its
        first ``max_samples`` rows.
    start, stop : float, optional
        The span kept, ``start <= t <= stop`` [s], ``t`` from 0 at the first sample; None
        leaves that end as it is.
    """

    time: str | None = None
    input: str = "u"
    output: str = "y"
    time_unit: str | None = None
    dt: float | None = None
    resample: bool = False
    sep: str | None = None
    decimal: str | None = None
    input_unit: str | None = None
    input_full_scale: float | None = None
    output_unit: str | None = None
    supply_voltage: float | None = None
    counts_per_rev: float | None = None
    direction: str | None = None
    direction_forward: float = 1.0
    duplicates: str = "refuse"
    thousands: str | None = None
    comment: str | None = "#"
    sheet: str | None = None
    max_samples: int = 2_000_000
    start: float | None = None
    stop: float | None = None

    def __post_init__(self) -> None:
        for key in ("start", "stop"):
            value = getattr(self, key)
            if value is not None and not (isinstance(value, int | float) and 0.0 <= value < float("inf")):
                raise DataError(f"{key}=... must be a time >= 0 [s], got {value!r:.80}")
        if self.start is not None and self.stop is not None and self.stop <= self.start:
            raise DataError(f"stop={self.stop:g} must be after start={self.start:g} [s]")

    @property
    def spanned(self) -> bool:
        """Whether a span is kept (``start`` or ``stop`` given): the record is then cut from a whole read."""
        return self.start is not None or self.stop is not None

    def _options(self) -> dict[str, Any]:
        """The options :func:`motorid.io.records.read_record` and :func:`motorid.io.records.iter_record` take."""
        return {k: v for k, v in asdict(self).items() if k not in ("max_samples", "start", "stop")}

    def read(self, path: str | os.PathLike[str], min_samples: int = 20) -> pd.DataFrame:
        """The record ``path`` with columns ``t`` [s], ``u``, ``y``, trimmed to the span.

        Parameters
        ----------
        path : str or os.PathLike
            The record file (any format :func:`motorid.io.records.read_record` reads).
        min_samples : int
            Fewest samples the record, and its span, must hold.
        """
        from motorid.io.records import read_record, trim_record

        record = read_record(
            path,
            min_samples=min_samples,
            max_samples=self.max_samples,
            other_columns=False,
            **self._options(),
        )
        return trim_record(self._speed(record, path), self.start, self.stop, path, min_samples=min_samples)

    def _speed(self, record: pd.DataFrame, path: str | os.PathLike[str]) -> pd.DataFrame:
        """``record``, its output differentiated to a speed when it is an encoder's position in counts."""
        from motorid.io.records import speed_from_position
        from motorid.units import ENCODER_COUNTS

        if (record.attrs.get("converted_from") or {}).get("y") != ENCODER_COUNTS:
            return record
        return speed_from_position(record, os.fspath(path))

    def read_segment(self, path: str | os.PathLike[str], min_samples: int = 20) -> tuple[pd.DataFrame, bool]:
        """As :meth:`read`, but a record longer than ``max_samples`` gives its first ``max_samples``
        rows (a segment, as ``motorid doctor`` reads it: :func:`motorid.io.records.read_head`);
        and whether it is a segment.

        Parameters
        ----------
        path : str or os.PathLike
            The record file.
        min_samples : int
            Fewest samples the record, and its span, must hold.
        """
        from motorid.io.records import read_head, trim_record

        record, segment = read_head(path, self.max_samples, min_samples, **self._options())
        return trim_record(
            self._speed(record, path), self.start, self.stop, path, min_samples=min_samples
        ), segment

    def iter_blocks(
        self, path: str | os.PathLike[str], min_samples: int = 20, chunk_rows: int | None = None
    ) -> Iterator[pd.DataFrame]:
        """The record ``path`` in consecutive blocks of ``chunk_rows`` rows, each read, checked and
        converted as the whole record is (:func:`motorid.io.records.iter_record`); neither
        ``max_samples`` nor the span applies. A record whose time stamps jitter raises
        :class:`motorid.errors.UniformGridError` (it is resampled whole: :meth:`read`), and so does
        one whose output is in encoder counts (differentiated whole).

        Parameters
        ----------
        path : str or os.PathLike
            The record file.
        min_samples : int
            Fewest samples the record must hold.
        chunk_rows : int, optional
            Rows per block; default :data:`motorid.io.records.CHUNK_ROWS`.
        """
        from motorid.errors import UniformGridError
        from motorid.io.records import CHUNK_ROWS, iter_record
        from motorid.units import ENCODER_COUNTS

        if self.output_unit == ENCODER_COUNTS:
            raise UniformGridError(
                f"{os.fspath(path)}: an encoder's counts are differentiated to a speed when the record is read whole"
            )
        return iter_record(
            path, min_samples=min_samples, chunk_rows=chunk_rows or CHUNK_ROWS, **self._options()
        )


__all__ = ["ReadOptions"]
