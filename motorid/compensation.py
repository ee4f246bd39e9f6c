"""Friction compensation from a drive model: the feed-forward that cancels the model's friction
and inverts its input dead zone.

For a rigid drive (:class:`~motorid.drive.rigid.RigidDrive`, the doctor's model)::

    J dω/dt = g D(u) - F(ω),      F(ω) = Σ_t θ_t T_t(ω, sgn ω)                [F]

with D the dead zone of half-width d [u] and F the model's friction (viscous, Coulomb,
Stribeck, asymmetric, quadratic drag, offset; the module table of
:mod:`motorid.drive.rigid`). A controller that asks for the effective input v [u] (what
drives the inertia beyond the friction) gets it when the command is::

    u = D̃⁻¹(v + F̃(ω_c) / g)                                                   [u]
    F̃(ω) = Σ_t θ_t T_t(ω, σ(ω)),         σ(ω) = clip(ω / ω_b, -1, 1)            [F]
    D̃⁻¹(x) = x + d clip(x / x_b, -1, 1)                                        [u]

so that ``g D(u) - F(ω) = g v`` wherever the drive moves faster than ω_b and
|x| > x_b.

A drive whose torque depends on the position θ [v s] (its position torque T_p: ``cogging``, a
ripple ``Σ_k A_s,k sin(k p θ) + A_c,k cos(k p θ)``; ``position_friction``, that sum as a level
against the motion, times sgn ω) has it fed forward at the *measured* position θ_m::

    u = D̃⁻¹(v + (F̃(ω_c) + T̃_p(θ_m, ω_c)) / g),    T̃_p = T_p(θ_m) (ripple) or T_p(θ_m) σ(ω_c)  [u]

(cogging compensation: the ripple's amplitudes and period are the model's). The torque is the
drive's own compiled law (:func:`~motorid.drive.kernels.position_torque`). Without a measured
position (a DAQ that reads the speed alone) it is left out, and only then. The sign of the speed in every level term (Coulomb, Stribeck, asymmetry) is
replaced by the ramp σ across the *speed band* ω_b [v], and the dead zone's jump by the
ramp across the *input band* x_b [u]: around zero the compensation fades in linearly
instead of switching between ±F_c and ±d, so that noise on a speed near zero, or a
controller output near zero, does not make it chatter. The terms are evaluated by the
drive's own compiled law (:func:`~motorid.drive.kernels.rigid_term`, with the ramp as the
direction, summed in one call by :func:`~motorid.drive.kernels.rigid_friction`), the same
one the simulation and the doctor's fit use.

Which speed ω_c drives the friction term (``source``):

``"reference"`` (the default)
    The reference speed: noise free, and a pure feed-forward, so it changes nothing in
    the feedback loop (its stability and the PI's tuning are as without it). At a
    reversal the reference leads the drive, so the compensation switches to the new
    direction first and breaks the drive away at once. It is wrong only while the drive
    does not follow (blocked, or a disturbance larger than the loop can take).
``"measured"``
    The measured speed: the friction the drive really has while it moves whatever the
    reference does, but the measurement's noise enters through the band (set ω_b above
    it), the compensation is inside the loop (cancelling the viscous term takes the
    loop's damping; design the PI without it), and a drive at rest gets no Coulomb
    compensation to break away with (σ(0) = 0): the integral action must do that.

The input path's memory (delay, lag, backlash) is not inverted: a feed-forward cannot
undo a delay (drive it with the reference advanced by the delay for that). Static friction's
breakaway excess (``static_friction``) is not fed forward either: it holds only at rest, for
the instant of a breakaway, where a feed-forward of it would overshoot once the drive moves. The input
saturation is the controller's limit (:class:`~motorid.speed_control.SpeedController`).
"""

from __future__ import annotations

import math

import numpy as np

from motorid.drive import effects, kernels
from motorid.drive.rigid import RigidDrive

__all__ = ["SOURCES", "FrictionCompensation"]

#: What drives the friction term: the reference speed or the measured one (module notes).
SOURCES = ("reference", "measured")
#: The input band as a share of the dead zone when it is not given.
INPUT_BAND_SHARE = 0.1


