"""Friction compensation from a drive model, the PI designed on it, and the closed loop on a DAQ."""

from __future__ import annotations

import math

import control
import numpy as np
import pandas as pd
import pytest

from motorid.compensation import FrictionCompensation
from motorid.drive import RigidDrive, paper_rig
from motorid.drive.input_path import input_path
from motorid.errors import DAQError
from motorid.io import SimulatedDAQ
from motorid.speed_control import (
    SpeedController,
    SpeedPI,
    TrackingMetrics,
    design_speed_pi,
    reversing_reference,
    run_closed_loop,
    tracking_metrics,
)

DT = 0.01


def doctor_like_drive(**changes: float) -> RigidDrive:
    """A rigid drive with every friction term the compensation cancels, and a dead zone."""
    params = {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044, "coulomb": 0.35, "stribeck": 0.2,
              "stribeck_velocity": 3.0, "coulomb_asymmetry": 0.05, "viscous_asymmetry": 0.004,
              "quadratic_drag": 1e-4, "offset": 0.02, "dead_zone": 0.7, **changes}  # fmt: skip
    effects = ("viscous_friction", "coulomb_friction", "stribeck_friction", "asymmetric_friction",
               "quadratic_drag", "offset", "input_dead_zone")  # fmt: skip
    return RigidDrive(effects, params, DT)


# --------------------------------------------------------------------------- compensation
@pytest.mark.parametrize("gain", [1.0, 0.021])
def test_compensation_cancels_the_models_friction_and_dead_zone_outside_the_bands(gain):
    drive = doctor_like_drive(input_gain=gain)
    comp = FrictionCompensation(drive, speed_band=1.0, input_band=0.05)
    rng = np.random.default_rng(0)
    speeds = rng.uniform(1.0, 200.0, 200) * rng.choice([-1.0, 1.0], 200)
    wanted = rng.uniform(0.1, 3.0, 200) * rng.choice([-1.0, 1.0], 200)  # v [V], beyond the input band
    # the compensation's feed-forward opposes the friction where it may be large against the wanted v
    u = np.array([comp.command(v, w, 0.0) for v, w in zip(wanted, speeds, strict=True)])
    x = np.array([v + comp.feedforward(w) for v, w in zip(wanted, speeds, strict=True)])
    keep = np.abs(x) > comp.input_band  # outside the input band the dead zone is inverted exactly
    assert keep.sum() > 150
    # the drive's own input map and friction (RigidDrive.input_path, RigidDrive.friction): the
    # drive feels g v, the controller's effective input, up to rounding
    net = gain * input_path(u, drive.params["dead_zone"]) - drive.friction(speeds)
    assert np.max(np.abs(net[keep] - gain * wanted[keep])) < 1e-12 * 200


def test_compensation_ramps_through_zero_speed_without_a_jump():
    drive = doctor_like_drive()
    comp = FrictionCompensation(drive, speed_band=0.5)
    w = np.linspace(-2.0, 2.0, 4001)
    ff = np.array([comp.feedforward(x) for x in w])
    # the steepest change is the level terms' ramp across the band: (F_c + F_s + ΔF_c)/ω_b per rad/s
    steepest = (0.35 + 0.2 + 0.05) / 0.5 + 0.05
    assert np.max(np.abs(np.diff(ff))) <= steepest * (w[1] - w[0])
    # at rest only the offset is fed forward; beyond the band the full levels are
    assert comp.feedforward(0.0) == pytest.approx(0.02)
    assert comp.feedforward(0.5) == pytest.approx(drive.friction(np.array([0.5]))[0])
    # the dead zone's inverse is continuous too: D̃⁻¹ is x + d x / x_b inside the band
    assert comp.invert_input(0.0) == 0.0
    assert comp.invert_input(comp.input_band / 2) == pytest.approx(comp.input_band / 2 + 0.35)


def test_compensation_follows_the_speed_its_source_names():
    drive = doctor_like_drive()
    by_reference = FrictionCompensation(drive, source="reference")
    by_measurement = FrictionCompensation(drive, source="measured")
    assert by_reference.command(0.0, 20.0, -20.0) == by_measurement.command(0.0, -20.0, 20.0)
    assert by_reference.command(0.0, 20.0, -20.0) > 0 > by_measurement.command(0.0, 20.0, -20.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"speed_band": 0.0}, "speed_band"), ({"speed_band": math.nan}, "speed_band"),
     ({"input_band": -1.0}, "input_band"), ({"source": "model"}, "source")],
)  # fmt: skip
def test_compensation_refuses_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FrictionCompensation(doctor_like_drive(), **kwargs)


