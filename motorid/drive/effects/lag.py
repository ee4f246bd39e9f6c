"""First-order lag of the input path ``T_l dz/dt = x - z``."""

from __future__ import annotations

import numpy as np

from motorid.drive.effects.base import Effect, Parameter
from motorid.drive.input_path import input_dynamics


class InputLag(Effect):
    """First-order lag of the input path ``T_l dz/dt = x - z`` (driver bandwidth, current loop;
    on the linear part the same as a first-order speed filter in the measurement): parameter
    ``lag_time_constant`` T_l [s], >= 0. The friction filters hold it in their input path."""

    name = "input_lag"
    kind = "input"
    not_on_a_mass = "the rig's one input lag is the electrical time constant L_a/R_a"
    parameters = (Parameter("lag_time_constant", "s", ">= 0"),)
    signature = "after every change of u: the force builds up over T_l, the acceleration is rounded"
    order = 3
    structure = True
    filter_known = True

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        if "input_delay" in shape:
            return x  # the delay's transform applied the lag with it (one map)
        return input_dynamics(x, dt, 0.0, shape["lag_time_constant"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        return {"lag_time_constant": (0.1 * scale["dt"], 100.0 * scale["dt"])}


__all__ = ["InputLag"]
