"""The friction EKF and UKF: the model and its Jacobian, the zero-speed rule, accuracy
on simulated rigs, consistency (NIS), divergence, bad data, and the two filters
against each other and against filterpy's ExtendedKalmanFilter.

Unless a test says otherwise the data come from :func:`motorid.drive.paper_rig`
with the friction moved onto the motor mass (Coulomb level and viscous coefficient
there, B_L = 0) so the rig's friction law is the filter's: sample time 0.04 s,
tachogenerator noise 10 mV (0.42 rad/s) read through the 12-bit ±10 V A/D
converter (0.2 rad/s steps), excitation the paper's two-sine signal with quiet
stretches (:func:`motorid.signals.two_sine_signal`), which reverses the
drive every few seconds and holds it near zero speed in between.
"""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pytest
from conftest import examples
from filterpy.common import Saver
from filterpy.kalman import ExtendedKalmanFilter
from hypothesis import given
from hypothesis import strategies as st

from motorid.drive import Friction, kernels, measure_speed, paper_rig
from motorid.errors import FilterDivergenceError
from motorid.estimators import FrictionEKF, FrictionUKF, available, create
from motorid.signals import two_sine_signal
from motorid.testing import check_estimator

#: two-sided 95 % band of chi-square with one degree of freedom
CHI2_1_LOW, CHI2_1_HIGH = 0.000982, 5.0239
EPS = np.finfo(float).eps
#: a prior away from the rig's friction (from_rig starts from the rig's own), so that the
#: tests of accuracy show what the filter learns: 5 mN m and 5e-5 N m s/rad
PRIOR = {"coulomb0": 5e-3, "viscous0": 5e-5}


def matched_rig(coulomb: float = 6e-3, viscous: float = 3e-5, **overrides):
    """The paper's rig with its friction on the motor mass only, as the filter models it."""
    friction = (Friction(("coulomb_friction",), {"coulomb": coulomb}, side="motor"),)
    return paper_rig(friction=friction, B_m=viscous, B_l=0.0, **overrides)


def record(rig, seconds: float = 60.0, seed: int = 0):
    """(u, y, frame) of the two-sine excitation on ``rig``."""
    _, u = two_sine_signal(seconds, rig.dt, seed=seed)
    df = rig.simulate(u, seed=seed)
    return df["u"].to_numpy(), df["y"].to_numpy(), df


@pytest.fixture(scope="module")
def paper_record():
    rig = matched_rig()
    u, y, df = record(rig, 60.0, seed=1)
    return rig, u, y, df


# --------------------------------------------------------------------------- interface
@pytest.mark.cpu_sensitive
@pytest.mark.parametrize("name", ["friction-ekf", "friction-ukf"])
def test_registered_and_conformant_with_defaults(name):
    """Both are registered and pass the conformance suite with no arguments (defaults
    from paper_rig); batch_filter gives the loop's numbers bit for bit (the EKF's
    compiled batch loop runs the kernels of predict and update, the UKF's batch is the
    loop). The suite's record comes from a different system, so the NIS check flags
    it: that warning is expected here and asserted."""
    assert name in available()
    with pytest.warns(RuntimeWarning, match="diverged at sample"):
        report = check_estimator(lambda: create(name))
    assert report["check_batch_equals_loop"] == 0.0
    assert report["check_reset"] == 0.0


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize(
    "options",
    [
        {"asymmetric": True, "stribeck": True},
        {"friction_side": "load"},
        {"current_state": True, "substeps": 160},
    ],
    ids=["asymmetric+stribeck", "load-side", "current-state"],
)
def test_variants_pass_the_conformance_suite(options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        report = check_estimator(lambda: FrictionEKF(**options))
    assert report["check_batch_equals_loop"] == 0.0


def test_params_name_the_friction_with_std_and_units(paper_record):
    rig, u, y, _ = paper_record
    ekf = FrictionEKF.from_rig(rig, asymmetric=True, stribeck=True)
    result = ekf.batch_filter(u[:300], y[:300])
    params = ekf.params
    assert set(params) == {
        "coulomb", "coulomb_std", "viscous", "viscous_std",
        "coulomb_neg", "coulomb_neg_std", "stribeck", "stribeck_std",
    }  # fmt: skip
    assert ekf.param_units["coulomb"] == "N m" and ekf.param_units["viscous"] == "N m s/rad"
    # the batch result carries what a plot of estimate ± std needs, per sample
    i = ekf.state_names.index("viscous")
    assert result.x[-1, i] == params["viscous"]
    assert math.sqrt(result.P_diag[-1, i]) == params["viscous_std"]  # the same P_ii, one IEEE sqrt
    assert result.to_frame().shape == (300, 3 + 2 * ekf.dim_x)


def test_from_rig_takes_the_known_constants_and_the_sensor_variance():
    """R_speed is the variance of what the rig's sensor chain reads, measured: the mean
    squared error of 10^6 readings of the tacho + A/D (true speeds spread over
    ±200 rad/s, the noise standard normal). Its standard error (0.14 % of R) is
    estimated from the same squared errors, and the test allows five of them; the
    draw is seeded, so the verdict cannot change between runs. A variance without the
    quantisation term (0.2 rad/s steps, q^2/12 = 1.9 % of R) would be off by 14."""
    rig = paper_rig(J_l=1e-4, dt=0.02)
    ekf = FrictionEKF.from_rig(rig)
    assert ekf.dt == 0.02
    rng = np.random.default_rng(12)
    omega = rng.uniform(-200.0, 200.0, 1_000_000)
    squared = (measure_speed(omega, rng.standard_normal(omega.size), rig.tacho, rig.adc) - omega) ** 2
    standard_error = squared.std() / math.sqrt(squared.size)
    assert abs(squared.mean() - ekf.R_speed) <= 5 * standard_error
    assert ekf._c[kernels.C_JL] == 1e-4
    assert not ekf.has_current_state  # dt = 20 ms >> L_a/R_a = 0.5 ms
    assert FrictionEKF.from_rig(paper_rig(dt=0.002)).has_current_state
    with pytest.raises(ValueError, match="rig"):
        FrictionEKF.from_rig("paper")


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"friction_side": "left"}, "friction_side"),
        ({"coulomb0": -1e-3}, "coulomb0"),
        ({"viscous_std0": 0.0}, "viscous_std0"),
        ({"nis_window": 0}, "nis_window"),
        ({"substeps": 0}, "substeps"),
        ({"R": float("nan")}, "R"),
        ({"on_divergence": "panic"}, "on_divergence"),
        ({"current_state": "yes"}, "current_state"),
    ],
)
def test_constructor_errors_name_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=name):
        FrictionEKF(**kwargs)


