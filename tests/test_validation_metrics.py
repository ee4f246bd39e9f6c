"""Error metrics against hand-computed values, and the one-step vs free-run comparison."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from motorid.errors import DataError
from motorid.estimators import ARXRLS, HammersteinRLS
from motorid.validation import (
    check_signals,
    compare_predictions,
    fit_percent,
    low_speed_mse,
    mse,
    rad_s_to_rpm,
    rmse,
    rpm_to_rad_s,
)

REALMOTORS = Path(__file__).resolve().parents[2] / "shared" / "data" / "realmotors"


def test_metrics_by_hand():
    y = np.array([1.0, -2.0, 0.5, 4.0])
    y_hat = np.array([1.5, -2.0, 0.0, 3.0])
    assert mse(y, y_hat) == pytest.approx((0.25 + 0 + 0.25 + 1.0) / 4)
    assert rmse(y, y_hat) == pytest.approx(np.sqrt(1.5 / 4))
    spread = np.sqrt(np.sum((y - y.mean()) ** 2))
    assert fit_percent(y, y_hat) == pytest.approx(100 * (1 - np.sqrt(1.5) / spread))
    assert fit_percent(y, y) == 100.0
    assert fit_percent(y, np.full(4, y.mean())) == pytest.approx(0.0)
    assert low_speed_mse(y, y_hat, threshold=1.2) == pytest.approx((0.25 + 0.25) / 2)
    assert np.isnan(low_speed_mse(y, y_hat, threshold=0.1))
    assert rad_s_to_rpm(2 * np.pi) == pytest.approx(60.0)
    assert rpm_to_rad_s(2400.0) == pytest.approx(2400 * 2 * np.pi / 60)


def test_metric_errors_name_the_problem():
    with pytest.raises(ValueError, match="one length"):
        mse([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match=r"y\[1\]"):
        mse([1.0, np.nan], [1.0, 1.0])
    with pytest.raises(ValueError, match="constant"):
        fit_percent([2.0, 2.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="threshold"):
        low_speed_mse([1.0], [1.0], threshold=0.0)
    assert mse([1.0, 2.0], [1.0, np.inf]) == np.inf  # a diverged free run


def test_linear_model_loses_at_low_speed_where_the_hammerstein_model_wins():
    """A drive behind an input dead zone: the free-run error of ARX concentrates at
    low speed; a Hammerstein model with the dead-zone basis removes it."""
    rng = np.random.default_rng(4)
    t = np.arange(4000) * 0.04
    u = 5 * np.sin(2 * np.pi * 0.05 * t) * np.sin(2 * np.pi * 0.31 * t) + 0.2 * rng.standard_normal(4000)
    x = np.sign(u) * np.maximum(np.abs(u) - 1.0, 0.0)
    y = lfilter([0.0, 8.0, 4.0], [1.0, -1.0, 0.3], x) + 0.05 * rng.standard_normal(4000)
    threshold = 0.1 * np.abs(y).max()
    linear = compare_predictions(ARXRLS(2, 2), u, y, threshold, skip=100)
    nonlinear = compare_predictions(HammersteinRLS(2, 2, basis="dead_zone:1.0"), u, y, threshold, skip=100)
    assert list(linear.index) == ["one_step", "free_run"]
    assert nonlinear.loc["free_run", "mse"] < 0.1 * linear.loc["free_run", "mse"]
    assert nonlinear.loc["free_run", "low_speed_mse"] < 0.1 * linear.loc["free_run", "low_speed_mse"]
    assert nonlinear.loc["free_run", "fit_percent"] > 95.0
    assert linear.loc["one_step", "mse"] < linear.loc["free_run", "mse"]


def _verdicts(u, e):
    from motorid.validation import residual_tests

    return {t.name: t.passed for t in residual_tests(u, e, max_lag=20)}


def test_residual_tests_false_alarm_rate_on_white_independent_residuals():
    """White residual independent of a white input, 200 seeds: each test fails at its
    nominal rate 1 - confidence = 1 % (measured 1.0 % over 400 seeds)."""
    failures = np.zeros(5)
    for seed in range(200):
        rng = np.random.default_rng(seed)
        failures += ~np.array(list(_verdicts(rng.uniform(-1, 1, 3000), rng.standard_normal(3000)).values()))
    assert failures.sum() / (200 * 5) <= 0.025
    assert failures.max() <= 6  # no single test is biased


def test_residual_tests_catch_what_each_is_for():
    rng = np.random.default_rng(1)
    u, e = rng.uniform(-1, 1, 3000), rng.standard_normal(3000)
    coloured = lfilter([1.0], [1.0, -0.6], e)  # unmodelled dynamics of the noise
    assert not _verdicts(u, coloured)["autocorrelation"]
    lagged_input = e + 0.5 * np.concatenate([[0.0, 0.0], u[:-2]])  # unmodelled linear input term
    assert not _verdicts(u, lagged_input)["input_cross_correlation"]
    squared_input = e + 1.5 * (np.concatenate([[0.0], u[:-1]]) ** 2 - 1 / 3)  # even nonlinearity
    verdict = _verdicts(u, squared_input)
    assert verdict["input_cross_correlation"] and not verdict["billings_u2_e"]
    heteroscedastic = e * (1 + 2 * np.abs(np.concatenate([[0.0], u[:-1]])))  # noise level set by the input
    verdict = _verdicts(u, heteroscedastic)
    assert verdict["input_cross_correlation"] and not verdict["billings_u2_e2"]


def test_residual_tests_reject_bad_arguments(tmp_path):
    from motorid.validation import plot_residual_tests, residual_tests

    with pytest.raises(ValueError, match="max_lag"):
        residual_tests(np.zeros(40), np.ones(40), max_lag=20)
    with pytest.raises(ValueError, match=r"residual\[3\]"):
        residual_tests(np.zeros(400), np.r_[np.ones(3), np.nan, np.ones(396)])
    rng = np.random.default_rng(0)
    path = tmp_path / "resid.png"
    plot_residual_tests(residual_tests(rng.standard_normal(500), rng.standard_normal(500)), str(path))
    assert path.stat().st_size > 10_000


def test_check_signals_refuses_a_constant_column_and_names_an_outlier_row():
    t = np.arange(500) * 0.01
    u, y = np.sin(3 * t), np.cos(2 * t)
    check_signals({"u": u, "y": y})  # a good record passes
    with pytest.raises(DataError, match=r"column 'volts' is constant \(0 in every one of its 500 rows\)"):
        check_signals({"volts": np.zeros(500), "y": y})
    spiky = y.copy()
    spiky[250] = 1e300
    with pytest.raises(DataError, match=r"column 'speed' has an outlier 1e\+300 at row 250"):
        check_signals({"u": u, "speed": spiky})
    # a mostly-zero input (a pulse) has MAD 0: the mean absolute deviation is its spread then
    pulse = np.where((t > 1.0) & (t < 1.5), 2.0, 0.0)
    check_signals({"u": pulse})
    pulse[400] = 1e9
    with pytest.raises(DataError, match=r"'u' has an outlier .* at row 400"):
        check_signals({"u": pulse})


@pytest.mark.parametrize("name", sorted(p.name for p in REALMOTORS.glob("*.csv")) or ["none"])
def test_check_signals_passes_every_measured_record(name):
    if not REALMOTORS.is_dir():
        pytest.skip(f"{REALMOTORS} is not there")
    record = pd.read_csv(REALMOTORS / name, comment="#")
    check_signals({"u": record["u"], "y": record["y"]})
