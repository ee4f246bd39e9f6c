"""motorid.app.identify: the per-record work of ``motorid identify``, called from Python.

The reference is the command itself: the same numbers written to a CSV file and read by
``motorid identify FILE --json`` with the same column and unit options. Both read the record
with the same rules (:func:`motorid.io.records.normalise_record`) and run the same function
(:func:`motorid.app.identify.identify_record`), and pandas writes a float to CSV in the
shortest text that reads back to the same float, so the payloads are compared for equality,
key for key, with no tolerance.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid.app import IdentifyOptions, identify, identify_file
from motorid.cli.report import jsonable
from motorid.drive import paper_rig
from motorid.errors import DataError
from motorid.fleet import IdentifyJob
from motorid.io.records import RecordOptions
from motorid.signals import two_sine_signal

SUPPLY = 24.0  # [V]: the paper's rig takes at most 12 V, a duty of at most 50 %
RPM = 60.0 / (2.0 * math.pi)


@pytest.fixture(scope="module")
def logged():
    """60 s of the paper's rig at 40 ms as a logger writes it: ms since boot, duty in %, rpm."""
    rig = paper_rig()
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=4)
    rec = rig.simulate(u, seed=4)
    return pd.DataFrame({
        "Zeit [ms]": 5_000 + 40 * np.arange(len(rec)),
        "PWM [%]": rec["u"] / SUPPLY * 100,
        "Drehzahl": rec["y"] * RPM,
    })  # fmt: skip


READING = {"time": "Zeit [ms]", "time_unit": "ms", "input": "PWM [%]", "input_unit": "%",
           "supply_voltage": SUPPLY, "output": "Drehzahl", "output_unit": "rpm"}  # fmt: skip
COMMAND_LINE = ["--time", "Zeit [ms]", "--time-unit", "ms", "--input", "PWM [%]", "--input-unit", "%",
                "--supply-voltage", repr(SUPPLY), "--output", "Drehzahl", "--output-unit", "rpm"]  # fmt: skip


@pytest.mark.parametrize(
    ("estimator", "python", "options"),
    [
        ("hammerstein-rls", {"na": 2, "nb": 2, "degree": 3, "skip": 30}, ["--na", "2", "--nb", "2", "--degree", "3",
                                                                           "--skip", "30"]),
        ("arx-rls", {"lam": 0.999, "max_lag": 10, "low_speed_rpm": 100.0},
         ["--lam", "0.999", "--max-lag", "10", "--low-speed-rpm", "100"]),
    ],
)  # fmt: skip
def test_identify_on_a_dataframe_equals_the_command_on_the_same_data_as_csv(
    capsys, tmp_path, logged, estimator, python, options
):
    path = tmp_path / "log.csv"
    logged.to_csv(path, index=False)
    payload = identify(logged, estimator, **READING, **python)
    code, out, err = run(
        capsys, "identify", str(path), "--estimator", estimator, *COMMAND_LINE, *options, "--json"
    )
    assert code == 0, err
    assert out.pop("figure") is None and out.pop("model") is None
    assert json.loads(json.dumps(jsonable(payload))) == out
    # what the payload holds: the record read in motorid's units, the identified model scored
    assert payload["estimator"] == estimator and payload["samples"] == len(logged)
    assert payload["output_unit"] == "rad/s" and "mse_rpm2" in payload["scores"]["one_step"]
    assert payload["scores"]["one_step"]["fit_percent"] > 90.0  # a noisy rig, its own input: a close fit
    assert {"autocorrelation", "input_cross_correlation"} <= set(payload["residual_tests"])


def test_identify_refuses_bad_options_naming_them(logged):
    with pytest.raises(DataError, match="unknown option 'order'"):
        identify(logged, **READING, order=4)
    with pytest.raises(DataError, match="unknown estimator 'nope'"):
        identify(logged, "nope", **READING)
    with pytest.raises(DataError, match="rpm"):  # the output column is not there
        identify(logged, **{**READING, "output": "rpm"})
    with pytest.raises(DataError, match="takes no 'degree' argument"):
        identify(logged, "arx-rls", **READING, degree=3)


def test_the_fleets_identify_job_is_the_application_layers_options():
    """One class: the fleet runs identify with the options the command line builds."""
    assert IdentifyJob is IdentifyOptions
    assert IdentifyOptions(na=2, param=["R=0.1"]).param == ("R=0.1",)
    with pytest.raises(DataError, match="KEY=VALUE texts"):
        IdentifyOptions(param="R=0.1")


@pytest.mark.parametrize("span", [{}, {"start": 2.0, "stop": 40.0}])
def test_identify_file_with_read_options_equals_the_command(capsys, tmp_path, logged, span):
    """A file read through the shared record options: in blocks, or with a span cut from the record
    read whole, the payload of ``motorid identify FILE --json`` with the same options."""
    path = tmp_path / "log.csv"
    logged.to_csv(path, index=False)
    read = RecordOptions(**READING, **span)
    payload, _, _ = identify_file(path, IdentifyOptions(na=2, nb=2, degree=3), read)
    spanned = [arg for key, value in span.items() for arg in (f"--{key}", repr(value))]
    code, out, err = run(capsys, "identify", str(path), "--na", "2", "--nb", "2", "--degree", "3",
                         *COMMAND_LINE, *spanned, "--json")  # fmt: skip
    assert code == 0, err
    assert out.pop("figure") is None and out.pop("model") is None
    assert json.loads(json.dumps(jsonable(payload))) == out
    assert payload["samples"] == (len(logged) if not span else round(38.0 / 0.04) + 1)
