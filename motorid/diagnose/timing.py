"""A logger's time base: the input delay measured along a record, and whether it drifts.

A logger that stamps the speed late by a delay that grows through the record (a serial link's
buffer filling, a clock that runs slow) gives a record whose input delay is no constant: the
speed answers a step 16 ms late at 5 s and 114 ms late at 50 s. One delay for the whole record
then fits neither end. :func:`delay_drift` cuts each record's settled span into :data:`SEGMENTS`
consecutive segments and measures, on each, how late the measured speed w runs behind the final
model's free run w_sim (the model as fitted, every parameter held): the shift s_i that minimises

    Σ_k (w(t_k) - w_sim(t_k - s_i))²

over the segment's decimated samples (w_sim interpolated between its samples), with its standard
error from the curvature, σ_i² = σ_e² / Σ_k ẇ_sim(t_k - s_i)² · (1 + ρ) / (1 - ρ) (σ_e² the
residual's mean square, ρ its lag-one autocorrelation: a residual that is the model's own error,
not white noise, counts as fewer samples). The segment's delay is the model's input delay plus
s_i. A line through them by weighted least squares (weights 1/σ_i²),

    d(t) = d_0 + r t,

gives the drift r [s/s]; its standard error σ_r is scaled by the delays' scatter about the line
where they scatter more than their errors say (``σ_r sqrt(max(χ²/(n - 2), 1))``, χ² their weighted
squares). The time base drifts where the line moves over the record's span T by more than
:data:`DRIFT_SAMPLES` samples and by more than :data:`DRIFT_ERRORS` of its scaled standard errors
(|r| > 3 σ_r).

Why the free run and not the torque balance: refitted on a segment with its linear parameters
free, the balance trades the delay with the inertia (``J + B τ_d`` is what it sees first), and its
cost (the residual in acceleration units) leans to the larger inertia: on benches whose logger
drifts by 1-3 ms a second, the segments' delays came out 1-15 samples short of the truth and their
line said the drift on 13 of 15 (``bank(range(3), ["drifting_delay"])``). With the model held, the
shift is a shift of the whole response, which the inertia cannot take: on the same 15 benches the
drift is said on all, its rate within 15 % of the logger's on the held levels, 18 % on the two
sines and 38 % on the chirps. What the model's own delay got wrong (a delay the fit took into its
inertia) moves every segment alike, and the more so at a chirp's higher frequencies: the line's
level can be off by that delay, its slope a little. ``align`` takes out the slope alone
(:func:`~motorid.diagnose.workflow.aligned_record`) and measures it again against the aligned
record's own model (within 1 % of the logger's), leaving the start's delay for the structure
search of the aligned record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from motorid.drive.rigid import RigidDrive

#: Segments a record is cut into for its delays.
SEGMENTS = 5
#: A drift moves the delay by more than this many samples over the record ... Measured with the
#: base the bank uses (``bank``'s): the line moved 2.9-16 samples on the 50 ``drifting_delay``
#: benches of seeds 0-9 (a 10 ms held-levels stair whose logger drifts 1.1 ms a second: 2.9,
#: missed at 3 samples with 10 noise floors left), at most 0.89 on the 50 ``constant_delay`` and
#: ``none`` benches of seeds 0-4 (0.1 but on one chirp).
DRIFT_SAMPLES = 1.5
#: ... and by more than this many of its standard errors (scaled by the delays' scatter about
#: the line where it exceeds their errors).
DRIFT_ERRORS = 3.0
#: Grid points the shift is searched on over the delay's reach either way before the bounded
#: search refines it (a step of a 40th of the reach: 7.5 ms at the 0.3 s reach of 30 s at 1 kHz,
#: well inside a period of what the records excite).
SHIFT_GRID = 81


@dataclass(frozen=True)
class DelayDrift:
    """The input delay along one record.

    Attributes
    ----------
    label : str
        The record.
    times : ndarray
        Middle of each segment from the record's first sample [s].
    delays : ndarray
        The input delay on each segment [s]: the model's plus the segment's shift.
    delay_std : ndarray
        Its standard error on each segment [s].
    first, last : float
        The line's delay at the record's first and last settled sample [s] (0 where the line
        falls below it).
    drifts : bool
        Whether the time base drifts (see the module notes).
    rate : float
        The line's slope r [s/s]: the delay's growth per second of the record.
    span : tuple of float
        The times of the record's first and last settled sample [s].
    """

    label: str
    times: np.ndarray
    delays: np.ndarray
    delay_std: np.ndarray
    first: float
    last: float
    drifts: bool
    rate: float
    span: tuple[float, float]

    def sentence(self) -> str:
        """One line for the report."""
        grows = "grows" if self.rate > 0 else "shrinks"
        return (
            f"the input delay {grows} from {1e3 * self.first:.3g} to {1e3 * self.last:.3g} ms over the record "
            f"({1e3 * self.rate:.3g} ms a second; {', '.join(f'{1e3 * d:.3g}' for d in self.delays)} ms on its "
            f"{self.delays.size} segments): the logger's time base drifts, and one delay fits neither end"
        )

    def starting_at(self, delay: float) -> DelayDrift:
        """The same drift, its line moved to start at ``delay`` [s] (the start's delay measured on
        the record with the drift taken out)."""
        moved = delay - self.first
        return DelayDrift(
            self.label, self.times, self.delays + moved, self.delay_std, delay,
            max(delay + self.rate * (self.span[1] - self.span[0]), 0.0), self.drifts, self.rate, self.span,
        )  # fmt: skip

    def with_rate(self, rate: float) -> DelayDrift:
        """The same drift with its line turned to ``rate`` [s/s] about its first sample (the rate
        measured again on the record it aligned: :func:`~motorid.diagnose.workflow.aligned_record`)."""
        last = max(self.first + rate * (self.span[1] - self.span[0]), 0.0)
        return DelayDrift(
            self.label,
            self.times,
            self.delays,
            self.delay_std,
            self.first,
            last,
            self.drifts,
            rate,
            self.span,
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "label": self.label, "times": self.times.tolist(), "delays": self.delays.tolist(),
            "delay_std": self.delay_std.tolist(), "first": self.first, "last": self.last,
            "drifts": self.drifts, "rate": self.rate, "span": list(self.span),
        }  # fmt: skip


def output_shift(
    w: np.ndarray, sim: np.ndarray, at: np.ndarray, dt: float, reach: float
) -> tuple[float, float]:
    """How late ``w`` runs behind ``sim`` at the samples ``at``, and its standard error (see the
    module notes).

    Parameters
    ----------
    w : ndarray
        The measured speed at every sample [v].
    sim : ndarray
        The free run at every sample [v] (NaN where it has not started).
    at : ndarray of int
        The samples the shift is fitted on.
    dt : float
        The sample time [s].
    reach : float
        The largest shift searched, either way [s].

    Returns
    -------
    shift, std : float
        The shift s [s] (w(t) ≈ sim(t - s)) and its standard error [s]; NaN and inf where the
        free run does not move over ``at``.
    """
    started = np.flatnonzero(np.isfinite(sim))
    first = int(started[0]) if started.size else sim.size
    measured = w[at]

    def late(s: float, offset: float = 0.0) -> np.ndarray:
        x = at - s / dt + offset
        return np.interp(x, np.arange(first, sim.size), sim[first:], left=np.nan, right=np.nan)

    def cost(s: float) -> float:
        e = measured - late(s)
        e = e[np.isfinite(e)]
        return float(np.mean(e * e)) if e.size > 2 else math.inf

    grid = np.linspace(-reach, reach, SHIFT_GRID)
    costs = np.array([cost(s) for s in grid])
    if not np.isfinite(costs).any():
        return math.nan, math.inf
    i = int(np.argmin(costs))
    found = minimize_scalar(
        cost, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]), method="bounded",
        options={"xatol": 1e-3 * dt},
    )  # fmt: skip
    shift = float(found.x) if found.fun <= costs[i] else float(grid[i])
    e = measured - late(shift)
    slope = (late(shift, 0.5) - late(shift, -0.5)) / dt  # ẇ_sim at t - s [v/s]
    ok = np.isfinite(e) & np.isfinite(slope)
    e, slope = e[ok], slope[ok]
    curvature = float(np.sum(slope * slope))
    if e.size < 3 or not curvature > 0.0:
        return math.nan, math.inf
    rho = float(np.clip(np.corrcoef(e[:-1], e[1:])[0, 1], 0.0, 0.999)) if np.std(e) > 0 else 0.0
    std = math.sqrt(float(np.mean(e * e)) / curvature * (1.0 + rho) / (1.0 - rho))
    return shift, std


def delay_drift(pool, model: RigidDrive) -> list[DelayDrift]:
    """The input delay of ``model`` measured on each segment of each record of ``pool`` (a
    :class:`~motorid.diagnose.prepare.Pool`) as its free run's shift against the measured speed,
    every parameter of ``model`` held, and the line through them (see the module notes).

    Parameters
    ----------
    pool : Pool
        The records.
    model : RigidDrive
        The final model.
    """
    delay = float(model.params.get("input_delay", 0.0)) if "input_delay" in model.effects else 0.0
    out = []
    for label, prep in zip(pool.labels, pool.parts, strict=True):
        dt = prep.kin.dt
        sim = prep.simulate(model)
        idx = prep.data.idx
        settled = idx[prep.kin.valid[idx] & np.isfinite(sim[idx])]
        if settled.size < SEGMENTS * 30:
            continue
        reach = float(prep.data.scale["delay_reach"])
        times, delays, stds = [], [], []
        for at in np.array_split(settled, SEGMENTS):
            shift, std = output_shift(prep.kin.w, sim, at, dt, reach)
            if not math.isfinite(shift):
                continue
            times.append(0.5 * (at[0] + at[-1]) * dt)
            delays.append(delay + shift)
            stds.append(std if std > 0 else math.inf)
        del sim
        t, d, sd = np.asarray(times), np.asarray(delays), np.asarray(stds)
        weight = 1.0 / sd**2
        fit = weight > 0
        if np.count_nonzero(fit) < 3:
            continue
        # the weighted line d = d0 + r t, the standard error of r scaled by the scatter about it
        X = np.column_stack([np.ones_like(t), t])
        normal = X.T @ (weight[:, None] * X)
        intercept, rate = (float(v) for v in np.linalg.solve(normal, X.T @ (weight * d)))
        chi2 = float(np.sum(weight[fit] * (d[fit] - intercept - rate * t[fit]) ** 2)) / (int(fit.sum()) - 2)
        rate_std = math.sqrt(float(np.linalg.inv(normal)[1, 1]) * max(chi2, 1.0))
        span = (float(settled[0] * dt), float(settled[-1] * dt))
        first, last = intercept + rate * span[0], intercept + rate * span[1]
        move = abs(rate) * (span[1] - span[0])  # the line's own, below zero included
        drifts = bool(move > DRIFT_SAMPLES * dt and abs(rate) > DRIFT_ERRORS * rate_std)
        out.append(DelayDrift(label, t, d, sd, max(first, 0.0), max(last, 0.0), drifts, rate, span))
    return out


__all__ = [
    "DRIFT_ERRORS",
    "DRIFT_SAMPLES",
    "SEGMENTS",
    "SHIFT_GRID",
    "DelayDrift",
    "delay_drift",
    "output_shift",
]