# --------------------------------------------------------------------------- the model
def reference_drift(x, v, rig, s, side=0, decay=0.1, asymmetric=False, stribeck=False, shape="exponential"):
    """Plain-NumPy statement of the continuous model (quasi-static current)."""
    wm, wl, d = x[:3]
    coulomb, viscous = x[3], x[4]
    k = 5
    coulomb_neg = x[k] if asymmetric else coulomb
    k += asymmetric
    excess = x[k] if stribeck else 0.0
    i_a = (v - rig.K_m * wm) / rig.R_a
    t_s = rig.k_s * d + rig.B_s * (wm - wl)
    w = x[side]
    level = coulomb if s > 0 else coulomb_neg
    stribeck_decay = np.exp(-decay * abs(w)) if shape == "exponential" else np.exp(-((decay * w) ** 2))
    t_f = s * (level + excess * stribeck_decay) + viscous * w
    dwm = (rig.K_m * i_a - t_s - (t_f if side == 0 else 0.0)) / rig.J_m
    dwl = (t_s - rig.T_d - (t_f if side == 1 else 0.0)) / rig.J_l
    return np.concatenate([[dwm, dwl, wm - wl], np.zeros(len(x) - 3)])


VARIANTS = {
    "default": {},
    "asymmetric+stribeck": {"asymmetric": True, "stribeck": True},
    "gaussian-stribeck": {"stribeck": True, "stribeck_shape": "gaussian", "stribeck_decay": 0.05},
    "load-side": {"friction_side": "load"},
}


def central_differences(fn, x: np.ndarray, floor) -> np.ndarray:
    """The Jacobian of ``fn`` at ``x`` by central differences, column k with the step
    1e-6 max(|x_k|, floor_k) (``floor``: a number or one per state)."""
    floors = np.broadcast_to(np.asarray(floor, dtype=float), x.shape)
    columns = []
    for k in range(x.size):
        step = 1e-6 * max(abs(x[k]), floors[k])
        up, down = x.copy(), x.copy()
        up[k] += step
        down[k] -= step
        columns.append((fn(up) - fn(down)) / (2 * step))
    return np.column_stack(columns)


def moving_state(ekf: FrictionEKF, speed: float = 40.0) -> np.ndarray:
    x = ekf.x.copy()
    x[:3] = [speed, speed - 0.3, 2e-3]
    names = ekf.state_names
    x[names.index("coulomb")] = 5e-3
    x[names.index("viscous")] = 4e-5
    if "coulomb_neg" in names:
        x[names.index("coulomb_neg")] = 3e-3
    if "stribeck" in names:
        x[names.index("stribeck")] = 2e-3
    return x


