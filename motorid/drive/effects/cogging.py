"""Cogging: a torque ripple periodic in the position."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from motorid.drive import kernels
from motorid.drive.effects.base import Effect, Parameter


class Cogging(Effect):
    """Cogging: a torque ripple periodic in the position θ [v s] (rad or m),
    ``T = A_s sin(p θ) + A_c cos(p θ) = A sin(p θ + φ)`` [F], at any speed and at rest
    (:func:`~motorid.drive.kernels.ripple_torque`).

    Parameters ``cogging_sin`` A_s and ``cogging_cos`` A_c [F], any sign, enter the balance
    linearly; ``cogging_periods`` p [1/q, q = v s the position unit], > 0, is the shape parameter:
    per radian of a rotary drive, so the ripple's periods per revolution (the pole and slot count
    sets it), per metre of a linear one (2π over the ripple's pitch). Reported as the amplitude
    ``A = sqrt(A_s² + A_c²)`` and phase ``φ = atan2(A_c, A_s)`` besides (:meth:`derived`).

    The doctor's position is the record's (a position record) or the integral of its speed, so the
    phase is relative to the record's first sample; records of one drive fitted as one model share
    a phase only when they are position records of one origin (pooled velocity records do not).
    A free run at its own position follows the ripple as far as that position stays within a
    fraction of a period of the drive's; over many periods it drifts out of phase, and a ripple out
    of phase adds to the gap what it should take away. The doctor's free run takes the ripple at
    the record's position (``RigidDrive.free_run(..., position=)``): on a bank's once-per-revolution
    ripple the final gaps fell from 7-13 to 1.3-1.6 noise floors. The
    friction filters hold it as a known part of their model, at the measured position (their
    ``batch_filter(..., position=)``); the friction compensation feeds it forward at the measured
    position.

    The doctor tries it with every other effect. It was named on none of 50 planted records that
    hide nothing, nor of 25 of an encoder's speed, and on none of the real motors' records of
    ``realmotors/``; on the EMPS record (a ball screw) its ripple passes the evidence threshold
    yet does not shrink the free-run gap, and the report says so.
    """

    name = "cogging"
    not_on_a_mass = "the rig's cogging is its motor's ripple (cogging_sin, cogging_cos, cogging_periods)"
    parameters = (
        Parameter("cogging_sin", "F", "any", in_position=True),
        Parameter("cogging_cos", "F", "any", in_position=True),
        Parameter("cogging_periods", "1/q", "> 0"),
    )
    signature = "periodic in the position, the same at every pass of a position, in both directions"
    position = True
    filter_known = True
    derived_units: ClassVar[dict[str, str]] = {"cogging_amplitude": "F", "cogging_phase": "rad"}
    #: Position bins per shortest period searched, the zero padding of the spectrum, and the most
    #: bins (beyond, a bin holds more than a quarter period and the shortest periods go unseen).
    BINS_PER_PERIOD = 4
    PADDING = 8
    MOST_BINS = 2**15

    def columns(
        self,
        w: np.ndarray,
        shape: dict[str, float],
        stribeck_shape: str = "exponential",
        position: np.ndarray | None = None,
    ) -> np.ndarray:
        """``sin(p θ)`` and ``cos(p θ)`` at the ``position`` θ [v s] of each sample, shape (N, 2)
        (:func:`~motorid.drive.kernels.ripple_columns`); ValueError without the position.

        Parameters
        ----------
        w : numpy.ndarray, shape (N,)
            Speeds ω [v] (the ripple does not depend on them).
        shape : dict
            ``cogging_periods`` p [1/(v s)].
        stribeck_shape : {"exponential", "gaussian"}
            Unused.
        position : numpy.ndarray, shape (N,)
            Positions θ [v s].
        """
        if position is None:
            raise ValueError("the cogging columns need the position of the samples")
        q = np.ascontiguousarray(np.asarray(position, dtype=float))
        return kernels.ripple_columns(q, float(shape["cogging_periods"])).T  # each column contiguous

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        """From two periods over the positions the record covers, ``4π / q_span``, to the ripple
        at the top of the useful band at the noise floor's speed, ``2π f_b / (3 w_noise)`` (at
        least 50 times the lowest).

        Parameters
        ----------
        scale : dict
            The record's scales (:meth:`Effect.bounds`): ``q_span`` [v s], ``band`` [Hz] and
            ``w_noise`` [v] are used.
        """
        lo = 4.0 * math.pi / max(scale["q_span"], 1e-300)
        hi = 2.0 * math.pi * scale["band"] / max(3.0 * scale["w_noise"], 1e-300)
        return {"cogging_periods": (lo, max(hi, 50.0 * lo))}

    def locate(
        self, bounds: dict[str, tuple[float, float]], residual: np.ndarray, position: np.ndarray
    ) -> dict[str, tuple[float, float]]:
        """The period from the residual's spectrum in position: the residual averaged in bins of a
        quarter of the shortest period over the positions covered, its zero-padded FFT's largest
        peak within the bounds, and the interval of one padded bin either side of it.

        Parameters
        ----------
        bounds : dict
            ``cogging_periods``'s search interval (:meth:`bounds`).
        residual : numpy.ndarray
            The balance residual of the model without cogging on the fitted rows [F].
        position : numpy.ndarray
            The position at those rows [v s].
        """
        lo, hi = bounds["cogging_periods"]
        ok = np.isfinite(residual) & np.isfinite(position)
        r, q = residual[ok], position[ok]
        if r.size < 8:
            return bounds
        q_min = float(np.min(q))
        span = float(np.max(q)) - q_min
        if not span > 0.0:
            return bounds
        width = 2.0 * math.pi / hi / self.BINS_PER_PERIOD
        n_bins = int(min(span / width + 1, self.MOST_BINS))
        index = np.minimum(((q - q_min) / span * (n_bins - 1)).astype(np.int64), n_bins - 1)
        sums = np.bincount(index, weights=r, minlength=n_bins)
        counts = np.bincount(index, minlength=n_bins)
        mean = np.divide(sums, counts, out=np.zeros(n_bins), where=counts > 0)
        size = 1 << math.ceil(math.log2(self.PADDING * n_bins))  # at most 2¹⁸ (2 MB)
        power = np.abs(np.fft.rfft(mean, size)) ** 2
        step = span / max(n_bins - 1, 1)  # position per bin
        periods = 2.0 * math.pi * np.fft.rfftfreq(size, step)
        inside = (periods >= lo) & (periods <= hi)
        if not inside.any():
            return bounds
        k = int(np.flatnonzero(inside)[np.argmax(power[inside])])
        dp = periods[1]
        return {"cogging_periods": (max(lo, periods[k] - dp), min(hi, periods[k] + dp))}

    def ripple(self, params: dict[str, float]) -> tuple:
        """``(A_s, A_c, p)`` of the drive's ``params``, at any direction (False) and without
        overtones: the ripple is the compiled one.

        Parameters
        ----------
        params : dict
            The drive's parameters.
        """
        a_s, a_c, p = (
            float(params["cogging_sin"]),
            float(params["cogging_cos"]),
            float(params["cogging_periods"]),
        )
        return a_s, a_c, p, False, kernels.NO_HARMONICS, kernels.NO_HARMONICS

    def derived(self, params: dict[str, float]) -> dict[str, float]:
        """``cogging_amplitude`` A [F] and ``cogging_phase`` φ [rad] of ``A sin(p θ + φ)``.

        Parameters
        ----------
        params : dict
            ``cogging_sin`` and ``cogging_cos`` [F].
        """
        a_s, a_c = float(params["cogging_sin"]), float(params["cogging_cos"])
        return {"cogging_amplitude": math.hypot(a_s, a_c), "cogging_phase": math.atan2(a_c, a_s)}


__all__ = ["Cogging"]
