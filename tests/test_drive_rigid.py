"""The rigid drive: each term against a plain-NumPy reference, the free run against the
steady-state balance, the linear solution, a reversal in closed form and an event-driven
``solve_ivp`` reference, and the model file round trip."""

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
    # exponential Euler is exact for a held force on a linear drive: what is left is rounding,
    # a few eps of the speed (2 rad/s) per step accumulated over 30,000 steps: below 1e-11
    exact = 2.0 * (1 - np.exp(-t / 0.5))
    assert np.allclose(drive.free_run(np.ones(3000), substeps=10), exact, rtol=0.0, atol=1e-11)
    params = {**EVERY_TERM, "offset": 0.0}
    held = RigidDrive(FRICTION_EFFECTS, params, dt)
    breakaway = params["coulomb"] + params["stribeck"] + params["coulomb_asymmetry"]
    below = 0.99 * breakaway / params["input_gain"]
    assert np.all(held.free_run(np.full(200, below)) == 0.0)
    assert np.all(held.free_run(np.full(200, 1.02 * breakaway / params["input_gain"]))[5:] > 0.0)
    backwards = params["coulomb"] + params["stribeck"] - params["coulomb_asymmetry"]
    assert np.all(held.free_run(np.full(200, -0.99 * backwards / params["input_gain"])) == 0.0)
    assert np.all(held.free_run(np.full(200, -1.02 * backwards / params["input_gain"]))[5:] < 0.0)


def test_position_with_substeps_follows_the_linear_solution():
    """J dw/dt = g u - B w from rest: w = F/B (1 - e^(-t/τ)), q = F/B (t - τ (1 - e^(-t/τ))), τ = J/B.
    Each internal step adds the speed's exact integral, so the position is exact for the held
    force; rounding over 30,000 steps of a position up to 7 m bounds the difference by 1e-10."""
    dt = 0.001
    drive = RigidDrive(("viscous_friction",), {"inertia": 0.5, "input_gain": 2.0, "viscous": 1.0}, dt)
    t = (np.arange(3000) + 1) * dt
    _, position = drive.motion(np.ones(3000), q0=1.0, substeps=10)
    exact = 1.0 + 2.0 * (t - 0.5 * (1.0 - np.exp(-t / 0.5)))
    assert np.allclose(position, exact, rtol=0.0, atol=1e-10)


# ------------------------------------------------------------------ a reversal, in closed form
# J dw/dt = F - F_c s - B w with the force F held: while moving in direction s the speed relaxes
# to w_s = (F - F_c s)/B with the time constant τ = J/B,
#     w(t) = w_s + (w0 - w_s) e^(-t/τ),
# reaching 0 at t0 = τ ln(1 - w0/w_s); from there, if |F| > F_c, it goes on the other way,
#     w(t) = w_-s (1 - e^(-(t - t0)/τ)),
# and otherwise it stays at rest. Without viscous friction (B -> 0) the same courses are straight
# lines: w(t) = w0 + (F - F_c s) t / J, t0 = J w0 / (F_c s - F).
REVERSAL = {"inertia": 0.01, "input_gain": 1.0, "viscous": 0.02, "coulomb": 0.05}


def reversal_course(t: np.ndarray, w0: float, force: float, p: dict) -> tuple[float, np.ndarray, np.ndarray]:
    """``(t0, w, q)``: the time [s] the speed reaches zero, the speed and the position (from 0) at
    times ``t`` of a Coulomb drive from ``w0`` > 0 under the held ``force``, in closed form."""
    J, B, fc = p["inertia"], p.get("viscous", 0.0), p["coulomb"]
    moving = abs(force) > fc
    if B == 0.0:
        t0 = J * w0 / (fc - force)
        w_before = w0 + (force - fc) * t / J
        q_before = w0 * t + 0.5 * (force - fc) * t**2 / J
        q0 = w0 * t0 + 0.5 * (force - fc) * t0**2 / J
        after = np.maximum(t - t0, 0.0)
        w_after = (force + fc) * after / J if moving else 0.0 * after
        q_after = q0 + (0.5 * (force + fc) * after**2 / J if moving else 0.0)
    else:
        tau = J / B
        ws = (force - fc) / B
        t0 = tau * math.log(1.0 - w0 / ws)
        w_before = ws + (w0 - ws) * np.exp(-t / tau)
        q_before = ws * t + (w0 - ws) * tau * (1.0 - np.exp(-t / tau))
        q0 = ws * t0 + (w0 - ws) * tau * (1.0 - math.exp(-t0 / tau))
        after = np.maximum(t - t0, 0.0)
        wo = (force + fc) / B if moving else 0.0
        w_after = wo * (1.0 - np.exp(-after / tau))
        q_after = q0 + wo * (after - tau * (1.0 - np.exp(-after / tau)))
    before = t < t0
    return t0, np.where(before, w_before, w_after), np.where(before, q_before, q_after)


