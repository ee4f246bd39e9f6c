"""The model on new data: ``motorid compare``, ``identify --validate``, friction filters started
from a drive model file, and warnings as one line.

Every score is held against an independent computation: the model simulated directly in the
test and FIT, RMSE and low-speed RMSE recomputed there with numpy from their definitions.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid import load_model
from motorid.drive import RigidDrive, paper_rig
from motorid.io.records import read_record, write_record
from motorid.signals import two_sine_signal
from motorid.validation import rpm_to_rad_s

#: The scores leave out the first 50 samples (the --skip default): the models start from rest.
SKIP = 50
#: The default low-speed band, |y| < 150 rpm, in rad/s.
BAND = float(rpm_to_rad_s(150.0))


def fit(y: np.ndarray, y_sim: np.ndarray) -> float:
    return 100.0 * (1.0 - np.linalg.norm(y - y_sim) / np.linalg.norm(y - y.mean()))


def rmse(y: np.ndarray, y_sim: np.ndarray) -> float:
    return float(np.sqrt(np.mean((y - y_sim) ** 2)))


def rig_reading(rig, u: np.ndarray) -> np.ndarray:
    """The rig's noise-free tacho and A/D reading of its load speed for the input ``u``."""
    quiet = rig.replace(tacho=dataclasses.replace(rig.tacho, noise_std=0.0))
    return quiet.simulate(u, seed=0)["y"].to_numpy()


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """A record of the default rig (dead zone, Coulomb friction, tacho noise), a second record of
    it, the true rig's model file, a wrong one (no dead zone), a rigid drive and its record."""
    root = tmp_path_factory.mktemp("compare")
    rig = paper_rig()
    for name, seed in (("rec", 1), ("other", 2)):
        _, u = two_sine_signal(duration=30.0, seed=seed)
        write_record(rig.simulate(u, seed=seed), root / f"{name}.csv")
    rig.save(root / "true.json")
    rig.replace(amplifier=dataclasses.replace(rig.amplifier, dead_zone=0.0)).save(root / "wrong.json")
    drive = RigidDrive(
        effects=("coulomb_friction", "viscous_friction", "input_dead_zone"),
        params={"inertia": 2e-4, "input_gain": 0.02, "coulomb": 0.004, "viscous": 1e-4, "dead_zone": 0.5},
        dt=0.04,
    )
    drive.save(root / "drive.json")
    _, u = two_sine_signal(duration=60.0, seed=2)
    write_record(drive.simulate(u), root / "drive_rec.csv")
    return root


def test_compare_scores_the_true_model_at_the_sensor_noise_and_a_wrong_one_worse(capsys, files, tmp_path):
    rec = str(files / "rec.csv")
    code, out, err = run(capsys, "compare", rec, "--model", str(files / "true.json"),
                         "--model", str(files / "wrong.json"), "--out", str(tmp_path / "figs"), "--json")  # fmt: skip
    assert code == 0, err
    record = read_record(files / "rec.csv")
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    noise = rmse(y[SKIP:], record["omega_l"].to_numpy()[SKIP:])  # the tacho and A/D error of the record
    true, wrong = out["models"][str(files / "true.json")], out["models"][str(files / "wrong.json")]
    # the true model misses only the sensor noise: measured 1.01 x the noise (0.43 rad/s), FIT 99.0 %
    assert true["rmse"] < 1.1 * noise and true["fit_percent"] > 98.0
    # without the dead zone the free run drifts at every slow stretch: measured 26 x the noise, FIT 75 %
    assert wrong["rmse"] > 10.0 * noise and wrong["fit_percent"] < true["fit_percent"] - 10.0
    assert wrong["low_speed_rmse"] > 5.0 * true["low_speed_rmse"]
    # the numbers: the rig simulated here and every score recomputed from its definition; the same
    # simulation on the same machine, so equal to rounding (1e-9 relative)
    for name, row in (("true", true), ("wrong", wrong)):
        y_sim = rig_reading(load_model(files / f"{name}.json"), u)[SKIP:]
        slow = np.abs(y[SKIP:]) < BAND
        assert row["fit_percent"] == pytest.approx(fit(y[SKIP:], y_sim), rel=1e-9)
        assert row["rmse"] == pytest.approx(rmse(y[SKIP:], y_sim), rel=1e-9)
        assert row["low_speed_rmse"] == pytest.approx(rmse(y[SKIP:][slow], y_sim[slow]), rel=1e-9)
        assert row["n_low_speed"] == int(slow.sum()) and row["kind"] == "two-mass rig"
    assert "FIT [%]" in err and "RMSE [rad/s]" in err and "true.json" in err and "wrong.json" in err
    assert (
        Path(out["figure"]) == tmp_path / "figs" / "compare.png"
        and Path(out["figure"]).stat().st_size > 10_000
    )