@pytest.mark.parametrize("variant", list(VARIANTS))
@pytest.mark.parametrize("s", [1.0, -1.0])
def test_continuous_model_and_jacobian_against_numpy_reference(variant, s):
    """The compiled f equals the plain-NumPy statement, and its analytic Jacobian
    equals central differences of that statement (direction s held)."""
    options = VARIANTS[variant]
    rig = paper_rig()
    ekf = FrictionEKF.from_rig(rig, **options)
    x = moving_state(ekf, speed=30.0 * s)
    v = 5.0 * s
    side = 0 if options.get("friction_side", "motor") == "motor" else 1
    ref = lambda xx: reference_drift(  # noqa: E731
        xx,
        v,
        rig,
        s,
        side,
        decay=options.get("stribeck_decay", 0.1),
        asymmetric=options.get("asymmetric", False),
        stribeck=options.get("stribeck", False),
        shape=options.get("stribeck_shape", "exponential"),
    )
    n = ekf.dim_x
    f = np.zeros(n)
    A = np.zeros((n, n))
    kernels.filter_drift(x, v, ekf._c, s, False, f, A)
    # The compiled f and this restatement add the same terms in other orders: they
    # agree to a few roundings of the largest term, K_m i_a / J_m = 3.2e3 rad/s^2 here
    # (30 rad/s, 5 V), whose unit in the last place is 4.5e-13; atol 1e-9 is 2000 of them.
    np.testing.assert_allclose(f, ref(x), rtol=1e-12, atol=1e-9)
    A_fd = central_differences(ref, x, 1e-3)
    np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6 * np.abs(A).max())


def rigid_drive(shape: str = "exponential"):
    """A rigid drive with every effect the filters model: J 1e-4 kg m², g 0.02 N m/V."""
    from motorid.drive import RigidDrive

    params = {
        "inertia": 1e-4, "input_gain": 0.02, "coulomb": 5e-3, "coulomb_asymmetry": 1e-3,
        "viscous_asymmetry": 0.0, "viscous": 3e-4, "stribeck": 4e-3, "stribeck_velocity": 5.0,
        "offset": 5e-4, "dead_zone": 0.5, "saturation": 10.0,
    }  # fmt: skip
    effects = ("coulomb_friction", "asymmetric_friction", "viscous_friction", "stribeck_friction",
               "offset", "input_dead_zone", "input_saturation")  # fmt: skip
    return RigidDrive(effects, params, 0.01, stribeck_shape=shape)


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
@pytest.mark.parametrize("s", [1.0, -1.0])
def test_rigid_drive_model_and_jacobian_against_numpy_reference(shape, s):
    """The one-mass model J dω/dt = g v - T_0 - T_f(ω), T_f as the rigid drive states it
    (:meth:`RigidDrive.friction`, its own compiled terms), and its Jacobian against
    central differences of a plain-NumPy restatement."""
    drive = rigid_drive(shape)
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    x = ekf.x.copy()
    x[0] = 3.0 * s
    v = 4.0 * s
    p = drive.params

    def reference(xx):
        w, coulomb, viscous, coulomb_neg, excess = xx
        decay = np.exp(-abs(w) / 5.0) if shape == "exponential" else np.exp(-((w / 5.0) ** 2))
        t_f = s * ((coulomb if s > 0 else coulomb_neg) + excess * decay) + viscous * w
        return np.array([(0.02 * v - p["offset"] - t_f) / 1e-4, 0.0, 0.0, 0.0, 0.0])

    f = np.zeros(5)
    A = np.zeros((5, 5))
    kernels.filter_drift(x, v, ekf._c, s, False, f, A)
    # the same terms summed in other orders: a few roundings of the largest, g v / J = 800 rad/s²
    np.testing.assert_allclose(f, reference(x), rtol=1e-12, atol=1e-10)
    # at the prior (the drive's own friction) the filter's torque is the drive's (offset included)
    t_drive = float(drive.friction(np.array([x[0]]))[0])
    assert (0.02 * v - f[0] * 1e-4) == pytest.approx(t_drive, rel=1e-12)
    A_fd = central_differences(reference, x, 1e-3)
    np.testing.assert_allclose(A, A_fd, rtol=1e-6, atol=1e-6 * np.abs(A).max())


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
def test_rigid_drive_filter_free_run_follows_the_drive(shape):
    """simulate() of a filter started from a rigid drive runs that drive: the same terms,
    stick/slip rule and input path; only the integrators differ (Heun sub-steps against
    the drive's exponential Euler with 1 to 50 steps), so the two agree to within 1 %
    of the speed range, and both hold the drive at rest below breakaway."""
    drive = rigid_drive(shape)
    _, u = two_sine_signal(30.0, drive.dt, seed=4)
    u = 8.0 * u / np.abs(u).max()
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    ours = ekf.simulate(u)
    theirs = drive.free_run(u, substeps=50)
    scale = np.abs(theirs).max()
    assert scale > 50.0  # the drive moves
    assert np.sqrt(np.mean((ours - theirs) ** 2)) < 0.01 * scale
    quiet = np.zeros(200) + 0.55  # 0.05 V past the dead zone: 1e-3 N m, below breakaway
    assert np.all(ekf.simulate(quiet) == 0.0) and np.all(drive.free_run(quiet) == 0.0)


