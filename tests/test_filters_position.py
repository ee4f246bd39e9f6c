"""The friction filters on a rigid drive whose torque depends on the position (cogging, position
friction): the position torque is a known part of their model, at the measured position, so a
ripple that holds the drive at low speed does not bias the Coulomb estimate; a record without the
position is refused naming the effect."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from motorid.drive import RigidDrive, paper_rig
from motorid.estimators import FrictionEKF, FrictionUKF, load_model

#: A small rotary drive at 200 Hz whose cogging (0.05 N m at 8 periods per revolution) is as
#: large as its Coulomb level: at a few rad/s it nearly stops the drive once a period.
BASE = {"inertia": 0.01, "input_gain": 0.1, "viscous": 1e-3, "coulomb": 0.05}
COGGING = {"cogging_sin": 0.05, "cogging_cos": 0.0, "cogging_periods": 8.0}
#: The speed noise [rad/s] and its variance, the filters' R.
NOISE = 0.01


def cogging_drive() -> RigidDrive:
    return RigidDrive(("viscous_friction", "coulomb_friction", "cogging"), {**BASE, **COGGING}, dt=0.005)


def position_friction_drive() -> RigidDrive:
    levels = {"sin": 0.01, "cos": -0.008, "sin2": 0.004, "cos2": 0.0, "sin3": 0.0, "cos3": 0.002}
    params = {
        **BASE,
        **{f"position_friction_{k}": v for k, v in levels.items()},
        "position_friction_periods": 0.2,
    }
    return RigidDrive(("viscous_friction", "coulomb_friction", "position_friction"), params, dt=0.005)


def slow_input(n: int = 8000, dt: float = 0.005) -> np.ndarray:
    """A slow sine through zero with a faster one on top [V]: speeds within ±2 rad/s, where the
    ripple holds the drive back once a period."""
    t = np.arange(n) * dt
    return 0.7 * np.sin(2 * np.pi * 0.1 * t) + 0.3 * np.sin(2 * np.pi * 0.73 * t)


def noisy_record(drive: RigidDrive, u: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The drive's free run (speed and position at the end of each sample) with white speed noise."""
    record = drive.simulate(u)
    y = record["y"].to_numpy() + np.random.default_rng(seed).normal(0.0, NOISE, u.size)
    return y, record["position"].to_numpy()


def coulomb_after(cls, drive: RigidDrive, u, y, position) -> float:
    est = cls.from_rig(drive, R=NOISE**2, coulomb0=0.02, on_divergence="ignore")
    est.batch_filter(u, y, position=position)
    return est.params["coulomb"]


@pytest.mark.parametrize("cls", [FrictionEKF, FrictionUKF])
@pytest.mark.parametrize("seed", [1, 2])
def test_known_cogging_keeps_the_coulomb_estimate_unbiased(cls, seed):
    """On a record of a drive with strong cogging the filter that holds the ripple at the measured
    position ends within 6 % of the true Coulomb level (0.05 N m). Measured on these seeds: EKF
    -2.7 and -3.2 %, UKF +0.1 and -0.3 %; the EKF's own bias on the same input from a drive with
    no ripple at all is -2.6 %, so the 6 % is that bias with a margin. The filter without the
    ripple (the drive model without cogging) takes the ripple's hold at low speed for friction:
    +23 to +25 % (asserted above +12 %)."""
    drive = cogging_drive()
    u = slow_input()
    y, position = noisy_record(drive, u, seed)
    known = coulomb_after(cls, drive, u, y, position)
    unknown = coulomb_after(cls, drive.without("cogging"), u, y, None)
    truth = BASE["coulomb"]
    assert abs(known - truth) < 0.06 * truth, known
    assert unknown - truth > 0.12 * truth, unknown
    assert abs(unknown - truth) > 3 * abs(known - truth)


def test_known_position_friction_tracks_the_level_along_the_travel():
    """Position-dependent friction (a level F(θ) sgn ω with three harmonics) held as a known part:
    on the noise-free record the one-step prediction follows the drive (innovations below 8e-4
    rad/s RMS, measured 3.9e-4: the difference between the filter's Heun sub-steps and the drive's
    exact integrator) and the Coulomb level is found within 1 % (measured 0.001 %); the filter
    without it predicts 13 times worse (asserted 10)."""
    drive = position_friction_drive()
    u = slow_input(4000) * 1.5
    record = drive.simulate(u)
    y, position = record["y"].to_numpy(), record["position"].to_numpy()
    rms = {}
    for model, pos in ((drive, position), (drive.without("position_friction"), None)):
        ekf = FrictionEKF.from_rig(model, R=NOISE**2, on_divergence="ignore")
        result = ekf.batch_filter(u, y, position=pos)
        rms[model.position_effects] = float(np.sqrt(np.nanmean(result.innovation[200:] ** 2)))
        if pos is not None:
            assert abs(ekf.params["coulomb"] - BASE["coulomb"]) < 0.01 * BASE["coulomb"]
    assert rms[("position_friction",)] < 8e-4
    assert rms[()] > 10 * rms[("position_friction",)]