def test_compare_figure_has_units_on_every_axis_and_a_legend(files):
    from motorid.comparison import compare_models

    record = read_record(files / "rec.csv")
    models = {name: load_model(files / f"{name}.json") for name in ("true", "wrong")}
    fig = compare_models(record, models, BAND, SKIP).figure("V")
    axes = fig.axes
    assert [ax.get_title() for ax in axes] == [
        "whole record",
        f"low speed (|y| < {BAND:.3g} rad/s)",
        "a reversal of the measured output",
    ]
    for ax in axes:
        assert ax.get_xlabel() == "time t [s]" and ax.get_ylabel() == "output y [rad/s]"
        labels = [text.get_text() for text in ax.get_legend().get_texts()]
        assert (
            labels[0] == "measured"
            and labels[1].startswith("true (FIT 99.")
            and labels[2].startswith("wrong")
        )
    # the low-speed panel shows mostly slow samples; the reversal panel a change of sign
    low, reversal = (ax.get_lines()[0].get_ydata() for ax in axes[1:])
    assert np.mean(np.abs(low) < BAND) > 0.8 and low.size == 125
    assert reversal.max() > 0.5 * BAND and reversal.min() < -0.5 * BAND
    # the low-speed panel on the band's axis, whatever faster samples its window holds
    assert axes[1].get_ylim() == pytest.approx((-2.0 * BAND, 2.0 * BAND))


def test_compare_json_structure(capsys, files):
    code, out, err = run(
        capsys, "compare", str(files / "rec.csv"), "--model", str(files / "true.json"), "--json"
    )
    assert code == 0, err
    assert set(out) == {"record", "samples", "scored_samples", "dt", "timing", "skip", "output_unit",
                        "low_speed_threshold", "models", "figure"}  # fmt: skip
    assert out["samples"] == 750 and out["scored_samples"] == 700 and out["skip"] == SKIP
    assert out["output_unit"] == "rad/s" and out["timing"] == "hold" and out["figure"] is None
    assert out["low_speed_threshold"] == pytest.approx(BAND)
    (row,) = out["models"].values()
    assert set(row) == {"kind", "fit_percent", "rmse", "low_speed_rmse", "mse", "low_speed_mse", "n_low_speed",
                        "diverges_from_sample", "notes"}  # fmt: skip
    assert row["mse"] == pytest.approx(row["rmse"] ** 2)
    assert "motorid compare" in err  # human text on stderr, the JSON alone on stdout


def test_compare_skip_and_low_speed_band(capsys, files):
    true = str(files / "true.json")
    code, out, err = run(capsys, "compare", str(files / "rec.csv"), "--model", true, "--skip", "100",
                         "--low-speed-rpm", "50", "--json")  # fmt: skip
    assert code == 0, err
    record = read_record(files / "rec.csv")
    y = record["y"].to_numpy()[100:]
    y_sim = rig_reading(load_model(files / "true.json"), record["u"].to_numpy())[100:]
    band = float(rpm_to_rad_s(50.0))
    slow = np.abs(y) < band
    row = out["models"][true]
    assert out["scored_samples"] == 650 and out["low_speed_threshold"] == pytest.approx(band)
    assert row["n_low_speed"] == int(slow.sum()) and row["rmse"] == pytest.approx(rmse(y, y_sim), rel=1e-9)
    assert row["low_speed_rmse"] == pytest.approx(rmse(y[slow], y_sim[slow]), rel=1e-9)


def test_compare_an_identified_estimator_equals_its_own_simulation(capsys, files, tmp_path):
    est_file = tmp_path / "est.json"
    code, _, err = run(
        capsys, "identify", str(files / "rec.csv"), "--basis", "u,sign", "--save-model", str(est_file)
    )
    assert code == 0, err
    code, out, err = run(capsys, "compare", str(files / "other.csv"), "--model", str(est_file), "--json")
    assert code == 0, err
    other = read_record(files / "other.csv")
    y = other["y"].to_numpy()[SKIP:]
    y_sim = load_model(est_file).simulate(other["u"].to_numpy())[SKIP:]
    row = out["models"][str(est_file)]
    assert row["kind"] == "estimator hammerstein-rls"
    assert row["fit_percent"] == pytest.approx(fit(y, y_sim), rel=1e-9)
    assert row["rmse"] == pytest.approx(rmse(y, y_sim), rel=1e-9)


