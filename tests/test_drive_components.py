"""Friction laws, amplifier and sensor chain against the paper's equations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motorid.drive import (
    ADConverter,
    Amplifier,
    AsymmetricLaw,
    CoulombLaw,
    Encoder,
    LuGreLaw,
    StribeckLaw,
    Tachogenerator,
    ViscousLaw,
    friction_from_dict,
    measure_speed,
    paper_rig,
    steady_state_speed,
)

speeds = st.floats(-300.0, 300.0, allow_nan=False)
coef = st.floats(0.0, 0.05)


@given(w=speeds, a0=coef, a1=coef, a2=st.floats(0.0, 5.0))
def test_coulomb_and_stribeck_follow_eqs_8_and_9(w, a0, a1, a2):
    sgn = float(np.sign(w))  # eq. (10): sgn(0) = 0
    assert CoulombLaw(alpha=a0).torque(w) == pytest.approx(a0 * sgn)
    expected = a0 * sgn + a1 * math.exp(-a2 * abs(w)) * sgn
    assert StribeckLaw(a0, a1, a2).torque(w) == pytest.approx(expected)


@given(w=speeds, a0=coef, a1=coef, a2=st.floats(0.0, 5.0))
def test_gaussian_stribeck_decays_with_the_square_of_the_speed(w, a0, a1, a2):
    sgn = float(np.sign(w))
    expected = (a0 + a1 * math.exp(-((a2 * w) ** 2))) * sgn
    assert StribeckLaw(a0, a1, a2, stribeck_shape="gaussian").torque(w) == pytest.approx(expected)
    decay = math.exp(-((a2 * w) ** 2))
    asymmetric = AsymmetricLaw(a0, a1, a2, a1, a0, a2, stribeck_shape="gaussian").torque(w)
    assert asymmetric == pytest.approx(
        a0 + a1 * decay if w >= 0 else -(a1 + a0 * decay)
    )  # eq. (11): sgn1(0) = 1


def test_a_gaussian_stribeck_rig_runs_at_its_own_steady_state():
    """The integrators use the law's shape: the steady speed is the root of the balance
    with exp(-(α2 ω)²), written here in NumPy, and differs from the exponential rig's."""
    import scipy.optimize

    a0, a1, a2 = 1e-3, 8e-3, 0.05
    rates = {}
    for shape in ("gaussian", "exponential"):
        law = StribeckLaw(a0, a1, a2, stribeck_shape=shape, side="motor")
        rig = paper_rig(friction=(law,), amplifier=Amplifier())
        decay = (
            (lambda w: math.exp(-((a2 * w) ** 2))) if shape == "gaussian" else (lambda w: math.exp(-a2 * w))
        )
        B = rig.B_m + rig.B_l

        def balance(w, decay=decay, rig=rig, B=B):
            return rig.K_m * (2.0 - rig.K_m * w) / rig.R_a - B * w - a0 - a1 * decay(w) - rig.T_d

        truth = scipy.optimize.brentq(balance, 1e-9, 2.0 / rig.K_m)
        rates[shape] = rig.simulate(np.full(100, 2.0), seed=0)["omega_l"].iloc[-1]
        assert rates[shape] == pytest.approx(truth, rel=1e-3)  # the tacho's ripple, as the asymmetric test
    assert abs(rates["gaussian"] - rates["exponential"]) > 0.01 * rates["exponential"]


@given(w=speeds, a=st.tuples(coef, coef, st.floats(0, 5), coef, coef, st.floats(0, 5)))
def test_asymmetric_follows_eq_11(w, a):
    sgn1 = 1.0 if w >= 0 else 0.0
    sgn2 = 0.0 if w >= 0 else -1.0
    expected = (a[0] + a[1] * math.exp(-a[2] * abs(w))) * sgn1 + (
        a[3] + a[4] * math.exp(-a[5] * abs(w))
    ) * sgn2
    assert AsymmetricLaw(*a).torque(w) == pytest.approx(expected)


def test_breakaway_and_direction_at_zero_speed():
    f = AsymmetricLaw(1e-3, 2e-3, 1.0, 3e-3, 1e-3, 1.0)
    assert f.breakaway_positive == pytest.approx(3e-3)
    assert f.breakaway_negative == pytest.approx(4e-3)
    assert StribeckLaw(1e-3, 2e-3, 1.0).torque(0.0, direction=-1) == pytest.approx(-3e-3)
    assert CoulombLaw(alpha=2e-3).torque(0.0) == 0.0


