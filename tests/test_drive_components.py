"""Friction on the rig's masses, amplifier and sensor chain against the paper's equations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from motorid.drive import (
    ADConverter,
    Amplifier,
    Encoder,
    Friction,
    RigidDrive,
    Tachogenerator,
    friction_from_dict,
    measure_speed,
    paper_rig,
    steady_state_speed,
)
from motorid.errors import ModelFileError

speeds = st.floats(-300.0, 300.0, allow_nan=False)
coef = st.floats(0.0, 0.05)
velocity = st.floats(0.05, 50.0)
STRIBECK = ("coulomb_friction", "stribeck_friction")


def stribeck(fc: float, fs: float, vs: float, shape: str = "exponential", side: str = "both") -> Friction:
    """Coulomb friction F_c and a Stribeck excess F_s decaying at v_s [rad/s] on ``side``."""
    return Friction(STRIBECK, {"coulomb": fc, "stribeck": fs, "stribeck_velocity": vs}, side, shape)


@given(w=speeds, fc=coef, fs=coef, vs=velocity)
def test_coulomb_and_stribeck_follow_eqs_8_and_9(w, fc, fs, vs):
    sgn = float(np.sign(w))  # eq. (10): sgn(0) = 0
    assert Friction(("coulomb_friction",), {"coulomb": fc}).torque(w) == pytest.approx(fc * sgn)
    expected = fc * sgn + fs * math.exp(-abs(w) / vs) * sgn
    assert stribeck(fc, fs, vs).torque(w) == pytest.approx(expected)


@given(w=speeds, fc=coef, fs=coef, vs=velocity, share=st.floats(-1.0, 1.0), dv=st.floats(-1e-4, 1e-4))
def test_gaussian_stribeck_and_the_asymmetry_on_a_mass(w, fc, fs, vs, share, dv):
    sgn = float(np.sign(w))
    decay = math.exp(-((w / vs) ** 2))
    assert stribeck(fc, fs, vs, "gaussian").torque(w) == pytest.approx((fc + fs * decay) * sgn)
    # eq. (11)'s different levels each way: F_c ± ΔF_c, and B ± ΔF_v
    asymmetric = Friction(
        (*STRIBECK, "asymmetric_friction"),
        {"coulomb": fc, "stribeck": fs, "stribeck_velocity": vs, "coulomb_asymmetry": share * fc,
         "viscous_asymmetry": dv},
        stribeck_shape="gaussian",
    )  # fmt: skip
    expected = (fc + fs * decay) * sgn + (share * fc + dv * abs(w)) * abs(sgn)
    assert asymmetric.torque(w) == pytest.approx(expected, abs=1e-15)


def test_a_gaussian_stribeck_rig_runs_at_its_own_steady_state():
    """The integrators use the friction's shape: the steady speed is the root of the balance
    with exp(-(ω/v_s)²), written here in NumPy, and differs from the exponential rig's."""
    import scipy.optimize

    fc, fs, vs = 1e-3, 8e-3, 20.0
    rates = {}
    for shape in ("gaussian", "exponential"):
        rig = paper_rig(friction=(stribeck(fc, fs, vs, shape, "motor"),), amplifier=Amplifier())
        decay = (
            (lambda w: math.exp(-((w / vs) ** 2))) if shape == "gaussian" else (lambda w: math.exp(-w / vs))
        )
        B = rig.B_m + rig.B_l

        def balance(w, decay=decay, rig=rig, B=B):
            return rig.K_m * (2.0 - rig.K_m * w) / rig.R_a - B * w - fc - fs * decay(w) - rig.T_d

        truth = scipy.optimize.brentq(balance, 1e-9, 2.0 / rig.K_m)
        rates[shape] = rig.simulate(np.full(100, 2.0), seed=0)["omega_l"].iloc[-1]
        assert rates[shape] == pytest.approx(truth, rel=1e-3)  # the tacho's ripple, as the asymmetric test
    assert abs(rates["gaussian"] - rates["exponential"]) > 0.01 * rates["exponential"]


