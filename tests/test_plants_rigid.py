"""The rigid drive: each term against a plain-NumPy reference, the free run against the
steady-state balance and the linear solution, and the model file round trip."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.optimize

from motorid.diagnose import EFFECTS
from motorid.models import load_model
from motorid.plants import RIGID_EFFECTS, RigidDrive
from motorid.plants.fast_integrator import lugre_level, stribeck_decay
from motorid.plants.rigid import input_path, term_columns

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
    assert list(EFFECTS) == list(RIGID_EFFECTS)
    for name, cls in EFFECTS.items():
        assert (*cls.linear, *cls.nonlinear) == RIGID_EFFECTS[name]


@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
def test_friction_terms_match_the_table(shape):
    drive = RigidDrive(FRICTION_EFFECTS, EVERY_TERM, dt=0.01, stribeck_shape=shape)
    w = np.linspace(-20.0, 20.0, 401)
    # the rate form exp(-|w| (1/v_s)) and the table's exp(-|w|/v_s) differ by rounding only
    assert np.allclose(drive.friction(w), reference_friction(EVERY_TERM, w, shape), rtol=1e-13, atol=1e-16)
    cols = term_columns(("stribeck",), w, 3.0, shape)[:, 0]
    ref = np.sign(w) * (np.exp(-np.abs(w) / 3.0) if shape == "exponential" else np.exp(-((w / 3.0) ** 2)))
    assert np.allclose(cols, ref, rtol=1e-13, atol=1e-16)


def test_lugre_level_is_the_gaussian_stribeck_decay():
    for w in (-2.0, -0.3, 0.0, 0.7, 5.0):
        assert lugre_level(1.0, 1.5, 0.5, w) == 1.0 + 0.5 * stribeck_decay(w, 1.0 / 0.5, 1)
        assert lugre_level(1.0, 1.5, 0.5, w) == pytest.approx(
            1.0 + 0.5 * math.exp(-((w / 0.5) ** 2)), rel=1e-15
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


def test_simulate_record_and_model_file_round_trip(tmp_path):
    drive = RigidDrive((*FRICTION_EFFECTS, "input_dead_zone", "backlash"),
                       {**EVERY_TERM, "dead_zone": 0.3, "backlash_time": 0.05}, dt=0.005,
                       stribeck_shape="gaussian")  # fmt: skip
    u = 4.0 * np.sin(np.linspace(0.0, 12.0, 800))
    record = drive.simulate(u)
    assert list(record.columns) == ["t", "u", "y"] and record.attrs["dt"] == 0.005
    assert np.array_equal(record["y"].to_numpy(), drive.free_run(u))
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