def test_friction_dict_round_trip_and_sides():
    laws = [
        ViscousLaw(B=1e-5, side="motor"),
        CoulombLaw(alpha=1e-3, side="load"),
        StribeckLaw(1e-3, 1e-3, 2.0),
        AsymmetricLaw(1e-3, 0.0, 0.0, 2e-3, 0.0, 0.0, side="motor"),
        LuGreLaw(sigma0=2.0, sigma1=1e-3, sigma2=1e-5, Fc=1e-3, Fs=2e-3, omega_s=1.0),
    ]
    for law in laws:
        assert friction_from_dict(law.to_dict()) == law
    assert StribeckLaw().sides() == ("motor", "load")
    with pytest.raises(ValueError, match="kind"):
        friction_from_dict({"kind": "magic"})
    with pytest.raises(ValueError, match="LuGre"):
        paper_rig(friction=(laws[4], LuGreLaw(Fc=1e-3, Fs=1e-3, side="motor")))


def test_asymmetric_friction_shows_in_the_rig():
    """Asymmetric friction: the same |u| gives different |speed| in the two directions."""
    fr = (AsymmetricLaw(2e-3, 0.0, 0.0, 8e-3, 0.0, 0.0, side="both"),)
    rig = paper_rig(friction=fr)
    fwd = steady_state_speed(rig, 3.0)
    back = steady_state_speed(rig, -3.0)
    assert fwd > -back > 0
    df = rig.simulate(np.r_[np.full(40, 3.0), np.full(40, -3.0)],
                      seed=0).replace(0, np.nan)  # fmt: skip
    assert df["omega_l"].iloc[39] == pytest.approx(fwd, rel=1e-3)
    assert df["omega_l"].iloc[-1] == pytest.approx(back, rel=1e-3)


def test_lugre_reaches_its_steady_state_curve():
    lugre = LuGreLaw(sigma0=2.0, sigma1=3e-3, sigma2=0.0, Fc=3e-3, Fs=4e-3, omega_s=2.0)
    rig = paper_rig(friction=(lugre,))
    for u in (2.0, 6.0, -4.0):
        w = rig.simulate(np.full(60, u), seed=0)["omega_l"].iloc[-1]
        assert w == pytest.approx(steady_state_speed(rig, u), rel=1e-4)
    z = lugre.g(5.0) / lugre.sigma0
    assert lugre.torque(z, 5.0) == pytest.approx(lugre.steady_state_torque(5.0))


@pytest.mark.parametrize(
    ("amplifier", "u", "v_a"),
    [
        # the paper rig's amplifier: unit gain, 0.6 V dead zone, ±12 V rating (Fig. 4)
        (Amplifier(1.0, 0.6, 12.0), 0.0, 0.0),
        (Amplifier(1.0, 0.6, 12.0), 0.3, 0.0),
        (Amplifier(1.0, 0.6, 12.0), -0.6, 0.0),  # the edge of the band is still dead
        (Amplifier(1.0, 0.6, 12.0), 1.0, 0.4),
        (Amplifier(1.0, 0.6, 12.0), -6.0, -5.4),
        (Amplifier(1.0, 0.6, 12.0), 12.0, 11.4),  # the largest voltage, V_max - d
        (Amplifier(1.0, 0.6, 12.0), 20.0, 11.4),  # beyond the rating: nothing more
        (Amplifier(1.0, 0.6, 12.0), -20.0, -11.4),
        # gain 2: the dead zone and the rating apply to the amplified command
        (Amplifier(2.0, 0.5, 10.0), 0.25, 0.0),
        (Amplifier(2.0, 0.5, 10.0), 1.0, 1.5),
        (Amplifier(2.0, 0.5, 10.0), 6.0, 9.5),
        (Amplifier(), -7.0, -7.0),  # the defaults: an ideal amplifier
    ],
)
def test_amplifier_at_known_points(amplifier, u, v_a):
    assert amplifier(u) == pytest.approx(v_a, abs=1e-15)  # one rounding of a few volts