def test_compare_a_rigid_drive_on_its_own_record_in_either_timing(capsys, files, tmp_path):
    """A rigid drive's record is noise free: its own model reproduces it exactly. The same
    record logged by a sampled loop (y read before u is applied: y_s[k+1] = y[k]) is paired
    back, so the model still reproduces it."""
    drive_file = str(files / "drive.json")
    code, out, err = run(capsys, "compare", str(files / "drive_rec.csv"), "--model", drive_file, "--json")
    assert code == 0, err
    row = out["models"][drive_file]
    assert row["kind"] == "rigid drive" and row["rmse"] < 1e-9 and row["fit_percent"] > 100.0 - 1e-7
    record = read_record(files / "drive_rec.csv")
    sampled = record.copy()
    sampled["y"] = np.concatenate([[0.0], record["y"].to_numpy()[:-1]])
    sampled.attrs = {**record.attrs, "timing": "sampled"}
    write_record(sampled, tmp_path / "sampled.csv")
    code, out, err = run(capsys, "compare", str(tmp_path / "sampled.csv"), "--model", drive_file, "--json")
    assert code == 0, err
    assert out["timing"] == "sampled" and out["samples"] == len(record)
    assert out["models"][drive_file]["rmse"] < 1e-9


def test_compare_runs_a_drive_model_at_the_records_sample_time_and_says_so(capsys, files, tmp_path):
    drive = load_model(files / "drive.json")
    _, u = two_sine_signal(duration=20.0, dt=0.01, seed=3)
    write_record(drive.replace(dt=0.01).simulate(u), tmp_path / "fast.csv")
    code, out, err = run(
        capsys, "compare", str(tmp_path / "fast.csv"), "--model", str(files / "drive.json"), "--json"
    )
    assert code == 0, err
    row = out["models"][str(files / "drive.json")]
    assert row["rmse"] < 1e-9  # the physics at the record's 10 ms, not the file's 40 ms
    assert "dt = 0.01 s" in row["notes"][0] and "0.04 s" in row["notes"][0] and "note:" in err


def test_compare_a_duty_record_through_a_rigid_drive_says_so(capsys, files, tmp_path):
    record = read_record(files / "drive_rec.csv")[["t", "u", "y"]]
    record.to_csv(tmp_path / "duty.csv", index=False)  # a plain CSV: its input read as % duty
    code, out, err = run(capsys, "compare", str(tmp_path / "duty.csv"), "--input-unit", "%",
                         "--model", str(files / "drive.json"), "--json")  # fmt: skip
    assert code == 0, err
    (row,) = out["models"].values()
    assert "input gain" in row["notes"][0] and row["rmse"] < 1e-9


def test_compare_runs_a_rigid_drive_in_position_on_a_record_of_positions(capsys, files, tmp_path):
    """The drive's own record of positions (its ``position`` column as ``y``, in rad): the drive,
    from rest and placed at the first measured position, repeats it: its start is the record's,
    and the sample time read back from the plain CSV's time column, 0.04 s to 2e-14, moves
    positions of up to 2e3 rad by about 2e-11 rad, so 1e-9 rad bounds it. The low-speed band is judged on the speed of the positions. A two-mass rig
    gives a velocity and still refuses a position."""
    record = read_record(files / "drive_rec.csv")
    positions = record[["t", "u", "position"]].rename(columns={"position": "y"})
    positions.to_csv(tmp_path / "position.csv", index=False)
    wrong = load_model(files / "drive.json").with_params(coulomb=0.006)
    wrong.save(tmp_path / "wrong_drive.json")
    code, out, err = run(capsys, "compare", str(tmp_path / "position.csv"), "--output-unit", "rad",
                         "--model", str(files / "drive.json"), "--model", str(tmp_path / "wrong_drive.json"),
                         "--skip", str(SKIP), "--out", str(tmp_path / "figs"), "--json")  # fmt: skip
    assert code == 0, err
    own, other = out["models"][str(files / "drive.json")], out["models"][str(tmp_path / "wrong_drive.json")]
    assert np.max(np.abs(positions["y"])) < 2e3
    assert own["rmse"] < 1e-9 and own["fit_percent"] == pytest.approx(100.0, abs=1e-9)
    assert other["rmse"] > 0.05 and other["fit_percent"] < own["fit_percent"]
    y = positions["y"].to_numpy()
    assert own["n_low_speed"] == int(np.sum(np.abs(np.gradient(y, 0.04)[SKIP:]) < BAND))
    assert "|dy/dt|" in err and (tmp_path / "figs" / "compare.png").exists()
    code, _, err = run(capsys, "compare", str(tmp_path / "position.csv"), "--output-unit", "deg",
                       "--model", str(files / "true.json"))  # fmt: skip
    assert (
        code == 2 and "position in rad" in err and "true.json" in err and len(err.strip().splitlines()) == 1
    )
    code, _, err = run(capsys, "compare", str(tmp_path / "position.csv"), "--output-unit", "m/s",
                       "--model", str(files / "true.json"))  # fmt: skip
    assert code == 2 and "rad/s" in err and "m/s" in err


