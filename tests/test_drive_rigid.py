"""The rigid drive: each term against a plain-NumPy reference, the free run against the
steady-state balance and the linear solution, and the model file round trip."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.optimize
from conftest import examples
from hypothesis import given
from hypothesis import strategies as st

from motorid.drive import RigidDrive, effects
from motorid.drive.input_path import input_dynamics, input_path
from motorid.drive.kernels import lugre_level, stribeck_decay
from motorid.drive.rigid import term_columns
from motorid.errors import DataError
from motorid.estimators import load_model

EVERY_TERM = {
    "inertia": 2e-3, "input_gain": 0.05, "viscous": 2e-3, "coulomb": 0.02, "stribeck": 0.015,
    "stribeck_velocity": 3.0, "coulomb_asymmetry": 0.004, "viscous_asymmetry": 4e-4,
    "quadratic_drag": 2e-5, "offset": -0.003,
}  # fmt: skip
FRICTION_EFFECTS = ("coulomb_friction", "stribeck_friction", "asymmetric_friction", "viscous_friction",
                    "quadratic_drag", "offset")  # fmt: skip


def reference_friction(p: dict, w: np.ndarray, shape: str) -> np.ndarray:
    """Σ T_e(w) of the module table, written out in plain NumPy (moving drive, s = sgn w)."""
    s = np.sign(w)
    x = w / p["stribeck_velocity"]
    decay = np.exp(-np.abs(x)) if shape == "exponential" else np.exp(-(x**2))
    return (
        p["viscous"] * w + p["coulomb"] * s + p["stribeck"] * decay * s + p["coulomb_asymmetry"] * np.abs(s)
        + p["viscous_asymmetry"] * np.abs(w) + p["quadratic_drag"] * w * np.abs(w) + p["offset"]
    )  # fmt: skip


def test_the_drive_and_the_doctor_name_the_same_effects_and_parameters():
    assert effects.names() == (
        "coulomb_friction", "stribeck_friction", "asymmetric_friction", "viscous_friction", "quadratic_drag",
        "input_dead_zone", "input_saturation", "backlash", "offset", "input_delay", "input_lag", "static_friction",
        "cogging", "position_friction", "lugre_friction",
    )  # fmt: skip
    # LuGre's bristle state is the two-mass rig's alone
    assert [n for n in effects.names() if effects.get(n).not_on_a_rigid_drive] == ["lugre_friction"]
    for name in effects.names():
        cls = effects.get(name)
        assert (*cls.linear, *cls.nonlinear) == tuple(p.name for p in cls.parameters)


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
def test_friction_terms_match_the_table(shape):
    drive = RigidDrive(FRICTION_EFFECTS, EVERY_TERM, dt=0.01, stribeck_shape=shape)
    w = np.linspace(-20.0, 20.0, 401)
    # the rate form exp(-|w| (1/v_s)) and the table's exp(-|w|/v_s) differ by rounding only
    assert np.allclose(drive.friction(w), reference_friction(EVERY_TERM, w, shape), rtol=1e-13, atol=1e-16)
    cols = term_columns(("stribeck",), w, 3.0, shape)[:, 0]
    ref = np.sign(w) * (np.exp(-np.abs(w) / 3.0) if shape == "exponential" else np.exp(-((w / 3.0) ** 2)))
    assert np.allclose(cols, ref, rtol=1e-13, atol=1e-16)


def test_lugre_level_is_the_stribeck_decay_of_its_shape():
    for w in (-2.0, -0.3, 0.0, 0.7, 5.0):
        assert lugre_level(1.0, 0.5, 2.0, 1, w) == 1.0 + 0.5 * stribeck_decay(w, 2.0, 1)
        assert lugre_level(1.0, 0.5, 2.0, 1, w) == pytest.approx(
            1.0 + 0.5 * math.exp(-((w / 0.5) ** 2)), rel=1e-15
        )
        assert lugre_level(1.0, 0.5, 2.0, 0, w) == pytest.approx(
            1.0 + 0.5 * math.exp(-abs(w) / 0.5), rel=1e-15
        )


def test_input_path_is_saturation_then_dead_zone():
    u = np.linspace(-10.0, 10.0, 2001)
    ref = np.clip(u, -6.0, 6.0)
    ref = np.where(np.abs(ref) <= 0.8, 0.0, ref - 0.8 * np.sign(ref))
    assert np.array_equal(input_path(u, dead_zone=0.8, saturation=6.0), ref)  # the same operations
    drive = RigidDrive(("input_dead_zone", "input_saturation"),
                       {"inertia": 1.0, "input_gain": 0.5, "dead_zone": 0.8, "saturation": 6.0}, dt=0.01)  # fmt: skip
    assert np.array_equal(drive.input_force(u), 0.5 * ref)


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
@pytest.mark.parametrize("u", [3.0, -2.0, 0.8])
def test_free_run_settles_at_the_steady_state_balance(shape, u):
    drive = RigidDrive(FRICTION_EFFECTS, EVERY_TERM, dt=0.01, stribeck_shape=shape)
    force = EVERY_TERM["input_gain"] * u
    w_end = drive.free_run(np.full(3000, u))[-1]
    s = math.copysign(1.0, force - EVERY_TERM["offset"])
    w_ss = scipy.optimize.brentq(
        lambda w: force - float(reference_friction(EVERY_TERM, np.array([w]), shape)[0]), s * 1e-12, s * 1e3
    )
    # 30 s is over 30 mechanical time constants J/(B + 2 c |w|): the transient is gone to far below 1e-9
    assert w_end == pytest.approx(w_ss, rel=1e-9)


def test_free_run_stays_at_rest_below_breakaway_and_follows_the_linear_solution():
    dt = 0.001
    drive = RigidDrive(("viscous_friction",), {"inertia": 0.5, "input_gain": 2.0, "viscous": 1.0}, dt)
    t = (np.arange(3000) + 1) * dt
    # semi-implicit Euler at h = 1e-4 s on a 0.5 s time constant: error about h/(2τ) of the step
    assert np.allclose(drive.free_run(np.ones(3000), substeps=10), 2.0 * (1 - np.exp(-t / 0.5)), atol=2e-3)
    params = {**EVERY_TERM, "offset": 0.0}
    held = RigidDrive(FRICTION_EFFECTS, params, dt)
    breakaway = params["coulomb"] + params["stribeck"] + params["coulomb_asymmetry"]
    below = 0.99 * breakaway / params["input_gain"]
    assert np.all(held.free_run(np.full(200, below)) == 0.0)
    assert np.all(held.free_run(np.full(200, 1.02 * breakaway / params["input_gain"]))[5:] > 0.0)
    backwards = params["coulomb"] + params["stribeck"] - params["coulomb_asymmetry"]
    assert np.all(held.free_run(np.full(200, -0.99 * backwards / params["input_gain"])) == 0.0)
    assert np.all(held.free_run(np.full(200, -1.02 * backwards / params["input_gain"]))[5:] < 0.0)


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
def test_position_is_the_trapezoidal_integral_of_the_free_run_speed(shape):
    """One internal step per sample: the compiled position is q0 plus the trapezoidal sum of the
    speeds at the sample ends, computed here by SciPy. Both add the same N terms, in other
    orders: rounding bounds the difference by N eps max|q| (N = 2000, |q| < 1: about 4e-13)."""
    import scipy.integrate

    drive = RigidDrive((*FRICTION_EFFECTS, "static_friction"), {**EVERY_TERM, "breakaway_excess": 0.005},
                       dt=0.01, stribeck_shape=shape)  # fmt: skip
    u = np.repeat(np.random.default_rng(3).normal(0.0, 1.5, 200), 10)  # rests, breakaways and reversals
    w0, q0 = 0.4, -0.25
    speed, position = drive.motion(u, w0=w0, q0=q0, substeps=1)
    assert np.array_equal(speed, drive.free_run(u, w0=w0, substeps=1))  # the speed, to the last bit
    assert np.any(speed == 0.0) and np.any(speed > 0.0) and np.any(speed < 0.0)
    reference = q0 + scipy.integrate.cumulative_trapezoid(np.r_[w0, speed], dx=drive.dt)
    bound = u.size * np.finfo(float).eps * max(1.0, np.max(np.abs(reference)))
    np.testing.assert_allclose(position, reference, rtol=0.0, atol=bound)
    stuck = np.flatnonzero((speed[1:] == 0.0) & (speed[:-1] == 0.0)) + 1
    assert stuck.size and np.all(position[stuck] == position[stuck - 1])  # a drive at rest stays put


def test_position_with_substeps_follows_the_linear_solution():
    """J dw/dt = g u - B w from rest: w = F/B (1 - e^(-t/τ)), q = F/B (t - τ (1 - e^(-t/τ))), τ = J/B.
    With h = 1e-4 s the implicit Euler speed lags the exact one by about (h/2) dw/dt; integrated,
    the position lags by about (h/2) (w(T) - w(0)) = 1e-4 m: twice that bounds it."""
    dt = 0.001
    drive = RigidDrive(("viscous_friction",), {"inertia": 0.5, "input_gain": 2.0, "viscous": 1.0}, dt)
    t = (np.arange(3000) + 1) * dt
    _, position = drive.motion(np.ones(3000), q0=1.0, substeps=10)
    exact = 1.0 + 2.0 * (t - 0.5 * (1.0 - np.exp(-t / 0.5)))
    assert np.allclose(position, exact, rtol=0.0, atol=2e-4)
    assert np.max(np.abs(position - exact)) > 0.0  # a real integration, not the formula


def test_simulate_record_and_model_file_round_trip(tmp_path):
    drive = RigidDrive((*FRICTION_EFFECTS, "input_dead_zone", "backlash"),
                       {**EVERY_TERM, "dead_zone": 0.3, "backlash_time": 0.05}, dt=0.005,
                       stribeck_shape="gaussian")  # fmt: skip
    u = 4.0 * np.sin(np.linspace(0.0, 12.0, 800))
    record = drive.simulate(u)
    assert list(record.columns) == ["t", "u", "y", "position"] and record.attrs["dt"] == 0.005
    assert np.array_equal(record["y"].to_numpy(), drive.free_run(u))
    assert np.array_equal(record["position"].to_numpy(), drive.motion(u)[1])
    assert record.attrs["units"]["position"] == "rad"
    drive.save(tmp_path / "drive.json")
    again = load_model(tmp_path / "drive.json")
    assert again == drive
    assert np.array_equal(again.simulate(u)["y"].to_numpy(), record["y"].to_numpy())


@pytest.mark.parametrize(
    "change, message",
    [
        ({"effects": ("stiction",)}, "unknown effect 'stiction'"),
        ({"params": {"inertia": 1.0}}, "'input_gain' is missing"),
        ({"params": {**EVERY_TERM, "dead_zone": 0.1}}, "'dead_zone' belongs to no effect"),
        ({"params": {**EVERY_TERM, "coulomb": math.nan}}, "coulomb must be finite"),
        ({"dt": 0.0}, "dt must be a finite number > 0"),
        ({"stribeck_shape": "cubic"}, "stribeck_shape must be one of exponential, gaussian"),
    ],
)
def test_bad_drive_descriptions_are_refused_naming_the_field(change, message):
    fields = {"effects": FRICTION_EFFECTS, "params": EVERY_TERM, "dt": 0.01, **change}
    with pytest.raises(ValueError, match=message):
        RigidDrive(**fields)


def test_a_non_physical_fit_is_kept_but_not_saved(tmp_path):
    fitted = RigidDrive(("coulomb_friction",), {"inertia": 1.0, "input_gain": 1.0, "coulomb": -0.1}, 0.01)
    assert np.all(np.isfinite(fitted.free_run(np.ones(10))))
    with pytest.raises(ValueError, match=r"coulomb must be >= 0, got -0\.1"):
        fitted.save(tmp_path / "m.json")
    assert not (tmp_path / "m.json").exists()
    assert np.all(np.isnan(fitted.with_params(inertia=-1.0).free_run(np.ones(10))))


def held_mean_reference(x: np.ndarray, dt: float, delay: float = 0.0, lag: float = 0.0) -> np.ndarray:
    """Mean over each sample of the held ``x`` delayed by ``delay`` and lagged by ``lag`` [s], by brute
    force: 2000 sub-steps per sample, the lag stepped exactly (a held sub-step), the mean by the
    trapezoid rule (x[0] before the record, z at rest on it)."""
    sub = 2000
    h = dt / sub
    t = (np.arange(x.size * sub + 1)) * h - delay
    held = x[np.clip(np.floor(t / dt + 1e-9).astype(int), 0, x.size - 1)]
    z = np.empty_like(held)
    z[0] = x[0]
    a = math.exp(-h / lag) if lag > 0 else 0.0
    for j in range(1, held.size):
        z[j] = held[j - 1] + (z[j - 1] - held[j - 1]) * a
    trap = 0.5 * (z[:-1] + z[1:])
    return trap.reshape(x.size, sub).mean(axis=1)


@pytest.mark.parametrize(
    ("delay", "lag"), [(0.02, 0.0), (0.0137, 0.0), (0.0, 0.025), (0.0049, 0.041), (0.015, 0.01)]
)
def test_input_delay_and_lag_are_the_held_signal_delayed_and_lagged_on_average(delay, lag):
    rng = np.random.default_rng(5)
    x = np.repeat(rng.uniform(-1.0, 1.0, 30), 7)
    effects, params = ["viscous_friction"], {"inertia": 1e-3, "input_gain": 1.0, "viscous": 1e-3}
    if delay:
        effects.append("input_delay")
        params["input_delay"] = delay
    if lag:
        effects.append("input_lag")
        params["lag_time_constant"] = lag
    drive = RigidDrive(tuple(effects), params, dt=0.01)
    # the reference's sub-step edges (2000 per sample) and trapezoid rule leave errors of ~1e-4 of a
    # unit step at a held-input change; the compiled form is exact for the held input
    assert np.allclose(drive.input_force(x), held_mean_reference(x, 0.01, delay, lag), atol=2e-3)


def test_a_whole_sample_delay_shifts_the_free_run():
    u = np.concatenate([np.zeros(5), np.repeat([2.0, -1.5, 0.5, 3.0], 40)])
    base = RigidDrive(("viscous_friction", "coulomb_friction"), {**EVERY_TERM_SMALL}, dt=0.01)
    delayed = base.with_effects((*base.effects, "input_delay"), {**base.params, "input_delay": 0.03})
    # a delay of exactly 3 samples on an input at rest before it: the same free run, 3 samples later
    assert np.array_equal(delayed.free_run(u)[3:], base.free_run(u)[:-3])
    assert np.array_equal(input_dynamics(u, 0.01, 0.03)[3:], u[:-3])


EVERY_TERM_SMALL = {"inertia": 2e-3, "input_gain": 0.05, "viscous": 2e-3, "coulomb": 0.02}


def test_static_friction_breaks_away_high_and_keeps_moving_down_to_the_kinetic_level():
    p = {**EVERY_TERM_SMALL, "breakaway_excess": 0.015}
    drive = RigidDrive(("viscous_friction", "coulomb_friction", "static_friction"), p, dt=0.01)
    g, fc, fs = p["input_gain"], p["coulomb"], p["breakaway_excess"]
    up = np.linspace(0.0, 1.5 * (fc + fs) / g, 400)
    w_up = drive.free_run(up)
    # at rest until the force passes the breakaway level F_c + ΔF_s, moving from the next sample on
    first = int(np.flatnonzero(w_up > 0.0)[0])
    assert g * up[first - 1] <= fc + fs < g * up[first]
    assert np.all(w_up[:first] == 0.0)
    # the same ramp without static friction breaks away at F_c already
    kinetic = RigidDrive(("viscous_friction", "coulomb_friction"), EVERY_TERM_SMALL, dt=0.01).free_run(up)
    assert (
        g * up[int(np.flatnonzero(kinetic > 0.0)[0]) - 1]
        <= fc
        < g * up[int(np.flatnonzero(kinetic > 0.0)[0])]
    )
    # hysteresis: held at a force between F_c and the breakaway level, a moving drive keeps moving
    # (to (F - F_c)/B), a resting one stays
    hold = np.full(600, (fc + 0.5 * fs) / g)
    steady = (g * hold[0] - fc) / p["viscous"]
    # 600 samples are 3 time constants J/B = 1 s: within 5 % of the steady speed from either side
    assert drive.free_run(hold, w0=2.0 * steady)[-1] == pytest.approx(steady, rel=0.05)
    assert np.all(drive.free_run(hold, w0=0.0) == 0.0)


def test_new_effects_round_trip_through_a_model_file_and_bad_values_are_named(tmp_path):
    p = {**EVERY_TERM_SMALL, "input_delay": 0.013, "lag_time_constant": 0.02, "breakaway_excess": 0.01}
    drive = RigidDrive(
        ("viscous_friction", "coulomb_friction", "input_delay", "input_lag", "static_friction"), p, dt=0.01
    )
    drive.save(tmp_path / "d.json")
    again = load_model(tmp_path / "d.json")
    assert again == drive
    u = np.repeat([1.0, -0.8, 0.6], 50)
    assert np.array_equal(again.free_run(u), drive.free_run(u))
    text = (tmp_path / "d.json").read_text()
    for key in ("input_delay", "lag_time_constant", "breakaway_excess"):
        with pytest.raises(ValueError, match=f"{key} must be >= 0"):
            drive.with_params(**{key: -0.001}).check_physical()
        data = json.loads(text)
        data["model"]["params"][key] = -0.001
        (tmp_path / "bad.json").write_text(json.dumps(data))
        with pytest.raises(DataError, match=rf"bad.json: model.params.{key}: {key} must be >= 0"):
            load_model(tmp_path / "bad.json")


# -- the running simulation: a record a sample at a time -------------------------------------------
#: Ranges of each parameter for the drives drawn below (physical, the sizes of small drives).
PARAMETER_RANGES = {
    "inertia": (1e-4, 5e-2), "input_gain": (0.01, 1.0), "viscous": (0.0, 0.05), "coulomb": (0.0, 0.1),
    "stribeck": (0.0, 0.1), "stribeck_velocity": (0.05, 10.0), "coulomb_asymmetry": (-0.02, 0.02),
    "viscous_asymmetry": (-5e-3, 5e-3), "quadratic_drag": (0.0, 1e-3), "offset": (-0.02, 0.02),
    "dead_zone": (0.0, 1.0), "saturation": (0.5, 12.0), "backlash_time": (0.0, 0.1),
    "input_delay": (0.0, 0.1), "lag_time_constant": (0.0, 0.1), "breakaway_excess": (0.0, 0.05),
    "cogging_sin": (-0.02, 0.02), "cogging_cos": (-0.02, 0.02), "cogging_periods": (0.5, 50.0),
    **{f"position_friction_{k}": (-0.01, 0.01) for k in ("sin", "cos", "sin2", "cos2", "sin3", "cos3")},
    "position_friction_periods": (0.1, 5.0),
}  # fmt: skip


@st.composite
def drives(draw) -> RigidDrive:
    """A rigid drive with a random set of effects, parameters, sample time and Stribeck shape."""
    rigid = [n for n in effects.names() if not effects.get(n).not_on_a_rigid_drive]
    chosen = draw(st.lists(st.sampled_from(rigid), unique=True))
    if "cogging" in chosen and "position_friction" in chosen:  # one torque that depends on the position
        chosen.remove(draw(st.sampled_from(["cogging", "position_friction"])))
    names = effects.parameter_names(chosen)
    params = {n: draw(st.floats(*PARAMETER_RANGES[n])) for n in names}
    dt = draw(st.sampled_from([0.001, 0.005, 0.01, 0.02]))
    shape = draw(st.sampled_from(["exponential", "gaussian"]))
    return RigidDrive(tuple(chosen), params, dt=dt, stribeck_shape=shape)


@st.composite
def held_inputs(draw) -> np.ndarray:
    """An input [u] held in levels of 1 to 30 samples, zeros and reversals included."""
    levels = draw(st.lists(st.one_of(st.just(0.0), st.floats(-15.0, 15.0)), min_size=1, max_size=25))
    lengths = draw(st.lists(st.integers(1, 30), min_size=len(levels), max_size=len(levels)))
    return np.repeat(levels, lengths)


@pytest.mark.cpu_sensitive
@examples(200)
@given(drive=drives(), u=held_inputs())
def test_the_running_simulation_is_the_record_to_the_last_bit(drive, u):
    record = drive.simulate(u)["y"].to_numpy()
    simulation = drive.simulation(seed=3)
    for _ in range(2):  # and reset gives the same again
        steps = np.array([simulation.step(v) for v in u])
        np.testing.assert_array_equal(steps, record)  # the same functions on the same state: exact
        assert simulation.sample_index == u.size and simulation.state["omega"] == record[-1]
        simulation.reset(seed=4)  # noise free: the seed changes nothing


@pytest.mark.cpu_sensitive
@examples(100)
@given(drive=drives(), u=held_inputs(), cut=st.integers(0, 60))
def test_the_running_simulation_in_blocks_is_the_record_to_the_last_bit(drive, u, cut):
    """run() on two blocks (split at ``cut``, which may leave one empty), with the input path's
    delay, lag and backlash carried between them: the record's free run, exactly."""
    record = drive.free_run(u)
    simulation = drive.simulation()
    cut = min(cut, u.size)
    np.testing.assert_array_equal(np.concatenate([simulation.run(u[:cut]), simulation.run(u[cut:])]), record)
    assert simulation.sample_index == u.size


