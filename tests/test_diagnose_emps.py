"""The find-the-missing-effect workflow on real measured data: the EMPS benchmark.

Starting from inertia + viscous friction + offset on ``DATA_EMPS.mat`` (position
output, force = gtau * vir, 1 kHz, the controller reads the position and then holds
its output: ``timing="sampled"``, which ``load_emps`` records), the workflow must name
Coulomb friction first, land its level within 5 % of the published 20.39 N, bring
the force error from about 17 % to the published 4-5 % or below, and hold up on the
validation set ``DATA_EMPS_PULSES.mat`` without refitting. By the benchmark's own figure (the
test set's simulated position), the doctor's final model refitted in position is below every
black-box baseline but dynoNet.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest
from emps_fixtures import emps_folder, requires_emps

from motorid.cli import main
from motorid.datasets import EMPS_BENCHMARK_RESULTS, EMPS_REFERENCE, emps_benchmark_rmse, load_emps
from motorid.diagnose import diagnose
from motorid.diagnose.position import refit_in_position
from motorid.io.records import write_record

pytestmark = requires_emps

BASE = ("viscous_friction", "offset")
EMPS_PAGE = Path(__file__).resolve().parents[1] / "docs" / "guide" / "emps.md"


@pytest.fixture(scope="module")
def estimation():
    return load_emps(emps_folder(), which="estimation")


@pytest.fixture(scope="module")
def diagnosis(estimation):
    return diagnose(estimation, output_kind="position", input_gain=estimation.attrs["input_gain"], base=BASE)


def test_coulomb_friction_is_named_first_near_the_published_level(diagnosis):
    first = diagnosis.steps[0]
    assert first.effect == "coulomb_friction"
    assert first.params["coulomb"] == pytest.approx(EMPS_REFERENCE["coulomb"], rel=0.05)
    assert diagnosis.model.params["coulomb"] == pytest.approx(EMPS_REFERENCE["coulomb"], rel=0.05)
    # the gap concentrates at low speed and follows the sign of the speed, as Coulomb friction does
    assert first.region.feature == "speed" and first.region.sign_follows == "sgn(w)"
    assert first.gap_after.region <= 0.5 * first.gap_before.region


def test_force_error_falls_from_about_17_to_the_published_4_to_5_percent(diagnosis):
    first = diagnosis.steps[0]
    assert 15.0 <= diagnosis.initial_gap.force_error_percent <= 19.0
    assert first.gap_before.force_error_percent == diagnosis.initial_gap.force_error_percent
    assert first.gap_after.force_error_percent <= 5.0
    assert diagnosis.final_gap.force_error_percent <= first.gap_after.force_error_percent
    assert diagnosis.final_gap.overall < 0.35 * diagnosis.initial_gap.overall


def test_parameters_agree_with_the_published_inverse_dynamics_model(diagnosis):
    params = diagnosis.steps[0].model.params
    assert params["inertia"] == pytest.approx(EMPS_REFERENCE["mass"], rel=0.05)
    assert params["viscous"] == pytest.approx(EMPS_REFERENCE["viscous"], rel=0.05)
    assert params["offset"] == pytest.approx(EMPS_REFERENCE["offset"], abs=1.0)


def test_asymmetric_friction_fits_the_balance_but_predicts_a_held_out_half_worse(diagnosis):
    """The viscous asymmetry of the published asymmetric model (Fv+ 166.7, Fv- 240.4 N s/m) lowers
    the torque balance's error on held-out blocks (measured 0.0220 -> 0.0143 m/s² at step 2), but
    each half of the record's position predicted from a fit to the other half is worse with it
    (6.45 -> 6.51 mm), as the benchmark's test set is (6.72 -> 9.06 mm): it is not named, at the
    second step nor the third; the level along the travel is (6.45 -> 6.27 mm). Static friction,
    shown by the rests, predicts the held-out halves worse too (6.27 -> 7.32 mm)."""
    assert diagnosis.named == ["coulomb_friction", "position_friction"], diagnosis.stop_reason
    asymmetric = [r for r in diagnosis.rejected if r.effect == "asymmetric_friction"]
    assert [r.step for r in asymmetric] == [2, 3]
    for r in asymmetric:
        assert r.held_out_error_after < 0.8 * r.held_out_error_before  # the balance: better
        assert r.held_out_position_error_after > r.held_out_position_error_before  # the position: worse
        assert "held-out free-run position error" in r.reason
    level = diagnosis.steps[1].evidence
    assert level.held_out_position_error_after < 0.99 * level.held_out_position_error_before
    static = [r for r in diagnosis.rejected if r.effect == "static_friction"]
    assert static and static[0].held_out_position_error_after > static[0].held_out_position_error_before


def test_validation_set_without_refitting(diagnosis):
    validation = load_emps(emps_folder(), which="validation")
    table = diagnosis.evaluate(validation)
    assert list(table.index) == ["initial", "+coulomb_friction", "+position_friction"]
    error = table["force_error_percent"].to_numpy()
    assert 15.0 <= error[0] <= 19.0
    assert error[1] <= EMPS_REFERENCE["force_error_validation"]
    assert np.all(np.diff(error) < 0)
    assert np.all(np.diff(table["overall"].to_numpy()) < 0)


def test_doctor_command_on_the_measurement(estimation, tmp_path, capsys):
    path = tmp_path / "emps.csv"
    write_record(estimation, path)
    code = main(
        [
            "doctor", str(path), "--output-kind", "position",
            "--input-gain", str(estimation.attrs["input_gain"]),
            "--base", ",".join(BASE), "--json", "--out", str(tmp_path / "out"),
        ]
    )  # fmt: skip
    assert code == 0
    printed = capsys.readouterr()
    report = json.loads(printed.out)
    assert report["steps"][0]["effect"] == "coulomb_friction"
    # the final model refitted in position: both position errors, in the JSON and on stderr
    refit = report["position_refit"]
    assert refit["unit"] == "m" and refit["position_error_refitted"] < refit["position_error_fitted"]
    assert refit["effects"] == report["model"]["effects"]
    assert f"free-run position error {refit['position_error_fitted']:.4g} m" in printed.err
    assert report["steps"][0]["params"]["coulomb"] == pytest.approx(EMPS_REFERENCE["coulomb"], rel=0.05)
    assert report["final_gap"]["force_error_percent"] < 5.0
    assert len(list((tmp_path / "out").glob("*.png"))) >= 2


# --------------------------------------------------------------------------- the benchmark's figure
@pytest.fixture(scope="module")
def emps_benchmark_script():
    """scripts/emps_benchmark.py, imported from its path (scripts/ is not a package)."""
    path = Path(__file__).resolve().parents[1] / "scripts" / "emps_benchmark.py"
    spec = importlib.util.spec_from_file_location("emps_benchmark", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def test_set():
    return load_emps(emps_folder(), which="validation")


def test_the_doctors_models_by_the_benchmarks_protocol(diagnosis, estimation, test_set):
    """Measured: 20.37 mm at the start, 6.71 with Coulomb friction, 6.43 with the level along the
    travel; refitted in position on the train set 7.00, 6.91 and 4.31. The bounds leave 10 % for
    rounding across machines (a free-run position drifts with the slow force balance). Each
    step brings the model closer, as fitted and refitted. The refit with Coulomb friction alone
    lands where its start puts it: from starts 5 % apart it reaches the same train-set error
    (2.88-2.93 mm) and 6.8-8.5 mm on the test set, along a trade of Coulomb against viscous
    friction the train set hardly sees."""
    figures = {label: emps_benchmark_rmse(model, test_set) for label, model in diagnosis.models}
    assert figures["initial"] > 15.0
    assert figures["+coulomb_friction"] < 7.4
    assert figures["+position_friction"] < min(7.0, figures["+coulomb_friction"])
    coulomb = emps_benchmark_rmse(refit_in_position(diagnosis.steps[0].model, estimation), test_set)
    assert coulomb < 7.6
    assert emps_benchmark_rmse(refit_in_position(diagnosis.model, estimation), test_set) < min(4.7, coulomb)


def test_the_doctors_final_model_refitted_in_position_is_below_the_black_box_baselines(diagnosis, test_set):
    """The doctor's last stage on a position record: its final model's parameters fitted to the
    train set's free-run position (the train set's position error 3.02 -> 2.12 mm). On the test
    set: measured 4.50 mm, 0.67 mm below the polynomial NARX's 5.17 (the best black box but
    dynoNet's 0.452); the bound 4.95 mm leaves 10 % for rounding across machines."""
    assert diagnosis.position_model.effects == diagnosis.model.effects
    error = diagnosis.position_error
    assert error.unit == "m" and error.refitted < 0.8 * error.fitted
    figure = emps_benchmark_rmse(diagnosis.position_model, test_set)
    assert figure < 4.95
    assert figure < min(v for k, v in EMPS_BENCHMARK_RESULTS.items() if k != "dynoNet")