def test_identify_validate_equals_the_estimators_simulation_on_the_other_record(capsys, files, tmp_path):
    est_file = tmp_path / "est.json"
    code, out, err = run(capsys, "identify", str(files / "rec.csv"), "--basis", "u,sign", "--validate",
                         str(files / "other.csv"), "--save-model", str(est_file), "--json")  # fmt: skip
    assert code == 0, err
    other = read_record(files / "other.csv")
    y = other["y"].to_numpy()[SKIP:]
    y_sim = load_model(est_file).simulate(other["u"].to_numpy())[
        SKIP:
    ]  # the model as identified, not refitted
    validation = out["validation"]
    row = validation["scores"]["free_run"]
    slow = np.abs(y) < BAND
    assert validation["record"] == str(files / "other.csv") and validation["samples"] == len(other)
    assert row["mse"] == pytest.approx(np.mean((y - y_sim) ** 2), rel=1e-9)
    assert row["fit_percent"] == pytest.approx(fit(y, y_sim), rel=1e-9)
    assert row["low_speed_mse"] == pytest.approx(np.mean((y[slow] - y_sim[slow]) ** 2), rel=1e-9)
    assert "without refitting" in err and f"FIT {row['fit_percent']:.2f} %" in err
    code, out, _ = run(capsys, "identify", str(files / "rec.csv"), "--json")
    assert code == 0 and "validation" not in out  # as the doctor's: only with --validate


def test_friction_ekf_from_a_rigid_drive_file_converges_to_its_friction(capsys, files):
    """The filter takes the drive's inertia, gain and dead zone from the file; started from a
    Coulomb level a quarter of the file's and no viscous friction, it finds both on the drive's
    noise-free record (60 s of reversals and slow stretches)."""
    code, out, err = run(capsys, "identify", str(files / "drive_rec.csv"), "--estimator", "friction-ekf",
                         "--model", str(files / "drive.json"), "--param", "R=0.01", "--param", "coulomb0=0.001",
                         "--param", "viscous0=0", "--json")  # fmt: skip
    assert code == 0, err
    p = load_model(files / "drive.json").params
    # measured: coulomb 0.00410 (2.5 % off), viscous 9.92e-5 (0.8 % off); 5 % is twice the Coulomb error
    assert out["params"]["coulomb"] == pytest.approx(p["coulomb"], rel=0.05)
    assert out["params"]["viscous"] == pytest.approx(p["viscous"], rel=0.05)


def test_friction_ekf_on_a_sampled_record_pairs_each_input_with_the_next_output(capsys, files, tmp_path):
    """The drive's record logged by a sampled loop (y_s[k+1] = y[k]): the filter, a physical
    model, is given u[k] with y_s[k+1] and finds the same friction as on the hold record."""
    record = read_record(files / "drive_rec.csv")
    sampled = record.copy()
    sampled["y"] = np.concatenate([[0.0], record["y"].to_numpy()[:-1]])
    sampled.attrs = {**record.attrs, "timing": "sampled"}
    write_record(sampled, tmp_path / "sampled.csv")
    code, out, err = run(capsys, "identify", str(tmp_path / "sampled.csv"), "--estimator", "friction-ekf",
                         "--model", str(files / "drive.json"), "--param", "R=0.01", "--param", "coulomb0=0.001",
                         "--param", "viscous0=0", "--json")  # fmt: skip
    assert code == 0, err
    p = load_model(files / "drive.json").params
    assert out["params"]["coulomb"] == pytest.approx(p["coulomb"], rel=0.05)  # as on the hold record
    assert out["params"]["viscous"] == pytest.approx(p["viscous"], rel=0.05)
    assert "y[k+1]" in out["notes"][0] and "y[k+1]" in err