@given(w=speeds, fc=coef, excess=coef, rate=st.just(0.0) | st.floats(1e-3, 5.0), share=st.floats(-1.0, 1.0))
def test_a_law_of_an_older_file_reads_as_its_effects_with_the_torque_of_eq_11(w, fc, excess, rate, share):
    """A file written before the rig took the effects holds eq. (11)'s α-form laws; read, each is
    the effects that give the same torque (a Stribeck rate α2 of 0, an excess that never decays, is
    Coulomb friction)."""
    a = (fc + share * fc, excess, rate, fc - share * fc, excess, rate)
    law = {"kind": "asymmetric_friction", **{f"alpha{k}": v for k, v in enumerate(a)},
           "stribeck_shape": "exponential", "side": "load"}  # fmt: skip
    friction = friction_from_dict(law)
    assert friction.side == "load"
    decay = math.exp(-a[2] * abs(w))
    expected = a[0] + a[1] * decay if w > 0 else (-(a[3] + a[4] * decay) if w < 0 else 0.0)
    assert friction.torque(w) == pytest.approx(expected, rel=1e-12, abs=1e-15)


def test_breakaway_and_direction_at_zero_speed():
    f = Friction(
        (*STRIBECK, "asymmetric_friction", "static_friction"),
        {"coulomb": 2e-3, "stribeck": 1e-3, "stribeck_velocity": 1.0, "coulomb_asymmetry": 5e-4,
         "viscous_asymmetry": 0.0, "breakaway_excess": 4e-4},
    )  # fmt: skip
    assert f.kinetic == pytest.approx((3.5e-3, 2.5e-3))
    assert f.breakaway == pytest.approx((3.9e-3, 2.9e-3))  # the static friction's excess above them
    assert f.torque(0.0, direction=-1) == pytest.approx(-2.5e-3)
    assert Friction(("coulomb_friction",), {"coulomb": 2e-3}).torque(0.0) == 0.0


def test_friction_dict_round_trip_sides_and_the_laws_of_older_files():
    frictions = [
        Friction(("viscous_friction",), {"viscous": 1e-5}, side="motor"),
        Friction(("coulomb_friction", "quadratic_drag"), {"coulomb": 1e-3, "quadratic_drag": 1e-8}, "load"),
        stribeck(1e-3, 1e-3, 0.5, "gaussian"),
        Friction(
            ("coulomb_friction", "lugre_friction"),
            {"coulomb": 1e-3, "bristle_stiffness": 2.0, "bristle_damping": 1e-3},
        ),
    ]
    for f in frictions:
        assert friction_from_dict(f.to_dict()) == f
    assert frictions[2].sides() == ("motor", "load")
    older = {
        "viscous_friction": ({"B": 1e-5}, Friction(("viscous_friction",), {"viscous": 1e-5}, "motor")),
        "coulomb_friction": ({"alpha": 1e-3}, Friction(("coulomb_friction",), {"coulomb": 1e-3}, "motor")),
        "stribeck_friction": (
            {"alpha0": 1e-3, "alpha1": 1e-3, "alpha2": 2.0, "stribeck_shape": "gaussian"},
            stribeck(1e-3, 1e-3, 0.5, "gaussian", "motor"),
        ),
        "lugre_friction": (
            {"sigma0": 2.0, "sigma1": 1e-3, "sigma2": 1e-5, "Fc": 1e-3, "Fs": 1e-3, "omega_s": 1.0},
            Friction(
                ("coulomb_friction", "viscous_friction", "lugre_friction"),
                {"coulomb": 1e-3, "viscous": 1e-5, "bristle_stiffness": 2.0, "bristle_damping": 1e-3},
                "motor",
                "gaussian",
            ),
        ),
    }
    for kind, (law, friction) in older.items():
        assert friction_from_dict({"kind": kind, **law, "side": "motor"}) == friction
    with pytest.raises(ModelFileError, match="unknown friction law 'magic'"):
        friction_from_dict({"kind": "magic"})
    per_direction = {"kind": "asymmetric_friction", "alpha0": 1e-3, "alpha1": 1e-3, "alpha2": 1.0,
                     "alpha3": 1e-3, "alpha4": 2e-3, "alpha5": 1.0, "stribeck_shape": "exponential",
                     "side": "both"}  # fmt: skip
    with pytest.raises(
        ModelFileError, match=r"model.friction\[0\]: .*Stribeck excess or rate differs forwards"
    ):
        friction_from_dict(per_direction, "model.friction[0]")
    with pytest.raises(ValueError, match="more than one lugre_friction on the motor side"):
        lugre = Friction(("coulomb_friction", "lugre_friction"),
                         {"coulomb": 1e-3, "bristle_stiffness": 1.0, "bristle_damping": 0.0}, "motor")  # fmt: skip
        paper_rig(friction=(frictions[3], lugre))


