"""Model files of version 3 say what the model is (:class:`motorid.drive.files.ModelCard`), and every
command that reads one checks it: % duty and volts converted with a supply voltage, refused in one
line otherwise; ``motorid control``'s limit, clamp and simulated sensor follow the model."""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid.drive import RigidDrive
from motorid.drive.files import VERSION, ModelCard, read_model_file, save_model
from motorid.errors import DataError

KIT = real_motor_file("kit_chirp_run1.csv")
KIT_UNITS = ["--input-unit", "%", "--output-unit", "rad/s"]
WHEEL_TRAIN = real_motor_file("wheel_free_train_motor1.csv")
WHEEL_VALIDATION = real_motor_file("wheel_free_validation_motor1.csv")
WHEEL_UNITS = ["--input-unit", "%", "--output-unit", "rev/s"]
#: The kit's encoder step [rad/s] (realmotors/README.md).
KIT_ENCODER_STEP = 0.767

needs_kit = pytest.mark.skipif(
    not KIT.is_file(), reason=f"real motor data not found at {KIT} (set MOTORID_DATA)"
)
needs_wheel = pytest.mark.skipif(
    not (WHEEL_TRAIN.is_file() and WHEEL_VALIDATION.is_file()),
    reason=f"real motor data not found at {WHEEL_TRAIN.parent} (set MOTORID_DATA)",
)


def a_drive() -> RigidDrive:
    return RigidDrive(("coulomb_friction", "viscous_friction"),
                      {"inertia": 0.01, "input_gain": 0.05, "coulomb": 0.02, "viscous": 1e-3}, dt=0.01)  # fmt: skip


def a_card(**changes) -> ModelCard:
    card = ModelCard(
        input_unit="%", supply_voltage=None, output_unit="rad/s", dt=0.01, timing="hold", quantisation_step=0.15,
        noise_bands=({"speed_from": 0.0, "speed_to": 10.0, "std": 0.1}, {"speed_from": 10.0, "speed_to": 80.0,
                                                                         "std": 0.3}),
        records=({"file": "r.csv", "sha256": "ab" * 32, "samples": 100, "start": 0.0, "stop": 0.99},),
        parameters={"coulomb": {"standard_error": 0.1, "determined": True}},
    )  # fmt: skip
    return ModelCard(**{**card.__dict__, **changes})


def test_a_card_is_written_as_version_3_and_read_back(tmp_path):
    drive = a_drive()
    save_model(drive, tmp_path / "m.json", card=a_card())
    data = json.loads((tmp_path / "m.json").read_text())
    assert data["version"] == VERSION == 3
    assert data["card"]["input"] == {"unit": "%", "kind": "duty", "supply_voltage": None, "full_scale": None}
    assert data["card"]["output"] == {"unit": "rad/s", "kind": "speed"}
    read = read_model_file(tmp_path / "m.json")
    assert read.model == drive and read.card == a_card() and read.version == 3
    save_model(drive, tmp_path / "bare.json")
    assert read_model_file(tmp_path / "bare.json").card is None


@pytest.mark.parametrize(
    ("change", "named"),
    [
        (
            lambda c: c["input"].update(unit="furlongs"),
            "card.input.unit: must be one of V, %, counts or null",
        ),
        (lambda c: c["input"].update(kind="voltage"), 'card.input.kind: must be "duty"'),
        (lambda c: c["output"].update(unit="rpm"), "card.output.unit"),
        (lambda c: c.update(timing="late"), "card.timing"),
        (
            lambda c: c["records"][0].update(sha256="xyz"),
            "card.records[0].sha256: must be 64 hexadecimal digits",
        ),
        (
            lambda c: c["sensor"]["noise_bands"][0].update(std=-1.0),
            "card.sensor.noise_bands[0].std: must be >= 0",
        ),
        (
            lambda c: c["parameters"]["coulomb"].pop("determined"),
            "card.parameters.coulomb.determined: missing",
        ),
        (lambda c: c.update(extra=1), "card.extra: unknown key"),
    ],
)
def test_a_bad_card_is_refused_naming_its_key(tmp_path, change, named):
    save_model(a_drive(), tmp_path / "m.json", card=a_card())
    data = json.loads((tmp_path / "m.json").read_text())
    change(data["card"])
    (tmp_path / "m.json").write_text(json.dumps(data))
    with pytest.raises(DataError, match=r"m\.json: ") as caught:
        read_model_file(tmp_path / "m.json")
    assert named in str(caught.value)