class FrictionCompensation:
    """The feed-forward of a rigid drive model's friction and the inverse of its dead zone.

    See the module notes for the law and the choice of ``source``.

    Parameters
    ----------
    drive : RigidDrive
        The drive model (the doctor's, ``motorid doctor --save-model``); its friction
        parameters [F] and input gain g [F/u], so the compensation is in the input's unit u.
    speed_band : float
        ω_b [v] > 0: half-width of the ramp that replaces sgn(ω) in the level terms. Above
        the noise of the speed it is driven with (1 rad/s is 2.4 σ of the paper's
        tachogenerator noise, about 4 rpm).
    input_band : float, optional
        x_b [u] > 0: half-width of the ramp that replaces the dead zone's jump; default
        a tenth of the dead zone.
    source : {"reference", "measured"}
        The speed that drives the friction term.

    Attributes
    ----------
    dead_zone : float
        d [u] of the model (0 without ``input_dead_zone``).
    position_effect : str
        The model's effect whose torque depends on the position (``cogging``,
        ``position_friction``), fed forward at the measured position; empty for none.
    """

    def __init__(
        self,
        drive: RigidDrive,
        speed_band: float = 1.0,
        input_band: float | None = None,
        source: str = "reference",
    ) -> None:
        if not isinstance(drive, RigidDrive):
            raise ValueError(f"drive must be a RigidDrive (the doctor's model), got {type(drive).__name__}")
        drive.check_physical()
        if not (isinstance(speed_band, int | float) and math.isfinite(speed_band) and speed_band > 0):
            raise ValueError(f"speed_band must be a finite number > 0 [v], got {speed_band!r}")
        if source not in SOURCES:
            raise ValueError(f"source must be one of {', '.join(SOURCES)}, got {source!r}")
        self.drive = drive
        self.speed_band = float(speed_band)
        self.source = source
        self.dead_zone = drive.params.get("dead_zone", 0.0)
        if input_band is None:
            input_band = INPUT_BAND_SHARE * self.dead_zone if self.dead_zone > 0 else 1.0
        if not (isinstance(input_band, int | float) and math.isfinite(input_band) and input_band > 0):
            raise ValueError(f"input_band must be a finite number > 0 [u], got {input_band!r}")
        self.input_band = float(input_band)
        kept = [(p, term) for p, term in drive.linear_terms() if drive.params[p] != 0.0]
        self._terms = np.array([term for _, term in kept], dtype=np.int64)
        self._coefs = np.array([drive.params[p] for p, _ in kept])
        vs = drive.params.get("stribeck_velocity", 1.0)
        self._rate = 1.0 / vs
        self._shape = kernels.STRIBECK_SHAPES.index(drive.stribeck_shape)
        self._gain = drive.input_gain
        self.position_effect = drive.position_effects[0] if drive.position_effects else ""
        self._ripple = effects.get(self.position_effect).ripple(drive.params) if self.position_effect else ()

    def _ramp(self, speed: float) -> float:
        """σ(ω) = clip(ω / ω_b, -1, 1): the sign of ``speed`` [v] ramped across the band."""
        s = speed / self.speed_band
        return 1.0 if s > 1.0 else (-1.0 if s < -1.0 else s)

    def friction(self, speed: float, position: float | None = None) -> float:
        """F̃(ω) [F]: the model's friction at ``speed`` [v] with the sign ramped across the band,
        plus its position torque T̃_p at ``position`` [v s] where given (module notes).

        Parameters
        ----------
        speed : float
            ω_c [v].
        position : float, optional
            The measured position θ_m [v s] (rad or m); None leaves the position torque out.
        """
        w = float(speed)
        s = self._ramp(w)
        total = kernels.rigid_friction(self._terms, self._coefs, w, s, self._rate, self._shape)
        if self._ripple and position is not None:
            a_s, a_c, periods, directed, harmonic_sin, harmonic_cos = self._ripple
            torque = kernels.position_torque(float(position), a_s, a_c, periods, harmonic_sin, harmonic_cos)
            total += s * torque if directed else torque
        return total

    def feedforward(self, speed: float, position: float | None = None) -> float:
        """F̃(ω)/g [u]: the input that balances the friction at ``speed`` [v] (and the position
        torque at ``position`` [v s] where given).

        Parameters
        ----------
        speed : float
            ω_c [v].
        position : float, optional
            The measured position θ_m [v s].
        """
        return self.friction(speed, position) / self._gain

    def invert_input(self, x: float) -> float:
        """D̃⁻¹(x) [u]: the command whose dead zone passes ``x`` [u] (ramped across the input band)."""
        if self.dead_zone == 0.0:
            return float(x)
        r = x / self.input_band
        r = 1.0 if r > 1.0 else (-1.0 if r < -1.0 else r)
        return float(x + self.dead_zone * r)

    def command(self, v: float, reference: float, measured: float, position: float | None = None) -> float:
        """u = D̃⁻¹(v + (F̃(ω_c) + T̃_p(θ_m, ω_c))/g) [u] for the effective input ``v`` [u], ω_c the
        ``source`` speed, θ_m the measured ``position`` [v s] (None: no position torque).

        Parameters
        ----------
        v : float
            The effective input the controller asks for [u].
        reference, measured : float
            The reference and measured speeds [v].
        position : float, optional
            The measured position [v s].
        """
        speed = reference if self.source == "reference" else measured
        return self.invert_input(v + self.feedforward(speed, position))

    def __repr__(self) -> str:
        return (
            f"FrictionCompensation(effects={list(self.drive.effects)}, speed_band={self.speed_band!r}, "
            f"input_band={self.input_band!r}, source={self.source!r})"
        )
