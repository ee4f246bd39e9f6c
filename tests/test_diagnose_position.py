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


def test_the_doctor_names_an_asymmetry_the_held_out_halves_confirm_and_refits_in_position():
    """On a position record the doctor also asks a candidate to predict each half's position from
    a fit to the other half. Where the viscous asymmetry is real (the drive above without its
    delay, the position read with 5e-8 m of noise as EMPS's encoder), that check confirms it:
    the held-out position error falls from 1.07 to 0.098 mm (measured; bound 0.2 of it). The
    final model's parameters refitted to the record's free-run position leave 0.019 mm against
    0.104 mm as fitted to the balance (measured; bound 0.5 of it)."""
    from motorid.diagnose import diagnose

    record = position_record(TRUE.without("input_delay"))
    record["y"] += 5e-8 * np.random.default_rng(1).standard_normal(len(record))
    d = diagnose(record, output_kind="position", input_gain=35.15, base=("viscous_friction", "offset"))
    assert d.named == ["coulomb_friction", "asymmetric_friction"], d.stop_reason
    evidence = d.steps[1].evidence
    assert evidence.held_out_position_error_after < 0.2 * evidence.held_out_position_error_before
    assert d.position_model is not None and d.position_model.effects == d.model.effects
    assert d.position_error.refitted < 0.5 * d.position_error.fitted
    report = d.to_dict()["position_refit"]
    assert report["unit"] == "m" and report["position_error_refitted"] == d.position_error.refitted
    assert report["params"]["viscous_asymmetry"] == pytest.approx(-37.0, rel=0.05)


def test_motorid_doctor_prints_and_reports_both_position_errors(tmp_path, capsys):
    """``motorid doctor --output-kind position``: the position error of the final model as fitted
    and refitted in position, in the JSON's ``position_refit`` and on stderr; not on a speed record."""
    import json

    from motorid.cli import main
    from motorid.io.records import write_record

    record = position_record(TRUE.without("input_delay"))
    write_record(record, tmp_path / "position.csv")
    args = [
        "doctor",
        str(tmp_path / "position.csv"),
        "--input-gain",
        "35.15",
        "--base",
        "viscous_friction,offset",
    ]
    assert main([*args, "--output-kind", "position", "--json"]) == 0
    printed = capsys.readouterr()
    refit = json.loads(printed.out)["position_refit"]
    assert refit["unit"] == "m" and refit["position_error_refitted"] <= refit["position_error_fitted"]
    assert (
        f"free-run position error {refit['position_error_fitted']:.4g} m; the final model's parameters "
        f"refitted in position: {refit['position_error_refitted']:.4g} m"
    ) in printed.err
    speed = record.assign(y=TRUE.without("input_delay").free_run(record["u"].to_numpy()))
    speed.attrs.update(record.attrs, units={"t": "s", "u": "V", "y": "m/s"})
    write_record(speed, tmp_path / "speed.csv")
    assert (
        main(["doctor", str(tmp_path / "speed.csv"), "--input-gain", "35.15", "--json", "--max-steps", "0"])
        == 0
    )
    printed = capsys.readouterr()
    assert "position_refit" not in json.loads(printed.out) and "position error" not in printed.err