def test_friction_ekf_from_the_true_rig_file(capsys, files):
    code, out, err = run(capsys, "identify", str(files / "rec.csv"), "--estimator", "friction-ekf",
                         "--model", str(files / "true.json"), "--json")  # fmt: skip
    assert code == 0, err
    rig = paper_rig()
    total = sum(
        f.params["coulomb"] for f in rig.friction
    )  # the filter estimates the friction on both masses as one
    assert out["params"]["coulomb"] == pytest.approx(total, rel=0.2)
    assert out["notes"] == [] and "diverged" not in err


def test_friction_ekf_on_a_duty_record_with_a_rig_in_volts_is_refused(capsys, files, tmp_path):
    record = read_record(files / "rec.csv")[["t", "u", "y"]]
    record.to_csv(tmp_path / "duty.csv", index=False)
    code, _, err = run(capsys, "identify", str(tmp_path / "duty.csv"), "--input-unit", "%",
                       "--estimator", "friction-ekf", "--model", str(files / "true.json"))  # fmt: skip
    assert code == 2 and "%" in err and "--supply-voltage" in err and len(err.strip().splitlines()) == 1


def test_a_warning_is_one_line_on_stderr(files):
    """The friction EKF started far from the truth diverges and warns; the user sees one line,
    not Python's source line."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    done = subprocess.run(
        [sys.executable, "-m", "motorid.cli", "identify", str(files / "rec.csv"), "--estimator", "friction-ekf",
         "--param", "coulomb0=1"],
        capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    warned = [line for line in lines if "warn" in line.lower()]
    assert len(warned) == 1 and warned[0].startswith("motorid: warning: friction-ekf diverged at sample"), (
        lines
    )
    assert not any(line.startswith(" ") and "warnings.warn" in line for line in lines)
    assert not any("Warning:" in line for line in lines)  # no "RuntimeWarning: ..." of Python's format


WHEEL_TRAIN, WHEEL_VALIDATION = (
    real_motor_file(f"wheel_free_{w}_motor1.csv") for w in ("train", "validation")
)
WHEEL_UNITS = ["--input-unit", "%", "--output-unit", "rev/s"]


@pytest.mark.skipif(
    not (WHEEL_TRAIN.exists() and WHEEL_VALIDATION.exists()),
    reason=f"real motor data not found at {WHEEL_TRAIN.parent} (set MOTORID_DATA)",
)
def test_a_real_motors_model_on_its_validation_record(capsys, files, tmp_path):
    """A lifted robot wheel (``realmotors/``: PWM duty in %, speed in rev/s): the doctor's model
    fitted on the train record, compared on the validation record; the duty goes through its
    input gain, and a rig whose input is volts, or a friction filter without a model, is refused."""
    model = tmp_path / "wheel.json"
    code, _, err = run(capsys, "doctor", str(WHEEL_TRAIN), *WHEEL_UNITS, "--save-model", str(model))
    assert code == 0, err
    code, out, err = run(
        capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--model", str(model), "--json"
    )
    assert code == 0, err
    row = out["models"][str(model)]
    # measured FIT 92.3 %, RMSE 5.7 rad/s of speeds up to 80 rad/s; the output converted from rev/s
    assert row["fit_percent"] > 85.0 and out["output_unit"] == "rad/s" and out["samples"] == 6000
    # the model's card says it was fitted on % duty, as the record is: nothing assumed, nothing said
    assert row["notes"] == []
    code, _, err = run(
        capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--model", str(files / "true.json")
    )
    assert code == 2 and "--supply-voltage" in err
    code, _, err = run(capsys, "identify", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--estimator", "friction-ekf")
    assert code == 2 and "--model" in err and len(err.strip().splitlines()) == 1


# --------------------------------------------------------------------------- a record in blocks
#: Rows per block of the streamed comparisons: a prime, so that no block boundary falls on a
#: round sample and the sampled pairing's carry crosses each boundary mid-signal.
AWKWARD_ROWS = 997
#: FIT, RMSE and low-speed RMSE from running sums against numpy's whole-array sums: the free runs
#: are the same to the last bit, so only the order of the additions differs (a few ulp per
#: sum: 1e-12 relative is a thousand times that on these few thousand samples).
SUMS_RTOL = 1e-12


@pytest.fixture(scope="module")
def long_files(files, tmp_path_factory) -> Path:
    """A 120 s record of the default rig (3000 samples: four blocks of 997 rows), a rigid drive's
    model and an ARX model identified on the rig's record."""
    from motorid.estimators.arx import ARXRLS

    root = tmp_path_factory.mktemp("compare_long")
    _, u = two_sine_signal(duration=120.0, seed=4)
    record = paper_rig().simulate(u, seed=4)
    write_record(record, root / "long.csv")
    est = ARXRLS(na=2, nb=2)
    est.batch_filter(record["u"].to_numpy(), record["y"].to_numpy())
    est.save(root / "arx.json")
    return root


