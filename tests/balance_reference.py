"""The doctor's balance of a velocity record written out apart from the library's code, for the
tests to hold its solves to: each sample's difference and mean speed (:mod:`motorid.diagnose.model`),
zeroed where the balance does not hold, decimated by the record's own filter."""

from __future__ import annotations

import numpy as np

from motorid.drive.rigid import term_columns


def measured_speed(kin) -> np.ndarray:
    """The measured speed at each sample's end, back from the balance's mean and difference
    (the first sample's mean is its own speed)."""
    y = kin.balance_w + 0.5 * kin.dt * kin.balance_a
    y[0] = kin.balance_w[0]
    return y


def held_samples(prep) -> np.ndarray:
    """The samples the balance holds on, written out: both ends of the sample (the measured
    speed before and after it) above the moving threshold, with one sign."""
    kin, data = prep.kin, prep.data
    y = measured_speed(kin)
    before = np.concatenate([[y[0]], y[:-1]])
    return (np.minimum(np.abs(before), np.abs(y)) > data.w_threshold) & (before * y > 0.0)


def reference_columns(prep, names: list[str]) -> np.ndarray:
    """The decimated regressor columns written out: J_b's column, the difference of the measured
    speed over each sample, then each term's column on the sample's mean speed, each zeroed
    where the balance does not hold."""
    kin = prep.kin
    y = measured_speed(kin)
    before = np.concatenate([[y[0]], y[:-1]])
    a = np.diff(y, prepend=y[0]) / kin.dt
    a[0] = a[1]
    terms = term_columns(tuple(names), 0.5 * (before + y), 1.0, "exponential")
    held = held_samples(prep)
    columns = [a, *(terms[:, j] for j in range(len(names)))]
    return np.column_stack([kin.decimate(np.where(held, c, 0.0)) for c in columns])


def reference_target(prep) -> np.ndarray:
    """F_in = g u (g = 1) held over each sample, zeroed where the balance does not hold, decimated."""
    kin = prep.kin
    return kin.decimate(np.where(held_samples(prep), np.asarray(kin.u, dtype=float), 0.0))