def test_the_final_effects_refitted_on_the_test_set_reach_a_millimetre_and_a_half(
    diagnosis, estimation, test_set
):
    """The EMPS page's reading of the figures: the structure can follow the test set better than the
    train set lets it (1.51 mm when its parameters are refitted there), with a Coulomb level
    1.17 N above the train set's (19.77 against 18.60 N)."""
    on_test = refit_in_position(diagnosis.model, test_set)
    assert emps_benchmark_rmse(on_test, test_set) < 1.75
    on_train = refit_in_position(diagnosis.model, estimation)
    assert on_test.params["coulomb"] - on_train.params["coulomb"] == pytest.approx(1.17, abs=0.1)


def test_the_emps_page_shows_the_benchmark_table_of_the_script(
    emps_benchmark_script, diagnosis, estimation, test_set
):
    text = EMPS_PAGE.read_text(encoding="utf-8")
    begin, end = emps_benchmark_script.BEGIN, emps_benchmark_script.END
    shown = text[text.index(begin) + len(begin) : text.index(end)].strip()
    assert shown == emps_benchmark_script.benchmark_table(diagnosis, estimation, test_set), (
        "docs/guide/emps.md's EMPS benchmark table is stale: run python scripts/emps_benchmark.py and paste its table"
    )
    assert emps_benchmark_script.BASE == BASE  # the script runs the doctor as these tests do
