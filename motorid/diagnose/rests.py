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
  the run is ended at the last sample whose speed is below a quarter of ``w_rest``;
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


__all__ = ["Rests", "rests"]