def test_rigid_drive_filter_refuses_what_it_cannot_model():
    from motorid.drive import RigidDrive

    drive = rigid_drive()
    with pytest.raises(ValueError, match=r"^R: "):
        FrictionEKF.from_rig(drive)
    with pytest.raises(ValueError, match="quadratic_drag"):
        FrictionEKF.from_rig(drive.with_effects((*drive.effects, "quadratic_drag"),
                                                {**drive.params, "quadratic_drag": 1e-6}), R=0.04)  # fmt: skip
    with pytest.raises(ValueError, match="viscous_asymmetry"):
        FrictionEKF.from_rig(drive.with_params(viscous_asymmetry=1e-5), R=0.04)
    with pytest.raises(ValueError, match="rigid drive's backlash is not in the friction filters' model"):
        FrictionEKF.from_rig(drive.with_effects((*drive.effects, "backlash"), {**drive.params, "backlash_time": 0.02}),
                             R=0.04)  # fmt: skip
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    ekf.predict(1.0)
    with pytest.raises(ValueError, match="current"):
        ekf.update(1.0, current=0.1)
    with pytest.raises(ValueError, match="current"):
        FrictionEKF.from_rig(drive, R=0.04).batch_filter([1.0], [0.0], current=[0.1])
    assert isinstance(drive, RigidDrive)


def delayed_rigid_drive(shape: str = "exponential"):
    """:func:`rigid_drive` with a fractional input delay of 2.7 samples, an input lag and
    static friction 2 mN m above the kinetic levels."""
    drive = rigid_drive(shape)
    return drive.with_effects(
        (*drive.effects, "input_delay", "input_lag", "static_friction"),
        {**drive.params, "input_delay": 0.027, "lag_time_constant": 0.015, "breakaway_excess": 2e-3},
    )


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
def test_rigid_drive_filter_with_delay_lag_and_static_friction_follows_the_drive(shape):
    """The filter's input per sample is the drive's input path (dead zone, saturation, delay,
    lag): the same function, so exactly the drive's; its free run follows the drive's as in
    the test above (1 % of the speed range: the two integrators differ)."""
    drive = delayed_rigid_drive(shape)
    _, u = two_sine_signal(30.0, drive.dt, seed=4)
    u = 8.0 * u / np.abs(u).max()
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    np.testing.assert_array_equal(ekf.model_inputs(u, None), drive.input_signal(u))
    ours = ekf.simulate(u)
    theirs = drive.free_run(u, substeps=50)
    scale = np.abs(theirs).max()
    assert scale > 50.0  # the drive moves
    assert np.sqrt(np.mean((ours - theirs) ** 2)) < 0.01 * scale
    # a filter without the delay and lag misses the drive by over twice that bound (3.5 %)
    plain = FrictionEKF.from_rig(rigid_drive(shape), R=0.04).simulate(u)
    assert np.sqrt(np.mean((plain - theirs) ** 2)) > 0.02 * scale


def test_rigid_drive_filter_breaks_away_at_the_static_level():
    """At rest the filter's stick rule holds the drive up to the kinetic level plus the static
    excess, as the drive's free run does: F_c + ΔF_c + F_s + ΔF_s forwards."""
    drive = delayed_rigid_drive()
    p = drive.params
    g, t0 = p["input_gain"], p["offset"]
    kinetic = p["coulomb"] + p["coulomb_asymmetry"] + p["stribeck"]
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    for level, moves in (
        (kinetic + 0.5 * p["breakaway_excess"], False),
        (kinetic + 1.5 * p["breakaway_excess"], True),
    ):
        # the input (past the dead zone) whose force net of the offset is ``level``
        u = np.full(100, (level + t0) / g + p["dead_zone"])
        assert bool(np.any(ekf.simulate(u) > 0.0)) is moves
        assert bool(np.any(drive.free_run(u) > 0.0)) is moves
        assert np.all(ekf.simulate(u) >= 0.0)


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize("cls", [FrictionEKF, FrictionUKF])
def test_rigid_drive_filter_online_equals_batch_and_reloads_its_input_memory(cls, tmp_path):
    """predict(u) carries the input path's memory a sample at a time; batch_filter runs the same
    function over the record: the same estimates. A filter saved mid-record and reloaded goes
    on with the same memory (the delay's last inputs, the lag's state)."""
    from motorid.errors import DataError
    from motorid.estimators import load_model

    drive = delayed_rigid_drive()
    _, u = two_sine_signal(6.0, drive.dt, seed=2)
    u = 8.0 * u / np.abs(u).max()
    y = drive.free_run(u) + np.random.default_rng(0).normal(0.0, 0.2, u.size)
    loop = cls.from_rig(drive, R=0.04)
    inputs = []
    for k in range(u.size):
        loop.predict(u[k])
        inputs.append(loop.v)
        loop.update(y[k])
    np.testing.assert_array_equal(inputs, drive.input_signal(u))
    batch = cls.from_rig(drive, R=0.04)
    half = u.size // 2
    batch.batch_filter(u[:half], y[:half])
    batch.save(tmp_path / "filter.json")
    again = load_model(tmp_path / "filter.json")
    for est in (batch, again):
        est.batch_filter(u[half:], y[half:])
        np.testing.assert_array_equal(est.x, loop.x)
        np.testing.assert_array_equal(est.P, loop.P)
    fresh = cls.from_rig(drive, R=0.04)
    with pytest.raises(ValueError, match=r"input_ring must have shape \(4,\) for this filter"):
        fresh.set_state({**batch.get_state(), "input_ring": np.zeros(3)})  # 2.7 samples of delay hold 4
    data = json.loads((tmp_path / "filter.json").read_text())
    data["model"]["state"]["input_ring"] = [0.0]
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(
        DataError, match=r"bad.json: model.state.input_ring: must have shape \(4,\), got \(1,\)"
    ):
        load_model(tmp_path / "bad.json")


