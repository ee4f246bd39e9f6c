"""Input dead zone ``D(u) = 0`` for ``|u| <= d``, else ``u - d sgn(u)`` (paper Fig. 4)."""

from __future__ import annotations

import numpy as np

from motorid.drive.effects.base import KINETIC_FRICTION, Effect, Parameter
from motorid.drive.input_path import input_path


class InputDeadZone(Effect):
    """Input dead zone ``D(u) = 0`` for ``|u| <= d``, else ``u - d sgn(u)`` (paper Fig. 4):
    parameter ``dead_zone`` d [u], >= 0. The friction filters hold it in their input path."""

    name = "input_dead_zone"
    kind = "input"
    not_on_a_mass = "the rig's input path is its amplifier, whose dead zone [V] it is"
    parameters = (Parameter("dead_zone", "u", ">= 0"),)
    signature = "at small |u| and wherever u drives: a force deficit whose sign follows sgn(u)"
    order = 1
    filter_known = True

    def physics(self, model: tuple[str, ...]) -> str:
        return KINETIC_FRICTION

    def level(self, params: dict[str, float]) -> float:
        """The force g d the dead zone withholds [F]."""
        return float(params["input_gain"] * params["dead_zone"])

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        return input_path(x, dead_zone=shape["dead_zone"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        return {"dead_zone": (1e-3 * scale["u_max"], 0.5 * scale["u_max"])}


__all__ = ["InputDeadZone"]
