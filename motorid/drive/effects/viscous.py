"""Viscous friction ``T = B ω`` [F]."""

from __future__ import annotations

from typing import Any

from motorid.drive import kernels
from motorid.drive.effects.base import Effect, Parameter


class ViscousFriction(Effect):
    """Viscous friction ``T = B ω`` [F] (bearings, back-EMF through the driver): parameter
    ``viscous`` B [F s/v], >= 0."""

    name = "viscous_friction"
    parameters = (Parameter("viscous", "F s/v", ">= 0", term=kernels.TERM_VISCOUS),)
    signature = "grows in proportion to w, sign follows sgn(w), largest at high |w|"
    filter_states = ("viscous",)

    def filter_prior(self, params: dict[str, float], stribeck_shape: str) -> dict[str, Any]:
        """B."""
        return {"viscous0": params["viscous"]}


__all__ = ["ViscousFriction"]