def test_two_mass_friction_the_filter_cannot_hold_is_refused():
    """The filters hold one Stribeck term: two of different rates are refused by name."""
    rig = paper_rig(friction=(
        Friction(("coulomb_friction", "stribeck_friction"),
                 {"coulomb": 1e-3, "stribeck": 2e-3, "stribeck_velocity": 10.0}, side="motor"),
        Friction(("coulomb_friction", "stribeck_friction"),
                 {"coulomb": 1e-3, "stribeck": 2e-3, "stribeck_velocity": 1 / 0.3}, side="load"),
    ))  # fmt: skip
    with pytest.raises(ValueError, match="different rates"):
        FrictionEKF.from_rig(rig)
    ekf = FrictionEKF.from_rig(rig, stribeck=False)  # a user may drop it
    assert not ekf.stribeck
    drag = Friction(
        ("coulomb_friction", "quadratic_drag"), {"coulomb": 1e-3, "quadratic_drag": 1e-8}, side="motor"
    )
    with pytest.raises(
        ValueError, match=r"^rig: a mass's quadratic_drag is not in the friction filters' model"
    ):
        FrictionEKF.from_rig(paper_rig(friction=(drag,)))
    # LuGre by its steady state: its mass's Coulomb and Stribeck levels, Gaussian
    lugre = Friction(
        ("coulomb_friction", "stribeck_friction", "lugre_friction"),
        {"coulomb": 3e-3, "stribeck": 1e-3, "stribeck_velocity": 2.0, "bristle_stiffness": 2.0,
         "bristle_damping": 3e-3},
        "load", "gaussian",
    )  # fmt: skip
    ekf = FrictionEKF.from_rig(paper_rig(friction=(lugre,)))
    x = dict(zip(ekf.state_names, ekf.x, strict=True))
    assert (x["coulomb"], x["stribeck"], ekf.stribeck_decay, ekf.stribeck_shape) == (
        3e-3,
        1e-3,
        0.5,
        "gaussian",
    )


@pytest.mark.parametrize("variant", [*VARIANTS, "current-state"])
@pytest.mark.parametrize("s", [1.0, -1.0])
def test_sample_jacobian_against_finite_differences_away_from_zero(variant, s):
    """F set by predict is the derivative of the whole sub-stepped sample map, checked
    column by column against central differences where no speed nears zero."""
    options = VARIANTS.get(variant, {"current_state": True})
    ekf = FrictionEKF(**options)
    x = moving_state(ekf, speed=60.0 * s)
    if ekf.has_current_state:
        x[ekf.state_names.index("i_a")] = 0.4 * s
    v = 6.0 * s
    n = ekf.dim_x
    F = np.empty((n, n))
    x_next = kernels.filter_propagate(x, v, ekf._c, F, True)
    assert np.sign(x_next[0]) == s and np.sign(x_next[1]) == s  # no reversal in the sample
    dummy = np.empty((0, 0))
    floors = [1e-2 if k < 3 else 1e-5 for k in range(n)]
    F_fd = central_differences(
        lambda state: kernels.filter_propagate(state, v, ekf._c, dummy, False), x, floors
    )
    scale = np.abs(F).max(axis=1, keepdims=True)
    np.testing.assert_allclose(F, F_fd, rtol=1e-5, atol=1e-7 * scale.max())
    # predict() leaves in ekf.F what this very propagate gives at the voltage it applied
    ekf.x = x
    ekf.predict(v + (0.6 * s))  # amplifier dead zone 0.6 V, gain 1
    assert ekf.v == pytest.approx(v, rel=4 * EPS)  # 6.6 - 0.6, rounded
    F_applied = np.empty((n, n))
    kernels.filter_propagate(x, ekf.v, ekf._c, F_applied, True)
    np.testing.assert_array_equal(ekf.F, F_applied)


