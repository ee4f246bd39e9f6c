"""A two-mass rig given to the doctor: its search runs on the rig's rigid equivalent, its gaps
are the rig's own simulation, and the effects it finds go back to the rig.

:class:`GivenRig` is the model the doctor works on when ``diagnose(model=rig)`` is a
:class:`~motorid.drive.two_mass.TwoMassRig`: the torque balance of its rigid equivalent
(:meth:`TwoMassRig.rigid_equivalent <motorid.drive.two_mass.TwoMassRig.rigid_equivalent>`),
the free run of the rig itself. :func:`rig_note` is the sentence the report says of it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import cast

import numpy as np

from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import TwoMassRig


@dataclass(frozen=True)
class GivenRig(RigidDrive):
    """A two-mass rig given to the doctor (``diagnose(model=rig)``), as the doctor judges it: its
    torque balance is that of its rigid equivalent (:meth:`TwoMassRig.rigid_equivalent
    <motorid.drive.two_mass.TwoMassRig.rigid_equivalent>`, whose effects and parameters this drive
    holds), its free run the rig's own simulation.

    Parameters
    ----------
    effects, params, dt, stribeck_shape : see RigidDrive
        The rigid equivalent's (:class:`~motorid.drive.rigid.RigidDrive`).
    rig : TwoMassRig
        The rig as given.
    """

    rig: TwoMassRig | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.rig, TwoMassRig):
            raise ValueError(f"rig must be a TwoMassRig, got {type(self.rig).__name__}")

    @classmethod
    def of(cls, rig: TwoMassRig) -> GivenRig:
        """The rig as the doctor works on it; ValueError when it has no rigid equivalent.

        Parameters
        ----------
        rig : TwoMassRig
            The rig given.
        """
        equivalent = rig.rigid_equivalent()
        return cls(equivalent.effects, equivalent.params, equivalent.dt, equivalent.stribeck_shape, rig=rig)

    def free_run(
        self,
        u: np.ndarray,
        w0: float = 0.0,
        substeps: int | None = None,
        start: int = 0,
        q0: float = 0.0,
        position: np.ndarray | None = None,
    ) -> np.ndarray:
        """The rig's measured load speed [rad/s] for the command ``u`` [V], through its sensors
        noise free (tacho gain and A/D steps), at this drive's sample time: from rest at the first
        sample (the rig starts there, ``w0`` is not taken; its internal steps are its own), the
        samples from ``start`` on.

        Parameters
        ----------
        u : numpy.ndarray, shape (N,)
            Command [V], held over each sample.
        w0 : float
            Not taken: the rig runs from rest.
        substeps : int, optional
            Not taken: the rig's own.
        start : int
            The first sample returned.
        q0 : float
            Not taken: the rig runs from its own position 0 (its motor's ripple counts from there).
        position : numpy.ndarray, optional
            Not taken: the record's position is the load's, and the rig's motor ripple follows
            the motor's own position.
        """
        rig = cast(TwoMassRig, self.rig)  # checked at construction
        quiet = dataclasses.replace(rig.tacho, noise_std=0.0)
        y = rig.replace(dt=self.dt, tacho=quiet).simulate(u, seed=0)["y"].to_numpy()
        return y[start:]


def rig_note(rig: TwoMassRig, band: float) -> str:
    """What the doctor says of a two-mass rig it was given: searched on its rigid equivalent, and
    where the shaft mode lies against the ``band`` [Hz] the record excites.

    Parameters
    ----------
    rig : TwoMassRig
        The rig given.
    band : float
        The record's useful band [Hz] (:mod:`.kinematics`).
    """
    mode = math.sqrt(rig.k_s * (1.0 / rig.J_m + 1.0 / rig.J_l)) / (2.0 * math.pi)
    where = (
        f"above the {band:.3g} Hz band the record excites, so the record does not show it"
        if mode > band
        else f"inside the {band:.3g} Hz band the record excites: where the record shows it, the rigid "
        "equivalent misses it"
    )
    return (
        "searched on the rigid equivalent of the two-mass rig (inertias summed, the amplifier and "
        f"K_m/R_a as input gain, its dead zone and saturation): the shaft mode at {mode:.3g} Hz lies {where}; "
        "the initial gap is the rig as given, simulated noise free, and the effects found are handed "
        "back to the rig (its improved model is a two-mass rig)"
    )


__all__ = ["GivenRig", "rig_note"]
