"""Excitation signals: time base, seeding, and the properties each one promises."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motorid.signals import chirp, multisine, prbs, steps, two_sine_signal

GENERATORS = [two_sine_signal, prbs, multisine, chirp, steps]


@pytest.mark.parametrize("gen", GENERATORS)
def test_time_base_and_seeding(gen):
    t, u = gen(duration=20.0, dt=0.04, seed=3)
    assert t.shape == u.shape == (500,)
    np.testing.assert_allclose(t, np.arange(500) * 0.04)
    assert np.all(np.isfinite(u))
    _, u2 = gen(duration=20.0, dt=0.04, seed=3)
    np.testing.assert_array_equal(u, u2)
    _, u3 = gen(duration=20.0, dt=0.04, seed=4)
    assert not np.array_equal(u, u3)


@pytest.mark.parametrize("gen", GENERATORS)
@pytest.mark.parametrize("bad", [{"dt": 0.0}, {"dt": -1.0}, {"duration": 0.0}, {"duration": float("nan")}])
def test_bad_time_arguments(gen, bad):
    kw = {"duration": 10.0, "dt": 0.04, **bad}
    name = next(iter(bad))
    with pytest.raises(ValueError, match=name):
        gen(**kw)


def test_two_sine_signal_has_quiet_stretches_around_zero():
    """Fig. 8: bidirectional, around 0 V, with deliberate low-amplitude stretches."""
    _, u = two_sine_signal(duration=120.0, dt=0.04, seed=1)
    assert abs(np.mean(u)) < 0.5
    assert u.max() > 3.0 and u.min() < -3.0
    # windowed peak amplitude: some 2 s windows stay within ±1.5 V, others exceed 4 V
    win = 50
    peaks = np.array([np.max(np.abs(u[k : k + win])) for k in range(0, u.size - win, win)])
    assert np.mean(peaks < 1.5) >= 0.15
    assert np.mean(peaks > 4.0) >= 0.3
    # zero crossings both ways at low amplitude
    quiet = np.abs(u) < 1.5
    assert np.sum(np.diff(np.sign(u[quiet])) != 0) > 10


@given(
    amplitude=st.floats(0.1, 12.0),
    hold=st.integers(1, 5),
    nbits=st.integers(3, 12),
    seed=st.integers(0, 2**31),
)
def test_prbs_is_binary_and_holds(amplitude, hold, nbits, seed):
    _, u = prbs(duration=40.0, dt=0.04, amplitude=amplitude, hold=hold, nbits=nbits, seed=seed)
    assert set(np.unique(u)) <= {-amplitude, amplitude}
    changes = np.flatnonzero(np.diff(u)) + 1
    assert np.all(changes % hold == 0)


def test_prbs_is_maximum_length():
    _, u = prbs(duration=2 * 1023 * 0.01, dt=0.01, nbits=10, seed=1)
    period = 1023
    np.testing.assert_array_equal(u[:period], u[period : 2 * period])
    # a maximum-length sequence has one more +1 than -1 per period
    assert np.sum(u[:period] > 0) - np.sum(u[:period] < 0) == 1


def test_multisine_peak_and_spectrum():
    dt, duration = 0.04, 40.0
    _, u = multisine(duration=duration, dt=dt, amplitude=2.0, f_min=0.1, f_max=2.0, n_freqs=10, seed=0)
    assert np.max(np.abs(u)) == pytest.approx(2.0)
    spec = np.abs(np.fft.rfft(u))
    freqs = np.fft.rfftfreq(u.size, dt)
    lines = freqs[spec > 0.05 * spec.max()]
    assert lines.min() >= 0.1 - 1 / duration and lines.max() <= 2.0 + 1 / duration
    with pytest.raises(ValueError, match="f_max"):
        multisine(duration=10, dt=0.04, f_max=20.0)


def test_chirp_sweeps_up():
    dt = 0.01
    _, u = chirp(duration=60.0, dt=dt, f0=0.1, f1=3.0, amplitude=1.5, method="linear", seed=0)
    assert np.max(np.abs(u)) <= 1.5 + 1e-12
    crossings = np.flatnonzero(np.diff(np.sign(u)) != 0)
    gaps = np.diff(crossings)
    assert gaps[:5].mean() > 5 * gaps[-5:].mean()


def test_steps_levels_and_holds():
    _, u = steps(duration=60.0, dt=0.04, amplitude=5.0, hold_seconds=(1.0, 2.0), seed=9)
    assert np.all(np.abs(u) <= 5.0)
    edges = np.flatnonzero(np.diff(u)) + 1
    runs = np.diff(np.concatenate([[0], edges, [u.size]]))
    assert np.all(runs[:-1] >= 25) and np.all(runs <= 50)