def test_zero_speed_sticks_exactly_and_teaches_nothing_about_friction():
    """The chosen zero-speed rule: a resting drive whose torque stays below the
    Coulomb level stays at exactly 0 (Karnopp), the Jacobian row of the stuck speed
    is zero, so the output carries no information on the friction that sample; a
    drive coasting down stops at exactly zero instead of chattering."""
    ekf = FrictionEKF(coulomb0=6e-3)
    n = ekf.dim_x
    F = np.empty((n, n))
    x = ekf.x.copy()  # at rest
    # 0.1 V past the 0.6 V dead zone: K_m * 0.1 / R_a = 2.1 mN m < 6 mN m
    x_next = kernels.filter_propagate(x, 0.1, ekf._c, F, True)
    assert x_next[0] == 0.0 and x_next[1] == 0.0
    assert np.all(F[0] == 0.0)
    assert F[1, ekf.state_names.index("coulomb")] == 0.0
    # 1 V: 21 mN m > 6 mN m breaks it away, forwards
    assert kernels.filter_propagate(x, 1.0, ekf._c, F, False)[0] > 0.0
    # coasting from 2 rad/s with no voltage: stops at exactly zero and stays
    x[:2] = 2.0
    x1 = kernels.filter_propagate(x, 0.0, ekf._c, F, True)
    assert x1[0] == 0.0 and np.all(F[0] == 0.0)
    x2 = kernels.filter_propagate(x1, 0.0, ekf._c, F, False)
    assert x2[0] == 0.0


def test_model_free_run_matches_the_plant(paper_record):
    """With the true friction, simulate() (the filter's model: quasi-static current,
    Heun sub-steps) reproduces the plant's load speed closely."""
    rig, u, _, df = paper_record
    ekf = FrictionEKF.from_rig(rig, coulomb0=6e-3, viscous0=3e-5)
    y_model = ekf.simulate(u)
    omega = df["omega_l"].to_numpy()
    rms_error = np.sqrt(np.mean((y_model - omega) ** 2))
    assert rms_error < 0.01 * np.sqrt(np.mean(omega**2))
    assert rms_error < 0.5  # below the tacho noise (0.42 rad/s)


# --------------------------------------------------------------------------- accuracy
@examples(6)
@given(
    coulomb=st.floats(3e-3, 10e-3),
    viscous=st.floats(3e-5, 1e-4),
    J_m=st.floats(1.5e-5, 5e-5),
    J_l=st.floats(5e-5, 2e-4),
    seed=st.integers(0, 2**16),
)
def test_ekf_learns_coulomb_within_5_and_viscous_within_10_percent(coulomb, viscous, J_m, J_l, seed):
    """60 s (1500 samples at dt = 0.04 s) of the two-sine excitation on a random rig
    (Coulomb 3-10 mN m, viscous 3e-5-1e-4 N m s/rad, J_m 1.5e-5-5e-5 and J_L
    5e-5-2e-4 kg m²), tacho noise 10 mV (σ = 0.42 rad/s) through the 12-bit A/D;
    prior 5 mN m ± 5 mN m and 5e-5 ± 5e-5 N m s/rad. After 60 s the Coulomb level
    is within 5 % and the viscous coefficient within 10 % of the truth, and P is
    symmetric positive definite."""
    rig = matched_rig(coulomb, viscous, J_m=J_m, J_l=J_l)
    u, y, _ = record(rig, 60.0, seed=seed)
    ekf = FrictionEKF.from_rig(rig, **PRIOR)
    ekf.batch_filter(u, y)
    assert ekf.params["coulomb"] == pytest.approx(coulomb, rel=0.05)
    assert ekf.params["viscous"] == pytest.approx(viscous, rel=0.10)
    assert np.array_equal(ekf.P, ekf.P.T) and np.linalg.eigvalsh(ekf.P).min() > 0
    assert not ekf.diverged


def test_nis_inside_its_95_percent_band_on_90_percent_of_samples(paper_record):
    """On the correctly modelled rig (60 s, dt = 0.04 s, σ = 0.42 rad/s + A/D) the
    NIS y²/S lies in the two-sided 95 % chi-square(1) band on >= 90 % of samples,
    for the EKF and the UKF, and its mean is near 1."""
    rig, u, y, _ = paper_record
    for cls in (FrictionEKF, FrictionUKF):
        est = cls.from_rig(rig, **PRIOR)
        result = est.batch_filter(u, y)
        nis = result.innovation**2 / result.S
        inside = np.mean((nis >= CHI2_1_LOW) & (nis <= CHI2_1_HIGH))
        assert inside >= 0.90, f"{cls.__name__}: NIS inside the band on {inside:.1%} of samples"
        assert 0.7 < np.mean(nis) < 1.3
        assert est.nis == pytest.approx(nis[-1]) and not est.diverged


