"""The controller exported as C99 (:mod:`motorid.controller_c`), compiled with the system's C compiler
and driven with the reference and measurement sequence the Python controller gets: the commands
agree within float32 rounding."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from cli_fixtures import run

from motorid.compensation import FrictionCompensation
from motorid.controller_c import controller_c_sources, export_controller_c
from motorid.drive import RigidDrive
from motorid.drive.files import ModelCard, save_model
from motorid.speed_control import SpeedController, design_speed_pi, reversing_reference

COMPILER = shutil.which("cc") or shutil.which("gcc")
needs_compiler = pytest.mark.skipif(COMPILER is None, reason="no C compiler (cc or gcc) on this machine")

#: A program that reads "reference measured" lines and prints each command to 9 digits (a float32's).
DRIVER = r"""
#include <stdio.h>
#include "NAME.h"
int main(void)
{
    NAME_state state;
    float r, y;
    NAME_reset(&state);
    while (scanf("%f %f", &r, &y) == 2) {
        printf("%.9g\n", NAME_step(&state, r, y));
    }
    return 0;
}
"""

EVERY_TERM = {
    "inertia": 0.004, "input_gain": 0.05, "viscous": 2e-4, "coulomb": 0.02, "stribeck": 0.01,
    "stribeck_velocity": 3.0, "coulomb_asymmetry": 0.002, "viscous_asymmetry": 3e-5, "quadratic_drag": 1e-6,
    "offset": -0.001, "dead_zone": 0.4,
}  # fmt: skip
EVERY_EFFECT = ("viscous_friction", "coulomb_friction", "stribeck_friction", "asymmetric_friction",
                "quadratic_drag", "offset", "input_dead_zone")  # fmt: skip


def compile_controller(folder, controller: SpeedController, name: str = "ctrl"):
    export_controller_c(controller, folder, name=name, input_unit="V", model="test.json")
    (folder / "main.c").write_text(DRIVER.replace("NAME", name))
    program = folder / "controller"
    subprocess.run(
        [COMPILER, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic", "-o", str(program),
         str(folder / f"{name}.c"), str(folder / "main.c"), "-lm"],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return program


def c_commands(program, reference: np.ndarray, measured: np.ndarray) -> np.ndarray:
    lines = "".join(f"{r:.9g} {y:.9g}\n" for r, y in zip(reference, measured, strict=True))
    done = subprocess.run([str(program)], input=lines, capture_output=True, text=True, check=True)
    return np.array(done.stdout.split(), dtype=float)


def python_commands(controller: SpeedController, reference: np.ndarray, measured: np.ndarray) -> np.ndarray:
    controller.reset()
    return np.array([controller.step(float(r), float(y)) for r, y in zip(reference, measured, strict=True)])


@needs_compiler
@pytest.mark.parametrize("shape", ["exponential", "gaussian"])
@pytest.mark.parametrize("source", ["reference", "measured"])
def test_the_c_controller_gives_the_python_controllers_commands(tmp_path, shape, source):
    drive = RigidDrive(EVERY_EFFECT, EVERY_TERM, dt=0.01, stribeck_shape=shape)
    pi = design_speed_pi(drive, 0.01, u_max=12.0, damping=0.0 if source == "measured" else None)
    controller = SpeedController(pi, 0.01, FrictionCompensation(drive, speed_band=0.5, source=source))
    program = compile_controller(tmp_path, controller)
    _, reference = reversing_reference("triangle", 40.0, 4.0, 20.0, 0.01)
    rng = np.random.default_rng(1)
    # a lagging, noisy speed through every band, and stretches where the command sits on the limit
    measured = np.roll(reference, 15) * 0.8 + rng.normal(0.0, 0.3, reference.size)
    measured[600:700] = 0.0
    # the C program reads the float32 nearest each input: the Python controller gets the same numbers
    reference, measured = reference.astype(np.float32), measured.astype(np.float32)
    expected = python_commands(controller, reference, measured)
    got = c_commands(program, reference, measured)
    assert got.shape == expected.shape == (2000,)
    assert np.abs(expected).max() == pytest.approx(12.0) and np.abs(expected).min() < 1.0
    # one float32 rounding a step accumulates in the integral: at most N eps32 of the largest command
    tolerance = expected.size * np.finfo(np.float32).eps * 12.0
    np.testing.assert_allclose(got, expected, rtol=0.0, atol=tolerance)


@needs_compiler
def test_the_pi_alone_compiles_and_agrees(tmp_path):
    drive = RigidDrive(
        ("viscous_friction",), {"inertia": 0.004, "input_gain": 0.05, "viscous": 2e-4}, dt=0.01
    )
    controller = SpeedController(design_speed_pi(drive, 0.01, u_max=5.0), 0.01)
    program = compile_controller(tmp_path, controller, name="pi_only")
    reference = np.linspace(-30.0, 30.0, 500).astype(np.float32)
    measured = (0.5 * reference).astype(np.float32)
    expected = python_commands(controller, reference, measured)
    tolerance = expected.size * np.finfo(np.float32).eps * 5.0
    np.testing.assert_allclose(c_commands(program, reference, measured), expected, rtol=0.0, atol=tolerance)


def test_the_source_names_each_parameter_with_its_unit():
    drive = RigidDrive(EVERY_EFFECT, EVERY_TERM, dt=0.01)
    controller = SpeedController(design_speed_pi(drive, 0.01), 0.01, FrictionCompensation(drive))
    header, source = controller_c_sources(controller, "wheel", input_unit="%", model="wheel1.json")
    assert "float wheel_step(wheel_state *state, float reference, float measured);" in header
    assert "static const float COULOMB = 2.000000000e-02f; /* coulomb [F] */" in source
    assert "/* viscous [F s/(rad/s)] */" in source and "/* dead_zone d [%] */" in source
    assert "wheel1.json" in source and "#include <math.h>" in source
    with pytest.raises(ValueError, match="C identifier"):
        controller_c_sources(controller, "9lives")


@needs_compiler
def test_control_exports_the_controller_it_runs(capsys, tmp_path):
    drive = RigidDrive(("coulomb_friction", "viscous_friction"),
                       {"inertia": 0.004, "input_gain": 1.0, "coulomb": 7.0, "viscous": 0.4}, dt=0.001)  # fmt: skip
    model = tmp_path / "kit.json"
    save_model(drive, model, card=ModelCard(input_unit="%", output_unit="rad/s", dt=0.001, timing="hold"))
    code, out, err = run(capsys, "control", "--design", str(model), "--model", str(model), "--export-c",
                         str(tmp_path / "c"), "--out", str(tmp_path / "run.csv"), "--json")  # fmt: skip
    assert code == 0, err
    assert out["export_c"] == [
        str(tmp_path / "c" / "motorid_speed.h"),
        str(tmp_path / "c" / "motorid_speed.c"),
    ]
    assert "MOTORID_SPEED_U_MAX 1.000000000e+02f" in (tmp_path / "c" / "motorid_speed.h").read_text()
    source = (tmp_path / "c" / "motorid_speed.c").read_text()
    assert "coulomb [F]" in source and "K_p [%/(rad/s)]" in source