def test_compensation_needs_a_physical_rigid_drive():
    with pytest.raises(ValueError, match="RigidDrive"):
        FrictionCompensation(paper_rig())
    with pytest.raises(ValueError, match="coulomb must be >= 0"):
        FrictionCompensation(doctor_like_drive(coulomb=-0.1))


# --------------------------------------------------------------------------- the PI design
def plant_tf(drive: RigidDrive) -> control.TransferFunction:
    return control.tf([drive.input_gain], [drive.inertia, drive.params.get("viscous", 0.0)])


def test_pi_cancels_a_fast_mechanical_pole_for_a_first_order_loop_of_the_bandwidth():
    drive = doctor_like_drive()  # B/J = 8.8 rad/s > ω_c / 4
    pi = design_speed_pi(drive, DT, bandwidth=20.0)
    assert pi.tracking_time == pytest.approx(drive.inertia / 0.044)
    closed = control.feedback(pi.transfer_function() * plant_tf(drive), 1)
    # L(s) = ω_c / s exactly: the closed loop is ω_c / (s + ω_c), one pole at -ω_c once the
    # cancelled pair is taken out (1e-6: minreal's tolerance on the cancellation)
    reduced = control.minreal(closed, tol=1e-6, verbose=False)
    assert reduced.poles() == pytest.approx([-20.0], rel=1e-6)
    assert control.dcgain(reduced) == pytest.approx(1.0)


def test_pi_on_an_integrating_drive_has_its_stated_phase_margin():
    drive = doctor_like_drive(viscous=0.0)
    pi = design_speed_pi(drive, DT, bandwidth=20.0)
    assert pi.tracking_time == pytest.approx(4.0 / 20.0)
    _, pm, _, _ = control.margin(pi.transfer_function() * plant_tf(drive))[:4]
    # L = ω_c (s + ω_c/4) / s²: |L| = 1 at 1.03 ω_c, phase margin atan(4 · 1.03) = 76°
    assert pm == pytest.approx(76.4, abs=0.5)


def test_default_bandwidth_takes_the_delay_and_lag_and_the_saturation_limits_the_command():
    drive = doctor_like_drive().with_effects(
        ("viscous_friction", "input_delay", "input_lag", "input_saturation"),
        {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044, "input_delay": 0.02,
         "lag_time_constant": 0.01, "saturation": 9.0},
    )  # fmt: skip
    pi = design_speed_pi(drive, DT)
    assert pi.bandwidth == pytest.approx(0.2 / (0.01 + 0.02 + 0.01))
    assert pi.u_max == 9.0
    with pytest.raises(ValueError, match="bandwidth"):
        design_speed_pi(drive, DT, bandwidth=-1.0)


# --------------------------------------------------------------------------- the controller
def test_controller_step_is_the_pi_law_with_back_calculation():
    pi = SpeedPI(kp=0.1, ki=1.0, tracking_time=0.1, u_max=1.0, bandwidth=20.0)
    ctrl = SpeedController(pi, DT)
    assert ctrl.step(5.0, 0.0) == pytest.approx(0.5)  # v = K_p e, inside the limit
    assert ctrl.integral == pytest.approx(DT * 1.0 * 5.0)
    i0 = ctrl.integral
    assert ctrl.step(20.0, 0.0) == 1.0  # v = 2.05 clipped to 1
    assert ctrl.integral == pytest.approx(i0 + DT * (1.0 * 20.0 + (1.0 - (2.0 + i0)) / 0.1))


def test_anti_windup_holds_the_integral_at_the_limit_on_a_reference_out_of_reach():
    drive = RigidDrive(("viscous_friction",), {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044}, DT)
    pi = design_speed_pi(drive, DT, bandwidth=20.0, u_max=3.0)
    ctrl = SpeedController(pi, DT)
    record = run_closed_loop(SimulatedDAQ(drive, u_max=12.0), ctrl, np.full(500, 500.0), progress=False)
    # steady state of dI/dt = K_i e + (u_sat - u)/T_t with T_t = T_i: I = u_sat, whatever e
    assert ctrl.integral == pytest.approx(3.0, rel=1e-6)
    assert record["u"].iloc[-1] == 3.0
    # without anti-windup (T_t very long) it winds up to many times the limit
    unbounded = SpeedController(SpeedPI(pi.kp, pi.ki, 1e9, 3.0, pi.bandwidth), DT)
    run_closed_loop(SimulatedDAQ(drive), unbounded, np.full(500, 500.0), progress=False)
    assert unbounded.integral > 10 * 3.0


