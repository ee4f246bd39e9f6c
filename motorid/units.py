"""Units at the edge: a record's input and output converted once, as it is read, to motorid's units.

Inside motorid the input is in volts [V] (or left in the drive's own command
unit, such as PWM duty [%], when no conversion to volts is known) and the
output in SI units: rad/s, rad, m/s or m. Records from DAQs arrive in rpm,
rev/s, degrees, millimetres or PWM duty; each unit is converted here by one
factor,

    x_SI = factor * x_file,

and the record's ``attrs["units"]`` then names the unit its columns hold, so
nothing downstream ever takes rpm for rad/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import pandas as pd

from motorid.errors import DataError

__all__ = [
    "ENCODER_COUNTS",
    "INPUT_UNITS",
    "MOTORID_RECORD_UNITS",
    "OTHER_UNITS",
    "OUTPUT_UNITS",
    "OUTPUT_UNIT_NAMES",
    "RECORD_UNITS",
    "SHOWN_AS",
    "TIME_UNITS",
    "UNNAMED_INPUT",
    "UNNAMED_OUTPUT",
    "ShownOutput",
    "check_input_range",
    "check_unit",
    "convert_record",
    "input_factor",
    "input_unit_name",
    "output_factor",
    "per",
    "rate",
    "shown_output",
]

#: Output units: name -> (factor to the SI unit, the SI unit).
OUTPUT_UNITS: dict[str, tuple[float, str]] = {
    "rad/s": (1.0, "rad/s"),
    "rpm": (2.0 * math.pi / 60.0, "rad/s"),
    "rev/min": (2.0 * math.pi / 60.0, "rad/s"),
    "rev/s": (2.0 * math.pi, "rad/s"),
    "rps": (2.0 * math.pi, "rad/s"),
    "deg/s": (math.pi / 180.0, "rad/s"),
    "rad": (1.0, "rad"),
    "rev": (2.0 * math.pi, "rad"),
    "deg": (math.pi / 180.0, "rad"),
    "m/s": (1.0, "m/s"),
    "mm/s": (1e-3, "m/s"),
    "m": (1.0, "m"),
    "mm": (1e-3, "m"),
}

#: An encoder's position in counts: ``rad = 2 pi counts / N`` with ``N`` counts per revolution,
#: a factor known only with ``N`` (``counts_per_rev``).
ENCODER_COUNTS = "counts"

#: Every unit an output column may be in: :data:`OUTPUT_UNITS` and :data:`ENCODER_COUNTS`.
OUTPUT_UNIT_NAMES: tuple[str, ...] = (*OUTPUT_UNITS, ENCODER_COUNTS)

#: Input units: name -> factor to volts; ``%`` (PWM duty) converts only with a supply voltage, and
#: ``counts`` (a PWM compare value, e.g. 0..255 for 8 bits) becomes duty with the full-scale count.
INPUT_UNITS: dict[str, float | None] = {"V": 1.0, "mV": 1e-3, "%": None, "counts": None}

#: Units of a record's time column: name -> factor to seconds.
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}

#: Units of a record's other columns (armature current, torque, force), named and kept as they are.
OTHER_UNITS: tuple[str, ...] = ("A", "N m", "N")

#: Every unit a record's ``attrs["units"]`` may name.
RECORD_UNITS: tuple[str, ...] = tuple(dict.fromkeys((*OUTPUT_UNITS, *INPUT_UNITS, *TIME_UNITS, *OTHER_UNITS)))


def check_unit(unit: object, column: object, where: str) -> str:
    """``unit``, the unit a record's attrs give ``column``, if it is one of :data:`RECORD_UNITS`.

    Parameters
    ----------
    unit : object
        The unit as read (text, or anything a file holds).
    column : object
        The column's name, for the message.
    where : str
        The record, for the message (``"rec.csv: attrs.units"``).

    Raises
    ------
    DataError
        ``{where}: column 'y' has the unknown unit 'furlongs' (known: ...)``, or a unit
        that is not text.
    """
    if not isinstance(unit, str):
        raise DataError(f"{where}: the unit of column {column!r} must be text, got {unit!r:.60}")
    if unit not in RECORD_UNITS:
        raise DataError(
            f"{where}: column {column!r} has the unknown unit {unit!r:.60} (known: {', '.join(RECORD_UNITS)})"
        )
    return unit


#: The units of a record motorid simulates or records: time, input and output (read-only).
MOTORID_RECORD_UNITS: Mapping[str, str] = MappingProxyType({"t": "s", "u": "V", "y": "rad/s"})

#: What a figure or a report calls the unit of an input or output the record does not name:
#: the numbers are in the record's own units, whatever they are.
UNNAMED_INPUT = "input units"
UNNAMED_OUTPUT = "output units"

#: Units an output is shown in at the edge (figures, tables) instead of the unit held inside:
#: speeds in rpm, as the paper reports them.
SHOWN_AS: dict[str, str] = {"rad/s": "rpm"}

#: The quantity an output's SI unit measures.
_QUANTITY = {"rad/s": "speed", "m/s": "speed", "rad": "position", "m": "position"}


@dataclass(frozen=True)
class ShownOutput:
    """How an output is shown: ``shown = factor * y``, in ``unit``, a ``quantity`` (speed,
    position or output).

    Attributes
    ----------
    quantity : str
        ``"speed"``, ``"position"`` or ``"output"``.
    factor : float
        Shown value per held value [shown unit / held unit].
    unit : str
        The unit shown.
    """

    quantity: str
    factor: float
    unit: str


def shown_output(unit: str | None) -> ShownOutput:
    """How an output held in ``unit`` is shown in a figure or a report.

    ``rad/s`` is shown in rpm (:data:`SHOWN_AS`), a unit of :data:`OUTPUT_UNITS`
    as it is, and an output whose unit nobody named (``None``) in its own
    numbers, called :data:`UNNAMED_OUTPUT`: no unit is invented for it.

    Parameters
    ----------
    unit : str or None
        The unit the output is held in (a key of :data:`OUTPUT_UNITS`), None if unnamed.

    Examples
    --------
    >>> shown_output("rad/s").unit, round(shown_output("rad/s").factor, 4)
    ('rpm', 9.5493)
    >>> shown_output(None)
    ShownOutput(quantity='output', factor=1.0, unit='output units')
    """
    if unit is None:
        return ShownOutput("output", 1.0, UNNAMED_OUTPUT)
    quantity = _QUANTITY.get(OUTPUT_UNITS[unit][1], "output") if unit in OUTPUT_UNITS else "output"
    shown = SHOWN_AS.get(unit)
    if shown is None:
        return ShownOutput(quantity, 1.0, unit)
    return ShownOutput(quantity, OUTPUT_UNITS[unit][0] / OUTPUT_UNITS[shown][0], shown)


def input_unit_name(unit: str | None) -> str:
    """The name of an input's unit in a figure or a report: ``unit``, or :data:`UNNAMED_INPUT`.

    Parameters
    ----------
    unit : str or None
        The input's unit, None if unnamed.
    """
    return unit or UNNAMED_INPUT


def rate(unit: str | None) -> str:
    """The unit of the rate of change of a quantity in ``unit`` (``rad`` -> ``rad/s``; no unit:
    ``output units/s``).

    Parameters
    ----------
    unit : str or None
        The quantity's unit, None if unnamed.
    """
    return f"{unit or UNNAMED_OUTPUT}/s"


def per(numerator: str, denominator: str) -> str:
    """A unit ratio in words: ``per("rad/s", "V") == "rad/s per V"``, and an unnamed input
    unit in the singular (``output units per input unit``).

    Parameters
    ----------
    numerator, denominator : str
        The two units.
    """
    return f"{numerator} per {'input unit' if denominator == UNNAMED_INPUT else denominator}"


def output_factor(
    unit: str, option: str = "output_unit=...", counts_per_rev: float | None = None
) -> tuple[float, str]:
    """The factor from ``unit`` to its SI unit, and that SI unit.

    An encoder's counts (:data:`ENCODER_COUNTS`) are a position: with ``N`` counts
    per revolution, ``theta = 2 pi n / N`` [rad].

    Parameters
    ----------
    unit : str
        An output unit (:data:`OUTPUT_UNIT_NAMES`: ``rpm``, ``deg/s``, ``counts`` ...).
    option : str
        The option or argument that gave it, for the message.
    counts_per_rev : float, optional
        Counts per revolution ``N`` of an encoder, for ``counts``.

    Raises
    ------
    DataError
        ``unit`` is not one of :data:`OUTPUT_UNIT_NAMES` (the message lists them), or
        ``counts`` without ``counts_per_rev``.
    """
    if unit == ENCODER_COUNTS:
        if counts_per_rev is None:
            raise DataError(
                "output_unit='counts' needs the encoder's counts per revolution: counts_per_rev=..."
            )
        return 2.0 * math.pi / counts_per_rev, "rad"
    try:
        return OUTPUT_UNITS[unit]
    except KeyError:
        raise DataError(
            f"{option}: unknown unit {unit!r:.80}; known: {', '.join(OUTPUT_UNIT_NAMES)}"
        ) from None


def input_factor(
    unit: str, supply_voltage: float | None = None, option: str = "input_unit=...",
    full_scale: float | None = None,
) -> tuple[float, str]:  # fmt: skip
    """The factor from the input ``unit`` to volts, and the unit the converted input is in.

    PWM duty ``%`` becomes volts with the drive's supply voltage ``V_s`` [V]:
    ``u_V = u_% * V_s / 100``. Without ``supply_voltage`` the duty stays in
    ``%`` (factor 1): the model's input gain then absorbs the supply. PWM
    ``counts`` become duty with the count of full duty ``C`` (``full_scale``,
    255 for 8 bits): ``u_% = 100 u_counts / C``, then as duty.

    Parameters
    ----------
    unit : str
        An input unit (a key of :data:`INPUT_UNITS`: ``V``, ``mV``, ``%``, ``counts``).
    supply_voltage : float, optional
        The drive's supply voltage ``V_s`` [V], for duty and counts.
    option : str
        The option or argument that gave ``unit``, for the message.
    full_scale : float, optional
        The count of full duty ``C`` [counts], for ``counts``.

    Raises
    ------
    DataError
        An unknown unit, counts without a full scale, or a supply voltage or a
        full scale that is not a positive number.
    """
    if unit not in INPUT_UNITS:
        raise DataError(f"{option}: unknown unit {unit!r}; known: {', '.join(INPUT_UNITS)}")
    if supply_voltage is not None and not (math.isfinite(supply_voltage) and supply_voltage > 0):
        raise DataError(f"supply_voltage=... must be a positive voltage [V], got {supply_voltage!r:.80}")
    if full_scale is not None and (unit != "counts" or not (math.isfinite(full_scale) and full_scale > 0)):
        raise DataError(
            f"input_full_scale=... must be a positive count and goes with input_unit='counts', "
            f"got {full_scale!r:.80} with input_unit={unit!r}"
        )
    factor = INPUT_UNITS[unit]
    if factor is not None:
        return factor, "V"
    duty = 1.0
    if unit == "counts":
        if full_scale is None:
            raise DataError(
                "input_unit='counts' needs the count of full duty: input_full_scale=..., "
                "e.g. 255 for an 8-bit PWM"
            )
        duty = 100.0 / full_scale
    if supply_voltage is None:
        return duty, "%"
    return duty * supply_voltage / 100.0, "V"


def check_input_range(
    values: np.ndarray, unit: str, full_scale: float | None = None,
    where: Callable[[int], str] | None = None, column: str = "u",
) -> None:  # fmt: skip
    """Refuse PWM duty beyond ±100 % or counts beyond ±``full_scale``, naming the first such row.

    Parameters
    ----------
    values : ndarray
        The input column as read, in ``unit``.
    unit : str
        Its unit; only ``%`` and ``counts`` have a range.
    full_scale : float, optional
        The count of full duty [counts], for ``counts``.
    where : callable, optional
        Row index -> its place in the file (default ``row k``).
    column : str
        The input column's name, for the message.

    Raises
    ------
    DataError
        Naming the column, the value, the row (``where(row)``, default ``row k``)
        and what the unit allows, with the counts option as the likely fix.
    """
    limit = {"%": 100.0, "counts": full_scale}.get(unit)
    if limit is None:
        return
    beyond = np.flatnonzero(np.abs(values) > limit)
    if beyond.size:
        row = int(beyond[0])
        place = where(row) if where is not None else f"row {row}"
        hint = (
            "; if it holds PWM counts, say input_unit='counts' and input_full_scale=N" if unit == "%" else ""
        )
        raise DataError(
            f"input column {column!r} is {values[row]:g} at {place}, beyond ±{limit:g} {unit} "
            f"(input_unit={unit!r}){hint}"
        )


def convert_record(
    record: pd.DataFrame,
    input_unit: str | None = None,
    output_unit: str | None = None,
    supply_voltage: float | None = None,
    *,
    input_full_scale: float | None = None,
    counts_per_rev: float | None = None,
    where: Callable[[int], str] | None = None,
    column: str = "u",
) -> pd.DataFrame:
    """A copy of ``record`` with ``u`` in volts (or duty %) and ``y`` in SI units.

    Parameters
    ----------
    record : DataFrame
        Columns ``u`` and ``y``; ``attrs["units"]`` may name their units.
    input_unit, output_unit : str, optional
        The units of ``u`` and ``y`` in the file. Given, they override
        ``attrs["units"]``; not given, the attrs say (a record written by
        motorid carries them). A record without either is used as it is, in
        units nobody named (results then say "input units"), and a unit of
        :data:`RECORD_UNITS` the attrs name that has no factor to the column's
        unit (a force input in N, say) is kept as it is (:func:`check_unit`
        refuses the others as the record is read).
    supply_voltage : float, optional
        Supply voltage [V] of a PWM drive, for ``input_unit="%"`` or ``"counts"``.
    input_full_scale : float, optional
        Count of full duty for ``input_unit="counts"``.
    counts_per_rev : float, optional
        Counts per revolution of an encoder, for ``output_unit="counts"`` (a position in rad).
    where : callable, optional
        Row index -> its place in the file, for the message of a duty beyond
        100 % (:func:`check_input_range`).
    column : str
        The input's name in that message.

    Returns
    -------
    DataFrame
        The converted record, ``attrs`` kept, ``attrs["units"]`` updated and
        ``attrs["converted_from"]`` naming the file's units where they were
        converted (``attrs["counts_per_rev"]`` with an encoder's counts).

    Raises
    ------
    DataError
        An unknown unit given as an argument (named, with the known ones), a
        bad supply voltage, a supply voltage for an input that is not PWM
        duty, or a duty beyond 100 % (counts beyond the full scale) at a row.
    """
    units = dict(record.attrs.get("units") or {})
    if supply_voltage is not None and (input_unit or units.get("u")) not in ("%", "counts"):
        raise DataError(
            "supply_voltage=... converts PWM duty to volts: it needs input_unit='%' (or 'counts')"
        )
    if input_full_scale is not None and (input_unit or units.get("u")) != "counts":
        raise DataError("input_full_scale=... goes with input_unit='counts'")
    out = record.copy()
    out.attrs = dict(record.attrs)
    converted = dict(out.attrs.get("converted_from") or {})
    for name, given in (("u", input_unit), ("y", output_unit)):
        unit = given or units.get(name)
        if (
            unit is None or name not in record.columns
        ):  # nothing says: the column is taken as it is and its unit stays unnamed
            continue
        table = INPUT_UNITS if name == "u" else OUTPUT_UNIT_NAMES
        if given is None and unit not in table:  # a unit the file declares without a factor here
            continue
        if name == "u":
            check_input_range(record["u"].to_numpy(), unit, input_full_scale, where, column)
        factor, si = (
            input_factor(unit, supply_voltage, full_scale=input_full_scale)
            if name == "u"
            else output_factor(unit, counts_per_rev=counts_per_rev)
        )
        if factor != 1.0:
            out[name] = record[name] * factor
        if si != unit:
            converted[name] = unit
        units[name] = si
    if units:
        out.attrs["units"] = units
    if converted:
        out.attrs["converted_from"] = converted
    if converted.get("y") == ENCODER_COUNTS:  # what the speed derived from it is quantised by
        out.attrs["counts_per_rev"] = counts_per_rev
    return out
