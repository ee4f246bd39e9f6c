"""A constant torque ``T = T_0`` [F], also at rest."""

from __future__ import annotations

from motorid.drive import kernels
from motorid.drive.effects.base import Effect, Parameter


class Offset(Effect):
    """Constant torque ``T = T_0`` [F] (gravity on a tilted axis, a biased amplifier), also at
    rest: parameter ``offset`` T_0 [F], of either sign. The friction filters hold it as a known
    disturbance torque."""

    name = "offset"
    not_on_a_mass = "the rig's constant torque is its load torque T_d"
    parameters = (Parameter("offset", "F", "any", term=kernels.TERM_OFFSET),)
    signature = "constant, the same sign in both directions of motion and at rest"
    filter_known = True


__all__ = ["Offset"]