def test_ekf_and_ukf_agree(paper_record):
    """The UKF (no Jacobian) and the EKF on one record: the same friction to within
    a third of their standard deviation, predictions within a tenth of the noise."""
    rig, u, y, _ = paper_record
    ekf, ukf = FrictionEKF.from_rig(rig, **PRIOR), FrictionUKF.from_rig(rig, **PRIOR)
    r_ekf, r_ukf = ekf.batch_filter(u, y), ukf.batch_filter(u, y)
    for key in ("coulomb", "viscous"):
        assert abs(ekf.params[key] - ukf.params[key]) < 0.3 * ekf.params[f"{key}_std"]
        assert ekf.params[f"{key}_std"] == pytest.approx(ukf.params[f"{key}_std"], rel=0.1)
    assert ekf.params["coulomb"] == pytest.approx(6e-3, rel=0.05)
    assert ukf.params["viscous"] == pytest.approx(3e-5, rel=0.10)
    settled = slice(250, None)
    gap = np.sqrt(np.mean((r_ekf.y_hat[settled] - r_ukf.y_hat[settled]) ** 2))
    assert gap < 0.1 * math.sqrt(ekf.R_speed)


def test_ekf_equals_filterpy_extended_kalman_filter(paper_record):
    """Our EKF step for step against filterpy's ExtendedKalmanFilter given the same
    model (predict_x = our sub-stepped map, F = our Jacobian), H, Q and R.

    They differ only in how they round the measurement updates (filterpy: NumPy
    matrix products; ours: compiled loops); the time update is the same function.
    Each state is measured on its own scale, so the units (1e-5 N m s/rad to
    1e2 rad/s) cancel: x_i on |x_i| + sqrt(P_ii) (rounding x_i costs eps of its
    size, an update moves it by about a standard deviation), P_ij on
    sqrt(P_ii P_jj). A step's rounding is amplified by up to the condition number of
    the correlation matrix P_ij / sqrt(P_ii P_jj) (up to 4e3 here), and the steps'
    errors add up, at worst linearly over the 400 samples: the tolerance is
    400 eps cond(correlation) on those scales. Measured: 6 % of it for x, 0.2 % for P."""
    rig, u, y, _ = paper_record
    ours = FrictionEKF.from_rig(rig, **PRIOR)
    n = ours.dim_x
    peer = ExtendedKalmanFilter(dim_x=n, dim_z=1)
    peer.x = ours.x.reshape(n, 1).copy()
    peer.P = ours.P.copy()
    peer.Q = ours.Q.copy()
    peer.R = np.array([[ours.R_speed]])
    H = np.zeros((1, n))
    H[0, 1] = 1.0
    state = {"v": 0.0}

    def predict_x(u=0):
        F = np.empty((n, n))
        peer.x = kernels.filter_propagate(peer.x.ravel(), state["v"], ours._c, F, True).reshape(n, 1)
        peer.F = F

    peer.predict_x = predict_x
    for k in range(400):
        ours.predict(u[k])
        ours.update(y[k])
        state["v"] = ours.v
        peer.predict()
        peer.update(np.array([[y[k]]]), lambda x: H, lambda x: x[1:2])
        std = np.sqrt(np.diag(peer.P))
        tol = 400 * EPS * np.linalg.cond(peer.P / np.outer(std, std))
        assert np.all(np.abs(ours.x - peer.x.ravel()) <= tol * (np.abs(peer.x.ravel()) + std)), k
        assert np.all(np.abs(ours.P - peer.P) <= tol * np.outer(std, std)), k
    assert ours.params["coulomb"] > 0 and ours.params["viscous"] > 0  # no projection was needed


@pytest.mark.cpu_sensitive
def test_measured_current_sharpens_the_estimate_and_batch_equals_loop(paper_record):
    """The armature current, where measured, is a second update; batch and loop give
    the same numbers bit for bit (the batch loop runs the same compiled kernels)."""
    rig, u, y, df = paper_record
    current = df["i_a"].to_numpy() + 0.01 * np.random.default_rng(3).standard_normal(len(u))
    current[17] = np.nan
    loop = FrictionEKF.from_rig(rig, R_current=1e-4, **PRIOR)
    with pytest.warns(RuntimeWarning, match="current at sample 17"):
        for k in range(300):
            loop.predict(u[k])
            loop.update(y[k], current=current[k])
    batch = FrictionEKF.from_rig(rig, R_current=1e-4, **PRIOR)
    with pytest.warns(RuntimeWarning, match="current is NaN at 1 sample"):
        batch.batch_filter(u[:300], y[:300], current=current[:300])
    np.testing.assert_array_equal(batch.x, loop.x)
    np.testing.assert_array_equal(batch.P, loop.P)
    without = FrictionEKF.from_rig(rig, **PRIOR)
    without.batch_filter(u[:300], y[:300])
    assert batch.P[0, 0] < without.P[0, 0]  # the motor speed is seen through i_a


