"""The doctor's torque balance on a velocity record is written on each sample's own ends, which
holds exactly for a drive with viscous and Coulomb friction whatever the sample time
(:func:`motorid.diagnose.model.discrete_inertia`); the references here are closed forms."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from motorid.diagnose.kinematics import CUTOFF_PER_BAND, noise_left
from motorid.diagnose.measures import one_step_noise
from motorid.diagnose.model import discrete_inertia, discrete_inertia_slope, fit_model, inertia_from_discrete
from motorid.diagnose.prepare import ONE_STEP_SAMPLE_SHARE, Pool, one_step_noise_pool, prepare

BASE = ("viscous_friction", "coulomb_friction")  # one direction: an offset would repeat the Coulomb column


def test_the_balance_inertia_is_the_bernoulli_series_and_its_inverse_gives_the_inertia_back():
    J, dt = 2e-6, 0.01
    for x in (1e-4, 1e-2, 0.1):
        B = x * J / dt
        # x / (1 - e^-x) - x / 2 = 1 + x²/12 - x⁴/720 + x⁶/30240 - ...: the terms left out are below 1e-13
        series = J * (1.0 + x**2 / 12.0 - x**4 / 720.0 + x**6 / 30240.0)
        assert discrete_inertia(J, B, dt) == pytest.approx(series, rel=1e-12)
    for x in (1e-6, 0.3, 1.0, 4.0):
        B = x * J / dt
        assert inertia_from_discrete(discrete_inertia(J, B, dt), B, dt) == pytest.approx(J, rel=1e-9)
    assert discrete_inertia(J, 0.0, dt) == J
    assert inertia_from_discrete(J, 0.0, dt) == J
    # the delta method's slope against a central difference of the inverse (its own error ~h²)
    for x in (1e-3, 0.3, 1.0, 4.0):
        B = x * J / dt
        jb, h = discrete_inertia(J, B, dt), 1e-5 * J
        difference = (inertia_from_discrete(jb + h, B, dt) - inertia_from_discrete(jb - h, B, dt)) / (2 * h)
        assert discrete_inertia_slope(jb, B, dt) == pytest.approx(difference, rel=1e-6)
    assert discrete_inertia_slope(J, 0.0, dt) == 1.0


def held_response(
    u: np.ndarray, J: float, B: float, g: float, coulomb: float, w0: float, dt: float
) -> np.ndarray:
    """The exact speed at the end of each sample of a drive ``J ẇ = g u - B w - C`` whose input is
    held over each sample and whose speed stays positive: ``w_k = e^{-x} w_{k-1} + (1 - e^{-x})
    (g u_k - C) / B``, ``x = B dt / J``."""
    decay = math.exp(-B * dt / J)
    w = np.empty(u.size)
    last = w0
    for k, level in enumerate(u):
        last = decay * last + (1.0 - decay) * (g * level - coulomb) / B
        w[k] = last
    return w


#: The held drive of the tests below: J [kg m²], B [N m s/rad], C [N m]; its input gain G [N m/V].
TRUTH = {"inertia": 1.4e-6, "viscous": 1.1e-4, "coulomb": 2.6e-3}
G = 2e-3


def held_drive_record(ratio: float, noise_share: float, seed: int) -> tuple[pd.DataFrame, float]:
    """4000 samples of the drive :data:`TRUTH` turning one way under a held two-tone input, sampled
    at ``ratio`` times its time constant J / B, with white noise of ``noise_share`` of its largest
    speed; and that noise's standard deviation [rad/s]."""
    J, B, coulomb = TRUTH["inertia"], TRUTH["viscous"], TRUTH["coulomb"]
    dt = ratio * J / B
    t = np.arange(4000) * dt
    u = 8.0 + 2.5 * np.sin(2 * np.pi * t / (400 * dt)) + 1.5 * np.sign(np.sin(2 * np.pi * t / (37 * dt)))
    w = held_response(u, J, B, G, coulomb, w0=(G * 8.0 - coulomb) / B, dt=dt)
    sigma = noise_share * float(np.max(w))
    record = pd.DataFrame(
        {"t": t, "u": u, "y": w + sigma * np.random.default_rng(seed).standard_normal(w.size)}
    )
    record.attrs["dt"] = dt
    return record, sigma


@pytest.mark.parametrize("ratio", [0.05, 0.8, 1.5])
def test_a_drive_sampled_near_its_time_constant_is_fitted_to_its_truth(ratio):
    """A drive turning one way under a held two-tone input, sampled at ``ratio`` times its time
    constant J / B (the central differences of the filtered speed took the inertia 10 % high at
    0.8), with white noise of 0.1 % of its speed: the fit gives J, B and C of the truth. B and C
    within 0.5 % (their spread over seeds is below 0.1 %); J within 3 %: the noise compensation
    takes the speed's noise from its part near the Nyquist frequency, where a drive sampled at
    1.5 J/B also has signal, which takes J 2.2 % high on the noise-free record (0.7 % at 0.8)."""
    record, _ = held_drive_record(ratio, noise_share=1e-3, seed=3)
    fitted = fit_model(prepare(record, input_gain=G).data, BASE).model.params
    J, B, coulomb = TRUTH["inertia"], TRUTH["viscous"], TRUTH["coulomb"]
    assert fitted["viscous"] == pytest.approx(B, rel=0.005)
    assert fitted["coulomb"] == pytest.approx(coulomb, rel=0.005)
    assert fitted["inertia"] == pytest.approx(J, rel=0.03)


@pytest.mark.parametrize("ratio", [0.05, 0.8, 1.5])
def test_a_drive_sampled_near_its_time_constant_has_its_noise_measured_by_the_one_step_prediction(ratio):
    """The same drive with white noise of a known σ: the model's one-step prediction measures σ
    within 5 % at any sample time (its error is ``n_k - e^{-x} n_{k-1}``; 5 %: 4000 samples give
    the variance within 2.2 % at one standard error, and the fitted model's own error). Where the
    record is sampled slower than a quarter of J / B the speed's part near the Nyquist frequency
    holds signal (measured 2.4 and 4.9 times σ at 0.8 and 1.5), and the pool takes the noise from
    the prediction; at 0.05 J / B it keeps the figure near Nyquist (measured 1.11 σ there: 15 %)."""
    record, sigma = held_drive_record(ratio, noise_share=2e-3, seed=4)
    dt = record.attrs["dt"]
    prep = prepare(record, input_gain=G)
    model = fit_model(prep.data, BASE).model
    assert one_step_noise(model, prep.data) == pytest.approx(sigma, rel=0.05)
    pool = Pool([prep], ["record"])
    near_nyquist = prep.kin.noise / noise_left(CUTOFF_PER_BAND * prep.kin.band, dt)
    measured = one_step_noise_pool(pool, [model])
    if ratio > ONE_STEP_SAMPLE_SHARE:
        assert near_nyquist > 2.0 * sigma
        assert measured is not pool and "one-step prediction" in measured.parts[0].notes[-1]
        assert measured.noise == pytest.approx(
            sigma * noise_left(CUTOFF_PER_BAND * prep.kin.band, dt), rel=0.05
        )
    else:
        assert near_nyquist == pytest.approx(sigma, rel=0.15)
        assert measured is pool
