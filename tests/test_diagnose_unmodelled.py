"""Records no drive model describes are refused in one line, never reported with ``nan`` or saved
with a negative inertia (issue 31): a drive pulsed by a PWM slower than the motor."""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid.diagnose import diagnose
from motorid.diagnose.search import figure
from motorid.drive.rigid import RigidDrive
from motorid.errors import DataError
from motorid.io.records import write_record


@pytest.fixture(scope="module")
def pulsed() -> pd.DataFrame:
    """A small motor (τ = J/B = 15 ms, 210 rad/s at full duty) driven by a 10 Hz PWM: the record
    holds the duty [%] of a 0.25 Hz sine and the encoder's speed, which falls back towards zero in
    every off phase (the motor stops well within the 100 ms period at low duty)."""
    dt = 0.001
    t = np.arange(20000) * dt
    duty = 80.0 * np.sin(2 * np.pi * 0.25 * t)
    applied = np.where((t * 10.0) % 1.0 < np.abs(duty) / 100.0, np.sign(duty) * 12.0, 0.0)
    params = {"inertia": 1.5e-6, "input_gain": 0.002, "viscous": 1e-4, "coulomb": 0.003, "offset": 0.0}
    w = RigidDrive(("viscous_friction", "coulomb_friction", "offset"), params, dt).free_run(
        applied, substeps=5
    )
    y = 0.767 * np.round((w + 0.5 * np.random.default_rng(1).standard_normal(w.size)) / 0.767)
    record = pd.DataFrame({"t": t, "u": duty, "y": y})
    record.attrs["dt"] = dt
    return record


def test_a_pulsed_drive_is_refused_naming_what_the_record_shows(pulsed):
    """Refused before any fit by its stops under a held input, one in each period of the PWM (100 ms):
    the closest two within a period (a stop comes later in the off phase as the duty rises)."""
    with pytest.raises(
        DataError, match=r"no drive model describes this record: the speed falls to zero"
    ) as info:
        diagnose(pulsed)
    assert "a pulsed drive" in str(info.value) and "nan" not in str(info.value)
    apart = float(re.search(r"the closest two ([0-9.]+) ms apart", str(info.value)).group(1))
    assert 50.0 <= apart <= 101.0


def test_a_fit_with_a_negative_inertia_or_a_free_run_that_diverges_is_refused():
    """What a record no drive model describes leaves where nothing refused it earlier: the final
    model's inertia not positive, or its free run not finite."""
    from motorid.diagnose.workflow import refuse_unphysical

    units = {"F": "V", "v": "rad/s", "u": "V"}
    params = {"inertia": 1e-3, "input_gain": 1.0, "viscous": 0.1}
    good = RigidDrive(("viscous_friction",), params, 0.01)
    refuse_unphysical(good, 0.5, units)  # physical and finite: nothing said
    with pytest.raises(DataError, match=r"the fitted inertia is -0.001 V s²/rad/s, not physical") as info:
        refuse_unphysical(good.with_params(inertia=-1e-3), 0.5, units)
    assert "averaged over whole PWM periods" in str(info.value)
    with pytest.raises(DataError, match="the final model's free run does not stay finite"):
        refuse_unphysical(good, math.nan, units)


def test_the_command_line_exits_2_in_one_line_and_writes_no_model(capsys, pulsed, tmp_path):
    path = tmp_path / "pulsed.csv"
    write_record(pulsed, path)
    model = tmp_path / "pulsed.json"
    code, out, err = run(capsys, "doctor", str(path), "--save-model", str(model), "--json")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "no drive model describes this record" in err and "nan" not in err
    assert not model.exists()


@pytest.mark.parametrize(
    ("value", "text"), [(1.23456, "1.235"), (math.nan, "diverges"), (math.inf, "diverges")]
)
def test_a_gap_that_is_not_finite_is_said_to_diverge(value, text):
    assert figure(value) == text