@pytest.mark.parametrize("viscous", [0.02, 0.0], ids=["viscous", "coulomb alone"])
@pytest.mark.parametrize("force", [-0.2, -0.03], ids=["reverses", "sticks"])
@pytest.mark.parametrize("substeps", [1, 7])
def test_a_reversal_inside_a_step_is_the_closed_form_solution(viscous, force, substeps):
    """The drive decelerates through zero inside a sample: its speed and position at every sample
    end are the closed form's, so the zero is reached at the closed form's time and the drive goes
    on (or sticks) from there. Each piece is integrated exactly; what is left is rounding, a few
    eps of a speed of order 10 rad/s and a position of order 1 rad per step: 1e-12."""
    p = {**REVERSAL, "viscous": viscous}
    effects_ = ("viscous_friction", "coulomb_friction") if viscous else ("coulomb_friction",)
    drive = RigidDrive(effects_, {k: v for k, v in p.items() if viscous or k != "viscous"}, dt=0.01)
    w0 = 3.1  # the zero falls 0.4 of a sample into sample 12 without viscous friction
    t = (np.arange(60) + 1) * drive.dt
    t0, w_exact, q_exact = reversal_course(t, w0, force, p)
    assert t[0] < t0 < t[-1] and 0.05 < t0 / drive.dt % 1.0 < 0.95  # the zero falls inside a sample
    speed, position = drive.motion(np.full(t.size, force), w0=w0, substeps=substeps)
    np.testing.assert_allclose(speed, w_exact, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(position, q_exact, rtol=0.0, atol=1e-12)
    after = t > t0
    first = int(np.flatnonzero(after)[0])
    if abs(force) > p["coulomb"]:
        assert np.all(speed[after] < 0.0)
        # the time of the zero read back from the first sample after it
        if viscous:
            tau, wo = p["inertia"] / viscous, (force + p["coulomb"]) / viscous
            t0_seen = t[first] + tau * math.log(1.0 - speed[first] / wo)
        else:
            t0_seen = t[first] - p["inertia"] * speed[first] / (force + p["coulomb"])
        assert t0_seen == pytest.approx(t0, abs=1e-11)
    else:
        assert np.all(speed[after] == 0.0)  # stuck at exactly 0 from the zero on
        assert np.all(position[after] == position[first])


def test_a_static_drive_breaks_away_at_the_zero_only_beyond_its_breakaway_level():
    """With static friction ΔF_s the drive decelerating through zero sticks unless the held force
    exceeds F_c + ΔF_s the other way: between F_c and F_c + ΔF_s it stops at t0 and stays."""
    p = {**REVERSAL, "breakaway_excess": 0.03}
    drive = RigidDrive(("viscous_friction", "coulomb_friction", "static_friction"), p, dt=0.01)
    t = (np.arange(60) + 1) * drive.dt
    between = -(p["coulomb"] + 0.5 * p["breakaway_excess"])
    t0, _, _ = reversal_course(t, 3.0, between, REVERSAL)
    speed = drive.free_run(np.full(t.size, between), w0=3.0, substeps=1)
    assert np.all(speed[t > t0] == 0.0) and np.all(speed[t < t0] > 0.0)
    beyond = -(p["coulomb"] + 1.5 * p["breakaway_excess"])
    _, w_exact, _ = reversal_course(t, 3.0, beyond, REVERSAL)
    np.testing.assert_allclose(drive.free_run(np.full(t.size, beyond), w0=3.0, substeps=1), w_exact,
                               rtol=0.0, atol=1e-12)  # fmt: skip


@pytest.mark.parametrize("z", [0.0, 1e-9, -1e-6, 3e-3, -0.2, 0.4999, -0.5, 0.5, 2.0, -7.0, -40.0])
def test_the_step_functions_are_their_closed_forms_to_rounding(z):
    """φ1(z) = (e^z - 1)/z and φ2(z) = (e^z - 1 - z)/z² (series below |z| = 1/2) and log(1 + x)/x
    against the same quantities in 40-digit decimal arithmetic: within 4 eps (the closed form's
    cancellation costs at most a factor 4 at |z| = 1/2)."""
    import decimal

    from motorid.drive.kernels import log1p_ratio, relative_area, relative_growth

    with decimal.localcontext() as ctx:
        ctx.prec = 40
        d = decimal.Decimal(z)
        if z == 0.0:
            phi1, phi2, ratio = 1.0, 0.5, 1.0
        else:
            phi1 = float((d.exp() - 1) / d)
            phi2 = float((d.exp() - 1 - d) / (d * d))
            ratio = float((1 + d).ln() / d) if z > -1.0 else None
    eps = np.finfo(float).eps
    assert relative_growth(z) == pytest.approx(phi1, rel=4 * eps, abs=0.0)
    assert relative_area(z) == pytest.approx(phi2, rel=4 * eps, abs=0.0)
    if ratio is not None:
        assert log1p_ratio(z) == pytest.approx(ratio, rel=4 * eps, abs=0.0)


def reference_motion(
    p: dict, u: np.ndarray, dt: float, w0: float, q0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Speed and position of a rigid drive with every friction term of the module table and static
    friction, by ``scipy.integrate.solve_ivp`` (tight tolerances) in plain Python: each zero of the
    speed an event, where Karnopp's rule decides (stick while the force lies within the breakaway
    band, else slip towards it)."""
    import scipy.integrate

    excess = p.get("breakaway_excess", 0.0)
    up = p["coulomb"] + p["stribeck"] + p["coulomb_asymmetry"] + excess  # breakaway forwards
    down = p["coulomb"] + p["stribeck"] - p["coulomb_asymmetry"] + excess  # and backwards (offset aside)

    def friction(w: float, s: float) -> float:
        decay = math.exp(-abs(w) / p["stribeck_velocity"])
        return (p["viscous"] * w + (p["coulomb"] + p["stribeck"] * decay) * s + p["coulomb_asymmetry"]
                + p["viscous_asymmetry"] * s * w + p["quadratic_drag"] * w * abs(w) + p["offset"])  # fmt: skip

    w, q, s = w0, q0, 0.0
    speed, position = np.empty(u.size), np.empty(u.size)
    for k, f in enumerate(u * p["input_gain"]):
        t, t_end = k * dt, (k + 1) * dt
        while t < t_end:
            if w == 0.0:
                net = f - p["offset"]
                if -down <= net <= up:
                    break  # stuck for the rest of the held sample
                s = 1.0 if net > 0.0 else -1.0
            else:
                s = 1.0 if w > 0.0 else -1.0

            def stop(_t, x, s=s):
                return s * x[0]

            stop.terminal, stop.direction = True, -1.0
            sol = scipy.integrate.solve_ivp(
                lambda _t, x, s=s, f=f: [(f - friction(x[0], s)) / p["inertia"], x[0]],
                (t, t_end), [w, q], events=stop, rtol=1e-12, atol=1e-14, method="DOP853",
            )  # fmt: skip
            w, q, t = float(sol.y[0, -1]), float(sol.y[1, -1]), float(sol.t[-1])
            if sol.status == 1:
                w = 0.0
        speed[k], position[k] = w, q
    return speed, position


def test_the_free_run_converges_to_an_event_driven_reference_through_reversals_and_rests():
    """Held random levels (rests, breakaways, reversals inside samples) on a drive with every
    friction term and static friction, against :func:`reference_motion`. Holding the Stribeck
    decay and the quadratic drag's |w| over a step errs by O(h): measured 0.14 % of the largest
    speed at 5 steps per sample and 0.014 % at 50; asserted: at least fivefold less for ten times
    the steps, and below 0.05 % at 50. With the Stribeck and quadratic terms off the levels are
    constant and the free run is the reference to its tolerance (measured 5e-15 of the largest
    speed, 2e-14 rad; asserted 1e-8, the reference's rtol 1e-12 summed over its steps)."""
    p = {**EVERY_TERM, "breakaway_excess": 0.005}
    effects_ = (*FRICTION_EFFECTS, "static_friction")
    u = np.repeat(np.random.default_rng(5).normal(0.0, 1.2, 30), 8)
    drive = RigidDrive(effects_, p, dt=0.01)
    w_ref, q_ref = reference_motion(p, u, drive.dt, 0.3, -0.2)
    assert np.any(w_ref == 0.0) and np.any(w_ref > 0.0) and np.any(w_ref < 0.0)
    peak = np.max(np.abs(w_ref))
    errors = [np.max(np.abs(drive.free_run(u, w0=0.3, substeps=n) - w_ref)) for n in (5, 50)]
    assert errors[1] < errors[0] / 5.0 and errors[1] < 5e-4 * peak
    constant = {**p, "stribeck": 0.0, "quadratic_drag": 0.0}
    w_ref, q_ref = reference_motion(constant, u, drive.dt, 0.3, -0.2)
    speed, position = RigidDrive(effects_, constant, dt=0.01).motion(u, w0=0.3, q0=-0.2, substeps=1)
    np.testing.assert_allclose(speed, w_ref, rtol=0.0, atol=1e-8 * peak)
    np.testing.assert_allclose(position, q_ref, rtol=0.0, atol=1e-8 * max(1.0, np.max(np.abs(q_ref))))


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
