"""Direction-dependent friction: levels that differ forwards and backwards."""

from __future__ import annotations

from typing import Any

from motorid.drive import kernels
from motorid.drive.effects.base import Effect, Parameter


class AsymmetricFriction(Effect):
    """Direction-dependent friction: ``T = ΔF_c |sgn ω| + ΔF_v |ω|`` [F] on top of B ω + F_c sgn ω.

    Forwards the friction is ``(F_c + ΔF_c) + (B + ΔF_v) ω``, backwards
    ``-(F_c - ΔF_c) + (B - ΔF_v) ω``. While the drive moves, ΔF_c is the same
    column as a constant offset; the fit drops it when an offset is in the model.
    It refines a model's Coulomb and viscous friction, so it is a candidate only
    once both are in the model. Parameters ``coulomb_asymmetry`` ΔF_c [F] and
    ``viscous_asymmetry`` ΔF_v [F s/v], of either sign. The friction filters hold
    ΔF_c (as their backward level) but not ΔF_v.
    """

    name = "asymmetric_friction"
    parameters = (
        Parameter("coulomb_asymmetry", "F", "any", term=kernels.TERM_COULOMB_ASYMMETRY),
        Parameter("viscous_asymmetry", "F s/v", "any", term=kernels.TERM_VISCOUS_ASYMMETRY),
    )
    requires = ("coulomb_friction", "viscous_friction")
    signature = "same sign in both directions of motion (even in w), growing with |w|"
    filter_states = ("coulomb_neg",)
    filter_zero = ("viscous_asymmetry",)

    def filter_prior(self, params: dict[str, float], stribeck_shape: str) -> dict[str, Any]:
        """+ΔF_c forwards, -ΔF_c backwards."""
        return {"coulomb0": params["coulomb_asymmetry"], "coulomb_neg0": -params["coulomb_asymmetry"]}


__all__ = ["AsymmetricFriction"]
