"""Stribeck friction: an excess at low speed that decays with the speed."""

from __future__ import annotations

from typing import Any

from motorid.drive import kernels
from motorid.drive.effects.base import BREAKAWAY_FRICTION, KINETIC, KINETIC_FRICTION, Effect, Parameter


class StribeckFriction(Effect):
    """Stribeck excess ``T = F_s decay(ω) sgn(ω)`` [F], ``decay = exp(-|ω|/v_s)`` or
    ``exp(-(ω/v_s)²)`` (the drive's ``stribeck_shape``; paper eq. 9, α1 and α2 = 1/v_s).

    Parameters ``stribeck`` F_s [F], >= 0, and ``stribeck_velocity`` v_s [v], > 0.
    """

    name = "stribeck_friction"
    parameters = (
        Parameter("stribeck", "F", ">= 0", term=kernels.TERM_STRIBECK),
        Parameter("stribeck_velocity", "v", "> 0"),
    )
    signature = "sign follows sgn(w), confined to |w| below a few v_s and decaying with |w|"
    acts = "rest"
    filter_states = ("stribeck",)

    def physics(self, model: tuple[str, ...]) -> str:
        """Breakaway friction beside a kinetic level; without one, its decay slow enough to hold
        back a moving drive at every speed (a Stribeck velocity far above the low speeds) makes
        it the model's kinetic friction.

        Parameters
        ----------
        model : tuple of str
            The effects of the model it is added to.
        """
        return BREAKAWAY_FRICTION if any(n in model for n in KINETIC) else KINETIC_FRICTION

    def level(self, params: dict[str, float]) -> float:
        """The excess F_s at rest over the kinetic level [F]."""
        return float(params["stribeck"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        lo = max(2.0 * scale["w_noise"], 1e-3 * scale["w_max"])
        return {"stribeck_velocity": (lo, 0.3 * scale["w_max"])}

    def filter_prior(self, params: dict[str, float], stribeck_shape: str) -> dict[str, Any]:
        """The excess F_s, the rate 1/v_s and the shape."""
        return {
            "stribeck0": params["stribeck"],
            "stribeck_decay": 1.0 / params["stribeck_velocity"],
            "stribeck_shape": stribeck_shape,
        }


__all__ = ["StribeckFriction"]
