"""Transport delay of the input path ``Δ(x)(t) = x(t - τ_d)``."""

from __future__ import annotations

import numpy as np

from motorid.drive.effects.base import Effect, Parameter
from motorid.drive.input_path import input_dynamics


class InputDelay(Effect):
    """Transport delay of the input path ``Δ(x)(t) = x(t - τ_d)``, whole and fractional samples
    (driver latency, a controller's computation time): parameter ``input_delay`` τ_d [s], >= 0.
    With a lag it is one map (:func:`~motorid.drive.input_path.input_dynamics`). The friction
    filters hold it in their input path."""

    name = "input_delay"
    kind = "input"
    not_on_a_mass = "the rig's input path has no transport delay between the command and the armature"
    parameters = (Parameter("input_delay", "s", ">= 0"),)
    signature = "after every change of u: the measured drive answers τ_d late, in both directions"
    order = 2
    structure = True
    filter_known = True

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        # with a lag in the model the two are one map (the drive's), applied here
        return input_dynamics(x, dt, shape["input_delay"], shape.get("lag_time_constant", 0.0))

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        # from a twentieth of a sample (below it the balance cannot tell) to the record's reach
        # (the doctor's: a share of the record), 20 samples where none is given
        return {"input_delay": (0.05 * scale["dt"], scale.get("delay_reach", 20.0 * scale["dt"]))}


__all__ = ["InputDelay"]
