"""The doctor's effects refitted to a position record's free run (output error in position)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from motorid.datasets import emps_benchmark_rmse
from motorid.diagnose.model import refitted_parameters
from motorid.diagnose.position import refit_in_position
from motorid.drive import RigidDrive

TRUE = RigidDrive(
    ("coulomb_friction", "asymmetric_friction", "viscous_friction", "offset", "input_delay"),
    {"inertia": 95.0, "input_gain": 35.15, "coulomb": 20.4, "coulomb_asymmetry": 0.0, "viscous": 200.0,
     "viscous_asymmetry": -37.0, "offset": -0.2, "input_delay": 0.002},
    dt=1e-3,
)  # fmt: skip


def position_record(drive: RigidDrive) -> pd.DataFrame:
    """8 s of a closed-loop-like force with reversals; ``y`` the position [m], sampled timing."""
    t = np.arange(8000) * 1e-3
    u = 1.5 * np.sin(2 * np.pi * 0.4 * t) + 0.5 * np.sin(2 * np.pi * 2.3 * t + 1.0)
    _, q = drive.motion(u, w0=0.0, q0=0.1)
    frame = pd.DataFrame({"t": t, "u": u, "y": np.r_[0.1, q[:-1]]})
    frame.attrs.update(dt=1e-3, timing="sampled", units={"t": "s", "u": "V", "y": "m"})
    return frame


def test_the_refit_finds_the_drive_that_made_the_record():
    """Noise free, from a start 5 % off in every level (millimetres of drift), the fit lands on
    the drive: its position error to 1e-4 mm, its parameters within 1e-4 relative (a
    position that drifts no more than that pins them to about that)."""
    record = position_record(TRUE)
    start = TRUE.with_params(inertia=90.0, coulomb=21.4, viscous=190.0, viscous_asymmetry=-35.0, offset=0.3)
    assert emps_benchmark_rmse(start, record) > 1.0
    refitted = refit_in_position(start, record)
    assert emps_benchmark_rmse(refitted, record) < 1e-4
    for name in ("inertia", "coulomb", "viscous", "viscous_asymmetry"):
        assert refitted.params[name] == pytest.approx(TRUE.params[name], rel=1e-4), name
    assert refitted.params["offset"] + refitted.params["coulomb_asymmetry"] == pytest.approx(-0.2, abs=1e-3)
    assert refitted.params["input_delay"] == 0.002 and refitted.input_gain == 35.15  # kept as given


def test_the_parameters_refitted_leave_the_scale_the_structure_and_the_breakaway():
    drive = TRUE.with_effects((*TRUE.effects, "static_friction"), {**TRUE.params, "breakaway_excess": 1.0})
    assert refitted_parameters(drive) == (
        "inertia", "coulomb", "coulomb_asymmetry", "viscous_asymmetry", "viscous", "offset",
    )  # fmt: skip
