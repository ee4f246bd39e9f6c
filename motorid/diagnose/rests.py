"""The rests of a drive: where the measured speed stays at zero, how long, and the input it
breaks away at.

A drive held by friction stops after a reversal and rests until the net force beats the
friction at rest; with static friction above the kinetic level it breaks away at a higher
input than the kinetic level it then moves against. The rests are measured from the
zero-phase low-passed speed ``w`` [v] (:mod:`.kinematics`):

- **at rest**: ``|w| <= w_rest``, with ``w_rest`` the larger of the output's quantisation
  step and three noise floors near rest (what a resting drive's filtered speed stays within);
- **a rest**: a run of at least ``min_samples`` samples at rest (and at least 3 ms), between
  two samples of motion; an excursion above ``w_rest`` no longer than two periods of the
  filter's cut-off and below twice ``w_rest`` is the rest's noise, not motion
  (:func:`noise_excursions`);
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
    settle: int = 1,
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
    settle : int
        The filtered speed's memory [samples] (one period of its cut-off): an excursion above
        ``w_rest`` between two runs at rest that lasts no more than twice it and stays below
        ``2 w_rest`` is the rest's own noise, and the two runs one rest.
    """
    n = w.size
    valid = np.ones(n, dtype=bool) if valid is None else valid
    still = (np.abs(w) <= w_rest) & valid
    still |= noise_excursions(np.abs(w), still, valid, 2 * settle, 2.0 * w_rest)
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


def noise_excursions(
    speed: np.ndarray, still: np.ndarray, valid: np.ndarray, longest: int, peak: float
) -> np.ndarray:
    """The samples of each excursion from rest that is the rest's noise, not motion: a run of
    settled samples not ``still`` between two ``still`` ones, at most ``longest`` samples long and
    with the filtered ``speed`` [v] below ``peak`` throughout.

    A resting drive's filtered speed crosses a threshold of three noise floors now and then, for a
    few samples and barely (on a drifting logger's two sines at 2 ms, 2-9 samples at 1.01-1.27
    times it); each crossing had cut the rest in two, the first part ending in a breakaway the
    drive never made, in the direction of the dip.
    """
    out = np.zeros(speed.size, dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate(([1], still.astype(np.int8), [1]))))
    for a, b in zip(edges[::2], edges[1::2], strict=True):  # runs [a, b) not at rest
        if 0 < a and b < speed.size and b - a <= longest and valid[a:b].all() and speed[a:b].max() < peak:
            out[a:b] = True
    return out


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
    equation, ``w_j = Σ_{i <= j} a^(j-i) (1 - a) / B g_i`` with ``a = exp(-B dt / J)`` and g the
    force held over sample i, for every k at once):

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
    longest = 3 * reach + 2
    lags = np.arange(longest)[:, None] - np.arange(longest)[None, :]  # j - i
    # the speed at the end of sample j per unit force held over sample i <= j (0 above the diagonal)
    response = np.where(lags >= 0, per_force * decay ** np.maximum(lags, 0), 0.0)
    out = np.empty(rests.count, dtype=int)
    for r, (a, b) in enumerate(zip(rests.start, rests.stop, strict=True)):
        lo = max(int(a), int(b) - reach - 1)
        end = min(int(b) + 2 * reach + 1, n, int(rests.start[r + 1]) if r + 1 < rests.count else n)
        s = float(rests.direction[r])
        ks = np.arange(max(lo + 1, int(b) - reach), min(int(b) + 2 * reach, end - 2) + 1)
        ks = ks[s * (force[ks] - force[ks - 1]) > 0.0]  # a force held or falling holds a drive held before
        if ks.size == 0:
            out[r] = int(b) + 1
            continue
        width = end - lo
        resp = response[:width, :width]
        f, w = force[lo:end], y[lo:end]
        # from each start column c on: Σ_{i >= c} R[j, i] F_i and Σ_{i >= c} R[j, i], for every j
        forced = np.cumsum((resp * f)[:, ::-1], axis=1)[:, ::-1]
        unit = np.cumsum(resp[:, ::-1], axis=1)[:, ::-1]
        cols = ks - lo
        grown = forced[:, cols] - f[cols] * unit[:, cols]  # the force's growth since each k (0 before k)
        step_unit = s * unit[:, cols]  # the speed of a unit step s ΔF from each k
        left = w[:, None] - grown
        moving = np.arange(width)[:, None] >= cols[None, :]
        left_moving = np.where(moving, left, 0.0)
        num = np.sum(step_unit * left_moving, axis=0)
        den = np.sum(step_unit * step_unit, axis=0)
        step = np.maximum(num / den, 0.0)
        still = np.sum(np.where(moving, 0.0, w[:, None] ** 2), axis=0)
        cost = still + np.sum(left_moving**2, axis=0) - 2.0 * step * num + step**2 * den
        out[r] = int(ks[int(np.argmin(cost))])
    return out


__all__ = ["Rests", "first_moving", "rests"]