def _blocks(path: Path, timing: str, rows: int = AWKWARD_ROWS):
    from motorid.io.records import iter_record

    for block in iter_record(path, chunk_rows=rows):
        block.attrs["timing"] = timing
        yield block


@pytest.mark.parametrize("timing", ["hold", "sampled"])
def test_compare_in_blocks_equals_the_whole_record(files, long_files, timing):
    """A two-mass rig, a rigid drive and an ARX model on a record read in blocks of 997 rows:
    each free run is the whole record's to the last bit, the scores equal the whole record's
    within the rounding of running sums, in either timing (the sampled pairing carried across
    the blocks)."""
    from motorid.comparison import BlockFreeRun, compare_blocks, compare_models, free_run_on_record

    path = long_files / "long.csv"
    record = read_record(path)
    record.attrs["timing"] = timing
    models = {
        "rig": load_model(files / "true.json"),
        "drive": load_model(files / "drive.json"),
        "arx": load_model(long_files / "arx.json"),
    }
    u, dt = record["u"].to_numpy(), record.attrs["dt"]
    for name, model in models.items():
        run_in_blocks = BlockFreeRun(model, dt, timing, name)
        streamed = np.concatenate([run_in_blocks(b["u"].to_numpy()) for b in _blocks(path, timing)])
        np.testing.assert_array_equal(streamed, free_run_on_record(model, u, dt, timing, name))
    whole = compare_models(record, models, BAND, SKIP)
    blocks = compare_blocks(_blocks(path, timing), models, BAND, SKIP)
    assert blocks.to_dict().keys() == whole.to_dict().keys()
    assert blocks.to_dict()["samples"] == len(record) == 3000
    for a, b in zip(whole.models, blocks.models, strict=True):
        assert (a.name, a.kind, a.n_low_speed, a.diverges_from) == (
            b.name,
            b.kind,
            b.n_low_speed,
            b.diverges_from,
        )
        assert a.n_low_speed > 100  # the low-speed RMSE is over a real band
        for key in ("fit_percent", "rmse", "low_speed_rmse", "mse", "low_speed_mse"):
            assert getattr(b, key) == pytest.approx(getattr(a, key), rel=SUMS_RTOL, abs=0.0), (a.name, key)
        # 3000 samples fit in the envelope's 4000 runs: the whole-record panel holds every sample
        np.testing.assert_array_equal(b.y_sim[blocks.windows[next(iter(blocks.windows))]], a.y_sim)


def test_compare_in_blocks_figure_is_a_bounded_view_of_the_record(files, long_files):
    """Blocks of 16 rows, an envelope of at most 64 runs: the whole-record panel shows each run's
    minimum and maximum (the measured output's extremes stay in it); the low-speed window is the
    whole read's (the same samples), and the reversal panel changes sign."""
    from motorid.comparison import compare_blocks
    from motorid.figures import low_speed_window

    path = long_files / "long.csv"
    record = read_record(path)
    y = record["y"].to_numpy()
    models = {"rig": load_model(files / "true.json")}
    import motorid.diagnose.figures as diagnose_figures

    buckets = diagnose_figures.MAX_BUCKETS
    diagnose_figures.MAX_BUCKETS = 64
    try:
        blocks = compare_blocks(_blocks(path, "hold", rows=16), models, BAND, SKIP)
    finally:
        diagnose_figures.MAX_BUCKETS = buckets
    whole_title, low_title, reversal_title = blocks.windows
    assert whole_title.startswith("whole record (minimum and maximum of every 64 samples)")
    shown = blocks.y[blocks.windows[whole_title]]
    assert shown.size <= 2 * 64 and shown.max() == y.max() and shown.min() == y.min()
    width = round(5.0 / record.attrs["dt"])
    expected = low_speed_window(y, width, BAND, SKIP)
    np.testing.assert_array_equal(blocks.y[blocks.windows[low_title]], y[expected])
    reversal = blocks.y[blocks.windows[reversal_title]]
    assert reversal.size == width and reversal.max() > 0.5 * BAND and reversal.min() < -0.5 * BAND
    fig = blocks.figure("V")
    assert [ax.get_title() for ax in fig.axes] == list(blocks.windows)


