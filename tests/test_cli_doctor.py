"""``motorid doctor``: one JSON object on stdout, text on stderr, figures, clear errors."""

from __future__ import annotations

import re

import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import emps_folder, force_error_percent, published_inverse_dynamics, requires_emps

from motorid.diagnose.synthetic import planted_record
from motorid.io.records import write_record


@pytest.fixture(scope="module")
def planted():
    return planted_record("coulomb_friction", 7, sizes={"coulomb": 8e-3})


@pytest.fixture(scope="module")
def record_csv(tmp_path_factory, planted):
    path = tmp_path_factory.mktemp("doctor") / "rec.csv"
    rec = planted.record.rename(columns={"u": "volts", "y": "speed"})
    rec.attrs = dict(planted.record.attrs)
    write_record(rec, path)
    return path


def test_doctor_json_names_the_hidden_effect(capsys, record_csv, planted, tmp_path):
    code, out, err = run(
        capsys, "doctor", str(record_csv), "--input", "volts", "--output", "speed", "--output-kind", "velocity",
        "--input-gain", repr(planted.input_gain), "--base", "viscous_friction,offset", "--json",
        "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0, err
    assert {"initial_gap", "final_gap", "steps", "stop_reason"} <= set(out)
    assert out["steps"][0]["effect"] == "coulomb_friction"
    step = out["steps"][0]
    assert {"effect", "params", "region", "gap_before", "gap_after", "evidence"} <= set(step)
    assert step["params"]["coulomb"] == pytest.approx(8e-3, rel=0.15)
    assert step["gap_after"]["region"] < step["gap_before"]["region"]
    assert out["final_gap"]["overall"] < out["initial_gap"]["overall"]
    assert isinstance(out["stop_reason"], str) and out["stop_reason"]
    # the final gap against the record's noise floor, in the JSON and in words; one effect planted, one named
    ratio = out["final_gap"]["overall"] / out["noise_floor"]
    assert (
        out["stop_reason"].endswith("at the noise floor, nothing more to explain")
        and f"= {ratio:.1f} x" in (out["stop_reason"])
    )
    assert [s["effect"] for s in out["steps"]] == ["coulomb_friction"]
    assert all((tmp_path / p.split("/")[-1]).exists() for p in out["figures"]) and len(out["figures"]) == 2
    assert (tmp_path / "doctor_table.csv").exists()
    assert "coulomb_friction" in err and "stopped:" in err
    assert out["units"]["force"] == "N m" and re.search(r"coulomb = \S+ N m\b", err)
    # the text reads each step's typed evidence: its line gives the ΔBIC the JSON holds
    for s in out["steps"]:
        assert re.search(rf"\+ {s['effect']}: .* \(ΔBIC {s['evidence']['delta_bic']:.1f}\)\n", err), err
    # stderr is not a terminal here: no progress bar (tests/test_cli_output.py shows it on one)
    assert "stage" not in err and "\r" not in err


def test_doctor_takes_dt_from_the_command_line(capsys, planted, tmp_path):
    bare = tmp_path / "bare.csv"
    planted.record[["u", "y"]].to_csv(bare, index=False)  # no time column, no attribute line
    code, out, err = run(capsys, "doctor", str(bare), "--dt", "0.01", "--max-steps", "1", "--json")
    assert code == 0, err
    assert out["settings"]["dt"] == pytest.approx(0.01) and len(out["steps"]) <= 1
    # no --input-gain and no unit in the file: forces are per input unit, and say so
    assert out["units"]["force"] == out["units"]["params"]["coulomb"] == "input units"
    assert "forces are per input unit, in input units" in err


def test_doctor_without_input_gain_reports_forces_in_the_input_unit(capsys, record_csv, tmp_path):
    code, out, err = run(
        capsys, "doctor", str(record_csv), "--input", "volts", "--output", "speed", "--max-steps", "1",
        "--json", "--out", str(tmp_path),
    )  # fmt: skip
    assert code == 0, err
    assert out["units"]["force"] == out["units"]["params"]["coulomb"] == "V"
    assert re.search(r"coulomb = \S+ V\b", err) and "N m" not in err


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--output", "speed_rpm"], ["speed_rpm"]),
        (["--input", "v"], ["'v'"]),
        (["--base", "viscous_friction,coulomb"], ["--base", "'coulomb'"]),
        (["--candidates", "friction"], ["--candidates", "'friction'"]),
        (["--dt", "0"], ["--dt"]),
        (["--dt", "-0.01"], ["--dt"]),
        (["--input-gain", "-2"], ["--input-gain"]),
        (["--holdout", "2"], ["holdout"]),
        (["--validate", "no_such_record.csv"], ["no_such_record.csv"]),
    ],
)
def test_doctor_bad_arguments_exit_2_naming_the_problem(capsys, record_csv, args, words):
    base = ["doctor", str(record_csv), "--input", "volts", "--output", "speed"]
    if "--input" in args:
        base = ["doctor", str(record_csv), "--output", "speed"]
    code, out, err = run(capsys, *base, *args, "--json")
    assert code == 2 and out == ""
    assert all(w in err for w in words), err