def test_a_mass_refuses_what_it_cannot_hold_by_name():
    with pytest.raises(ValueError, match="input_delay: a mass of the two-mass rig cannot hold it"):
        Friction(("input_delay",), {"input_delay": 0.01})
    with pytest.raises(ValueError, match="lugre_friction needs coulomb_friction"):
        Friction(("lugre_friction",), {"bristle_stiffness": 1.0, "bristle_damping": 0.0})
    with pytest.raises(ValueError, match=r"backwards would be -0\.001 N m < 0"):
        Friction(("coulomb_friction", "asymmetric_friction"),
                 {"coulomb": 1e-3, "coulomb_asymmetry": 2e-3, "viscous_asymmetry": 0.0})  # fmt: skip
    with pytest.raises(ValueError, match="'stribeck_velocity' is missing"):
        Friction(STRIBECK, {"coulomb": 1e-3, "stribeck": 1e-3})
    with pytest.raises(ValueError, match="lugre_friction: a rigid drive cannot hold it"):
        RigidDrive(("coulomb_friction", "lugre_friction"),
                   {"inertia": 1.0, "input_gain": 1.0, "coulomb": 1.0, "bristle_stiffness": 1.0,
                    "bristle_damping": 0.0}, 0.01)  # fmt: skip


@given(w=speeds, fc=coef, fs=coef, vs=velocity, b=st.floats(0.0, 1e-4), c=st.floats(0.0, 1e-7))
def test_a_mass_and_a_rigid_drive_with_the_same_effects_have_one_torque(w, fc, fs, vs, b, c):
    """One vocabulary, one law: the friction on a mass is the rigid drive's friction for the same
    effects and parameters (both evaluate the compiled terms, summed in another order: rounding)."""
    effects = (*STRIBECK, "viscous_friction", "quadratic_drag")
    params = {"coulomb": fc, "stribeck": fs, "stribeck_velocity": vs, "viscous": b, "quadratic_drag": c}
    drive = RigidDrive(effects, {"inertia": 1.0, "input_gain": 1.0, **params}, 0.01)
    expected = float(drive.friction(np.array([w]))[0])
    assert Friction(effects, params).torque(w) == pytest.approx(expected, rel=1e-13, abs=1e-18)


def test_asymmetric_friction_shows_in_the_rig():
    """Asymmetric friction: the same |u| gives different |speed| in the two directions."""
    fr = (
        Friction(("coulomb_friction", "asymmetric_friction"),
                 {"coulomb": 5e-3, "coulomb_asymmetry": -3e-3, "viscous_asymmetry": 0.0}),
    )  # fmt: skip
    rig = paper_rig(friction=fr)
    fwd = steady_state_speed(rig, 3.0)
    back = steady_state_speed(rig, -3.0)
    assert fwd > -back > 0
    df = rig.simulate(np.r_[np.full(40, 3.0), np.full(40, -3.0)],
                      seed=0).replace(0, np.nan)  # fmt: skip
    assert df["omega_l"].iloc[39] == pytest.approx(fwd, rel=1e-3)
    assert df["omega_l"].iloc[-1] == pytest.approx(back, rel=1e-3)


def test_lugre_reaches_its_steady_state_curve():
    lugre = Friction(
        (*STRIBECK, "lugre_friction"),
        {"coulomb": 3e-3, "stribeck": 1e-3, "stribeck_velocity": 2.0, "bristle_stiffness": 2.0,
         "bristle_damping": 3e-3},
        stribeck_shape="gaussian",
    )  # fmt: skip
    rig = paper_rig(friction=(lugre,))
    for u in (2.0, 6.0, -4.0):
        w = rig.simulate(np.full(60, u), seed=0)["omega_l"].iloc[-1]
        assert w == pytest.approx(steady_state_speed(rig, u), rel=1e-4)


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
