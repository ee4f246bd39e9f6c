"""motorid.app.compare: the per-record work of ``motorid compare``, called from Python.

The reference is the command itself: the same numbers written to a CSV file and read by
``motorid compare FILE --model ... --json`` with the same column and unit options. Both bring
the record to motorid's columns and units with the same rules
(:func:`motorid.io.records.normalise_record`) and run each model free on the same input, so every
key and every free run is the same; the command reads the file in blocks and scores with running
sums (:func:`motorid.comparison.compare_blocks`), the Python call the whole record with numpy's
sums, so the five scores agree to the rounding of those sums (:data:`SUMS_RTOL`).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid import load_model
from motorid.app import CompareOptions, compare
from motorid.cli.report import jsonable
from motorid.drive import paper_rig
from motorid.errors import DataError
from motorid.signals import two_sine_signal

SUPPLY = 24.0  # [V]: the paper's rig takes at most 12 V, a duty of at most 50 %
RPM = 60.0 / (2.0 * math.pi)
READING = {"time": "Zeit [ms]", "time_unit": "ms", "input": "PWM [%]", "input_unit": "%",
           "supply_voltage": SUPPLY, "output": "Drehzahl", "output_unit": "rpm"}  # fmt: skip
COMMAND_LINE = ["--time", "Zeit [ms]", "--time-unit", "ms", "--input", "PWM [%]", "--input-unit", "%",
                "--supply-voltage", repr(SUPPLY), "--output", "Drehzahl", "--output-unit", "rpm"]  # fmt: skip
#: The same free runs scored by running sums and by numpy's whole-array sums: only the order of
#: the additions differs (a few ulp per sum; 1e-12 relative is a thousand times that on 750 samples).
SUMS_RTOL = 1e-12
SCORES = ("fit_percent", "rmse", "low_speed_rmse", "mse", "low_speed_mse")


@pytest.fixture(scope="module")
def logged(tmp_path_factory):
    """30 s of the paper's rig at 40 ms as a logger writes it (ms since boot, duty in %, rpm), the
    true rig's model file and a wrong one (no dead zone)."""
    root = tmp_path_factory.mktemp("app_compare")
    rig = paper_rig()
    _, u = two_sine_signal(duration=30.0, dt=rig.dt, seed=3)
    rec = rig.simulate(u, seed=3)
    rig.save(root / "true.json")
    rig.replace(amplifier=dataclasses.replace(rig.amplifier, dead_zone=0.0)).save(root / "wrong.json")
    frame = pd.DataFrame({
        "Zeit [ms]": 5_000 + 40 * np.arange(len(rec)),
        "PWM [%]": rec["u"] / SUPPLY * 100,
        "Drehzahl": rec["y"] * RPM,
    })  # fmt: skip
    frame.to_csv(root / "log.csv", index=False)
    return root, frame


def _same(payload: dict, out: dict) -> None:
    """``payload`` equals the command's ``out`` key for key, the scores to :data:`SUMS_RTOL`."""
    python = json.loads(json.dumps(jsonable(payload)))
    assert python.keys() == out.keys()
    assert {k: v for k, v in python.items() if k != "models"} == {
        k: v for k, v in out.items() if k != "models"
    }
    assert python["models"].keys() == out["models"].keys()
    for name, row in out["models"].items():
        ours = python["models"][name]
        assert {k: v for k, v in ours.items() if k not in SCORES} == {
            k: v for k, v in row.items() if k not in SCORES
        }
        for key in SCORES:
            assert ours[key] == pytest.approx(row[key], rel=SUMS_RTOL, abs=0.0), (name, key)


@pytest.mark.parametrize(
    ("python", "options"),
    [({}, []), ({"skip": 20, "low_speed_rpm": 100.0}, ["--skip", "20", "--low-speed-rpm", "100"])],
)
def test_compare_on_a_dataframe_equals_the_command_on_the_same_data_as_csv(capsys, logged, python, options):
    root, frame = logged
    models = [str(root / "true.json"), str(root / "wrong.json")]
    payload = compare(frame, models, **READING, **python)
    argv = [arg for name in models for arg in ("--model", name)]
    code, out, err = run(capsys, "compare", str(root / "log.csv"), *argv, *COMMAND_LINE, *options, "--json")
    assert code == 0, err
    assert out.pop("record") == str(root / "log.csv") and out.pop("figure") is None
    _same(payload, out)
    # what the payload holds: the record in motorid's units, the true rig close, the wrong one far off
    true, wrong = (payload["models"][name] for name in models)
    assert payload["samples"] == len(frame) and payload["output_unit"] == "rad/s"
    assert true["fit_percent"] > 95.0 and wrong["fit_percent"] < true["fit_percent"] - 10.0


def test_compare_takes_models_by_name(logged):
    """A mapping names the models: objects in memory, or files, score as the files do."""
    root, frame = logged
    by_file = compare(frame, [str(root / "true.json")], **READING)
    by_name = compare(frame, {"datasheet": load_model(root / "true.json")}, **READING)
    assert by_name["models"]["datasheet"] == by_file["models"][str(root / "true.json")]


def test_compare_refuses_bad_options_naming_them(logged):
    root, frame = logged
    models = [str(root / "true.json")]
    with pytest.raises(DataError, match="unknown option 'band'"):
        compare(frame, models, **READING, band=3.0)
    with pytest.raises(DataError, match="skip must be an integer >= 0"):
        compare(frame, models, **READING, skip=-1)
    with pytest.raises(DataError, match="rpm"):  # the output column is not there
        compare(frame, models, **{**READING, "output": "rpm"})
    with pytest.raises(DataError, match=r"missing\.json"):
        compare(frame, [str(root / "missing.json")], **READING)
    with pytest.raises(DataError, match="a sequence of model files"):
        compare(frame, str(root / "true.json"), **READING)
    with pytest.raises(DataError, match="a TwoMassRig in a sequence has no name"):
        compare(frame, [load_model(root / "true.json")], **READING)
    with pytest.raises(DataError, match="low_speed_rpm must be a speed > 0"):
        CompareOptions(low_speed_rpm=0.0)