# --------------------------------------------------------------------------- references and metrics
def test_reversing_references_cross_zero_and_peak_where_stated():
    t, r = reversing_reference("triangle", amplitude=40.0, period=4.0, duration=8.0, dt=DT)
    assert t[100] == pytest.approx(1.0)
    assert r[0] == 0.0 and r[100] == pytest.approx(40.0) and r[300] == pytest.approx(-40.0)
    assert r[200] == pytest.approx(0.0, abs=1e-12) and np.max(np.abs(np.diff(r))) == pytest.approx(0.4)
    _, s = reversing_reference("sine", amplitude=40.0, period=4.0, duration=8.0, dt=DT)
    assert s[100] == pytest.approx(40.0) and s[300] == pytest.approx(-40.0)
    with pytest.raises(ValueError, match="kind"):
        reversing_reference("square")


def test_tracking_metrics_of_a_known_record():
    t = np.arange(400) * DT
    r = np.where(t < 2.0, 10.0, -10.0)
    y = r.copy()
    stuck = (t >= 2.0) & (t < 2.3)
    y[stuck] = 0.0  # the drive stays at rest 0.3 s after the reversal
    metrics = tracking_metrics(pd.DataFrame({"t": t, "reference": r, "y": y}), low_speed=15.0)
    assert metrics["largest_stuck_after_reversal"] == pytest.approx(0.3)
    assert metrics["reversals"] == 1
    assert metrics["rms_error"] == pytest.approx(math.sqrt(30 * 100 / 400))
    assert metrics["low_speed_rms_error"] == pytest.approx(metrics["rms_error"])


def test_a_drive_that_never_follows_a_reversal_counts_as_stuck_until_the_next_one():
    t = np.arange(600) * DT
    r = np.where(t < 2.0, 10.0, np.where(t < 4.0, -10.0, 10.0))
    y = np.where(t < 2.0, 10.0, 0.0)  # stops at the first reversal and stays at rest
    metrics = tracking_metrics(pd.DataFrame({"t": t, "reference": r, "y": y}), low_speed=15.0)
    # stuck 2 s until the reference reverses again, then from 4 s to the last sample (5.99 s)
    assert metrics["reversals"] == 2
    assert metrics["largest_stuck_after_reversal"] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="low_speed"):
        TrackingMetrics(low_speed=0.0)


# --------------------------------------------------------------------------- the loop
def test_the_loops_metrics_cover_the_whole_run_whatever_it_keeps(tmp_path):
    drive = doctor_like_drive()
    ctrl = SpeedController(design_speed_pi(drive, DT), DT, FrictionCompensation(drive))
    _, r = reversing_reference(duration=8.0, dt=DT)
    fed = TrackingMetrics(low_speed=15.0)
    kept = run_closed_loop(SimulatedDAQ(drive), ctrl, r, out=tmp_path / "run.csv", progress=False, metrics=fed,
                           keep=100)  # fmt: skip
    assert len(kept) == 100 and kept.attrs["samples"] == r.size
    whole = pd.read_csv(tmp_path / "run.csv", comment="#")
    assert fed.result() == tracking_metrics(whole, low_speed=15.0)


def test_closed_loop_record_file_and_zero_volts_at_the_end(tmp_path):
    drive = doctor_like_drive()
    ctrl = SpeedController(design_speed_pi(drive, DT), DT, FrictionCompensation(drive))
    _, r = reversing_reference(duration=4.0, dt=DT)
    daq = SimulatedDAQ(drive)
    record = run_closed_loop(daq, ctrl, r, out=tmp_path / "run.csv", progress=False)
    assert list(record.columns) == ["t", "reference", "u", "y", "clamped"]
    assert record.attrs["timing"] == "sampled" and len(record) == r.size
    on_disk = pd.read_csv(tmp_path / "run.csv", comment="#")
    assert np.array_equal(
        on_disk[["t", "reference", "u", "y"]].to_numpy(), record[["t", "reference", "u", "y"]].to_numpy()
    )
    assert not daq.is_open and daq.u == 0.0
    # the loop tracks: the compensated drive on its own model follows within 1 rad/s RMS
    assert tracking_metrics(record, low_speed=15.0)["rms_error"] < 1.0
    with pytest.raises(FileExistsError):
        run_closed_loop(SimulatedDAQ(drive), ctrl, r, out=tmp_path / "run.csv", progress=False)


