"""The effect registry: each built-in effect spelled once, an effect registered at run time and
one from a plugin's entry point taken by the rigid drive, its model files, the doctor and the
friction filters as a built-in one is."""

from __future__ import annotations

import importlib
import json
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid import load_model
from motorid.cli.doctor import effect_list
from motorid.drive import RigidDrive, effects, kernels
from motorid.drive.effects import Effect, Parameter
from motorid.estimators.friction_kf import check_rigid_drive, filter_effects
from motorid.fleet import DoctorJob
from motorid.io.records import write_record


class ConstantTorque(Effect):
    """A user's constant torque ``T = T_c`` [F]: the compiled constant term, as ``offset`` is."""

    name = "constant_torque"
    parameters = (Parameter("constant_torque", "F", "any", term=kernels.TERM_OFFSET),)
    signature = "constant, the same sign in both directions of motion and at rest"


@pytest.fixture
def constant_torque():
    effects.register(ConstantTorque)
    try:
        yield ConstantTorque
    finally:
        effects.unregister("constant_torque")


def slow_sine_record(drive: RigidDrive, seed: int = 0) -> pd.DataFrame:
    """30 s of two slow sines (0.5 and 1.35 Hz) through ``drive``, speed noise 1 % of the largest speed."""
    t = np.arange(3000) * drive.dt
    u = 6.0 * np.sin(2 * np.pi * 0.5 * t) + 1.5 * np.sin(2 * np.pi * 1.35 * t + 1.0)
    w = drive.free_run(u, substeps=20)
    y = w + 0.01 * np.max(np.abs(w)) * np.random.default_rng(seed).standard_normal(u.size)
    record = pd.DataFrame({"t": t, "u": u, "y": y})
    record.attrs.update(dt=drive.dt, units={"t": "s", "u": "V", "y": "rad/s"})
    return record


BASE = {"inertia": 1e-3, "input_gain": 1.0, "viscous": 0.05, "coulomb": 0.5}


def test_each_parameter_is_spelled_once_with_its_unit_sign_and_term():
    seen: dict[str, str] = {p.name: "drive" for p in effects.DRIVE_PARAMETERS}
    for name in effects.names():
        effect = effects.get(name)
        for p in effect.parameters:
            assert p.name not in seen, f"{p.name} of {name} is also {seen[p.name]}'s"
            seen[p.name] = name
            assert effects.parameter(p.name) is p
            assert (p.term is not None or p.in_position) == (p.name in effect.linear)
            assert not p.in_position or effect.position  # a position amplitude only in a position effect
    # the physical signs a model file checks, and the compiled terms of the balance
    assert {n for n in seen if effects.parameter(n).sign == "> 0"} == {
        "inertia", "input_gain", "stribeck_velocity", "saturation", "cogging_periods",
        "position_friction_periods", "bristle_stiffness",
    }  # fmt: skip
    assert {n for n in seen if effects.parameter(n).sign == "any"} == {
        "coulomb_asymmetry", "viscous_asymmetry", "offset", "cogging_sin", "cogging_cos",
        *(f"position_friction_{k}" for k in ("sin", "cos", "sin2", "cos2", "sin3", "cos3")),
    }  # fmt: skip
    terms = {n: effects.parameter(n).term for n in seen if effects.parameter(n).term is not None}
    assert terms == {
        "viscous": kernels.TERM_VISCOUS, "viscous_asymmetry": kernels.TERM_VISCOUS_ASYMMETRY,
        "quadratic_drag": kernels.TERM_QUADRATIC_DRAG, "coulomb": kernels.TERM_COULOMB,
        "stribeck": kernels.TERM_STRIBECK, "coulomb_asymmetry": kernels.TERM_COULOMB_ASYMMETRY,
        "offset": kernels.TERM_OFFSET,
    }  # fmt: skip
    assert filter_effects() == (
        "coulomb_friction", "stribeck_friction", "asymmetric_friction", "viscous_friction",
        "input_dead_zone", "input_saturation", "offset", "input_delay", "input_lag", "static_friction",
        "cogging", "position_friction",
    )  # fmt: skip


