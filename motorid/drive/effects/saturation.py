"""Input saturation ``S(u) = clip(u, -u_s, u_s)``."""

from __future__ import annotations

import numpy as np

from motorid.drive.effects.base import Effect, Parameter
from motorid.drive.input_path import input_path


class InputSaturation(Effect):
    """Input saturation ``S(u) = clip(u, -u_s, u_s)``: parameter ``saturation`` u_s [u], > 0.
    The friction filters hold it in their input path."""

    name = "input_saturation"
    kind = "input"
    not_on_a_mass = "the rig's input path is its amplifier, whose saturation [V] it is"
    parameters = (Parameter("saturation", "u", "> 0"),)
    signature = "at the largest |u| only, sign follows sgn(u): the drive gets less than commanded"
    order = 0
    filter_known = True

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        return input_path(x, saturation=shape["saturation"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        return {"saturation": (0.2 * scale["u_max"], scale["u_max"])}

    def unreached(self, params: dict[str, float], scale: dict[str, float]) -> dict[str, float]:
        """A saturation at or above the records' largest |u| [u]: they never reach it (a clip at
        their largest input would clip any larger input the model is later given).

        Parameters
        ----------
        params : dict
            A model's parameters.
        scale : dict
            The records' scales (``u_max`` [u]).
        """
        level = params.get("saturation", 0.0)
        return {"saturation": float(level)} if level >= scale["u_max"] else {}


__all__ = ["InputSaturation"]