def test_a_file_of_version_2_has_no_card_and_version_3_needs_the_key(tmp_path):
    save_model(a_drive(), tmp_path / "m.json")
    data = json.loads((tmp_path / "m.json").read_text())
    old = {k: v for k, v in data.items() if k != "card"} | {"version": 2}
    (tmp_path / "v2.json").write_text(json.dumps(old))
    assert read_model_file(tmp_path / "v2.json").card is None
    (tmp_path / "v3.json").write_text(json.dumps({**old, "version": 3}))
    with pytest.raises(DataError, match="card: missing"):
        read_model_file(tmp_path / "v3.json")


# --------------------------------------------------------------------------- the doctor's card, compare
@pytest.fixture(scope="module")
def wheel_models(tmp_path_factory):
    """The doctor's model of a wheel motor fitted on % duty, and fitted in volts (15 V supply)."""
    if not (WHEEL_TRAIN.is_file() and WHEEL_VALIDATION.is_file()):
        pytest.skip(f"real motor data not found at {WHEEL_TRAIN.parent} (set MOTORID_DATA)")
    from motorid.cli import main

    folder = tmp_path_factory.mktemp("wheel")
    duty, volts = folder / "wheel1.json", folder / "wheel1_V.json"
    assert main(["doctor", str(WHEEL_TRAIN), *WHEEL_UNITS, "--save-model", str(duty), "-q"]) == 0
    assert main(["doctor", str(WHEEL_TRAIN), *WHEEL_UNITS, "--supply-voltage", "15", "--save-model", str(volts),
                 "-q"]) == 0  # fmt: skip
    return duty, volts


@needs_wheel
def test_the_doctor_writes_what_the_model_is(wheel_models):
    duty, volts = (read_model_file(path).card for path in wheel_models)
    assert (duty.input_unit, duty.supply_voltage, duty.output_unit, duty.timing) == (
        "%",
        None,
        "rad/s",
        "hold",
    )
    assert (volts.input_unit, volts.supply_voltage) == ("V", 15.0)
    assert duty.dt == pytest.approx(0.01)
    (record,) = duty.records
    assert record["file"] == WHEEL_TRAIN.name and record["samples"] == 6000
    assert record["sha256"] == hashlib.sha256(WHEEL_TRAIN.read_bytes()).hexdigest()
    # one encoder count per 10 ms: 0.0244 rev/s (README) = 0.153 rad/s
    assert duty.quantisation_step == pytest.approx(0.0244 * 2 * math.pi, rel=0.02)
    assert duty.noise_bands and all(band["std"] > 0 for band in duty.noise_bands)
    assert duty.parameters["coulomb"]["standard_error"] > 0 and duty.parameters["coulomb"]["determined"]


@needs_wheel
def test_compare_converts_duty_and_volts_with_a_supply_voltage(capsys, wheel_models):
    duty, volts = wheel_models
    code, same, err = run(
        capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--model", str(duty), "--json"
    )
    assert code == 0, err
    fit = same["models"][str(duty)]["fit_percent"]
    assert fit > 85.0  # measured 92.3 %
    # the record in volts, the model fitted on duty: converted back with the record's 15 V (was FIT 5.03 %)
    code, out, err = run(capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--supply-voltage", "15",
                         "--model", str(duty), "--json")  # fmt: skip
    assert code == 0, err
    row = out["models"][str(duty)]
    # u 100/15 of (u 15/100) is u up to the rounding of the two products
    assert row["fit_percent"] == pytest.approx(fit, rel=1e-9)
    assert "converted to the model's % duty (15 V supply)" in row["notes"][0]
    # the record in duty, the model in volts with its supply in its card
    code, out, err = run(
        capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--model", str(volts), "--json"
    )
    assert code == 0, err
    assert out["models"][str(volts)]["fit_percent"] > 85.0