@given(d=st.floats(0, 2), vmax=st.floats(1, 24), g=st.floats(0.5, 2), u=st.floats(-30, 30))
def test_amplifier_is_odd_monotone_bounded_and_dead_inside_its_band(d, vmax, g, u):
    """Properties of a dead zone behind a saturation, whatever the formula: odd,
    non-decreasing, never beyond V_max - d, exactly zero while |G u| <= d and nonzero
    outside the band below the rating."""
    amp = Amplifier(gain=g, dead_zone=d, v_max=vmax)
    grid = np.sort(np.r_[np.linspace(-30.0, 30.0, 601), u])
    v = amp(grid)
    np.testing.assert_array_equal(amp(-grid), -v)
    assert np.all(np.diff(v) >= 0.0)
    assert np.all(np.abs(v) <= max(vmax - d, 0.0))
    if abs(g * u) <= d:
        assert amp(u) == 0.0
    elif vmax > d:
        assert amp(u) != 0.0 and math.copysign(1.0, amp(u)) == math.copysign(1.0, u)


@pytest.mark.parametrize(("g", "d", "vmax"), [(1.0, 0.6, 12.0), (2.0, 0.5, 10.0), (0.7, 1.5, 24.0)])
def test_amplifier_slope_is_the_gain_between_band_and_rating(g, d, vmax):
    """Between the dead band and the rating dv_a/du = G, on both sides; beyond the
    rating 0. The slope comes from outputs volts apart, each within a rounding
    (1e-15 V) of its value: it is G to 1e-12."""
    amp = Amplifier(gain=g, dead_zone=d, v_max=vmax)
    low, high = (d + 0.25 * (vmax - d)) / g, (d + 0.75 * (vmax - d)) / g
    for sign in (1.0, -1.0):
        slope = (amp(sign * high) - amp(sign * low)) / (sign * (high - low))
        assert slope == pytest.approx(g, rel=1e-12)
        assert amp(sign * 2 * vmax / g) == amp(sign * 3 * vmax / g)


def test_tacho_and_adc_chain():
    tacho = Tachogenerator(noise_std=0.0)
    adc = ADConverter(bits=12, v_min=-10.0, v_max=10.0)
    w = np.linspace(-400, 400, 2001)
    y = measure_speed(w, 0.0, tacho, adc)
    lsb_speed = adc.lsb / tacho.gain
    inside = np.abs(tacho.gain * w) < 10.0 - adc.lsb
    assert np.max(np.abs(y - w)[inside]) <= lsb_speed / 2 + 1e-12
    assert len(np.unique(y)) <= 4096
    assert y.max() <= 10.0 / tacho.gain and y.min() >= -10.0 / tacho.gain  # range clips
    assert measure_speed([0.0], 0.0, tacho, adc)[0] == 0.0
    # noise: standard deviation in speed equals noise_std / gain (large vs the lsb)
    noisy = Tachogenerator(noise_std=0.05)
    n = np.random.default_rng(0).standard_normal(20000)
    y = measure_speed(np.full(20000, 50.0), n, noisy, adc)
    assert np.std(y) == pytest.approx(0.05 / noisy.gain, rel=0.03)


def test_encoder_counts():
    enc = Encoder(counts_per_rev=4)
    np.testing.assert_allclose(enc.measure([0.0, 1.0, 1.6, -0.1]), [0.0, 0.0, math.pi / 2, -math.pi / 2])


def test_friction_objects_evaluate_the_integrators_law_bit_for_bit():
    """torque() and z_dot() are the compiled functions the integrators call (one statement
    of each law), so they agree to the last bit with the packed rows the fast path uses."""
    from motorid.drive.friction import pack_static_friction
    from motorid.drive.kernels import lugre_rate, static_friction

    law = AsymmetricLaw(1e-3, 5e-4, 0.2, 2e-3, 1e-4, 0.3, side="motor")
    rows = pack_static_friction((law,))
    for w in np.linspace(-3.0, 3.0, 61):
        for d in (-1.0, 1.0):
            assert float(law.torque(w, direction=d)) == static_friction(
                rows, 0, w, d if w == 0 else np.sign(w)
            )
    lugre = LuGreLaw(sigma0=2.0, sigma1=1e-3, Fc=1e-3, Fs=2e-3, omega_s=1.0)
    z, w = np.linspace(-1e-3, 1e-3, 7), np.linspace(-2.0, 2.0, 7)
    assert lugre.z_dot(z, w).tolist() == [
        lugre_rate(2.0, 1e-3, 2e-3, 1.0, a, b) for a, b in zip(z, w, strict=True)
    ]
