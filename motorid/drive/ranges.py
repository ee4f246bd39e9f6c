"""The physical range of the drive parameters, stated once and checked where each is validated.

A model file, a record's attributes or a caller can hand motorid any float; a value
no drive has (a sample time of 1e308 s, a viscous coefficient of 1e308 N m s/rad, a
filter noise of 1e308 rad/s) would only overflow later, far from its cause, or ask
for memory or time without end. So every parameter of the drive models
(:class:`~motorid.drive.two_mass.TwoMassRig`, its friction laws, amplifier and sensors;
:class:`~motorid.drive.rigid.RigidDrive`) and of the friction filters is checked
with :func:`check_parameter` against these ranges, in SI units:

- a magnitude of at most :data:`LARGEST` = 1e12: the largest drives built
  (rolling-mill motors: torques of 1e7 N m, inertias of 1e5 kg m², shafts of
  1e9 N m/rad) stay a thousand times below it;
- a parameter that must be > 0 (an inertia, inductance, resistance, gain or time
  constant) at least :data:`SMALLEST` = 1e-15: the rotor of the smallest
  micromotor has 1e-10 kg m², its inductance is 1e-6 H.

Within [1e-15, 1e12] a product or quotient of up to twenty parameters stays inside
[1e-300, 1e300], so no equation of the drive overflows on parameters in range.
The sample time has its own range, :data:`SAMPLE_TIME` = [1e-9, 3600] s (from a
1 GHz converter to one sample an hour), and counts that size a loop or an array
are bounded by :data:`MOST_SUBSTEPS` and :data:`MOST_DELAY_SAMPLES`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "LARGEST",
    "MOST_DELAY_SAMPLES",
    "MOST_SUBSTEPS",
    "SAMPLE_TIME",
    "SMALLEST",
    "check_count",
    "check_parameter",
]

#: Largest magnitude of a drive parameter in SI units.
LARGEST = 1e12
#: Smallest value of a drive parameter that must be > 0, in SI units.
SMALLEST = 1e-15
#: Range of a sample time [s].
SAMPLE_TIME = (1e-9, 3600.0)
#: Most integration steps per sample: more is a run that does not end, not a finer model.
MOST_SUBSTEPS = 100_000
#: Most samples of an input delay: the delay line holds that many floats (800 kB).
MOST_DELAY_SAMPLES = 100_000


def check_parameter(
    name: str, value: Any, unit: str, *, sign: str = ">= 0", allow_inf: bool = False
) -> float:
    """``value`` as a float, or a ValueError naming ``name``, its range and ``unit``.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : real number
        The value (not a bool).
    unit : str
        Its SI unit, for the message.
    sign : {">= 0", "> 0", "any"}
        Non-negative (in [0, 1e12]), positive (in [1e-15, 1e12]) or of either sign
        (magnitude at most 1e12).
    allow_inf : bool
        Accept +inf (an infinite saturation: none).
    """
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ValueError(f"{name} must be a number, got {value!r}")
    number = float(value)
    if allow_inf and number == math.inf:
        return number
    if not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if sign == "> 0" and number <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if sign == ">= 0" and number < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    low = SMALLEST if sign == "> 0" else -LARGEST if sign == "any" else 0.0
    if not low <= number <= LARGEST:
        raise ValueError(
            f"{name} must be within [{low:g}, {LARGEST:g}] {unit} (the physical range of a drive), got {value!r}"
        )
    return number


def check_count(name: str, value: Any, lowest: int, most: int) -> int:
    """An integer in [``lowest``, ``most``], or a ValueError naming ``name`` and the range.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : Any
        The value given (true and false are refused).
    lowest, most : int
        The range, both ends included.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lowest <= value <= most:
        raise ValueError(f"{name} must be an integer in [{lowest}, {most}], got {value!r}")
    return int(value)