@needs_wheel
def test_compare_refuses_in_one_line_where_no_supply_voltage_is_known(capsys, wheel_models, tmp_path):
    _, volts = wheel_models
    data = json.loads(volts.read_text())
    data["card"]["input"]["supply_voltage"] = None
    unknown = tmp_path / "wheel1_V.json"
    unknown.write_text(json.dumps(data))
    code, _, err = run(capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--model", str(unknown))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "wheel1_V.json was fitted on V; this record is in % duty: give --supply-voltage" in err


@needs_wheel
def test_identify_saves_the_records_card(capsys, tmp_path):
    model = tmp_path / "arx.json"
    code, _, err = run(capsys, "identify", str(WHEEL_TRAIN), *WHEEL_UNITS, "--estimator", "arx-rls",
                       "--save-model", str(model))  # fmt: skip
    assert code == 0, err
    card = read_model_file(model).card
    assert (card.input_unit, card.output_unit, card.records[0]["samples"]) == ("%", "rad/s", 6000)
    assert card.records[0]["stop"] == pytest.approx(59.99)


def arx_record(n: int, seed: int, noise: float) -> pd.DataFrame:
    """An ARX(2, 2) drive-like record: ``y[k] = 1.5 y[k-1] - 0.6 y[k-2] + 0.5 u[k] + 0.2 u[k-1] + e[k]``,
    u white on ±1, e white of std ``noise``."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, n)
    e = noise * rng.standard_normal(n)
    y = np.zeros(n)
    for k in range(n):
        y[k] = (
            (1.5 * y[k - 1] - 0.6 * y[k - 2] if k >= 2 else 0.0) + 0.5 * u[k] + 0.2 * (u[k - 1] if k else 0.0)
        )
        y[k] += e[k]
    return pd.DataFrame({"t": np.arange(n) * 0.01, "u": u, "y": y})


def test_identify_saves_each_parameters_standard_error_as_least_squares_gives_it(capsys, tmp_path):
    """The card of an identified ARX model: each parameter's standard error is ordinary least squares'
    ``sqrt(s^2 (Phi^T Phi)^-1)`` on the same regression (an independent reference), within 2 %: RLS's
    P includes the prior delta I and its sigma^2 is the one-step (a priori) errors' mean square, not
    RSS / (N - n), each about n / N = 0.3 % of the figures here."""
    record = arx_record(3000, seed=1, noise=0.05)
    record.to_csv(tmp_path / "arx.csv", index=False)
    model = tmp_path / "arx.json"
    code, _, err = run(capsys, "identify", str(tmp_path / "arx.csv"), "--input-unit", "V", "--output-unit", "rad/s",
                       "--estimator", "arx-rls", "--save-model", str(model))  # fmt: skip
    assert code == 0, err
    assert "standard errors" in err
    table = read_model_file(model).card.parameters
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    rows = np.arange(4, len(y))
    phi = np.column_stack([-y[rows - i] for i in range(1, 5)] + [u[rows - k] for k in range(0, 5)])
    _, rss, *_ = np.linalg.lstsq(phi, y[rows], rcond=None)
    s2 = float(rss[0]) / (rows.size - phi.shape[1])
    reference = np.sqrt(np.diag(s2 * np.linalg.inv(phi.T @ phi)))
    names = [f"a{i}" for i in range(1, 5)] + [f"b{k}" for k in range(5)]
    assert list(table) == names
    assert [table[n]["standard_error"] for n in names] == pytest.approx(reference, rel=0.02)
    assert all(table[n]["determined"] for n in names)


def test_a_hammersteins_gamma_standard_error_matches_its_spread_over_records():
    """The delta method through step 2: the standard error of gamma2 of ``u, sign(u)`` predicts how far
    gamma2 moves from one noise realisation to the next. 40 records: the spread's own relative
    standard error is 1/sqrt(2 x 39) = 11 %, so the mean reported error lies within 35 % (3 of them)."""
    from motorid.app.model_cards import estimator_parameters
    from motorid.estimators import HammersteinRLS

    rng = np.random.default_rng(5)
    estimates, errors = [], []
    for _ in range(40):
        n = 2000
        u = rng.uniform(-1.0, 1.0, n)
        x = u + 0.3 * np.sign(u)
        y = np.zeros(n)
        for k in range(n):
            y[k] = (0.7 * y[k - 1] if k else 0.0) + 0.4 * x[k] + 0.1 * (x[k - 1] if k else 0.0)
        y += 0.05 * rng.standard_normal(n)
        est = HammersteinRLS(na=1, nb=1, basis="u,sign")
        result = est.batch_filter(u, y)
        table = estimator_parameters(est, float(np.mean(result.innovation[50:] ** 2)))
        estimates.append(est.params["gamma"][1])
        errors.append(table["gamma2"]["standard_error"])
        assert set(table) == {"a1", "b0", "b1", "gamma2"} and table["gamma2"]["determined"]
    assert np.mean(estimates) == pytest.approx(0.3, abs=3 * np.std(estimates))
    assert np.mean(errors) == pytest.approx(np.std(estimates, ddof=1), rel=0.35)


def test_a_parameter_the_record_never_excited_is_not_determined():
    """An input at zero throughout leaves every b at its prior (not determined); the output's own
    motion determines a1."""
    from motorid.app.model_cards import estimator_parameters
    from motorid.estimators import ARXRLS

    rng = np.random.default_rng(2)
    n = 1000
    y = np.zeros(n)
    e = rng.standard_normal(n)
    for k in range(1, n):
        y[k] = 0.8 * y[k - 1] + e[k]
    est = ARXRLS(na=1, nb=1)
    result = est.batch_filter(np.zeros(n), y)
    table = estimator_parameters(est, float(np.mean(result.innovation[50:] ** 2)))
    assert table["a1"]["determined"] and not table["b0"]["determined"] and not table["b1"]["determined"]


@needs_wheel
def test_compare_checks_an_identified_models_card(capsys, tmp_path):
    """An estimator fitted on % duty, compared on its validation record read in volts: converted back
    with the supply voltage (the same FIT as on the record in %, up to the two roundings of u), and
    refused in one line on a record in volts with no supply voltage (the L298N's, in V)."""
    model = tmp_path / "h.json"
    code, _, err = run(capsys, "identify", str(WHEEL_TRAIN), *WHEEL_UNITS, "--save-model", str(model))
    assert code == 0, err
    table = read_model_file(model).card.parameters
    assert {"a1", "b0", "gamma2"} <= set(table) and all(e["standard_error"] > 0 for e in table.values())
    code, duty, err = run(
        capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--model", str(model), "--json"
    )
    assert code == 0, err
    code, volts, err = run(capsys, "compare", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--supply-voltage", "15",
                           "--model", str(model), "--json")  # fmt: skip
    assert code == 0, err
    assert "the record's input in V converted to the model's % duty (15 V supply)" in err
    row, other = duty["models"][str(model)], volts["models"][str(model)]
    assert other["fit_percent"] == pytest.approx(row["fit_percent"], rel=1e-9)  # measured 89.86 % both
    l298n = real_motor_file("l298n_staircase.csv")
    if l298n.is_file():
        code, _, err = run(capsys, "compare", str(l298n), "--input-unit", "V", "--output-unit", "rpm", "--model",
                           str(model))  # fmt: skip
        assert code == 2 and len(err.strip().splitlines()) == 1
        assert "h.json was fitted on % duty; this record is in V: give --supply-voltage" in err


# --------------------------------------------------------------------------- control
@pytest.fixture(scope="module")
def kit_model(tmp_path_factory):
    if not KIT.is_file():
        pytest.skip(f"real motor data not found at {KIT} (set MOTORID_DATA)")
    from motorid.cli import main

    path = tmp_path_factory.mktemp("kit") / "kit.json"
    assert main(["doctor", str(KIT), *KIT_UNITS, "--save-model", str(path), "-q"]) == 0
    return path


def control(capsys, model, *options):
    code, out, err = run(capsys, "control", "--design", str(model), "--model", str(model), "--json", *options)
    assert code == 0, err
    return out, err


@needs_kit
def test_a_duty_model_is_controlled_within_100_percent_and_a_clamp_is_said(capsys, kit_model, tmp_path):
    out, err = control(capsys, kit_model, "--noise-free", "--out", str(tmp_path / "run.csv"))
    assert out["pi"]["u_max"] == 100.0 and out["input_unit"] == "%"
    assert out["clamped_share"] <= 0.05 and "warning" not in err
    assert out["rms_error"] < 1.0  # measured 0.112 rad/s (12.9 with the 12 of a model in volts)
    clamped, err = control(capsys, kit_model, "--noise-free", "--u-max", "12", "--out", str(tmp_path / "c.csv"),
                           "--overwrite")  # fmt: skip
    record = pd.read_csv(tmp_path / "c.csv", comment="#")
    # the column says where the command sits on the limit: measured 8,160 of 12,000 samples
    at_limit = (record["u"].abs() >= 12.0 - 1e-9).to_numpy()
    assert (record["clamped"].to_numpy() == 1).sum() == clamped["clamped_samples"] == at_limit.sum() > 600
    warning = [line for line in err.splitlines() if line.startswith("motorid: warning:")]
    assert len(warning) == 1 and "--u-max" in warning[0] and "±12 %" in warning[0]
    assert clamped["rms_error"] > 5 * out["rms_error"]


@needs_kit
def test_the_simulated_plant_measures_with_the_models_sensor(capsys, kit_model):
    """``control --daq sim --model kit.json`` measures the plant with the kit's encoder: noise of the
    card's band, rounded to its 0.767 rad/s step. The low-speed error is not at or above the step
    itself: rounding leaves an RMS error of q / sqrt(12) = 0.221 rad/s on a speed that moves
    through the steps, and the noise added before it is what rounding leaves of the band's sigma
    (0.281 rad/s below 23.8 rad/s, the doctor's measurement of the readings, rounding included),
    so the measurement alone errs by sigma RMS, as the real encoder did. The loop follows only the
    part of that noise inside its bandwidth (66.7 rad/s of the 3,142 rad/s Nyquist frequency: about
    2 % of white noise's power), so the measured error stays above 0.95 of it: measured 0.312 rad/s
    (0.389 when the band's sigma was added whole before rounding; 0.145 rad/s with --noise-free)."""
    quiet, _ = control(capsys, kit_model, "--noise-free")
    sensed, _ = control(capsys, kit_model)
    again, _ = control(capsys, kit_model, "--plant-seed", "0")
    other, _ = control(capsys, kit_model, "--plant-seed", "7")
    card = read_model_file(kit_model).card
    assert card.quantisation_step == pytest.approx(KIT_ENCODER_STEP, rel=0.01)
    band = card.noise_bands[0]
    assert band["speed_to"] >= sensed["low_speed_band"]  # the low-speed band lies in the card's first
    assert sensed["low_speed_rms_error"] >= 0.95 * band["std"]
    assert sensed["low_speed_rms_error"] > quiet["low_speed_rms_error"]
    # the same seed, the same run (but the loop's timing on this machine, largest_interval)
    timing = "largest_interval"
    assert {k: v for k, v in sensed.items() if k != timing} == {k: v for k, v in again.items() if k != timing}
    assert other["rms_error"] != sensed["rms_error"]


@needs_wheel
def test_control_converts_a_design_in_duty_for_a_plant_in_volts_or_refuses(capsys, wheel_models, tmp_path):
    duty, volts = wheel_models
    same, _ = control(capsys, duty, "--noise-free")
    code, out, err = run(
        capsys, "control", "--design", str(duty), "--model", str(volts), "--noise-free", "--json"
    )
    assert code == 0, err
    assert "converted to the model's V (15 V supply)" in err
    # the plant fitted in volts is the plant fitted on duty up to the doctor's fit: measured 1.52 rad/s both
    # (10 rad/s before the conversion)
    assert out["rms_error"] == pytest.approx(same["rms_error"], rel=0.2)
    data = json.loads(volts.read_text())
    data["card"]["input"]["supply_voltage"] = None
    unknown = tmp_path / "volts.json"
    unknown.write_text(json.dumps(data))
    code, _, err = run(capsys, "control", "--design", str(duty), "--model", str(unknown))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "give --supply-voltage" in err
    code, out, err = run(capsys, "control", "--design", str(duty), "--model", str(unknown), "--supply-voltage",
                         "15", "--noise-free", "--json")  # fmt: skip
    assert code == 0, err


@needs_wheel
def test_identify_and_simulate_follow_the_models_card(capsys, wheel_models, tmp_path):
    duty, volts = wheel_models
    # a friction filter started from the model fitted in volts, on the record in duty: converted at 15 V
    code, out, err = run(capsys, "identify", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--estimator", "friction-ekf",
                         "--model", str(volts), "--param", "R=0.05", "--json")  # fmt: skip
    assert code == 0, err
    assert any("converted to the model's V (15 V supply)" in note for note in out["notes"])
    data = json.loads(volts.read_text())
    data["card"]["input"]["supply_voltage"] = None
    unknown = tmp_path / "volts.json"
    unknown.write_text(json.dumps(data))
    code, _, err = run(capsys, "identify", str(WHEEL_VALIDATION), *WHEEL_UNITS, "--estimator", "friction-ekf",
                       "--model", str(unknown), "--param", "R=0.05")  # fmt: skip
    assert code == 2 and len(err.strip().splitlines()) == 1 and "was fitted on V" in err
    # simulate writes the record in the units the model was fitted on
    code, _, err = run(capsys, "simulate", "--model", str(duty), "--out", str(tmp_path / "sim.csv"),
                       "--duration", "2", "--amplitude", "30")  # fmt: skip
    assert code == 0, err
    from motorid.io.records import read_record

    assert read_record(tmp_path / "sim.csv").attrs["units"]["u"] == "%" and "in %" in err


@pytest.mark.parametrize("name", ["rigid-drive.v2", "two-mass-rig.v2"])
def test_a_drive_model_file_of_version_2_reads_bit_for_bit(name):
    """Files written by motorid's model files of version 2 (tests/data/model_files/*.v2.json): the model
    read back writes the same description, every float to the last bit, with the version 3 and no card."""
    from pathlib import Path

    from motorid.drive.files import model_to_dict

    path = Path(__file__).parent / "data" / "model_files" / f"{name}.json"
    saved = json.loads(path.read_text())
    assert saved["version"] == 2
    read = read_model_file(path)
    assert read.card is None and read.version == 2
    assert model_to_dict(read.model) == {**saved, "version": 3, "card": None}


@needs_wheel
def test_a_duty_model_without_u_max_is_clamped_no_more_than_the_same_model_in_volts(capsys, wheel_models):
    """The limit follows the model's unit: ±100 % for the model fitted on duty, its supply's ±15 V for
    the one fitted in volts on the same record: the same limit, so the same share of clamped samples
    up to the two fits' differences (a sample or so in 1,200)."""
    duty, volts = wheel_models
    on_duty, _ = control(capsys, duty, "--noise-free", "--amplitude", "400")
    in_volts, _ = control(capsys, volts, "--noise-free", "--amplitude", "400")
    assert (on_duty["pi"]["u_max"], in_volts["pi"]["u_max"]) == (100.0, 15.0)
    assert (
        on_duty["clamped_samples"] > 0
    )  # 400 rad/s asks for more than the limit near the peaks: measured 282 of 1,200 samples, both
    assert on_duty["clamped_share"] <= in_volts["clamped_share"] + 2 / 1200


def test_a_friction_filters_card_holds_its_posterior_standard_deviations(capsys, tmp_path):
    """The friction EKF on motorid's own simulation: the card's standard errors are the filter's
    posterior standard deviations (``coulomb_std``: the square root of P's diagonal), and the record
    determined both (their variance far below half the prior's)."""
    record = tmp_path / "sim.csv"
    code, _, err = run(capsys, "simulate", "--duration", "20", "--out", str(record))
    assert code == 0, err
    model = tmp_path / "ekf.json"
    code, out, err = run(capsys, "identify", str(record), "--estimator", "friction-ekf", "--save-model", str(model),
                         "--json")  # fmt: skip
    assert code == 0, err
    table = read_model_file(model).card.parameters
    assert set(table) == {"coulomb", "viscous"}
    for name, entry in table.items():
        assert entry["standard_error"] == out["params"][f"{name}_std"] and entry["determined"]