class FailingPlant:
    """A drive whose link fails at a given sample (what a lost rig does to the loop)."""

    def __init__(self, drive: RigidDrive, fail_at: int) -> None:
        self.sim, self.fail_at, self.dt = drive.simulation(), fail_at, drive.dt
        self.commands: list[float] = []

    def reset(self, seed=None):
        self.sim.reset()

    def step(self, u: float) -> float:
        self.commands.append(u)
        if len(self.commands) == self.fail_at:
            raise DAQError("the rig stopped answering")
        return self.sim.step(u)


def test_a_failing_rig_stops_the_loop_with_zero_volts_and_the_samples_on_disk(tmp_path):
    drive = doctor_like_drive()
    ctrl = SpeedController(design_speed_pi(drive, DT), DT, FrictionCompensation(drive))
    plant = FailingPlant(drive, fail_at=50)
    daq = SimulatedDAQ(plant)
    with pytest.raises(DAQError) as info:
        run_closed_loop(daq, ctrl, np.full(200, 10.0), out=tmp_path / "run.csv", progress=False)
    assert "after 48 of 200 samples" in " ".join(info.value.__notes__)
    assert len(pd.read_csv(tmp_path / "run.csv", comment="#")) == 48
    assert daq.u == 0.0 and not daq.is_open


# --------------------------------------------------------------------------- the simulated sensor
KIT_STEP = 0.767  # the kit encoder's speed step [rad/s] (one count per 1 ms sample)


def sensor_errors(card, u: np.ndarray, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """The speed a SensedPlant with ``card`` measures on the input ``u``, and its error against the true speed
    (the same plant without its sensor: the drive's simulation is deterministic)."""
    from motorid.speed_control import SensedPlant

    drive = RigidDrive(("viscous_friction",), {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044}, DT)
    sensed, truth = SensedPlant(drive, card), SensedPlant(drive, card, noise_free=True)
    sensed.reset(seed)
    truth.reset(seed)
    omega = np.array([truth.step(v) for v in u])
    y = np.array([sensed.step(v) for v in u])
    return omega, y - omega


def test_the_simulated_sensor_errs_by_the_cards_noise_rounding_included():
    """A rigid drive measured by a kit-like card (step q = 0.767 rad/s, sigma 0.281 rad/s below 24 rad/s and
    0.6 above, the doctor's figures on the kit's records): the reading errs by sigma RMS in each band, not
    sqrt(sigma^2 + q^2/12) = 0.358 rad/s as when the card's noise was added whole before rounding. The speed
    ramps slowly through the steps (2-20 and 27-90 rad/s over 60 s each), so the rounding errs uniformly;
    6,000 samples a band give the RMS within about 1 % (1 / sqrt(2 n)), the tolerance 4 %."""
    from motorid.drive.files import ModelCard

    card = ModelCard(quantisation_step=KIT_STEP, noise_bands=(
        {"speed_from": 0.0, "speed_to": 24.0, "std": 0.281}, {"speed_from": 24.0, "speed_to": 200.0, "std": 0.6},
    ))  # fmt: skip
    for low, high, std in ((0.1, 0.9, 0.281), (1.2, 4.0, 0.6)):
        omega, error = sensor_errors(card, np.linspace(low, high, 6000))
        in_band = (omega > 0.5 * low / 0.044) & (omega < high / 0.044)
        assert in_band.sum() > 5000
        assert np.sqrt(np.mean(error[in_band] ** 2)) == pytest.approx(std, rel=0.04)


def test_a_card_noise_below_the_rounding_error_adds_none_and_says_so(caplog):
    """sigma = 0.1 rad/s is below the step's own rounding error q / sqrt(12) = 0.221 rad/s: no noise is added,
    the reading errs by the rounding alone (0.221 within 4 %, as above), and the log says so."""
    from motorid.drive.files import ModelCard

    card = ModelCard(
        quantisation_step=KIT_STEP, noise_bands=({"speed_from": 0.0, "speed_to": 200.0, "std": 0.1},)
    )
    with caplog.at_level("INFO", logger="motorid.speed_control"):
        omega, error = sensor_errors(card, np.linspace(0.1, 0.9, 6000))
    assert np.sqrt(np.mean(error[omega > 2.0] ** 2)) == pytest.approx(KIT_STEP / math.sqrt(12), rel=0.04)
    assert "no noise is added there" in caplog.text and "0.221" in caplog.text
