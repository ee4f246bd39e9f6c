"""The rests of a drive: where the measured speed stays at zero, how long, and the input it
breaks away at.

A drive held by friction stops after a reversal and rests until the net force beats the
friction at rest; with static friction above the kinetic level it breaks away at a higher
input than the kinetic level it then moves against. The rests are measured from the
zero-phase low-passed speed ``w`` [v] (:mod:`.kinematics`):

- **at rest**: ``|w| <= w_rest``, with ``w_rest`` the larger of the output's quantisation
  step and three noise floors near rest (what a resting drive's filtered speed stays within);
- **a rest**: a run of at least ``min_samples`` samples at rest (and at least 3 ms), between
  two samples of motion;
- **its breakaway**: the last sample of the run, where the speed leaves zero for good; the
  input there, signed by the direction the drive then moves in, ``s u[k_b]`` [u], is the input
  at breakaway. The filtered speed leaves ``w_rest`` a little after the shaft leaves zero, so
  the run is ended at the last sample whose speed is below a quarter of ``w_rest``. The
  zero-phase filter also spreads the speed's rise back in time: on the bank's benches with
  static friction this reading lay 1-7 samples before the shaft moved. Given the drive's
  inertia and viscous friction, :func:`first_moving` reads the breakaway again on the measured
  speed;
- **the input's rate there**, ``s du/dt[k_b]`` [u/s] (central differences): a lag between the
  input and the force (an armature's electrical time constant τ_e, a driver's filter) raises
  the input at breakaway by about τ_e times it, which static friction does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Rests:
    """The rests of one record.

    Attributes
    ----------
    start, stop : ndarray of int
        First sample of each rest and its breakaway sample (full rate).
    direction : ndarray of int
        +1 or -1: the direction the drive moves in after the rest.
    breakaway_input : ndarray
        ``s u[stop]`` [u]: the input at breakaway, in the direction of the motion.
    input_rate : ndarray
        ``s du/dt[stop]`` [u/s]: how fast the input rises there, in the direction of the motion.
    dt : float
        Sample time [s].
    w_rest : float
        The speed below which the drive counts as at rest [v].
    """

    start: np.ndarray
    stop: np.ndarray
    direction: np.ndarray
    breakaway_input: np.ndarray
    input_rate: np.ndarray
    dt: float
    w_rest: float

    @property
    def count(self) -> int:
        return int(self.start.size)

    @property
    def lengths(self) -> np.ndarray:
        """Length of each rest [s]."""
        return (self.stop - self.start + 1) * self.dt

    def within(self, samples: np.ndarray) -> Rests:
        """The rests whose breakaway sample lies in the full-rate mask ``samples``."""
        keep = samples[self.stop]
        return Rests(
            self.start[keep], self.stop[keep], self.direction[keep], self.breakaway_input[keep],
            self.input_rate[keep], self.dt, self.w_rest,
        )  # fmt: skip

    def summary(self) -> dict[str, float]:
        """``count``, ``median_length`` [s], ``median_breakaway_input`` [u], ``median_input_rate``
        [u/s] (the medians NaN for no rest) and ``w_rest`` [v]."""

        def median(x: np.ndarray) -> float:
            return float(np.median(x)) if x.size else math.nan

        return {
            "count": self.count,
            "median_length": median(self.lengths),
            "median_breakaway_input": median(self.breakaway_input),
            "median_input_rate": median(self.input_rate),
            "w_rest": self.w_rest,
        }


def rests(
    u: np.ndarray,
    w: np.ndarray,
    dt: float,
    w_rest: float,
    valid: np.ndarray | None = None,
    min_samples: int = 3,
) -> Rests:
    """Find the rests of a record (see the module notes).

    Parameters
    ----------
    u : ndarray, shape (N,)
        Input [u].
    w : ndarray, shape (N,)
        Zero-phase low-passed speed [v].
    dt : float
        Sample time [s].
    w_rest : float
        Speed at or below which the drive is at rest [v], > 0.
    valid : ndarray of bool, optional
        Samples where ``w`` is settled; a rest must lie inside them.
    min_samples : int
        Fewest samples of a rest (raised to 3 ms).
    """
    n = w.size
    valid = np.ones(n, dtype=bool) if valid is None else valid
    still = (np.abs(w) <= w_rest) & valid
    shortest = max(min_samples, math.ceil(0.003 / dt))
    edges = np.flatnonzero(np.diff(np.concatenate(([0], still.astype(np.int8), [0]))))
    starts, ends = edges[::2], edges[1::2] - 1  # inclusive runs of samples at rest
    out_start, out_stop, out_dir = [], [], []
    quarter = np.abs(w) <= 0.25 * w_rest
    for a, b in zip(starts, ends, strict=True):
        if a == 0 or b >= n - 1 or not (valid[a - 1] and valid[b + 1]):
            continue  # a rest must be entered and left by motion inside the settled span
        low = np.flatnonzero(quarter[a : b + 1])
        if low.size == 0:
            continue  # the speed only dipped towards zero: no rest
        stop = a + int(low[-1])
        if stop - a + 1 < shortest:
            continue
        out_start.append(a)
        out_stop.append(stop)
        out_dir.append(1 if w[b + 1] > 0 else -1)
    start = np.asarray(out_start, dtype=int)
    stop = np.asarray(out_stop, dtype=int)
    direction = np.asarray(out_dir, dtype=int)
    u = np.asarray(u, dtype=float)
    rate = np.gradient(u, dt)[stop] if n > 1 else np.zeros(stop.size)
    return Rests(start, stop, direction, direction * u[stop], direction * rate, float(dt), float(w_rest))


def first_moving(
    y: np.ndarray, rests: Rests, force: np.ndarray, inertia: float, viscous: float, reach: int
) -> np.ndarray:
    """The first sample each rest's shaft moves in, read on the measured speed ``y`` as a change
    point: at rest up to sample k, then moving in the direction s as a rigid drive leaves rest,

        J dw/dt = s ΔF + (F(t) - F[k]) - B w,    w = 0 at the start of sample k,  ΔF >= 0,

    under the force ``F`` [F] held over each sample: the step ΔF it breaks away with (static
    friction letting go; none where a lag only delays the force's rise) and the force's growth
    since. Kinetic friction is what ``F[k] - s ΔF`` met, so no friction model enters. The speed is
    linear in ΔF, fitted by least squares for each k (the exact zero-order-hold solution of the
    equation, ``w_j = a w_{j-1} + (1 - a) / B g_j`` with ``a = exp(-B dt / J)`` and g the force
    held over sample j):

        k_m = argmin_k  Σ_{j < k} y_j²  +  min_{ΔF >= 0} Σ_{j >= k} (y_j - w_j)²,

    over ``j`` in ``[k_b - reach - 1, k_b + 2 reach]`` and ``k`` in ``[k_b - reach, k_b + 2 reach - 1]``,
    both before the next rest (``k_b`` the filtered speed's reading, :attr:`Rests.stop`; ``reach``
    one period of the filter's cut-off, about how far it spreads the rise), where the force rose
    into sample k (``s (F[k] - F[k-1]) > 0``: a drive held in sample k - 1 by friction is held in
    k by the same force; under held input levels the breakaway falls on a step). The noise on
    ``y`` is white, so the reading carries none of the zero-phase filter's lead; where no sample
    qualifies, the filtered reading stands.

    Parameters
    ----------
    y : ndarray, shape (N,)
        The measured speed [v] at the end of each sample.
    rests : Rests
        The rests found on the filtered speed (:func:`rests`).
    force : ndarray, shape (N,)
        The input force [F] held over each sample.
    inertia, viscous : float
        J [F s²/v] (> 0) and B [F s/v] (>= 0).
    reach : int
        Samples the filtered reading may lie off, >= 1.
    """
    n, dt = y.size, rests.dt
    if viscous > 0.0:
        decay = math.exp(-viscous * dt / inertia)
        per_force = (1.0 - decay) / viscous  # a sample's speed gain per unit force held over it
    else:
        decay, per_force = 1.0, dt / inertia
    powers = decay ** np.arange(3 * reach + 2, dtype=float)  # a^j over the longest stretch

    def held(g: np.ndarray) -> np.ndarray:
        """The speed from rest under the force ``g`` held over each sample: Σ_i a^(j-i) (1 - a)/B g_i."""
        a = powers[: g.size]
        if a[-1] > 1e-200:  # the sum scaled by a^j: a cumulative sum
            return per_force * a * np.cumsum(g / a)
        w = np.empty(g.size)  # a drive far faster than the sample time: the recursion itself
        last = 0.0
        for j, x in enumerate(g):
            last = decay * last + per_force * x
            w[j] = last
        return w

    out = np.empty(rests.count, dtype=int)
    for i, (a, b) in enumerate(zip(rests.start, rests.stop, strict=True)):
        lo = max(int(a), int(b) - reach - 1)
        end = min(int(b) + 2 * reach + 1, n, int(rests.start[i + 1]) if i + 1 < rests.count else n)
        s = float(rests.direction[i])
        still = np.concatenate(([0.0], np.cumsum(y[lo:end] ** 2)))  # Σ y² from lo to each sample
        best, at = np.inf, int(b) + 1
        for k in range(max(lo + 1, int(b) - reach), min(int(b) + 2 * reach, end - 2) + 1):
            if not s * (force[k] - force[k - 1]) > 0.0:
                continue  # a force held or falling: what held the drive in sample k - 1 holds it in k
            grown = held(force[k:end] - force[k])  # the force's growth since sample k
            unit = held(np.full(end - k, s))  # a unit step s ΔF
            left = y[k:end] - grown
            step = max(float(unit @ left) / float(unit @ unit), 0.0)
            left = left - step * unit
            cost = still[k - lo] + float(left @ left)
            if cost < best:
                best, at = cost, k
        out[i] = at
    return out


__all__ = ["Rests", "first_moving", "rests"]
