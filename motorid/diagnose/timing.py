"""A logger's time base: the input delay measured along a record, and whether it drifts.

A logger that stamps the speed late by a delay that grows through the record (a serial link's
buffer filling, a clock that runs slow) gives a record whose input delay is no constant: the
speed answers a step 16 ms late at 5 s and 114 ms late at 50 s. One delay for the whole record
then fits neither end. :func:`delay_drift` fits the final model's input delay on each of
:data:`SEGMENTS` consecutive segments of each record (every other shape held, the linear
parameters refitted on the segment), each with its standard error σ_i (the delay set free in
the segment's balance: :class:`~motorid.diagnose.model.DelayTrade`), and a line through them
by weighted least squares (weights 1/σ_i²),

    d(t) = d_0 + r t,

and says that the time base drifts where the line moves over the record's span T by more than
:data:`DRIFT_SAMPLES` samples, more than :data:`DRIFT_SHARE` of the mean delay and more than
:data:`DRIFT_ERRORS` of its own standard errors (|r| T > 3 σ_r T), and the delays lie on the line
within their errors (``Σ w_i (d_i - d_0 - r t_i)² / (n - 2)`` below :data:`DRIFT_SCATTER`). A segment whose input
barely shows a delay (a chirp's slow start, where the phase ωτ is small) has a large σ_i and
little say.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from motorid.diagnose.model import fit_model
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive

#: Segments a record is cut into for its delays.
SEGMENTS = 5
#: A drift moves the delay by more than this many samples over the record ...
DRIFT_SAMPLES = 3.0
#: ... and by more than this share of its mean ...
DRIFT_SHARE = 0.5
#: ... and by more than this many of its standard errors, where the segments' delays scatter about
#: the line by less than this (their weighted squares per degree of freedom): measured 1.3-6.5 on
#: benches whose logger drifts, 38 and 3,400 where a chirp's delay moves with its frequency (a
#: bias the standard errors do not carry), no time base's drift.
DRIFT_ERRORS = 3.0
DRIFT_SCATTER = 10.0


@dataclass(frozen=True)
class DelayDrift:
    """The input delay along one record.

    Attributes
    ----------
    label : str
        The record.
    times : ndarray
        Middle of each segment from the record's start [s].
    delays : ndarray
        The input delay fitted on each segment [s].
    delay_std : ndarray
        Its standard error on each segment [s].
    first, last : float
        The line's delay at the record's first and last settled sample [s].
    drifts : bool
        Whether the time base drifts (see the module notes).
    """

    label: str
    times: np.ndarray
    delays: np.ndarray
    delay_std: np.ndarray
    first: float
    last: float
    drifts: bool

    def sentence(self) -> str:
        """One line for the report."""
        grows = "grows" if self.last > self.first else "shrinks"
        return (
            f"the input delay {grows} from {1e3 * self.first:.3g} to {1e3 * self.last:.3g} ms over the record "
            f"({', '.join(f'{1e3 * d:.3g}' for d in self.delays)} ms on its {self.delays.size} segments): "
            "the logger's time base drifts, and one delay fits neither end"
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "label": self.label, "times": self.times.tolist(), "delays": self.delays.tolist(),
            "delay_std": self.delay_std.tolist(),
            "first": self.first, "last": self.last, "drifts": self.drifts,
        }  # fmt: skip


def delay_drift(pool, model: RigidDrive) -> list[DelayDrift]:
    """The input delay of ``model`` refitted on each segment of each record of ``pool`` (a
    :class:`~motorid.diagnose.prepare.Pool`), with every other shape parameter of ``model`` held.

    Parameters
    ----------
    pool : Pool
        The records.
    model : RigidDrive
        The final model; an input delay is added to it for the segments' fits where it has none.
    """
    effects = model.effects if "input_delay" in model.effects else (*model.effects, "input_delay")
    held = {
        p: float(model.params[p])
        for n in effects
        for p in get_effect(n).nonlinear
        if p != "input_delay" and p in model.params
    }
    sizes = [part.n for part in pool.data.parts]
    offsets = np.concatenate(([0], np.cumsum(sizes)))
    out = []
    for k, (label, prep) in enumerate(zip(pool.labels, pool.parts, strict=True)):
        idx = prep.data.idx
        times, delays, stds = [], [], []
        for segment in np.array_split(np.arange(sizes[k]), SEGMENTS):
            rows = np.zeros(int(offsets[-1]), dtype=bool)
            rows[offsets[k] + segment] = True
            if np.count_nonzero(rows & pool.data.moving) < 30:
                continue
            fit = fit_model(pool.data, effects, start=model.params, stribeck_shape=model.stribeck_shape,
                            fixed=held, rows=rows)  # fmt: skip
            times.append(0.5 * (idx[segment[0]] + idx[segment[-1]]) * prep.kin.dt)
            delays.append(float(fit.model.params["input_delay"]))
            trade = fit.delay_trade
            std = trade.delay_free_std if trade is not None else math.nan
            stds.append(std if math.isfinite(std) and std > 0 else math.inf)
        if len(delays) < 3:
            continue
        t, d, sd = np.asarray(times), np.asarray(delays), np.asarray(stds)
        weight = 1.0 / sd**2
        if np.count_nonzero(weight > 0) < 3:
            continue
        # the weighted line d = d0 + r t and the standard error of r
        X = np.column_stack([np.ones_like(t), t])
        normal = X.T @ (weight[:, None] * X)
        intercept, slope = np.linalg.solve(normal, X.T @ (weight * d))
        slope_std = math.sqrt(float(np.linalg.inv(normal)[1, 1]))
        span = (idx[0] * prep.kin.dt, idx[-1] * prep.kin.dt)
        first, last = float(intercept + slope * span[0]), float(intercept + slope * span[1])
        move = abs(last - first)
        mean = float(np.average(d, weights=weight))
        fit = weight > 0
        scatter = float(np.sum(weight[fit] * (d[fit] - intercept - slope * t[fit]) ** 2)) / max(
            int(fit.sum()) - 2, 1
        )
        drifts = bool(
            scatter < DRIFT_SCATTER
            and move > DRIFT_SAMPLES * prep.kin.dt
            and move > DRIFT_SHARE * max(mean, 0.0)
            and abs(slope) > DRIFT_ERRORS * slope_std
        )
        out.append(DelayDrift(label, t, d, sd, max(first, 0.0), max(last, 0.0), drifts))
    return out


__all__ = [
    "DRIFT_ERRORS",
    "DRIFT_SAMPLES",
    "DRIFT_SCATTER",
    "DRIFT_SHARE",
    "SEGMENTS",
    "DelayDrift",
    "delay_drift",
]
