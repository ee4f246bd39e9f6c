"""Identification quality against a peer on the demo's simulated record.

The record is the demo's (``run_paper_experiment()``: the default rig, the paper's
two-sine test signal, 120 s at 40 ms, seed 0). Our models, identified online on it
exactly as in the demo (lam = 1, P0 = 1e3 I):

- ARX-RLS, na = nb = 4 (9 parameters);
- Hammerstein-RLS, na = nb = 4, cubic polynomial (the paper's model, 19 parameters);
- Hammerstein-RLS, na = nb = 4, dead-zone basis, its width d chosen by a grid
  search over 0..2 V (beyond the paper, 9 parameters + d).

The peer: SysIdentPy's polynomial NARX of comparable size, FROLS choosing
19 terms (as many as the cubic Hammerstein has parameters) from a degree-3
polynomial of y(t-1..t-4) and u(t..t-4), parameters by least squares. SysIdentPy's
input lags start at 1, so it is given the input advanced by one sample: its lags
1..5 are then our u(t)..u(t-4), the same inputs the Hammerstein regressor holds.

Scores: free-run MSE (the identified model simulated from rest on the record's
input with its own past outputs) over the record after the first 50 samples, and
over its low-speed samples, |y| < 150 rpm (the demo's threshold). In rpm², as
the paper's tables. Lower is better. Fit times are wall times of one fit on the
warmed-up code, best of 3 (for the dead-zone model: the whole grid search plus the fit).

Reading it: the NARX's polynomial holds products of past outputs, so it can
express the speed-dependent Coulomb friction, which a Hammerstein model (its
nonlinearity acts on the input only) cannot; the cubic static block fits the
drive's dead zone poorly and its free run drifts far off, although its
low-speed error still beats ARX. A dead-zone static block is what makes the
Hammerstein model beat the NARX.

SysIdentPy is in the ``bench`` extra only (``pip install -e ".[bench]"``).
Run: ``python benchmarks/bench_quality.py``.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from _table import Row, print_rows

from motorid.estimators import HammersteinRLS
from motorid.experiment import dead_zone_width_by_grid, run_paper_experiment
from motorid.validation import RPM_PER_RAD_S, score_predictions

TITLE = "Free-run quality on the demo record (120 s, default rig): motorid vs SysIdentPy NARX"
LOW_SPEED_RPM = 150.0
ORDER, N_TERMS = 4, 19


def _timed(func) -> float:
    start = time.perf_counter()
    func()
    return time.perf_counter() - start


def narx_free_run(u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Fit SysIdentPy's FROLS polynomial NARX on (u, y); its free run and fit time [s]."""
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    x = np.r_[u[1:], u[-1]].reshape(-1, 1)  # x(t) = u(t+1): SysIdentPy's lag k is our lag k - 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = FROLS(
            order_selection=False,
            n_terms=N_TERMS,
            ylag=ORDER,
            xlag=ORDER + 1,
            estimator=LeastSquares(),
            basis_function=Polynomial(degree=3),
            model_type="NARMAX",
        )
        fit_s = min(_timed(lambda: model.fit(X=x, y=y.reshape(-1, 1))) for _ in range(3))
        y_free = model.predict(X=x, y=y[: model.max_lag].reshape(-1, 1)).ravel()[: len(y)]
    return y_free, fit_s


def measure() -> list[Row]:
    experiment = run_paper_experiment(low_speed_rpm=LOW_SPEED_RPM)
    record, threshold, skip = experiment.record, experiment.low_speed_threshold, experiment.skip
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    labels = list(experiment.runs)
    arx, cubic, zone = labels
    grid = np.round(np.arange(0.0, 2.01, 0.1), 2)  # the demo's grid of dead-zone half-widths [V]
    d = dead_zone_width_by_grid(u, y, ORDER, grid, 1.0, skip)

    y_narx, narx_fit_s = narx_free_run(u, y)
    narx = score_predictions(y, {"free_run": y_narx}, threshold, skip).loc["free_run"]

    def fit_time(fit) -> float:
        fit()  # warm: compiled code loaded
        return min(_timed(fit) for _ in range(3))

    cubic_fit_s = fit_time(lambda: HammersteinRLS(ORDER, ORDER, degree=3).batch_filter(u, y))

    def zone_fit() -> None:
        width = dead_zone_width_by_grid(u, y, ORDER, grid, 1.0, skip)
        HammersteinRLS(ORDER, ORDER, basis=f"dead_zone:{width}").batch_filter(u, y)

    zone_fit_s = fit_time(zone_fit)

    peer = f"SysIdentPy FROLS NARX, cubic, {N_TERMS} terms"
    to_rpm2 = RPM_PER_RAD_S**2
    names = {
        arx: f"ARX-RLS ({ORDER},{ORDER})",
        cubic: f"Hammerstein-RLS ({ORDER},{ORDER}) cubic",
        zone: f"Hammerstein-RLS ({ORDER},{ORDER}) dead zone {d:g} V",
    }
    rows = []
    for label, name in names.items():
        ours = experiment.runs[label].scores.loc["free_run"]
        rows.append(
            Row(f"free-run MSE, {name}", ours["mse"] * to_rpm2, narx["mse"] * to_rpm2, "rpm²", peer, False)
        )
        rows.append(
            Row(
                f"free-run MSE at low speed (< {LOW_SPEED_RPM:g} rpm), {name}",
                ours["low_speed_mse"] * to_rpm2,
                narx["low_speed_mse"] * to_rpm2,
                "rpm²",
                peer,
                False,
            )
        )
    rows.append(Row(f"fit time, {names[cubic]}", cubic_fit_s * 1e3, narx_fit_s * 1e3, "ms", peer, False))
    rows.append(
        Row(f"fit time, {names[zone]} incl. grid of d", zone_fit_s * 1e3, narx_fit_s * 1e3, "ms", peer, False)
    )
    return rows


if __name__ == "__main__":
    print_rows(measure(), TITLE)