def test_an_effect_registered_at_run_time_is_a_drive_effect(constant_torque, tmp_path):
    assert effects.names()[-1] == "constant_torque"
    drive = RigidDrive(
        ("viscous_friction", "coulomb_friction", "constant_torque"), {**BASE, "constant_torque": 0.3}, 0.01
    )
    # the same compiled term as the built-in offset: the same free run to the last bit
    same = RigidDrive(("viscous_friction", "coulomb_friction", "offset"), {**BASE, "offset": 0.3}, 0.01)
    u = 4.0 * np.sin(np.linspace(0.0, 12.0, 800))
    np.testing.assert_array_equal(drive.free_run(u), same.free_run(u))
    np.testing.assert_array_equal(
        drive.friction(np.linspace(-3, 3, 61)), same.friction(np.linspace(-3, 3, 61))
    )
    # its model file names it and reads back
    drive.save(tmp_path / "drive.json")
    assert json.loads((tmp_path / "drive.json").read_text())["model"]["effects"][-1] == "constant_torque"
    assert load_model(tmp_path / "drive.json") == drive
    # the friction filters refuse it by name: their model does not hold it
    with pytest.raises(
        ValueError, match="rigid drive's constant_torque is not in the friction filters' model"
    ):
        check_rigid_drive(drive)
    with pytest.raises(ValueError, match="is a built-in effect's"):
        effects.register(type("Offset2", (ConstantTorque,), {"name": "offset"}))
    with pytest.raises(ValueError, match="is taken; pass replace=True"):
        effects.register(ConstantTorque)
    with pytest.raises(ValueError, match="parameter 'coulomb' is taken by coulomb_friction"):
        effects.register(
            type("Dry", (Effect,), {"name": "dry", "parameters": (Parameter("coulomb", "F", term=3),)})
        )
    with pytest.raises(ValueError, match="adds torque terms only"):
        effects.register(
            type("Shaped", (Effect,), {"name": "shaped", "parameters": (Parameter("width", "v"),)})
        )


def test_an_unregistered_effect_is_unknown_again(tmp_path):
    effects.register(ConstantTorque)
    drive = RigidDrive(
        ("constant_torque",), {"inertia": 1e-3, "input_gain": 1.0, "constant_torque": 0.1}, 0.01
    )
    drive.save(tmp_path / "drive.json")
    effects.unregister("constant_torque")
    with pytest.raises(ValueError, match="unknown effect 'constant_torque'"):
        RigidDrive(("constant_torque",), drive.params, 0.01)
    with pytest.raises(ValueError, match=r"effects\[0\]: unknown effect 'constant_torque'"):
        load_model(tmp_path / "drive.json")


def test_the_doctor_names_a_registered_effect_and_saves_it(constant_torque, capsys, tmp_path):
    truth = RigidDrive(
        ("viscous_friction", "coulomb_friction", "constant_torque"), {**BASE, "constant_torque": 0.4}, 0.01
    )
    path = tmp_path / "record.csv"
    write_record(slow_sine_record(truth), path)
    code, out, err = run(
        capsys, "doctor", str(path), "--base", "viscous_friction,coulomb_friction",
        "--candidates", "constant_torque", "--max-steps", "1", "--save-model", str(tmp_path / "found.json"), "--json",
    )  # fmt: skip
    assert code == 0, err
    assert [s["effect"] for s in out["steps"]] == ["constant_torque"]
    # a constant level on 30 s of 1 %-noise speed: within 5 % of the truth
    assert out["model"]["params"]["constant_torque"] == pytest.approx(0.4, rel=0.05)
    assert out["units"]["params"]["constant_torque"] == "V"  # a force per volt: no input gain given
    found = load_model(tmp_path / "found.json")
    assert found.effects == ("coulomb_friction", "viscous_friction", "constant_torque")  # the library's order
    assert found.params["constant_torque"] == out["model"]["params"]["constant_torque"]
    # a model holding it is a base the doctor starts from
    assert effect_list("viscous_friction,constant_torque", "--base") == [
        "viscous_friction",
        "constant_torque",
    ]
    assert DoctorJob(base=("constant_torque",)).base == ("constant_torque",)


def test_an_effect_from_a_plugin_entry_point(tmp_path, monkeypatch, caplog):
    """An installed distribution declaring the group ``motorid.effects`` adds an effect the drive
    runs; a broken entry point is logged and left out."""
    package = tmp_path / "motorid_effect_plugin"
    package.mkdir()
    (package / "__init__.py").write_text(
        textwrap.dedent(
            '''
            from motorid.drive import kernels
            from motorid.drive.effects import Effect, Parameter

            class BeltDrag(Effect):
                """Drag of a belt in proportion to the speed, on the viscous term."""
                name = "belt_drag"
                parameters = (Parameter("belt_drag", "F s/v", ">= 0", term=kernels.TERM_VISCOUS),)
                signature = "grows in proportion to w"
            '''
        )
    )
    dist = tmp_path / "motorid_effect_plugin-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: motorid-effect-plugin\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(
        "[motorid.effects]\n"
        "belt_drag = motorid_effect_plugin:BeltDrag\n"
        "broken_effect = motorid_effect_plugin:DoesNotExist\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    try:
        assert "belt_drag" in effects.names() and "broken_effect" not in effects.names()
        assert "broken_effect" in caplog.text
        params = {"inertia": 1e-3, "input_gain": 1.0, "coulomb": 0.5}
        drive = RigidDrive(("coulomb_friction", "belt_drag"), {**params, "belt_drag": 0.05}, 0.01)
        same = RigidDrive(("coulomb_friction", "viscous_friction"), BASE, 0.01)
        u = 4.0 * np.sin(np.linspace(0.0, 12.0, 800))
        np.testing.assert_array_equal(drive.free_run(u), same.free_run(u))
        drive.save(tmp_path / "drive.json")
        assert load_model(tmp_path / "drive.json") == drive
    finally:
        monkeypatch.undo()
        sys.modules.pop("motorid_effect_plugin", None)
    assert "belt_drag" not in effects.names()