def test_compare_in_blocks_memory_does_not_grow_with_the_record():
    """compare_blocks on 200,000 and on 800,000 samples given in blocks of 8,192: the peak of
    Python's allocations is the same (the view holds the last 2 x 5,000 samples of 4 series,
    320 kB, and at most 4,000 runs' min and max, 256 kB; a block's arrays and the model's run
    on it, a few hundred kB), and far below the 800,000 samples' three columns (19 MB)."""
    import tracemalloc

    import pandas as pd

    from motorid.comparison import compare_blocks
    from motorid.estimators.arx import ARXRLS

    dt, rows = 0.001, 8192
    est = ARXRLS(na=1, nb=1)
    est.x = np.array([-0.9, 0.5, 0.5])

    def blocks(samples: int):
        for start in range(0, samples, rows):
            k = np.arange(start, min(start + rows, samples))
            u = np.sin(2 * np.pi * 0.3 * k * dt)
            block = pd.DataFrame({"t": k * dt, "u": u, "y": 10.0 * u}, index=k)
            block.attrs = {"dt": dt, "units": {"t": "s", "u": "V", "y": "rad/s"}, "timing": "hold"}
            yield block

    peaks = []
    for samples in (200_000, 800_000):
        tracemalloc.start()
        compare_blocks(blocks(samples), {"arx": est}, BAND, SKIP)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[1] < 1.25 * peaks[0], peaks
    assert peaks[1] < 5_000_000 < 800_000 * 3 * 8, peaks


def test_compare_streams_a_record_longer_than_max_samples_with_the_whole_reads_numbers(
    capsys, files, long_files, tmp_path
):
    """``motorid compare`` reads the record in blocks, so ``--max-samples 1000`` does not refuse the
    3000-sample record: the JSON keys of a comparison, and the scores of compare_models on the
    record read whole, and the figure written."""
    from motorid.comparison import compare_models

    path = long_files / "long.csv"
    models = {str(files / "true.json"): None, str(long_files / "arx.json"): None}
    argv = [arg for name in models for arg in ("--model", name)]
    code, out, err = run(capsys, "compare", str(path), *argv, "--max-samples", "1000", "--out",
                         str(tmp_path / "fig"), "--json")  # fmt: skip
    assert code == 0, err
    assert set(out) == {"record", "samples", "scored_samples", "dt", "timing", "skip", "output_unit",
                        "low_speed_threshold", "models", "figure"}  # fmt: skip
    assert out["samples"] == 3000 and Path(out["figure"]).is_file()
    whole = compare_models(read_record(path), {name: load_model(name) for name in models}, BAND, SKIP)
    for model in whole.models:
        row = out["models"][model.name]
        assert set(row) == set(model.scores())
        for key in ("fit_percent", "rmse", "low_speed_rmse", "mse", "low_speed_mse"):
            assert row[key] == pytest.approx(getattr(model, key), rel=SUMS_RTOL, abs=0.0)
        assert row["n_low_speed"] == model.n_low_speed


def test_compare_takes_a_friction_filter_whole_and_refuses_one_longer_than_max_samples(
    capsys, files, tmp_path
):
    from motorid.estimators import create

    create("friction-ekf").save(tmp_path / "ekf.json")
    argv = [
        "compare",
        str(files / "rec.csv"),
        "--model",
        str(tmp_path / "ekf.json"),
        "--model",
        str(files / "true.json"),
    ]
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    assert out["samples"] == 750 and set(out["models"]) == {
        str(tmp_path / "ekf.json"),
        str(files / "true.json"),
    }
    code, _, err = run(capsys, *argv, "--max-samples", "700")
    assert code == 2 and "longer than --max-samples 700" in err and "friction-ekf" in err
