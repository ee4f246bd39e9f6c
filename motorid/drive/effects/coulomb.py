"""Coulomb friction ``T = F_c sgn(ω)`` [F] (paper eq. 8)."""

from __future__ import annotations

from typing import Any

from motorid.drive import kernels
from motorid.drive.effects.base import KINETIC_FRICTION, Effect, Parameter


class CoulombFriction(Effect):
    """Coulomb friction ``T = F_c sgn(ω)`` [F] (paper eq. 8): a constant level whose sign follows
    the motion; parameter ``coulomb`` F_c [F], >= 0."""

    name = "coulomb_friction"
    parameters = (Parameter("coulomb", "F", ">= 0", term=kernels.TERM_COULOMB),)
    signature = "constant level whose sign follows sgn(w); dominates at low |w| and holds a resting drive"
    filter_states = ("coulomb",)

    def physics(self, model: tuple[str, ...]) -> str:
        return KINETIC_FRICTION

    def level(self, params: dict[str, float]) -> float:
        """The Coulomb level F_c [F]."""
        return float(params["coulomb"])

    def filter_prior(self, params: dict[str, float], stribeck_shape: str) -> dict[str, Any]:
        """F_c both ways."""
        return {"coulomb0": params["coulomb"], "coulomb_neg0": params["coulomb"]}


__all__ = ["CoulombFriction"]
