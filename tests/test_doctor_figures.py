"""The doctor's results held on two records: the names it gives, why it stops, and its figures.

The figures were recorded with SciPy designing and running the zero-phase filters and doing the
bounded scalar searches; before that the doctor ran its own copies of both, and its JSON on
these records (and on EMPS and the wheel motors) was byte for byte the same. A later SciPy, or a
CPU whose vector code rounds differently, may change a last bit of a filtered signal. Such a
change can move the end of a bounded search anywhere within its tolerance (``xatol`` 1e-3 in the
logarithm of a shape parameter: 0.1 %; 1e-4 of the searched range for the breakaway excess), and
the figures that follow from the parameter by as much: ``REL`` is twice that. A larger move is a
changed result, not rounding.
"""

from __future__ import annotations

import re

import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

#: Relative tolerance of every figure (see the module notes).
REL = 2e-3

STAIRCASE = real_motor_file("l298n_staircase.csv")


def assert_figures(found: dict[str, float], expected: dict[str, float]) -> None:
    assert set(found) >= set(expected)
    for key, value in expected.items():
        assert found[key] == pytest.approx(value, rel=REL), key


def test_the_readme_record_coulomb_friction_and_a_dead_zone(capsys, tmp_path):
    """The README's simulated record (the default rig with a 0.6 V dead zone and extra Coulomb
    friction on the motor), diagnosed as the README does."""
    record = tmp_path / "rec.csv"
    argv = ["--out", str(record), "--duration", "120", "--dead-zone", "0.6", "--coulomb-motor", "0.004"]
    code, _, err = run(capsys, "simulate", *argv)
    assert code == 0, err
    code, out, err = run(capsys, "doctor", str(record), "--input-gain", "0.02142", "--json")
    assert code == 0, err
    assert out["structure"]["effects"] == []
    assert [s["effect"] for s in out["steps"]] == ["coulomb_friction", "input_dead_zone"]
    # the best of the rest below zero: Stribeck friction's balance and static friction's free run (the
    # rests read a hair below the kinetic level, so the free run fits it, at 0) each lose ln n_eff
    best = re.match(
        r"no candidate passes the evidence threshold: the best, (\w+), has ΔBIC = (-?[\d.]+) <= 10",
        out["stop_reason"],
    )
    assert best and best[1] in ("stribeck_friction", "static_friction") and float(best[2]) < 0.0, out[
        "stop_reason"
    ]
    assert out["stop_reason"].endswith("at the noise floor, nothing more to explain")
    assert out["model"]["effects"] == ["coulomb_friction", "viscous_friction", "input_dead_zone", "offset"]
    assert_figures(out["initial_gap"], {"overall": 8.7194, "force_error_percent": 23.721})
    assert_figures(out["steps"][0]["gap_after"], {"overall": 0.57341, "force_error_percent": 6.5887})
    assert_figures(out["final_gap"], {"overall": 0.28662, "force_error_percent": 6.5545})
    assert out["noise_floor"] == pytest.approx(0.28148, rel=REL)
    assert_figures(
        out["model"]["params"],
        {"inertia": 9.9563e-5, "coulomb": 6.0386e-3, "viscous": 9.4661e-4, "dead_zone": 0.59966},
    )


@pytest.mark.skipif(
    not STAIRCASE.exists(), reason=f"real motor data not found at {STAIRCASE} (set MOTORID_DATA)"
)
def test_the_l298n_staircase_an_input_lag_and_static_friction(capsys):
    """The L298N staircase of ``realmotors/`` (volts in, rpm out): the README's figures."""
    code, out, err = run(
        capsys, "doctor", str(STAIRCASE), "--input-unit", "V", "--output-unit", "rpm", "--json"
    )
    assert code == 0, err
    assert out["structure"]["effects"] == ["input_lag"]
    assert [s["effect"] for s in out["steps"]] == ["static_friction"]
    assert (
        out["stop_reason"].startswith(
            "no candidate improves held-out data and shrinks the free-run gap beyond the noise: "
            "coulomb_friction (held-out error "
        )
        and "something is still missing" in out["stop_reason"]
    )
    assert [r["effect"] for r in out["rejected"]] == [
        "stribeck_friction", "coulomb_friction", "input_dead_zone", "stribeck_friction",
    ]  # fmt: skip
    assert out["structure"]["params"]["lag_time_constant"] == pytest.approx(0.041825, rel=REL)
    assert_figures(out["initial_gap"], {"overall": 3.1640, "force_error_percent": 28.996})
    assert_figures(out["final_gap"], {"overall": 1.3155, "force_error_percent": 13.459})
    assert out["noise_floor"] == pytest.approx(0.091089, rel=REL)
    assert_figures(
        out["model"]["params"],
        {"inertia": 0.036288, "viscous": 0.37311, "offset": 0.17617, "breakaway_excess": 3.8233},
    )
