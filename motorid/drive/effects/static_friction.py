"""Static friction above the kinetic level (the Karnopp stick rule of the free run)."""

from __future__ import annotations

from motorid.drive.effects.base import BREAKAWAY_FRICTION, KINETIC, Effect, Parameter


class StaticFriction(Effect):
    """Static friction above the kinetic level: a drive at rest breaks away only when the net
    force exceeds the kinetic level at 0± by ``ΔF_s`` [F]; moving, it slows against the kinetic
    level alone, so it breaks away high and keeps moving down to a lower force (hysteresis).

    Parameter ``breakaway_excess`` ΔF_s [F], >= 0. It acts through the stick/slip rule of the
    free run only (:func:`~motorid.drive.kernels.stick_or_slip`); the balance of the moving
    samples does not see it, so a fit of the balance keeps the value it is given, and the
    doctor fits and judges it on the free run
    (:func:`~motorid.diagnose.workflow.fit_static_friction`). The friction filters hold it in
    their stick rule.
    """

    name = "static_friction"
    parameters = (Parameter("breakaway_excess", "F", ">= 0"),)
    signature = "at rest only: the drive stays stuck under forces beyond its kinetic friction level"
    rest_only = True
    acts = "rests"
    filter_known = True

    def physics(self, model: tuple[str, ...]) -> str:
        """Breakaway friction, in a model with a kinetic level to break away above.

        Parameters
        ----------
        model : tuple of str
            The effects of the model it is added to.
        """
        return BREAKAWAY_FRICTION if any(n in model for n in (*KINETIC, "stribeck_friction")) else ""

    def level(self, params: dict[str, float]) -> float:
        """The breakaway excess ΔF_s [F]."""
        return float(params["breakaway_excess"])


__all__ = ["StaticFriction"]
