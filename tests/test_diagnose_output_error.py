"""The fit of a model's parameters to its output error (:func:`motorid.diagnose.model.fit_output_error`):
from a start 10-20 % off, it returns the drive that made the record."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from motorid.diagnose.model import fit_output_error, refitted_parameters
from motorid.diagnose.workflow import free_run_error, prepare
from motorid.drive.rigid import RigidDrive

TRUTH = {"inertia": 1e-3, "input_gain": 1.0, "viscous": 0.05, "coulomb": 0.4, "offset": 0.05}


@pytest.fixture(scope="module")
def record() -> pd.DataFrame:
    """A rigid drive with viscous and Coulomb friction and an offset on a two-sine input, its speed
    with white noise of 0.5 % of the largest speed."""
    dt = 0.005
    drive = RigidDrive(("viscous_friction", "coulomb_friction", "offset"), TRUTH, dt)
    t = np.arange(2000) * dt
    u = 3.0 * np.sin(2 * np.pi * 0.7 * t) + 1.5 * np.sin(2 * np.pi * 2.3 * t + 1.0)
    w = drive.free_run(u, substeps=10)
    y = w + 0.005 * np.max(np.abs(w)) * np.random.default_rng(0).standard_normal(u.size)
    out = pd.DataFrame({"t": t, "u": u, "y": y})
    out.attrs.update(dt=dt, units={"t": "s", "u": "V", "y": "rad/s"})
    return out


def test_the_free_run_fit_returns_the_drive_from_a_start_off_the_truth(record):
    prep = prepare(record, input_gain=1.0)
    start = RigidDrive(
        ("viscous_friction", "coulomb_friction", "offset"),
        {**TRUTH, "inertia": 1.2e-3, "viscous": 0.045, "coulomb": 0.48, "offset": 0.04},
        prep.kin.dt,
    )
    assert refitted_parameters(start) == ("inertia", "coulomb", "viscous", "offset")
    fitted = fit_output_error(start, lambda trial: free_run_error(prep, trial))
    # within 2 % of the truth (measured: the inertia 1.0 % low, the friction within 0.2 %)
    for name in ("inertia", "viscous", "coulomb"):
        assert fitted.params[name] == pytest.approx(TRUTH[name], rel=0.02), name
    assert fitted.params["input_gain"] == TRUTH["input_gain"]  # the force scale stays

    def rms(model: RigidDrive) -> float:
        err = free_run_error(prep, model)
        return float(np.sqrt(np.nanmean(err**2)))

    truth = start.with_params(**TRUTH)
    assert rms(fitted) < 0.5 * rms(start)
    assert rms(fitted) <= 1.01 * rms(truth)  # as close as the drive that made the record