def test_doctor_names_a_nan_sample(capsys, record_csv, tmp_path):
    broken = tmp_path / "broken.csv"
    df = pd.read_csv(record_csv, comment="#")
    df.loc[57, "speed"] = float("nan")
    df.to_csv(broken, index=False)
    code, _, err = run(capsys, "doctor", str(broken), "--input", "volts", "--output", "speed")
    assert code == 2 and "'speed'" in err and "57" in err
    code, _, err = run(capsys, "doctor", str(tmp_path / "missing.csv"))
    assert code == 2 and "no such file" in err


# --------------------------------------------------------------------------- the user's own model
def stribeck_rig():
    """The measured drive: the paper's rig (stiff shaft, 100 Hz) with Stribeck friction on the motor."""
    from motorid.drive import Friction, paper_rig

    friction = (
        Friction(("coulomb_friction",), {"coulomb": 4e-3}, side="motor"),
        Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="load"),
        Friction(("stribeck_friction",), {"stribeck": 6e-3, "stribeck_velocity": 10.0}, side="motor"),
    )  # fmt: skip
    return paper_rig(dt=0.01, substeps=20, k_s=20.0, B_s=0.02, friction=friction)


def datasheet_model(rig):
    """The user's simulation from the datasheet: right inertia, gain, losses and dead zone, no Stribeck."""
    from motorid.drive import RigidDrive

    params = {
        "inertia": rig.J_m + rig.J_l, "input_gain": rig.K_m / rig.R_a, "coulomb": 6e-3,
        "viscous": rig.K_m**2 / rig.R_a + rig.B_m + rig.B_l, "offset": 0.0, "dead_zone": 0.6,
    }  # fmt: skip
    return RigidDrive(("coulomb_friction", "viscous_friction", "offset", "input_dead_zone"), params, rig.dt)


