"""motorid.app.doctor: the per-record (and per-drive) work of ``motorid doctor``, called from Python.

The reference is the command itself: the same numbers written to CSV files and read by
``motorid doctor FILE... --json`` with the same column and unit options. Both bring the
record to motorid's columns and units with the same rules (:func:`motorid.io.records.normalise_record`)
and run the same doctor (:meth:`motorid.app.DoctorOptions.diagnose`), and pandas writes a float
to CSV in the shortest text that reads back to the same float, so the payloads are compared for
equality, key for key, with no tolerance.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid.app import DoctorOptions, doctor
from motorid.cli.report import jsonable
from motorid.diagnose.synthetic import planted_record
from motorid.errors import DataError
from motorid.fleet import DoctorJob
from motorid.fleet import RecordOptions as FleetRecordOptions
from motorid.io.records import RecordOptions

SUPPLY = 24.0  # [V]: the planted rig's input stays well inside it
RPM = 60.0 / (2.0 * math.pi)
READING = {"time": "Zeit [ms]", "time_unit": "ms", "input": "PWM [%]", "input_unit": "%",
           "supply_voltage": SUPPLY, "output": "Drehzahl", "output_unit": "rpm"}  # fmt: skip
COMMAND_LINE = ["--time", "Zeit [ms]", "--time-unit", "ms", "--input", "PWM [%]", "--input-unit", "%",
                "--supply-voltage", repr(SUPPLY), "--output", "Drehzahl", "--output-unit", "rpm"]  # fmt: skip
BASE = "viscous_friction,offset"


def logged(excitation_seed: int | None) -> pd.DataFrame:
    """20 s at 10 ms of a drive with Coulomb friction planted, as a logger writes it: ms since
    boot, duty in %, rpm (``excitation_seed``: another record of the same drive)."""
    planted = planted_record("coulomb_friction", 7, duration=20.0, sizes={"coulomb": 8e-3},
                             excitation_seed=excitation_seed)  # fmt: skip
    rec = planted.record
    return pd.DataFrame({
        "Zeit [ms]": 5_000 + 10 * np.arange(len(rec)),
        "PWM [%]": rec["u"] / SUPPLY * 100,
        "Drehzahl": rec["y"] * RPM,
    })  # fmt: skip


@pytest.fixture(scope="module")
def records() -> list[pd.DataFrame]:
    return [logged(None), logged(11)]


def _written(records: list[pd.DataFrame], folder: Path) -> list[str]:
    paths = []
    for k, record in enumerate(records):
        path = folder / f"log{k}.csv"
        record.to_csv(path, index=False)
        paths.append(str(path))
    return paths


def test_doctor_on_a_dataframe_equals_the_command_on_the_same_data_as_csv(capsys, tmp_path, records):
    (path,) = _written(records[:1], tmp_path)
    payload = doctor(records[0], labels=[path], **READING, base=BASE.split(","), max_steps=1)
    code, out, err = run(capsys, "doctor", path, *COMMAND_LINE, "--base", BASE, "--max-steps", "1", "--json")
    assert code == 0, err
    assert out.pop("figures") == [] and out.pop("segment") is False
    assert json.loads(json.dumps(jsonable(payload))) == out
    # what the payload holds: the record in motorid's units, the planted effect named
    assert payload["settings"]["dt"] == pytest.approx(0.01)
    assert [step["effect"] for step in payload["steps"]] == ["coulomb_friction"]
    assert payload["final_gap"]["overall"] < payload["initial_gap"]["overall"]


def test_doctor_on_records_of_one_drive_equals_the_command_on_their_files(capsys, tmp_path, records):
    """Two records of one drive, fitted as one model: the per-drive work, as ``motorid doctor A B``."""
    paths = _written(records, tmp_path)
    payload = doctor(records, labels=paths, **READING, base=BASE.split(","), max_steps=1)
    code, out, err = run(
        capsys, "doctor", *paths, *COMMAND_LINE, "--base", BASE, "--max-steps", "1", "--json"
    )
    assert code == 0, err
    assert out.pop("figures") == [] and out.pop("segment") is False
    assert json.loads(json.dumps(jsonable(payload))) == out
    assert [r["record"] for r in payload["records"]] == paths
    assert [step["effect"] for step in payload["steps"]] == ["coulomb_friction"]


def test_doctor_refuses_bad_options_naming_them(records):
    with pytest.raises(DataError, match="unknown option 'steps'"):
        doctor(records[0], **READING, steps=1)
    with pytest.raises(DataError, match="base: unknown effect 'friction'"):
        doctor(records[0], **READING, base=["friction"])
    with pytest.raises(DataError, match="rpm"):  # the output column is not there
        doctor(records[0], **{**READING, "output": "rpm"})
    with pytest.raises(DataError, match="labels: 1 labels for 2 records"):
        doctor(records, labels=["a"], **READING)


def test_the_fleets_doctor_job_and_read_options_are_the_application_layers():
    """One class each: the fleet runs the doctor with the options the command line builds."""
    assert DoctorJob is DoctorOptions and FleetRecordOptions is RecordOptions
    assert DoctorOptions(base=["offset"]).base == ("offset",)
    with pytest.raises(DataError, match="sequence of effect names"):
        DoctorOptions(base="offset")