@pytest.mark.parametrize("cls", [FrictionEKF, FrictionUKF])
@pytest.mark.parametrize("make", [cogging_drive, position_friction_drive])
def test_a_record_without_the_position_is_refused_naming_the_effect(cls, make):
    drive = make()
    u = slow_input(50)
    est = cls.from_rig(drive, R=NOISE**2)
    before = est.x.copy()
    effect = drive.position_effects[0]
    with pytest.raises(
        ValueError, match=rf"position: the rigid drive's {effect} torque depends on the position"
    ):
        est.batch_filter(u, np.zeros(u.size))
    np.testing.assert_array_equal(est.x, before)
    with pytest.raises(ValueError, match=r"position must have the length of u \(50\)"):
        est.batch_filter(u, np.zeros(u.size), position=np.zeros(3))
    with pytest.raises(ValueError, match=r"position\[4\] = inf is not finite"):
        est.batch_filter(u, np.zeros(u.size), position=np.where(np.arange(50) == 4, np.inf, 0.0))


@pytest.mark.parametrize("cls", [FrictionEKF, FrictionUKF])
def test_a_position_for_a_drive_without_a_position_torque_is_refused(cls):
    drive = cogging_drive().without("cogging")
    est = cls.from_rig(drive, R=NOISE**2)
    with pytest.raises(
        ValueError, match="position: this filter's drive has no torque that depends on the position"
    ):
        est.batch_filter(np.zeros(5), np.zeros(5), position=np.zeros(5))
    est.predict(0.0)
    with pytest.raises(ValueError, match="position: this filter's drive has no torque"):
        est.update(0.0, position=0.0)


def test_a_two_mass_rig_with_cogging_is_refused_naming_it():
    """The two-mass filter has no motor position in its state: refused, with the way out."""
    rig = paper_rig().replace(cogging_sin=0.01, cogging_periods=6.0)
    with pytest.raises(
        ValueError, match=r"two-mass rig's motor cogging is not in the friction filters' two-mass"
    ):
        FrictionEKF.from_rig(rig)
    FrictionEKF.from_rig(rig.rigid_equivalent(), R=NOISE**2)  # the rigid equivalent holds it


def test_online_equals_batch_and_a_saved_filter_goes_on(tmp_path):
    """predict/update with the position a sample at a time and the compiled batch give the same
    numbers (one kernel each way); a filter saved mid-record and reloaded goes on the same."""
    drive = cogging_drive()
    u = slow_input(1200)
    y, position = noisy_record(drive, u, 5)
    y[100] = np.nan  # a skipped speed: the position is still held
    loop = FrictionEKF.from_rig(drive, R=NOISE**2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for k in range(u.size):
            loop.predict(u[k])
            loop.update(y[k], position=position[k])
        batch = FrictionEKF.from_rig(drive, R=NOISE**2)
        half = u.size // 2
        batch.batch_filter(u[:half], y[:half], position=position[:half])
        batch.save(tmp_path / "filter.json")
        again = load_model(tmp_path / "filter.json")
        for est in (batch, again):
            est.batch_filter(u[half:], y[half:], position=position[half:])
            np.testing.assert_array_equal(est.x, loop.x)
            np.testing.assert_array_equal(est.P, loop.P)
    assert loop.x[loop.state_names.index("position")] == position[-1]


def test_identify_runs_the_filter_on_a_record_with_its_position_and_refuses_one_without(tmp_path, capsys):
    """The application's identify takes a record's ``position`` column for a model with cogging (a
    rigid drive's simulated record has it) and refuses a record without it, naming the effect;
    ``motorid identify`` (which reads t, u and y) exits 2 with that line."""
    from motorid.app.identify import IdentifyOptions, identify_record
    from motorid.cli import main
    from motorid.errors import DataError

    drive = cogging_drive()
    drive.save(tmp_path / "cogging.json")
    record = drive.simulate(slow_input(2000))
    record["y"] += np.random.default_rng(3).normal(0.0, NOISE, len(record))
    options = IdentifyOptions(
        estimator="friction-ekf", model=tmp_path / "cogging.json", param=(f"R={NOISE**2}", "coulomb0=0.02")
    )
    payload, _, est = identify_record(record, options)
    assert payload["samples"] == len(record)
    direct = FrictionEKF.from_rig(drive, R=NOISE**2, coulomb0=0.02)
    direct.batch_filter(record["u"], record["y"], position=record["position"])
    np.testing.assert_array_equal(est.x, direct.x)
    with pytest.raises(DataError, match=r"the record: the model's cogging torque depends on the position"):
        identify_record(record.drop(columns="position"), options)
    record.to_csv(tmp_path / "rec.csv", index=False)
    args = ["identify", str(tmp_path / "rec.csv"), "--estimator", "friction-ekf"]
    args += [
        "--model",
        str(tmp_path / "cogging.json"),
        "-p",
        f"R={NOISE**2}",
        "--save-model",
        str(tmp_path / "f.json"),
    ]
    assert main(args) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[-1].endswith(
        "the model's cogging torque depends on the position, and the record read has no "
        "position column [rad or m] (an encoder's; motorid identify reads t, u and y only): the friction filter "
        "needs it at every sample"
    )
    assert not (tmp_path / "f.json").exists()
