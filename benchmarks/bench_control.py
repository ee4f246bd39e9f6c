"""The speed controller's step: friction compensation + PI with anti-windup, per call.

Run: ``.venv/bin/python benchmarks/bench_control.py [--steps 100000]``

The controller (:class:`motorid.speed_control.SpeedController`) is stepped on a reversing
triangle reference with a measured speed that lags it, as in a loop: with the compensation
of a doctor-like model (viscous, Coulomb, Stribeck, asymmetric friction, quadratic drag, an
offset and a dead zone: six terms of the compiled friction law a step) and without it. The
peer is the same PI as a discrete ``control.StateSpace`` of python-control, stepped the way
python-control steps a system by hand (``dynamics`` for the state update and ``output`` for the
command, one sample each) with no limit and no compensation: the least a loop written with
python-control does a sample. The DAQ's exchange (a Modbus request is about a millisecond)
sets the loop rate, not the step. Best of 5 runs.
"""

from __future__ import annotations

import argparse

import control
import numpy as np
from _table import Row, best_of, print_rows

from motorid.compensation import FrictionCompensation
from motorid.drive import RigidDrive
from motorid.speed_control import SpeedController, design_speed_pi, reversing_reference

TITLE = "Speed controller: one step"
DT = 0.01
DRIVE = RigidDrive(
    ("viscous_friction", "coulomb_friction", "stribeck_friction", "asymmetric_friction", "quadratic_drag",
     "offset", "input_dead_zone"),
    {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044, "coulomb": 0.35, "stribeck": 0.2,
     "stribeck_velocity": 3.0, "coulomb_asymmetry": 0.05, "viscous_asymmetry": 0.004, "quadratic_drag": 1e-4,
     "offset": 0.02, "dead_zone": 0.7},
    DT,
)  # fmt: skip


def per_step(controller: SpeedController, r: list[float], y: list[float]) -> float:
    """Seconds per :meth:`SpeedController.step`, best of 5 runs over the whole reference."""
    controller.step(1.0, 0.0)  # compile the friction law

    def run() -> None:
        controller.reset()
        step = controller.step
        for rk, yk in zip(r, y, strict=True):
            step(rk, yk)

    return best_of(5, run) / len(r)


def python_control_step(pi: control.StateSpace, r: list[float], y: list[float]) -> float:
    """Seconds per sample of python-control's discrete PI stepped by ``dynamics`` and ``output``."""
    x0 = np.zeros(1)

    def run() -> None:
        x = x0
        for rk, yk in zip(r, y, strict=True):
            e = np.array([rk - yk])
            pi.output(0.0, x, e)
            x = pi.dynamics(0.0, x, e)

    return best_of(5, run) / len(r)


def measure(steps: int = 100_000) -> list[Row]:
    _, ref = reversing_reference("triangle", amplitude=40.0, period=4.0, duration=steps * DT, dt=DT)
    measured = np.concatenate([[0.0] * 3, ref[:-3]])  # the speed three samples behind
    r, y = ref.tolist(), measured.tolist()
    pi = design_speed_pi(DRIVE, DT)
    with_comp = per_step(SpeedController(pi, DT, FrictionCompensation(DRIVE)), r, y)
    without = per_step(SpeedController(pi, DT), r, y)
    peer_pi = control.ss([[1.0]], [[pi.ki * DT]], [[1.0]], [[pi.kp]], dt=DT)
    m = min(steps, 20_000)
    peer = python_control_step(peer_pi, r[:m], y[:m])
    return [
        Row(
            "friction compensation (7 effects) + PI with anti-windup, one step",
            with_comp * 1e6,
            peer * 1e6,
            "us",
            "python-control discrete PI (StateSpace dynamics + output), no limit",
            False,
        ),
        Row(
            "PI with anti-windup alone, one step",
            without * 1e6,
            peer * 1e6,
            "us",
            "python-control discrete PI (StateSpace dynamics + output), no limit",
            False,
        ),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    args = parser.parse_args()
    print_rows(measure(args.steps), TITLE)


if __name__ == "__main__":
    main()
