"""LuGre friction: the bristle dynamics of a mass's kinetic friction (Canudas de Wit et al., 1995)."""

from __future__ import annotations

from motorid.drive.effects.base import Effect, Parameter


class LuGreFriction(Effect):
    """LuGre dynamic friction (Canudas de Wit, Olsson, Åström, Lischinsky 1995) on a mass of the
    two-mass rig: the mass's Coulomb and Stribeck friction act through a bristle deflection z [q]::

        g(ω)  = F_c + F_s decay(ω)                        [F]   (coulomb F_c, stribeck F_s, v_s)
        dz/dt = ω - σ0 |ω| z / g(ω)                        [v]
        T     = σ0 z + σ1 dz/dt                            [F]   (+ B ω of viscous_friction)

    At constant speed T tends to ``g(ω) sgn ω``, the static laws' torque, so the effect adds the
    pre-sliding displacement (about F_c/σ0) and the frictional lag of those levels, not a level.
    Sticking is part of the law: the stick/slip rule is not applied to a mass with it. It needs
    ``coulomb_friction`` (F_c > 0) on the same mass and excludes ``asymmetric_friction`` and
    ``static_friction`` there (its levels are the same both ways and it has its own stiction). The
    fast integrator treats the bristle spring explicitly within a sub-step: keep
    ``h sqrt(σ0/J) < 0.5`` (h the internal step).

    Parameters ``bristle_stiffness`` σ0 [F/q], > 0, and ``bristle_damping`` σ1 [F s/q], >= 0. It
    has an internal state, which the rigid drive (and so the doctor) does not carry; the friction
    filters hold its steady state (its Coulomb and Stribeck levels).
    """

    name = "lugre_friction"
    parameters = (
        Parameter("bristle_stiffness", "F/q", "> 0"),
        Parameter("bristle_damping", "F s/q", ">= 0"),
    )
    signature = "a lag of the friction torque behind the speed's reversals, and creep at rest"
    requires = ("coulomb_friction",)
    not_on_a_rigid_drive = (
        "it has an internal bristle state, which a rigid drive does not carry; it runs on a mass of "
        "the two-mass rig (motorid.drive.Friction)"
    )


__all__ = ["LuGreFriction"]
