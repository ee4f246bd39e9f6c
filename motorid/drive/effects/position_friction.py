"""Position-dependent friction: a Coulomb-type level that varies smoothly along the travel."""

from __future__ import annotations

import math

import numpy as np

from motorid.drive import kernels
from motorid.drive.effects.base import Effect, Parameter

#: The harmonics of the level's variation (the fundamental and its overtones).
HARMONICS = 3


class PositionFriction(Effect):
    """Position-dependent friction: the kinetic friction level varies smoothly with the position
    θ [v s] (rad or m), a ball screw's or a guide's friction along its travel::

        T = F(θ) sgn ω,    F(θ) = Σ_{k=1..3} a_k sin(k p θ) + b_k cos(k p θ)        [F]

    added to the Coulomb level (:mod:`~motorid.drive.effects.coulomb`, which it requires: F is the
    variation around that mean). At rest it raises both breakaway levels by F(θ)
    (:func:`~motorid.drive.kernels.rigid_motion`, the compiled position torque
    :func:`~motorid.drive.kernels.position_torque` against the motion).

    Parameters ``position_friction_sin``, ``_cos`` (k = 1), ``_sin2``, ``_cos2``, ``_sin3``,
    ``_cos3`` [F], any sign, enter the balance linearly; ``position_friction_periods`` p
    [1/q, q = v s the position unit], > 0, is the shape parameter: the fundamental's period
    2π/p lies between half the record's travel and twice it (:meth:`bounds`), so the level is
    smooth over the travel, not a ripple (cogging is that).

    The doctor tries it by default on position records only (:attr:`Effect.measured_position
    <motorid.drive.effects.base.Effect.measured_position>`): the level is tied to places along the
    travel, and a model of it holds for records of the same origin. Over the integral of a
    measured speed, which drifts, a smooth level in position is a slow level in time: tried there,
    it was named on none of 40 planted records that hide nothing (nor of 40 of an encoder's
    speed), but on both of the kit motor's chirps in ``realmotors/``, where no name was before.
    Asked for (``candidates``) it is tried on any record. On simulated position-loop records
    (``tests/test_position_friction.py``) the first step names it on 30 of 30 with it and on
    none of 30 without; on EMPS the doctor names it third, a level of -1.3 to +1.2 N about the
    Coulomb level's 19.9 N along the 0.25 m travel.
    """

    name = "position_friction"
    not_on_a_mass = "the rig's friction levels do not depend on the position"
    parameters = (
        Parameter("position_friction_sin", "F", "any", in_position=True),
        Parameter("position_friction_cos", "F", "any", in_position=True),
        Parameter("position_friction_sin2", "F", "any", in_position=True),
        Parameter("position_friction_cos2", "F", "any", in_position=True),
        Parameter("position_friction_sin3", "F", "any", in_position=True),
        Parameter("position_friction_cos3", "F", "any", in_position=True),
        Parameter("position_friction_periods", "1/q", "> 0"),
    )
    signature = "a friction level against the motion that varies along the travel, the same at every pass"
    requires = ("coulomb_friction",)
    position = True
    measured_position = True
    filter_known = True

    def columns(
        self,
        w: np.ndarray,
        shape: dict[str, float],
        stribeck_shape: str = "exponential",
        position: np.ndarray | None = None,
    ) -> np.ndarray:
        """``sgn ω sin(k p θ)`` and ``sgn ω cos(k p θ)``, k = 1, 2, 3, at each sample, shape (N, 6)
        (:func:`~motorid.drive.kernels.ripple_columns` of each harmonic); ValueError without the
        position.

        Parameters
        ----------
        w : numpy.ndarray, shape (N,)
            Speeds ω [v]: their sign.
        shape : dict
            ``position_friction_periods`` p [1/(v s)].
        stribeck_shape : {"exponential", "gaussian"}
            Unused.
        position : numpy.ndarray, shape (N,)
            Positions θ [v s].
        """
        if position is None:
            raise ValueError("the position_friction columns need the position of the samples")
        q = np.ascontiguousarray(np.asarray(position, dtype=float))
        p = float(shape["position_friction_periods"])
        direction = np.sign(np.asarray(w, dtype=float))
        out = np.empty((2 * HARMONICS, q.size))
        for k in range(HARMONICS):
            out[2 * k : 2 * k + 2] = kernels.ripple_columns(q, (k + 1) * p) * direction
        return out.T

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        """The fundamental's period from twice the record's travel to half of it:
        ``p`` in ``[π / q_span, 4π / q_span]``.

        Parameters
        ----------
        scale : dict
            The record's scales (:meth:`Effect.bounds`): ``q_span`` [v s] is used.
        """
        span = max(scale["q_span"], 1e-300)
        return {"position_friction_periods": (math.pi / span, 4.0 * math.pi / span)}

    def ripple(self, params: dict[str, float]) -> tuple:
        """The compiled position torque's arguments: the fundamental ``(a_1, b_1, p)``, against the
        motion (True), and the overtones' ``a_k`` and ``b_k`` as arrays.

        Parameters
        ----------
        params : dict
            The drive's parameters.
        """
        n = self.name
        return (
            float(params[f"{n}_sin"]),
            float(params[f"{n}_cos"]),
            float(params[f"{n}_periods"]),
            True,
            np.array([float(params[f"{n}_sin{k}"]) for k in range(2, HARMONICS + 1)]),
            np.array([float(params[f"{n}_cos{k}"]) for k in range(2, HARMONICS + 1)]),
        )


__all__ = ["PositionFriction"]
