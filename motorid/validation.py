"""Model validation: error metrics, one-step-ahead against free-run prediction, and the
error restricted to low speed, where the paper's nonlinear model wins.

All metrics take the measured output ``y`` and a prediction ``y_hat`` in the same
unit (rad/s inside motorid); :func:`rad_s_to_rpm` converts at the edges, since the
paper reports rpm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from motorid.estimators.base import Estimator, as_float_vector, first_bad_index

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def rad_s_to_rpm(value: ArrayLike) -> np.ndarray | float:
    """Angular speed [rad/s] to [rev/min]."""
    return np.asarray(value, dtype=float) * RPM_PER_RAD_S


def rpm_to_rad_s(value: ArrayLike) -> np.ndarray | float:
    """Angular speed [rev/min] to [rad/s]."""
    return np.asarray(value, dtype=float) / RPM_PER_RAD_S


def _pair(y: ArrayLike, y_hat: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    y_arr, y_hat_arr = as_float_vector(y, "y"), as_float_vector(y_hat, "y_hat")
    if y_arr.shape != y_hat_arr.shape:
        raise ValueError(f"y and y_hat must have one length, got {y_arr.shape} and {y_hat_arr.shape}")
    if y_arr.size == 0:
        raise ValueError("y is empty: a metric needs at least one sample")
    bad = first_bad_index(y_arr)
    if bad is not None:
        raise ValueError(f"y[{bad}] = {y_arr[bad]} is not finite")
    if first_bad_index(y_hat_arr) is not None:  # a diverged free run scores infinitely badly
        y_hat_arr = np.where(np.isfinite(y_hat_arr), y_hat_arr, np.inf)
    return y_arr, y_hat_arr


def mse(y: ArrayLike, y_hat: ArrayLike) -> float:
    """Mean square error ``(1/N) sum (y - y_hat)^2`` [unit^2] (paper section 5.1)."""
    y_arr, y_hat_arr = _pair(y, y_hat)
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.mean((y_arr - y_hat_arr) ** 2))


def rmse(y: ArrayLike, y_hat: ArrayLike) -> float:
    """Root mean square error ``sqrt(mse)`` [unit]."""
    return math.sqrt(mse(y, y_hat))


def fit_percent(y: ArrayLike, y_hat: ArrayLike) -> float:
    """Normalised RMSE fit ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)`` [%].

    100 % is a perfect fit, 0 % no better than the mean, and it is negative when
    worse than the mean (MATLAB's ``compare`` figure). A constant ``y`` raises.
    """
    y_arr, y_hat_arr = _pair(y, y_hat)
    spread = float(np.linalg.norm(y_arr - y_arr.mean()))
    if spread == 0.0:
        raise ValueError("y is constant: FIT % is undefined")
    with np.errstate(over="ignore", invalid="ignore"):
        return 100.0 * (1.0 - float(np.linalg.norm(y_arr - y_hat_arr)) / spread)


def low_speed_mask(y: ArrayLike, threshold: float) -> np.ndarray:
    """Samples where ``|y| < threshold`` (same unit as ``y``)."""
    if not (math.isfinite(threshold) and threshold > 0.0):
        raise ValueError(f"threshold must be a positive finite speed, got {threshold!r}")
    return np.abs(as_float_vector(y, "y")) < threshold


def low_speed_mse(y: ArrayLike, y_hat: ArrayLike, threshold: float) -> float:
    """MSE over the samples with ``|y| < threshold`` only [unit^2].

    NaN when no sample is that slow (rather than an error, so that sweeps over
    many records still tabulate).
    """
    y_arr, y_hat_arr = _pair(y, y_hat)
    mask = low_speed_mask(y_arr, threshold)
    if not mask.any():
        return float("nan")
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.mean((y_arr[mask] - y_hat_arr[mask]) ** 2))


@dataclass(frozen=True)
class PredictionScores:
    """Scores of one prediction against the measurement.

    Attributes are in the output's unit (squared for MSE), FIT in percent.
    """

    mse: float
    rmse: float
    fit_percent: float
    low_speed_mse: float
    n_low_speed: int


def score(y: ArrayLike, y_hat: ArrayLike, low_speed_threshold: float) -> PredictionScores:
    """Every metric of this module for one prediction."""
    y_arr, y_hat_arr = _pair(y, y_hat)
    return PredictionScores(
        mse=mse(y_arr, y_hat_arr),
        rmse=rmse(y_arr, y_hat_arr),
        fit_percent=fit_percent(y_arr, y_hat_arr),
        low_speed_mse=low_speed_mse(y_arr, y_hat_arr, low_speed_threshold),
        n_low_speed=int(low_speed_mask(y_arr, low_speed_threshold).sum()),
    )


def compare_predictions(
    estimator: Estimator,
    u: ArrayLike,
    y: ArrayLike,
    low_speed_threshold: float,
    skip: int = 0,
) -> pd.DataFrame:
    """Identify ``estimator`` on a record and score its two predictions.

    ``one_step`` is the online one-step-ahead prediction made while identifying
    (the prior ``y_hat(t) = phi(t)^T theta(t-1)``, what the paper plots in
    Figs. 9-12); ``free_run`` is the identified model, frozen at the end of the
    record, simulated on the same input from rest with its own past outputs. The
    free run is the harder test: one-step prediction leans on the measured past
    and flatters any model.

    Parameters
    ----------
    estimator : Estimator
        Run from its current state over the record (it is changed).
    u, y : array_like
        Input [V] and measured output.
    low_speed_threshold : float
        |y| below this counts as low speed (output unit).
    skip : int
        Leading samples left out of the scores (start-up transient).

    Returns
    -------
    DataFrame
        Index ``one_step`` and ``free_run``; columns of :class:`PredictionScores`.
    """
    u_arr, y_arr = as_float_vector(u, "u"), as_float_vector(y, "y")
    if not 0 <= skip < len(y_arr):
        raise ValueError(f"skip must be in [0, {len(y_arr)}), got {skip}")
    one_step = estimator.batch_filter(u_arr, y_arr).y_hat
    free_run = estimator.simulate(u_arr)
    rows = {
        "one_step": score(y_arr[skip:], one_step[skip:], low_speed_threshold),
        "free_run": score(y_arr[skip:], free_run[skip:], low_speed_threshold),
    }
    return pd.DataFrame({name: vars(s) for name, s in rows.items()}).T