def test_doctor_improves_the_users_model_and_the_saved_model_predicts_a_fresh_measurement(capsys, tmp_path):
    import numpy as np

    from motorid.io.records import read_record

    rig = stribeck_rig()
    rig.save(tmp_path / "truth.json")
    datasheet_model(rig).save(tmp_path / "datasheet.json")
    signal = ("--duration", "60", "--signal", "paper")
    code, _, err = run(capsys, "simulate", "--model", str(tmp_path / "truth.json"), "--out",
                       str(tmp_path / "meas.csv"), *signal, "--seed", "1", "--plant-seed", "1")  # fmt: skip
    assert code == 0, err
    code, out, err = run(capsys, "doctor", str(tmp_path / "meas.csv"), "--model", str(tmp_path / "datasheet.json"),
                         "--save-model", str(tmp_path / "improved.json"), "--json")  # fmt: skip
    assert code == 0, err
    assert out["steps"][0]["effect"] == "stribeck_friction"
    assert out["settings"]["model"] == "given" and out["settings"]["base"] == [
        "coulomb_friction", "viscous_friction", "input_dead_zone", "offset"]  # fmt: skip
    # the first gap is the datasheet model as given; refitting its effects cannot close the gap, Stribeck does
    assert out["initial_model"]["params"]["coulomb"] == 6e-3
    assert (
        out["final_gap"]["overall"]
        < 0.5 * out["refitted_gap"]["overall"]
        < 0.5 * out["initial_gap"]["overall"]
    )
    assert "gap of the given model" in err and "wrote" in err and (tmp_path / "improved.json").exists()

    # a different input: the saved model simulated without refitting against a fresh measurement of the drive
    for name, model in (("fresh", "truth"), ("improved_sim", "improved"), ("datasheet_sim", "datasheet")):
        code, _, err = run(capsys, "simulate", "--model", str(tmp_path / f"{model}.json"), "--out",
                           str(tmp_path / f"{name}.csv"), *signal, "--seed", "2", "--plant-seed", "5")  # fmt: skip
        assert code == 0, err
    fresh = read_record(tmp_path / "fresh.csv")
    y = fresh["y"].to_numpy()
    noise = float(np.std(y - fresh["omega_l"].to_numpy()))  # the tacho and A/D error of the fresh record
    rms = {m: float(np.sqrt(np.mean((read_record(tmp_path / f"{m}_sim.csv")["y"].to_numpy() - y) ** 2)))
           for m in ("improved", "datasheet")}  # fmt: skip
    # measured: 1.23 x the noise (0.42 rad/s) for the improved model, 3.6 x for the datasheet's
    assert rms["improved"] < 1.4 * noise
    assert rms["datasheet"] > 2.5 * noise

    from motorid import load_model

    # a rigid drive's record holds its position too, from the same compiled free run as its speed
    simulated = read_record(tmp_path / "improved_sim.csv")
    speed, position = load_model(tmp_path / "improved.json").motion(simulated["u"].to_numpy())
    np.testing.assert_array_equal(simulated["y"].to_numpy(), speed)  # the CSV keeps every digit
    np.testing.assert_array_equal(simulated["position"].to_numpy(), position)

    # the friction filter started from the improved model tracks the fresh measurement online
    from motorid.estimators import FrictionEKF
    from motorid.estimators.friction_kf import tacho_variance

    improved = load_model(tmp_path / "improved.json")
    p = improved.params
    ekf = FrictionEKF.from_rig(
        improved, R=tacho_variance(rig)
    )  # R: the drive's tacho and A/D, from its datasheet
    assert ekf.state_names == ("omega", "coulomb", "viscous", "stribeck")
    np.testing.assert_array_equal(ekf.x, [0.0, p["coulomb"], p["viscous"], p["stribeck"]])
    assert ekf.stribeck_decay == 1.0 / p["stribeck_velocity"]
    result = ekf.batch_filter(fresh["u"], y)
    nis = result.innovation**2 / result.S
    # A consistent filter's innovations are white with NIS ~ chi2(1), so the mean over the
    # N = 6000 samples is chi2(N)/N: 99 % band 1 +- 2.58 sqrt(2/N) = [0.953, 1.047]
    # (measured 0.988); and the windowed mean never passes divergence_nis.
    band = 2.58 * np.sqrt(2.0 / nis.size)
    assert abs(nis.mean() - 1.0) < band and not ekf.diverged


@requires_emps
def test_doctor_saved_emps_model_validates_below_the_published_force_error(capsys, tmp_path):
    """EMPS: the doctor's model saved from the estimation set (from the published structure
    without Coulomb friction: inertia, viscous, offset), run unchanged on the validation set
    (DATA_EMPS_PULSES.mat). On the published recipe (tests/emps_fixtures.py) the published
    model's force error is 6.00 % there (published: 5.98 %); the saved model must do better
    than the published figure. Measured: 5.28 % on that recipe, 3.17 % on the doctor's own
    torque balance (its given-model gap on the validation record). The file holds the model
    refitted in position (the doctor's best on EMPS, said in its text): its force error on the
    recipe is 6.42 %, so the recipe's figure is that of the balance fit of ``--json``."""

    import scipy.signal

    from motorid import load_model
    from motorid.datasets import EMPS_REFERENCE, load_emps
    from motorid.drive import RigidDrive

    records = {which: load_emps(emps_folder(), which=which) for which in ("estimation", "validation")}
    for which, rec in records.items():
        write_record(rec, tmp_path / f"{which}.csv")
    gain = str(records["estimation"].attrs["input_gain"])
    code, out, err = run(capsys, "doctor", str(tmp_path / "estimation.csv"), "--output-kind", "position",
                         "--input-gain", gain, "--base", "viscous_friction,offset",
                         "--save-model", str(tmp_path / "emps.json"), "--json")  # fmt: skip
    assert code == 0, err
    assert out["steps"][0]["effect"] == "coulomb_friction"
    assert "wrote " + str(tmp_path / "emps.json") + ": the model refitted in position" in err
    saved = load_model(tmp_path / "emps.json")
    assert saved.params == out["position_refit"]["params"]
    model = RigidDrive(tuple(out["model"]["effects"]), out["model"]["params"], dt=saved.dt,
                       stribeck_shape=saved.stribeck_shape)  # fmt: skip
    code, out, err = run(capsys, "doctor", str(tmp_path / "validation.csv"), "--output-kind", "position",
                         "--model", str(tmp_path / "emps.json"), "--json")  # fmt: skip
    assert code == 0, err
    published = EMPS_REFERENCE["force_error_validation"]
    assert out["initial_gap"]["force_error_percent"] < published
    val = records["validation"]
    qd, qdd, force = published_inverse_dynamics(
        val["t"].to_numpy(), val["y"].to_numpy(), val["force"].to_numpy()
    )
    # the position on the recipe's grid (its 50 edge samples dropped, decimated by 12), for the
    # level along the travel the doctor names third
    position = scipy.signal.decimate(val["y"].to_numpy()[50:-50], 12, ftype="fir", zero_phase=True)
    error = force_error_percent(force, model.inertia * qdd + model.friction(qd, position))
    assert error < published
    # motorid compare on the test set: the saved file gives the position refit's figure, below the
    # balance fit's (scripts/emps_benchmark.py: 3.98 mm against 6.34 mm)
    model.save(tmp_path / "balance.json")
    rmse = {}
    for name in ("emps.json", "balance.json"):
        code, out, err = run(capsys, "compare", str(tmp_path / "validation.csv"), "--model", str(tmp_path / name),
                             "--json")  # fmt: skip
        assert code == 0, err
        rmse[name] = out["models"][str(tmp_path / name)]["rmse"]
    assert rmse["emps.json"] < 0.8 * rmse["balance.json"], rmse