# --------------------------------------------------------------------------- bad data
def test_nan_measurement_is_skipped_with_a_warning_naming_the_sample(paper_record):
    rig, u, y, _ = paper_record
    ekf = FrictionEKF.from_rig(rig)
    for k in range(5):
        ekf.predict(u[k])
        ekf.update(y[k])
    ekf.predict(u[5])
    x_prior, P_prior = ekf.x.copy(), ekf.P.copy()
    with pytest.warns(RuntimeWarning, match="z at sample 5 is NaN"):
        ekf.update(float("nan"))
    assert np.array_equal(ekf.x, x_prior) and np.array_equal(ekf.P, P_prior) and ekf.y == 0.0
    assert math.isnan(ekf.nis)

    z = y[:100].copy()
    z[[10, 40]] = np.nan
    for cls in (FrictionEKF, FrictionUKF):
        with pytest.warns(RuntimeWarning, match=r"z is NaN at 2 sample\(s\) \(10, 40\)"):
            result = cls.from_rig(rig).batch_filter(u[:100], z)
        skipped = cls.from_rig(rig).batch_filter(u[:100], [None if np.isnan(v) else v for v in z])
        assert np.isnan(result.innovation[[10, 40]]).all()
        np.testing.assert_array_equal(result.x, skipped.x)


def test_nan_input_raises_with_the_sample_index_and_changes_nothing(paper_record):
    rig, u, y, _ = paper_record
    for cls in (FrictionEKF, FrictionUKF):
        est = cls.from_rig(rig)
        est.batch_filter(u[:20], y[:20])
        x0, P0 = est.x.copy(), est.P.copy()
        with pytest.raises(ValueError, match="u at sample 20"):
            est.predict(float("nan"))
        bad = u[20:40].copy()
        bad[7] = np.nan
        with pytest.raises(ValueError, match=r"u\[7\]"):
            est.batch_filter(bad, y[20:40])
        assert np.array_equal(est.x, x0) and np.array_equal(est.P, P0) and est.sample_index == 20


# --------------------------------------------------------------------------- divergence
@pytest.mark.cpu_sensitive
def test_divergence_raises_naming_the_sample_in_loop_and_batch(paper_record):
    """A filter told the wrong torque constant (K_m 40 % high) cannot follow the data;
    the windowed NIS passes its threshold and FilterDivergenceError names the sample,
    the same one in the sample loop and in batch_filter."""
    rig, u, y, _ = paper_record
    wrong = rig.replace(K_m=rig.K_m * 1.4)
    loop = FrictionEKF.from_rig(wrong, on_divergence="raise")
    with pytest.raises(FilterDivergenceError, match=r"diverged at sample \d+") as caught:
        for k in range(len(u)):
            loop.predict(u[k])
            loop.update(y[k])
    assert caught.value.nis_mean > loop.divergence_nis and loop.diverged
    batch = FrictionEKF.from_rig(wrong, on_divergence="raise")
    with pytest.raises(FilterDivergenceError) as caught_batch:
        batch.batch_filter(u, y)
    assert caught_batch.value.sample == caught.value.sample
    assert batch.sample_index == loop.sample_index
    np.testing.assert_array_equal(batch.x, loop.x)  # the same kernels: the same numbers
    # the right constants on the same data: no alarm
    FrictionEKF.from_rig(rig, on_divergence="raise").batch_filter(u, y)


def test_divergence_warns_once_and_flags_with_on_divergence_warn(paper_record):
    """With on_divergence="warn" the same excursion sets ``diverged`` and warns once."""
    rig, u, y, _ = paper_record
    wrong = rig.replace(K_m=rig.K_m * 1.4)
    for cls in (FrictionEKF, FrictionUKF):
        est = cls.from_rig(wrong, on_divergence="warn")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            est.batch_filter(u[:600], y[:600])
        messages = [str(w.message) for w in caught if "diverged" in str(w.message)]
        assert len(messages) == 1 and est.diverged  # flagged, warned once, kept running
        assert re.search(r"at sample \d+: the mean normalised innovation squared", messages[0])
        assert est.sample_index == 600


def test_covariance_stays_symmetric_positive_definite_and_saver_records(paper_record):
    rig, u, y, _ = paper_record
    for cls in (FrictionEKF, FrictionUKF):
        est = cls.from_rig(rig)
        saver = Saver(est)
        est.batch_filter(u[:200], y[:200], saver=saver)
        saver.to_array()
        assert saver.x.shape == (200, est.dim_x) and saver.nis.shape == (200,)
        assert np.array_equal(est.P, est.P.T) and np.linalg.eigvalsh(est.P).min() > 0
