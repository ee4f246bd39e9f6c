"""Quadratic drag ``T = c ω |ω|`` [F] (windage, fluid drag)."""

from __future__ import annotations

from motorid.drive import kernels
from motorid.drive.effects.base import Effect, Parameter


class QuadraticDrag(Effect):
    """Quadratic drag ``T = c ω |ω|`` [F] (windage, fluid drag): parameter ``quadratic_drag``
    c [F s²/v²], >= 0. Not in the friction filters' model."""

    name = "quadratic_drag"
    parameters = (Parameter("quadratic_drag", "F s²/v²", ">= 0", term=kernels.TERM_QUADRATIC_DRAG),)
    signature = "grows as w², sign follows sgn(w), concentrated at the highest |w|"
    acts = "speed"


__all__ = ["QuadraticDrag"]