@pytest.mark.parametrize(
    "extra, words",
    [
        (("--base", "viscous_friction"), "--base cannot be combined with --model"),
        (("--model", "{rig}"), "backlash: the rig's shaft has a gap of ±0.001 rad"),
    ],
)
def test_doctor_model_options_refuse_what_does_not_fit(capsys, record_csv, tmp_path, extra, words):
    from motorid.drive import paper_rig

    paper_rig(backlash=1e-3).save(tmp_path / "rig.json")  # a rig without a rigid equivalent
    datasheet_model(stribeck_rig()).save(tmp_path / "sheet.json")
    argv = [
        "doctor",
        str(record_csv),
        "--input",
        "volts",
        "--output",
        "speed",
        "--model",
        str(tmp_path / "sheet.json"),
    ]
    argv += [a.replace("{rig}", str(tmp_path / "rig.json")) for a in extra]
    code, _, err = run(capsys, *argv)
    assert code == 2 and words in err


def test_doctor_without_out_imports_no_plotting_and_uses_one_blas_thread(record_csv):
    """The command without --out never loads matplotlib (about 0.5 s and 40 MB of start-up), and
    it runs BLAS on one thread unless told otherwise; checked in a fresh process, where the
    command's own imports are the first."""
    import json
    import os
    import subprocess
    import sys

    probe = (
        "import io, json, os, sys, contextlib\n"
        "from motorid.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        f"    code = main(['doctor', {str(record_csv)!r}, '--input', 'volts', '--output', 'speed', '--json'])\n"
        "print(json.dumps([code, 'matplotlib' in sys.modules, os.environ.get('OPENBLAS_NUM_THREADS')]))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True)
    assert json.loads(done.stdout.splitlines()[-1]) == [0, False, "1"]
    env["OPENBLAS_NUM_THREADS"] = "2"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True)
    assert json.loads(done.stdout.splitlines()[-1])[2] == "2"


def test_doctor_validate_scores_the_models_on_a_second_record_without_refitting(
    capsys, record_csv, planted, tmp_path
):
    """The same drive run on another input: the JSON ``validation`` holds each model's gaps on it,
    equal to ``Diagnosis.evaluate`` of the same diagnosis (one computation, no refit)."""
    from motorid.diagnose import diagnose

    second = planted_record("coulomb_friction", 7, sizes={"coulomb": 8e-3}, excitation_seed=31)
    path = tmp_path / "second.csv"
    rec = second.record.rename(columns={"u": "volts", "y": "speed"})
    rec.attrs = dict(second.record.attrs)
    write_record(rec, path)
    code, out, err = run(
        capsys, "doctor", str(record_csv), "--input", "volts", "--output", "speed", "--input-gain",
        repr(planted.input_gain), "--base", "viscous_friction,offset", "--validate", str(path), "--json",
    )  # fmt: skip
    assert code == 0, err
    scores = out["validation"]["models"]
    assert out["validation"]["record"] == str(path) and list(scores) == ["initial", "+coulomb_friction"]
    d = diagnose(planted.record, input_gain=planted.input_gain, base="viscous_friction,offset")
    want = d.evaluate(second.record)
    for label, row in scores.items():
        assert row == pytest.approx(
            want.loc[label].to_dict(), rel=1e-12
        )  # CSV floats round-trip exactly; 1e-12 for summation order
    assert scores["+coulomb_friction"]["overall"] < 0.5 * scores["initial"]["overall"]
    assert f"on {path} (" in err and "without refitting" in err
