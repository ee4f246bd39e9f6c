"""On rigs the controller has not seen (random two-mass rigs with Coulomb and Stribeck friction and an
amplifier dead zone), friction compensation from the doctor's model of a record:

- cuts the low-speed RMS tracking error of a reversing reference by at least half against the
  same PI without compensation,
- does better than compensation from the datasheet model (inertia, motor constants, the rated
  friction torque) that lacks the dead zone and the Stribeck effect,
- and better than a PI tuned for twice the bandwidth without compensation (the honest baseline:
  a faster PI shortens the sticking too).
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from motorid.compensation import FrictionCompensation
from motorid.diagnose import diagnose
from motorid.drive import Amplifier, Friction, RigidDrive, paper_rig
from motorid.io import SimulatedDAQ
from motorid.signals import two_sine_signal
from motorid.speed_control import (
    SpeedController,
    design_speed_pi,
    reversing_reference,
    run_closed_loop,
    tracking_metrics,
)
from motorid.validation import rpm_to_rad_s

DT = 0.01
LOW_SPEED = float(rpm_to_rad_s(150.0))  # the paper's low-speed band


@st.composite
def rigs(draw):
    """A rig around the paper's, stiff shaft (the rigid model's case), with hidden friction and dead zone."""
    J_m = draw(st.floats(1.5e-5, 4e-5))
    J_l = draw(st.floats(4e-5, 1.2e-4))
    K_m = draw(st.floats(0.035, 0.055))
    R_a = draw(st.floats(1.5, 3.0))
    coulomb_m = draw(st.floats(2e-3, 8e-3))
    coulomb_l = draw(st.floats(1e-3, 4e-3))
    stribeck = draw(st.floats(0.0, 5e-3))
    stribeck_speed = draw(st.floats(3.0, 10.0))
    dead_zone = draw(st.floats(0.3, 1.0))
    friction = (
        Friction(("coulomb_friction",), {"coulomb": coulomb_m}, side="motor"),
        Friction(("coulomb_friction",), {"coulomb": coulomb_l}, side="load"),
        Friction(
            ("stribeck_friction",), {"stribeck": stribeck, "stribeck_velocity": stribeck_speed}, side="motor"
        ),
    )
    return paper_rig(
        J_m=J_m, J_l=J_l, K_m=K_m, R_a=R_a, k_s=20.0, B_s=0.02, dt=DT, substeps=20, friction=friction,
        amplifier=Amplifier(dead_zone=dead_zone, v_max=12.0),
    )  # fmt: skip


def datasheet_model(rig) -> RigidDrive:
    """What the motor's datasheet gives, in volts (input gain 1 as the doctor's model without
    --input-gain): inertia, back-EMF and bearing damping, the rated friction torque; no dead zone
    (the amplifier's) and no Stribeck effect."""
    gain = rig.K_m / rig.R_a  # N m per V at rest
    coulomb = sum(f.params.get("coulomb", 0.0) for f in rig.friction)
    return RigidDrive(
        ("viscous_friction", "coulomb_friction"),
        {"inertia": (rig.J_m + rig.J_l) / gain, "input_gain": 1.0,
         "viscous": (rig.K_m**2 / rig.R_a + rig.B_m + rig.B_l) / gain, "coulomb": coulomb / gain},
        DT,
    )  # fmt: skip


def low_speed_error(rig, pi, compensation, reference) -> float:
    record = run_closed_loop(SimulatedDAQ(rig, seed=11), SpeedController(pi, DT, compensation), reference,
                             progress=False)  # fmt: skip
    return tracking_metrics(record, low_speed=LOW_SPEED)["low_speed_rms_error"]


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rig=rigs(), seed=st.integers(0, 2**16))
def test_compensation_from_the_doctors_model_on_random_rigs(rig, seed):
    _, u = two_sine_signal(duration=60.0, dt=DT, seed=seed)
    doctor = diagnose(rig.simulate(u, seed=seed + 1)).model
    pi = design_speed_pi(doctor, DT)
    _, reference = reversing_reference("triangle", amplitude=40.0, period=4.0, duration=12.0, dt=DT)

    without = low_speed_error(rig, pi, None, reference)
    with_doctor = low_speed_error(rig, pi, FrictionCompensation(doctor), reference)
    with_datasheet = low_speed_error(rig, pi, FrictionCompensation(datasheet_model(rig)), reference)
    faster_pi = low_speed_error(
        rig, design_speed_pi(doctor, DT, bandwidth=2.0 * pi.bandwidth), None, reference
    )

    summary = (f"low-speed RMS error [rad/s]: PI {without:.3g}, + doctor's compensation {with_doctor:.3g}, "
               f"+ datasheet's {with_datasheet:.3g}, PI at twice the bandwidth {faster_pi:.3g}; "
               f"doctor's model {doctor.effects}")  # fmt: skip
    assert with_doctor <= 0.5 * without, summary
    assert with_doctor < with_datasheet, summary
    assert with_doctor < faster_pi, summary
    assert np.isfinite([without, with_doctor, with_datasheet, faster_pi]).all()
