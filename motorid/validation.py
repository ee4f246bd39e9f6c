"""Model validation: error metrics, one-step-ahead against free-run prediction, and the
error restricted to low speed, where the paper's nonlinear model wins.

All metrics take the measured output ``y`` and a prediction ``y_hat`` in the same
unit (rad/s inside motorid); :func:`rad_s_to_rpm` converts at the edges, since the
paper reports rpm.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from statistics import NormalDist
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from motorid.errors import DataError
from motorid.estimators.base import Estimator, as_float_vector, first_bad_index
from motorid.progress import progress_bar

if TYPE_CHECKING:
    from matplotlib.figure import Figure

RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def rad_s_to_rpm(value: ArrayLike) -> np.ndarray | float:
    """Angular speed [rad/s] to [rev/min]."""
    return np.asarray(value, dtype=float) * RPM_PER_RAD_S


def rpm_to_rad_s(value: ArrayLike) -> np.ndarray | float:
    """Angular speed [rev/min] to [rad/s]."""
    return np.asarray(value, dtype=float) / RPM_PER_RAD_S


#: Fewest samples a score is computed on, after the skipped start.
MIN_SCORED_SAMPLES = 20


def check_scored_samples(samples: int, skip: int, source: str = "the record") -> None:
    """Refuse a record too short to score after its skipped start: DataError naming ``source``, the
    samples it holds, ``--skip`` and the largest skip it allows.

    Parameters
    ----------
    samples : int
        Samples in the record.
    skip : int
        Leading samples left out of the scores (the start from rest) [samples].
    source : str
        The record's name in the message (its file).

    Raises
    ------
    DataError
        When fewer than :data:`MIN_SCORED_SAMPLES` samples are left after ``skip``.
    """
    left = samples - skip
    if left < MIN_SCORED_SAMPLES:
        largest = samples - MIN_SCORED_SAMPLES
        how = (
            f"give skip={largest} or less, or a longer record"
            if largest >= 0
            else f"give a record of at least {MIN_SCORED_SAMPLES} samples"
        )
        raise DataError(
            f"{source}: {samples} samples; skip={skip} leaves {max(left, 0)} to score, at least "
            f"{MIN_SCORED_SAMPLES} are needed: {how}"
        )


#: A free run whose output leaves ``DIVERGENCE_FACTOR`` times the largest measured magnitude has
#: diverged (:func:`free_run_divergence`).
DIVERGENCE_FACTOR = 10.0


def free_run_divergence(y_sim: ArrayLike, largest_output: float, first: int = 0) -> int | None:
    """The first sample where a free run has diverged, or None.

    A free run has diverged at sample k when ``y_sim[k]`` is not finite, or when
    ``|y_sim[k]| > DIVERGENCE_FACTOR * largest_output``: ten times the largest magnitude the
    drive was measured at is no model of the record, whether the run grows without bound (an
    unstable model) or settles far off (a static block whose cubic term scales a duty of 100 %
    by 10**6).

    Parameters
    ----------
    y_sim : array_like
        The free run's output [output unit].
    largest_output : float
        The largest measured ``|y|`` of the record [output unit], >= 0.
    first : int
        The record's sample of ``y_sim[0]`` (a block of it), added to the index returned.

    Returns
    -------
    int or None
        The record's sample where the free run diverges; None when it stays within the bound.
    """
    run = np.asarray(y_sim, dtype=float)
    with np.errstate(invalid="ignore"):
        out = ~(np.abs(run) <= DIVERGENCE_FACTOR * float(largest_output))  # NaN and inf are out
    if not out.any():
        return None
    return first + int(np.argmax(out))


def divergence_words(name: str, sample: int, scored: bool) -> str:
    """One line on a free run that diverges (:func:`free_run_divergence`) for the user: where and what
    it means.

    Parameters
    ----------
    name : str
        The model's name (its estimator or its file).
    sample : int
        The first sample where it diverges.
    scored : bool
        Whether the run stayed finite, so its scores stand (far off); else it has none.
    """
    scores = "its free-run scores measure how far off it is" if scored else "it has no free-run score"
    return (
        f"{name}: the free run diverges from sample {sample} on (beyond {DIVERGENCE_FACTOR:g} x the largest "
        f"measured |y|, or not finite): the model does not hold on this input and {scores}"
    )


#: A sample further from the median than this many times the signal's spread is an outlier.
OUTLIER_SPREADS = 1e6


def check_signals(signals: Mapping[str, ArrayLike]) -> None:
    """Refuse signals that cannot identify a model, naming the column and the row.

    Each signal (a record's column, by name) must vary, and hold no outlier: a
    sample ``x[k]`` with ``|x[k] - median(x)| > OUTLIER_SPREADS * s``, where the
    spread ``s`` is the median absolute deviation from the median (or, when more
    than half the samples sit on the median, as with a mostly-zero input, the
    median of the nonzero deviations). The factor 1e6 passes any measured drive signal
    (measured: EMPS's force and position reach 7.3 spreads, the small motors of
    ``realmotors/`` 4.4) and
    catches a unit slip or a corrupt cell (1e300), which would overflow the
    squares of least squares and turn every result to NaN.

    Parameters
    ----------
    signals : mapping of str to array_like
        Column name -> samples (row k of the record is sample k).

    Raises
    ------
    DataError
        On a constant column, or an outlier (the first, by row).
    """
    for name, values in signals.items():
        x = check_signal_block(name, values)
        if x.size and np.all(x == x[0]):
            raise_constant(name, float(x[0]), x.size)


def check_signal_block(name: str, values: ArrayLike, first_row: int = 0) -> np.ndarray:
    """The checks of :func:`check_signals` that hold for a block of rows on its own: every sample
    finite, and no outlier against the block's own median and spread. ``first_row`` is the row of
    the block's first sample in the record (for the message). Returns the samples as floats."""
    x = as_float_vector(values, name)
    bad = first_bad_index(x)
    if bad is not None:
        raise DataError(f"column {name!r} has a non-finite value {x[bad]!r} at row {first_row + bad}")
    if x.size:
        check_outliers(name, x, first_row)
    return x


def raise_constant(name: str, value: float, rows: int) -> None:
    """The error of :func:`check_signals` on a column holding ``value`` in every one of its ``rows``."""
    raise DataError(
        f"column {name!r} is constant ({value:g} in every one of its {rows} rows): "
        "it carries nothing to identify a model from"
    )


def check_outliers(
    name: str, x: np.ndarray, first_row: int, reference: tuple[float, float] | None = None
) -> None:
    """The outlier check of :func:`check_signals` on the finite samples ``x`` (not empty) of column
    ``name``: against ``reference`` (the centre and spread of :func:`outlier_reference`), by default
    the samples' own; ``first_row`` is the row of ``x[0]`` in the record (for the message)."""
    if reference is None:
        reference = outlier_reference(x)
    if reference is None:  # every sample on the median: nothing stands out
        return
    centre, spread = reference
    outliers = np.flatnonzero(np.abs(x - centre) > OUTLIER_SPREADS * spread)
    if outliers.size:
        row = int(outliers[0])
        raise DataError(
            f"column {name!r} has an outlier {x[row]:.6g} at row {first_row + row}, more than "
            f"{OUTLIER_SPREADS:g} times the column's spread ({spread:.3g}) from its median ({centre:.3g}): "
            "a unit slip or a corrupt cell? Fix or drop that row"
        )


def outlier_reference(x: np.ndarray) -> tuple[float, float] | None:
    """The centre and spread :func:`check_signals` judges outliers by: the median of ``x`` and the
    median absolute deviation from it (or, when more than half the samples sit on the median, the
    median of the nonzero deviations); None when every sample sits on the median."""
    centre = float(np.median(x))
    deviation = np.abs(x - centre)
    spread = float(np.median(deviation))
    if spread == 0.0:
        moved = deviation[deviation > 0.0]
        if not moved.size:
            return None
        spread = float(np.median(moved))
    return centre, spread


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
        raise DataError("y is constant: FIT % is undefined")
    with np.errstate(over="ignore", invalid="ignore"):
        return 100.0 * (1.0 - float(np.linalg.norm(y_arr - y_hat_arr)) / spread)


def low_speed_mask(y: ArrayLike, threshold: float) -> np.ndarray:
    """Samples where ``|y| < threshold`` (same unit as ``y``)."""
    if not (math.isfinite(threshold) and threshold > 0.0):
        raise ValueError(f"threshold must be a positive finite speed, got {threshold!r}")
    return np.abs(as_float_vector(y, "y")) < threshold


def low_speed_mse(y: ArrayLike, y_hat: ArrayLike, threshold: float, speed: ArrayLike | None = None) -> float:
    """MSE over the samples with ``|y| < threshold`` only [unit^2]; ``speed``, when given, is
    what the band is judged on instead of ``y`` (the speed of a position record).

    NaN when no sample is that slow (rather than an error, so that sweeps over
    many records still tabulate).
    """
    y_arr, y_hat_arr = _pair(y, y_hat)
    mask = low_speed_mask(y_arr if speed is None else speed, threshold)
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


def score(
    y: ArrayLike, y_hat: ArrayLike, low_speed_threshold: float, speed: ArrayLike | None = None
) -> PredictionScores:
    """Every metric of this module for one prediction; the low-speed band on ``speed`` when
    given (:func:`low_speed_mse`)."""
    y_arr, y_hat_arr = _pair(y, y_hat)
    band = y_arr if speed is None else speed
    return PredictionScores(
        mse=mse(y_arr, y_hat_arr),
        rmse=rmse(y_arr, y_hat_arr),
        fit_percent=fit_percent(y_arr, y_hat_arr),
        low_speed_mse=low_speed_mse(y_arr, y_hat_arr, low_speed_threshold, band),
        n_low_speed=int(low_speed_mask(band, low_speed_threshold).sum()),
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
    predictions = {
        "one_step": estimator.batch_filter(u_arr, y_arr).y_hat,
        "free_run": estimator.simulate(u_arr),
    }
    return score_predictions(y_arr, predictions, low_speed_threshold, skip)


def score_predictions(
    y: ArrayLike, predictions: dict[str, np.ndarray], low_speed_threshold: float, skip: int = 0
) -> pd.DataFrame:
    """:func:`score` for several predictions of one measurement, leaving out the
    first ``skip`` samples; one row per prediction."""
    y_arr = as_float_vector(y, "y")
    if not 0 <= skip < len(y_arr):
        raise ValueError(f"skip must be in [0, {len(y_arr)}), got {skip}")
    rows = {
        name: vars(score(y_arr[skip:], np.asarray(y_hat)[skip:], low_speed_threshold))
        for name, y_hat in predictions.items()
    }
    return pd.DataFrame(rows).T


class RunningScore:
    """:func:`score` of a prediction given in consecutive blocks, from running sums.

    Memory does not grow with the record: per block it adds the sum of squared
    errors ``sum (y - y_hat)^2``, the same sum over the low-speed samples
    ``|y| < low_speed_threshold`` and their count, and merges the block's mean and
    sum of squared deviations of ``y`` into the record's (Chan, Golub and LeVeque's
    pairwise update: ``M2 = M2_a + M2_b + d^2 n_a n_b / n``, d the difference of
    the means), from which ``||y - mean(y)||`` of FIT % comes without a second pass.
    The scores equal :func:`score` of the whole prediction up to the rounding of
    those sums (a relative difference of about N * 1e-16 at most, in practice far
    less: each block is summed pairwise).

    Parameters
    ----------
    low_speed_threshold : float
        |y| below this counts as low speed (output unit).
    """

    def __init__(self, low_speed_threshold: float):
        low_speed_mask(np.zeros(0), low_speed_threshold)  # checks the threshold
        self.low_speed_threshold = float(low_speed_threshold)
        self.samples = 0
        self.sum_squares = 0.0
        self.mean = 0.0
        self.deviation_squares = 0.0
        self.low_speed_samples = 0
        self.low_speed_sum_squares = 0.0

    def add(self, y: ArrayLike, y_hat: ArrayLike) -> None:
        """Add the next block: measured ``y`` and predicted ``y_hat``, one length (may be empty)."""
        y_arr, y_hat_arr = as_float_vector(y, "y"), as_float_vector(y_hat, "y_hat")
        if y_arr.size == 0 and y_hat_arr.size == 0:
            return
        y_arr, y_hat_arr = _pair(y_arr, y_hat_arr)
        with np.errstate(over="ignore", invalid="ignore"):
            squares = (y_arr - y_hat_arr) ** 2
        slow = np.abs(y_arr) < self.low_speed_threshold
        self.sum_squares += float(np.sum(squares))
        self.low_speed_samples += int(np.count_nonzero(slow))
        self.low_speed_sum_squares += float(np.sum(squares[slow]))
        n_a, n_b = self.samples, y_arr.size
        mean_b = float(np.mean(y_arr))
        deviation = y_arr - mean_b
        difference = mean_b - self.mean
        self.samples = n_a + n_b
        self.mean += difference * n_b / self.samples
        self.deviation_squares += (
            float(np.dot(deviation, deviation)) + difference**2 * n_a * n_b / self.samples
        )

    def result(self) -> PredictionScores:
        """The scores of the blocks added so far (at least one sample)."""
        if self.samples == 0:
            raise ValueError("y is empty: a metric needs at least one sample")
        if self.deviation_squares == 0.0:
            raise DataError("y is constant: FIT % is undefined")
        mse_value = self.sum_squares / self.samples
        with np.errstate(over="ignore", invalid="ignore"):
            fit = 100.0 * (1.0 - math.sqrt(self.sum_squares) / math.sqrt(self.deviation_squares))
        return PredictionScores(
            mse=mse_value,
            rmse=math.sqrt(mse_value),
            fit_percent=fit,
            low_speed_mse=(
                self.low_speed_sum_squares / self.low_speed_samples
                if self.low_speed_samples
                else float("nan")
            ),
            n_low_speed=self.low_speed_samples,
        )


#: Samples of a signal given in blocks that its outlier reference (median and spread) is taken
#: from, evenly strided over the record (:class:`StridedSample`); a signal of at most this many
#: samples is taken whole, as :func:`check_signals` takes it.
REFERENCE_SAMPLES = 1_000_000


class StridedSample:
    """Every ``stride``-th sample of a signal given in consecutive blocks, in at most ``capacity``
    values: the stride starts at 1 and doubles (every other value kept is dropped) whenever the
    next block would not fit, so the values are always samples 0, s, 2s, ... of the signal.

    A signal of at most ``capacity`` samples is kept whole. Used for the outlier reference of a
    record given in blocks (:func:`outlier_reference` of the sample: its median and spread).

    Parameters
    ----------
    capacity : int
        Most values kept, >= 1.
    """

    def __init__(self, capacity: int):
        if not isinstance(capacity, int) or capacity < 1:
            raise ValueError(f"capacity must be an integer >= 1, got {capacity!r}")
        self._values = np.empty(capacity)
        self._kept = 0
        self.stride = 1
        #: Samples of the signal given so far.
        self.samples = 0

    def add(self, x: ArrayLike) -> None:
        """Add the next block of the signal."""
        x_arr = as_float_vector(x, "x")
        while True:
            taken = x_arr[(-self.samples) % self.stride :: self.stride]
            if self._kept + len(taken) <= len(self._values):
                break
            half = (self._kept + 1) // 2
            self._values[:half] = self._values[: self._kept : 2]
            self._kept, self.stride = half, 2 * self.stride
        self._values[self._kept : self._kept + len(taken)] = taken
        self._kept += len(taken)
        self.samples += len(x_arr)

    @property
    def values(self) -> np.ndarray:
        """The samples kept, in time order (a view)."""
        return self._values[: self._kept]


#: Samples of a record given in blocks that the residual tests are computed on: its last ones
#: (16 min 40 s at 1 kHz). The tests hold them and about ten arrays of their length at once
#: (about 100 MB); a record of at most this many samples is tested whole.
RESIDUAL_WINDOW = 1_000_000


class ResidualWindow:
    """The last ``size`` samples of the input and the residual of a record given in blocks, for
    :func:`residual_tests` (memory: two arrays of ``size`` floats, whatever the record's length).

    Parameters
    ----------
    size : int
        Samples kept, >= 1.
    """

    def __init__(self, size: int):
        if not isinstance(size, int) or size < 1:
            raise ValueError(f"size must be an integer >= 1, got {size!r}")
        self.size = size
        self._u = np.empty(size)
        self._e = np.empty(size)
        #: Samples added so far.
        self.samples = 0

    def add(self, u: ArrayLike, residual: ArrayLike) -> None:
        """Add the next block of input [V] and residual (one length)."""
        u_arr, e_arr = as_float_vector(u, "u"), as_float_vector(residual, "residual")
        if u_arr.shape != e_arr.shape:
            raise ValueError(f"u and residual must have one length, got {u_arr.shape} and {e_arr.shape}")
        count = len(u_arr)
        kept = min(count, self.size)
        start = (self.samples + count - kept) % self.size  # ring position of the first sample kept
        head = min(kept, self.size - start)
        for ring, values in ((self._u, u_arr[count - kept :]), (self._e, e_arr[count - kept :])):
            ring[start : start + head] = values[:head]
            ring[: kept - head] = values[head:]
        self.samples += count

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The input and residual of the last ``min(samples, size)`` samples, in time order."""
        if self.samples <= self.size:
            return self._u[: self.samples].copy(), self._e[: self.samples].copy()
        start = self.samples % self.size
        return (
            np.concatenate((self._u[start:], self._u[:start])),
            np.concatenate((self._e[start:], self._e[:start])),
        )


# --------------------------------------------------------------------------- residual analysis
@dataclass(frozen=True)
class CorrelationTest:
    """One correlation test of the residuals.

    Attributes
    ----------
    name : str
        Which test, e.g. ``"autocorrelation"``.
    formula : str
        The correlation, e.g. ``"r_ee(tau)"``.
    lags : ndarray
        Lags tau [samples].
    values : ndarray
        Normalised correlation at each lag, in [-1, 1].
    band : float
        Half-width of the per-lag confidence band, ``z_(1-a/2) / sqrt(N)``
        (what MATLAB's ``resid`` draws), a = 1 - confidence.
    simultaneous_band : float
        Half-width of the band that holds at every lag at once,
        ``z_(1-a/(2 m)) / sqrt(N)`` for m lags (Bonferroni).
    passed : bool
        True when every lag stays inside the simultaneous band: a white,
        independent residual fails with probability at most a, whatever the
        number of lags, and one strong lag is enough to fail.
    """

    name: str
    formula: str
    lags: np.ndarray
    values: np.ndarray
    band: float
    simultaneous_band: float
    passed: bool

    @property
    def fraction_outside(self) -> float:
        """Fraction of the lags whose correlation leaves the band."""
        return float(np.mean(np.abs(self.values) > self.band))


def _normalised_correlation(a: np.ndarray, b: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """r_ab(tau) = sum_t a(t) b(t + tau) / sqrt(sum a^2 sum b^2), for zero-mean a, b."""
    N = len(a)
    scale = math.sqrt(float(np.dot(a, a) * np.dot(b, b)))
    out = np.empty(len(lags))
    for i, tau in enumerate(lags):
        if tau >= 0:
            out[i] = np.dot(a[: N - tau], b[tau:])
        else:
            out[i] = np.dot(a[-tau:], b[: N + tau])
    return out / scale if scale > 0 else np.zeros(len(lags))


def residual_max_lag(max_lag: int, samples: int) -> int | None:
    """The largest lag the residual tests take on ``samples`` residuals, at most ``max_lag``.

    A correlation at lag tau averages N - tau products; :func:`residual_tests` takes lags
    below N/4, so each averages at least three quarters of the record. A shorter record gets
    the largest lag it allows, ``N // 4 - 1`` [samples], and one of fewer than 8 residuals
    none (None: too short to judge whiteness at any lag).

    Parameters
    ----------
    max_lag : int
        The largest lag asked for [samples], >= 1.
    samples : int
        Number of residuals N.

    Returns
    -------
    int or None
        ``min(max_lag, N // 4 - 1)``, or None when that is below 1.
    """
    if isinstance(max_lag, bool) or not isinstance(max_lag, int | np.integer) or max_lag < 1:
        raise ValueError(f"max_lag must be an integer >= 1, got {max_lag!r}")
    largest = int(samples) // 4 - 1
    return min(int(max_lag), largest) if largest >= 1 else None


def residual_tests(
    u: ArrayLike, residual: ArrayLike, max_lag: int = 25, confidence: float = 0.99
) -> list[CorrelationTest]:
    """Whiteness and independence tests of a model's residuals.

    The linear tests are those of MATLAB's ``resid`` (Ljung, System
    Identification, 16.6): the residual autocorrelation r_ee(tau), tau = 1..M,
    should be zero (white residual), and the input-residual cross-correlation
    r_ue(tau), tau = -M..M, should be zero (nothing left that the input explains).
    The nonlinear tests are those of Billings and Voon (1986), which catch
    unmodelled nonlinear terms the linear ones miss, with e the residual and
    primes marking removed means:

    * r_e(eu)(tau) = E[e(t) e(t-1-tau) u(t-1-tau)], tau >= 0;
    * r_(u^2)'e(tau) = E[(u^2)'(t) e(t+tau)], all tau;
    * r_(u^2)'(e^2)'(tau) = E[(u^2)'(t) (e^2)'(t+tau)], all tau.

    Each test passes when its correlations stay inside the simultaneous band
    (see :class:`CorrelationTest`); the figure shows the per-lag band shaded and
    the simultaneous band dashed.

    Parameters
    ----------
    u : array_like
        Input [V].
    residual : array_like
        Measured minus predicted output, same length.
    max_lag : int
        Largest lag M [samples].
    confidence : float
        Level of the band ``z / sqrt(N)`` (0.99 as in ``resid``).

    Returns
    -------
    list of CorrelationTest
    """
    u_arr, e_arr = as_float_vector(u, "u"), as_float_vector(residual, "residual")
    if u_arr.shape != e_arr.shape:
        raise ValueError(f"u and residual must have one length, got {u_arr.shape} and {e_arr.shape}")
    for name, arr in (("u", u_arr), ("residual", e_arr)):
        bad = first_bad_index(arr)
        if bad is not None:
            raise ValueError(f"{name}[{bad}] is not finite")
    N = len(e_arr)
    max_lag = int(max_lag)
    if not 1 <= max_lag < N // 4:
        raise ValueError(f"max_lag must be in [1, N/4) = [1, {N // 4}), got {max_lag}")
    if not 0.5 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0.5, 1), got {confidence}")
    alpha = 1.0 - confidence
    quantile = NormalDist().inv_cdf  # the standard library's (scipy.stats would add 65 MB to a process)
    band = quantile(1.0 - alpha / 2.0) / math.sqrt(N)
    e0 = e_arr - e_arr.mean()
    u0 = u_arr - u_arr.mean()
    u2 = u_arr**2 - np.mean(u_arr**2)
    e2 = e_arr**2 - np.mean(e_arr**2)
    pos = np.arange(1, max_lag + 1)
    both = np.arange(-max_lag, max_lag + 1)
    non_negative = np.arange(0, max_lag + 1)
    # r_e(eu)(tau): e(t) against the product e(t-1-tau) u(t-1-tau)
    eu = e0 * u0
    eu0 = eu - eu.mean()
    specs = [
        ("autocorrelation", "r_ee(tau)", pos, _normalised_correlation(e0, e0, pos)),
        ("input_cross_correlation", "r_ue(tau)", both, _normalised_correlation(u0, e0, both)),
        ("billings_e_eu", "r_e(eu)(tau)", non_negative, _normalised_correlation(eu0, e0, non_negative + 1)),
        ("billings_u2_e", "r_(u^2)'e(tau)", both, _normalised_correlation(u2, e0, both)),
        ("billings_u2_e2", "r_(u^2)'(e^2)'(tau)", both, _normalised_correlation(u2, e2, both)),
    ]
    tests = []
    for name, formula, lags, values in specs:
        simultaneous = quantile(1.0 - alpha / (2.0 * len(lags))) / math.sqrt(N)
        passed = bool(np.max(np.abs(values)) <= simultaneous)
        tests.append(CorrelationTest(name, formula, lags, values, band, simultaneous, passed))
    return tests


def residual_tests_figure(tests: list[CorrelationTest], title: str = "Residual analysis") -> Figure:
    """A panel per test: the normalised correlation [-] against the lag [samples],
    the per-lag band shaded and the band for all lags at once dashed (the test's verdict)."""
    from motorid.figures import set_title, subplots

    fig, axes = subplots(len(tests), 1, figsize=(8, 2.0 * len(tests) + 0.6))
    for ax, test in zip(np.atleast_1d(axes), tests, strict=True):
        ax.axhspan(-test.band, test.band, color="tab:blue", alpha=0.15, label="per-lag band")
        for level in (-test.simultaneous_band, test.simultaneous_band):
            ax.axhline(
                level, color="tab:red", lw=0.8, ls="--", label="band for all lags at once (the verdict)"
            )
        ax.stem(test.lags, test.values, basefmt=" ", label="correlation at each lag")
        verdict = "pass" if test.passed else "FAIL"
        set_title(ax, f"{test.formula}: {verdict} ({test.fraction_outside:.0%} of lags outside the per-lag band)",
                  fontsize=9)  # fmt: skip
        ax.set_ylabel("correlation [-]")
        ax.set_ylim(-1.05, 1.05)
        ax.set_xlabel("lag tau [samples]")
    set_title(fig, title)
    handles, labels = np.atleast_1d(axes)[0].get_legend_handles_labels()
    shown = dict(zip(labels, handles, strict=True))  # the two dashed lines under one entry
    fig.legend(shown.values(), shown.keys(), loc="outside lower center", ncols=3, fontsize=8)
    return fig


def plot_residual_tests(tests: list[CorrelationTest], path: str, title: str = "Residual analysis") -> None:
    """Write :func:`residual_tests_figure` as PNG at ``path``."""
    from motorid.figures import save

    save(residual_tests_figure(tests, title), path)


# --------------------------------------------------------------------------- the paper's experiment
@dataclass(frozen=True)
class SweepTables:
    """The paper's Tables 1 and 2 for one record, MSE in rpm^2 (the paper labels it rpm).

    Attributes
    ----------
    orders : DataFrame
        Table 1: index ``order`` (na = nb); columns ``mse_linear``, ``mse_nonlinear``,
        ``low_speed_mse_linear``, ``low_speed_mse_nonlinear``.
    degrees : DataFrame
        Table 2: index ``degree`` of the polynomial at the fixed order; columns
        ``mse``, ``low_speed_mse`` and ``gamma_2..gamma_n`` (NaN where absent).
    low_speed_threshold : float
        |y| below this counted as low speed [rad/s].
    prediction : str
        ``"one_step"`` (the online prediction, as in the paper) or ``"free_run"``.
    """

    orders: pd.DataFrame
    degrees: pd.DataFrame
    low_speed_threshold: float
    prediction: str


def order_sweep(
    u: ArrayLike,
    y: ArrayLike,
    orders: Sequence[int] = range(1, 7),
    degrees: Sequence[int] = range(2, 6),
    *,
    degree: int = 3,
    order: int = 4,
    lam: float = 1.0,
    delta: float = 1e3,
    low_speed_threshold: float | None = None,
    prediction: str = "one_step",
    skip: int = 0,
    progress: bool = False,
    output_unit: str | None = "rad/s",
) -> SweepTables:
    """Identify ARX-RLS and Hammerstein-RLS on one record over model orders and
    polynomial degrees, as in the paper's Tables 1 and 2.

    Parameters
    ----------
    u, y : array_like
        Input [V] and measured output [rad/s].
    orders : sequence of int
        Model orders na = nb for Table 1.
    degrees : sequence of int
        Polynomial degrees for Table 2, at ``order``.
    degree : int
        Polynomial degree of the Hammerstein models of Table 1 (3 in the paper).
    order : int
        Model order of Table 2 (4 in the paper).
    lam, delta : float
        RLS forgetting factor and initial covariance scale.
    low_speed_threshold : float, optional
        |y| below this is low speed [rad/s]; 10 % of max |y| by default.
    prediction : {"one_step", "free_run"}
        Which prediction is scored (:func:`compare_predictions`).
    skip : int
        Leading samples left out of the scores.
    progress : bool
        Show a progress bar on stderr (:func:`motorid.progress.progress_bar`).
    output_unit : str or None
        Unit of ``y``: the MSE is in rpm^2 (the paper's) when it is rad/s, else in
        the square of this unit, or of "output units" when it is None (no label
        is invented for a record that names no unit).
    """
    from motorid.estimators import ARXRLS, HammersteinRLS

    u_arr, y_arr = as_float_vector(u, "u"), as_float_vector(y, "y")
    check_signals({"u": u_arr, "y": y_arr})
    if prediction not in ("one_step", "free_run"):
        raise ValueError(f"prediction must be 'one_step' or 'free_run', got {prediction!r}")
    threshold = 0.1 * float(np.max(np.abs(y_arr))) if low_speed_threshold is None else low_speed_threshold
    to_rpm2 = RPM_PER_RAD_S**2 if output_unit == "rad/s" else 1.0
    mse_unit = "rpm^2" if output_unit == "rad/s" else f"({output_unit or 'output units'})^2"
    jobs = [("order", n) for n in orders] + [("degree", d) for d in degrees]
    order_rows: dict[int, dict[str, float]] = {}
    degree_rows: dict[int, dict[str, float]] = {}
    max_degree = max(degrees, default=1)
    for kind, value in progress_bar(jobs, show=progress, desc="order sweep", unit="model"):
        if kind == "order":
            models = {
                "linear": ARXRLS(value, value, lam=lam, delta=delta),
                "nonlinear": HammersteinRLS(value, value, degree=degree, lam=lam, delta=delta),
            }
        else:
            models = {"": HammersteinRLS(order, order, degree=value, lam=lam, delta=delta)}
        row: dict[str, float] = {}
        for label, est in models.items():
            scores = compare_predictions(est, u_arr, y_arr, threshold, skip=skip).loc[prediction]
            suffix = f"_{label}" if label else ""
            row[f"mse{suffix}"] = scores["mse"] * to_rpm2
            row[f"low_speed_mse{suffix}"] = scores["low_speed_mse"] * to_rpm2
        if kind == "order":
            order_rows[value] = row
        else:
            gamma = models[""].params["gamma"]
            for j in range(2, max_degree + 1):
                row[f"gamma_{j}"] = float(gamma[j - 1]) if j <= len(gamma) else float("nan")
            degree_rows[value] = row
    orders_df = pd.DataFrame.from_dict(order_rows, orient="index")
    orders_df.index.name = "order"
    degrees_df = pd.DataFrame.from_dict(degree_rows, orient="index")
    degrees_df.index.name = "degree"
    for df in (orders_df, degrees_df):
        df.attrs["units"] = {"mse": mse_unit, "gamma": "-"}
    return SweepTables(orders_df, degrees_df, threshold, prediction)