def test_the_running_simulation_refuses_a_non_finite_input_naming_the_sample():
    simulation = RigidDrive(("viscous_friction", "coulomb_friction"), EVERY_TERM_SMALL, dt=0.01).simulation()
    simulation.step(1.0)
    with pytest.raises(ValueError, match=r"u must be finite, got nan at sample 1"):
        simulation.step(math.nan)


def numpy_backlash_dwell(force: np.ndarray, dt: float, backlash_time: float) -> np.ndarray:
    """The dwell written out in NumPy: the force is 0 for ``backlash_time`` after each change of its
    sign (zeros keep the last sign), untouched before the first change."""
    s = np.sign(force)
    last_sign = s[np.maximum.accumulate(np.where(s != 0, np.arange(s.size), 0))]
    change = np.r_[False, (last_sign[1:] != last_sign[:-1]) & (last_sign[:-1] != 0)]
    since = (np.arange(s.size) - np.maximum.accumulate(np.where(change, np.arange(s.size), 0))) * dt
    since[: np.flatnonzero(change)[0] if change.any() else s.size] = math.inf
    return force * (since >= backlash_time)


@given(u=held_inputs(), backlash_time=st.floats(0.0, 0.2))
def test_the_compiled_backlash_dwell_is_the_numpy_reference(u, backlash_time):
    drive = RigidDrive(
        ("backlash",), {"inertia": 1.0, "input_gain": 0.5, "backlash_time": backlash_time}, 0.01
    )
    np.testing.assert_array_equal(drive.input_force(u), numpy_backlash_dwell(0.5 * u, 0.01, backlash_time))
