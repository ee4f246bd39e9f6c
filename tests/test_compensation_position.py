"""The friction compensation of a drive whose torque depends on the position: cogging (and
position friction) fed forward at the measured position shrinks the closed loop's speed ripple
to what a drive without cogging leaves."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from motorid.compensation import FrictionCompensation
from motorid.drive import RigidDrive
from motorid.io import SimulatedDAQ
from motorid.speed_control import SpeedController, design_speed_pi, reversing_reference, run_closed_loop

#: A small rotary drive at 200 Hz whose cogging (0.05 N m at 8 periods per revolution) is as
#: large as its Coulomb level (the drive of tests/test_filters_position.py).
BASE = {"inertia": 0.01, "input_gain": 0.1, "viscous": 1e-3, "coulomb": 0.05}
COGGING = {"cogging_sin": 0.05, "cogging_cos": 0.02, "cogging_periods": 8.0}
LEVELS = {"sin": 0.01, "cos": -0.008, "sin2": 0.004, "cos2": 0.0, "sin3": 0.0, "cos3": 0.002}


def cogging_drive() -> RigidDrive:
    return RigidDrive(("viscous_friction", "coulomb_friction", "cogging"), {**BASE, **COGGING}, dt=0.005)


def position_friction_drive() -> RigidDrive:
    params = {
        **BASE,
        **{f"position_friction_{k}": v for k, v in LEVELS.items()},
        "position_friction_periods": 0.2,
    }
    return RigidDrive(("viscous_friction", "coulomb_friction", "position_friction"), params, dt=0.005)


def moving_speed_error(drive: RigidDrive, compensation: FrictionCompensation, with_position: bool) -> float:
    """RMS speed error [rad/s] of the closed loop (the PI designed on the drive, its default
    bandwidth of 40 rad/s) on a 3 rad/s triangle through zero, while the reference moves faster
    than 1 rad/s after the first second: each speed y[k] at the end of sample k against the
    reference of the next sample, which it is to follow."""
    dt = drive.dt
    _, r = reversing_reference("triangle", 3.0, 4.0, 8.0, dt)
    controller = SpeedController(design_speed_pi(drive, dt), dt, compensation)
    sim = drive.simulation()
    y, q = 0.0, 0.0
    speeds = np.empty(r.size)
    for k in range(r.size):
        u = controller.step(r[k], y, q if with_position else None)
        y = sim.step(u)
        q = sim.state.get("position", 0.0)
        speeds[k] = y
    error = r[1:] - speeds[:-1]
    moving = (np.abs(r[1:]) > 1.0) & (np.arange(1, r.size) * dt > 1.0)
    return float(np.sqrt(np.mean(error[moving] ** 2)))


def test_cogging_fed_forward_at_the_measured_position_takes_the_speed_ripple_out():
    """On the rigid drive with cogging the loop compensated for its friction alone leaves a speed
    error of 0.090 rad/s while moving (the ripple: 0.084 rad/s of it, in quadrature); with the
    cogging fed forward at the measured position it is 0.0326 rad/s, what the same loop leaves on
    the drive without cogging (the triangle's own lag; equal to 1e-15). Asserted: below half the
    uncompensated figure and within 5 % of the drive without cogging (the model is exact here, so
    the ripple is cancelled whole; the margin is for a compiled law's last bits)."""
    drive = cogging_drive()
    compensation = FrictionCompensation(drive)
    with_cogging = moving_speed_error(drive, compensation, with_position=True)
    without = moving_speed_error(drive, compensation, with_position=False)
    plain = drive.without("cogging")
    floor = moving_speed_error(plain, FrictionCompensation(plain), with_position=False)
    assert with_cogging < 0.5 * without, (with_cogging, without)
    assert abs(with_cogging - floor) < 0.05 * floor, (with_cogging, floor)


@pytest.mark.parametrize("make", [cogging_drive, position_friction_drive])
def test_the_feedforward_is_the_drives_friction_at_the_measured_position(make):
    """Beyond the speed band the compensated torque is the drive's own friction with its position
    torque (RigidDrive.friction, evaluated apart from the compensation), at any position; within
    the band a position friction level is ramped like the Coulomb level."""
    drive = make()
    compensation = FrictionCompensation(drive, speed_band=0.5)
    rng = np.random.default_rng(0)
    speeds = rng.choice([-1.0, 1.0], 50) * rng.uniform(0.6, 20.0, 50)
    positions = rng.uniform(-30.0, 30.0, 50)
    expected = drive.friction(speeds, position=positions)
    got = [compensation.friction(w, q) for w, q in zip(speeds, positions, strict=True)]
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)  # the same compiled laws, summed apart
    assert compensation.feedforward(2.0, 1.3) == pytest.approx(drive.friction(2.0, 1.3) / drive.input_gain)
    torque = float(drive.position_torque(1.3))
    ramped = compensation.friction(0.25, 1.3) - compensation.friction(0.25)
    assert ramped == pytest.approx(
        0.5 * torque if drive.position_effects == ("position_friction",) else torque
    )


def test_a_loop_on_a_daq_says_the_position_torque_is_not_compensated(caplog):
    """A DAQ reads the speed alone: the loop runs with the rest of the compensation and logs that
    the model's cogging is left out."""
    drive = cogging_drive()
    controller = SpeedController(design_speed_pi(drive, drive.dt), drive.dt, FrictionCompensation(drive))
    with caplog.at_level(logging.WARNING, logger="motorid.speed_control"):
        run_closed_loop(SimulatedDAQ(plant=drive), controller, np.ones(20))
    assert "the model's cogging is not compensated" in caplog.text


@pytest.mark.parametrize("make", [cogging_drive, position_friction_drive])
def test_the_drive_in_python_control_carries_its_position(make):
    """nonlinear_system of a drive with a position torque holds the position in its state: the
    exported drive gives motorid's record bit for bit, one sample later (before, its position
    started from 0 at every sample)."""
    import control

    from motorid.control_design import nonlinear_system, rest_state

    drive = make()
    t = np.arange(600) * drive.dt
    u = 0.9 * np.sin(2 * np.pi * 0.5 * t)
    system = nonlinear_system(drive)
    response = control.input_output_response(system, t, u, initial_state=rest_state(drive))
    record = drive.simulate(u)
    assert np.array_equal(response.outputs[1:], record["y"].to_numpy()[:-1])
    assert np.array_equal(response.states[1, 1:], record["position"].to_numpy()[:-1])
