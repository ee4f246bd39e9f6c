"""Lookalikes said as lookalikes: effects of one physics that a record cannot tell apart are
reported side by side with both figures, and the lookalike rule names the same one whichever
of them the drive really has (``diagnose`` step 4)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid.diagnose import diagnose
from motorid.diagnose.synthetic import planted_record
from motorid.drive.rigid import RigidDrive
from motorid.io.records import write_record

KINETIC = 1.0  # V: the kinetic friction level planted, as a Coulomb level or a dead zone (input gain 1)


def slow_sine_record(effect: str, level: float = KINETIC, seed: int = 0) -> pd.DataFrame:
    """A drive whose speed follows its input within 20 ms, on two slow sines (0.5 and 1.35 Hz): it
    comes to rest before every reversal, so a Coulomb level and an input dead zone of the same
    size hold it back alike. Speed noise 1 % of the largest speed."""
    dt, tau, inertia = 0.01, 0.02, 1e-3
    params = {"inertia": inertia, "input_gain": 1.0, "viscous": inertia / tau, "offset": 0.0}
    params.update({"coulomb": level} if effect == "coulomb_friction" else {"dead_zone": level})
    drive = RigidDrive(("viscous_friction", "offset", effect), params, dt)
    t = np.arange(3000) * dt
    u = 6.0 * np.sin(2 * np.pi * 0.5 * t) + 1.5 * np.sin(2 * np.pi * 1.35 * t + 1.0)
    w = drive.free_run(u, substeps=20)
    y = w + 0.01 * np.max(np.abs(w)) * np.random.default_rng(seed).standard_normal(u.size)
    record = pd.DataFrame({"t": t, "u": u, "y": y})
    record.attrs.update(dt=dt, units={"t": "s", "u": "V", "y": "rad/s"})
    return record


@pytest.mark.parametrize("planted", ["coulomb_friction", "input_dead_zone"])
def test_coulomb_friction_and_a_dead_zone_that_fit_alike_get_one_name(planted, capsys, tmp_path):
    path = tmp_path / "slow.csv"
    write_record(slow_sine_record(planted), path)
    code, out, err = run(capsys, "doctor", str(path), "--max-steps", "1", "--json")
    assert code == 0, err
    # the same physics gets the same name whichever form the drive has: the first in the library
    assert [s["effect"] for s in out["steps"]] == ["coulomb_friction"]
    look = out["steps"][0]["lookalike"]
    assert out["lookalikes"] == [look]
    assert look["physics"] == "kinetic friction" and look["named"] == "coulomb_friction"
    assert look["effects"] == ["coulomb_friction", "input_dead_zone"]
    gaps = look["free_run_gaps"]
    # they fit alike: the gaps within half a noise floor of each other
    assert abs(gaps["coulomb_friction"] - gaps["input_dead_zone"]) <= look["tolerance"]
    assert look["tolerance"] == pytest.approx(0.5 * out["noise_floor"])
    # both levels are the kinetic friction planted (5 %: the four fits came within 3.3 % of it)
    for level in look["levels"].values():
        assert level == pytest.approx(KINETIC, rel=0.05)
    line = (
        f"kinetic friction {look['levels']['coulomb_friction']:.3g} V: coulomb_friction and input_dead_zone "
        f"fit alike (free-run gap {gaps['coulomb_friction']:.4g} vs {gaps['input_dead_zone']:.4g} rad/s, "
        f"within {look['tolerance']:.3g} rad/s); named coulomb_friction by the lookalike rule"
    )
    assert line in err, err


def test_the_rests_of_a_stribeck_drive_measure_its_breakaway_and_the_free_run_tells_a_decay(capsys, tmp_path):
    """A Stribeck excess of 6 mN m that decays within 6 rad/s breaks away above the kinetic level: its
    rests measure the Stribeck level as static friction's breakaway, and both pass the evidence;
    the free run tells a decay from a step at rest (its gaps lie more than half a noise floor
    apart), so they are not lookalikes and Stribeck friction is named."""
    planted = planted_record(
        "stribeck_friction", 2, sizes={"stribeck": 0.006, "stribeck_velocity": 6.0}, duration=60.0
    )
    path = tmp_path / "stribeck.csv"
    write_record(planted.record, path)
    code, out, err = run(
        capsys, "doctor", str(path), "--input-gain", repr(planted.input_gain), "--base",
        ",".join(planted.base), "--max-steps", "1", "--json",
    )  # fmt: skip
    assert code == 0, err
    assert [s["effect"] for s in out["steps"]] == ["stribeck_friction"]
    assert "lookalike" not in out["steps"][0]
    ranking = {c["effect"]: c for c in out["steps"][0]["evidence"]["ranking"]}
    static = ranking["static_friction"]
    assert static["measure"] == "rests" and static["delta_bic"] > out["settings"]["threshold"]
    # the rests' breakaway above the kinetic level is the planted Stribeck level: 0.00539 N m
    # measured (the decay has begun by the time the shaft is seen to move); 15 %, the tolerance
    assert static["breakaway"]["excess"] == pytest.approx(0.006, rel=0.15)
    # the balance's Stribeck level: 0.00593 N m measured (its decay and level trade along a valley)
    assert out["steps"][0]["params"]["stribeck"] == pytest.approx(0.006, rel=0.25)


def test_effects_the_record_tells_apart_are_not_lookalikes():
    """Static friction planted: the balance of the moving drive gives the Stribeck excess a negative
    level, so the two are told apart; a dead zone on a record that reverses while moving is told
    from Coulomb friction by the free run (1.3 noise floors apart on this one)."""
    planted = planted_record("static_friction", 2, duration=60.0)
    d = diagnose(planted.record, input_gain=planted.input_gain, base=planted.base, max_steps=1)
    assert d.named == ["static_friction"] and d.lookalikes == []
    planted = planted_record("input_dead_zone", 2, sizes={"dead_zone": 0.5})
    d = diagnose(planted.record, input_gain=planted.input_gain, base=planted.base, max_steps=1)
    assert d.named == ["input_dead_zone"] and d.lookalikes == [] and "lookalikes" not in d.to_dict()


def test_stribeck_and_static_friction_that_fit_alike_are_said_with_both_figures(capsys, tmp_path):
    """A Stribeck excess that decays within 2 rad/s (a few noise floors of speed) acts at the
    rests and the breakaways only: the rests measure it as static friction's breakaway, and the
    free run of either model comes within half a noise floor of the other's, so the record cannot
    tell a fast decay from a step at rest. The report says both names with both free-run gaps and
    names the first in the library's order, Stribeck friction; the JSON carries the pair."""
    excess = 0.005  # N m: the Stribeck level planted, the excess at rest over the kinetic level
    planted = planted_record(
        "stribeck_friction", 3, sizes={"stribeck": excess, "stribeck_velocity": 2.0}, duration=60.0
    )
    path = tmp_path / "fast_stribeck.csv"
    write_record(planted.record, path)
    code, out, err = run(
        capsys, "doctor", str(path), "--input-gain", repr(planted.input_gain), "--base",
        ",".join(planted.base), "--max-steps", "1", "--json",
    )  # fmt: skip
    assert code == 0, err
    step = out["steps"][0]
    assert step["effect"] == "stribeck_friction"
    look = step["lookalike"]
    assert out["lookalikes"] == [look]
    assert look["physics"] == "breakaway friction above the kinetic level"
    assert look["named"] == "stribeck_friction"
    assert look["effects"] == ["stribeck_friction", "static_friction"]
    gaps = look["free_run_gaps"]
    assert abs(gaps["stribeck_friction"] - gaps["static_friction"]) <= look["tolerance"]
    assert look["tolerance"] == pytest.approx(0.5 * out["noise_floor"])
    # each level is its own model's: the balance's Stribeck level, the rests' breakaway excess
    static = {c["effect"]: c for c in step["evidence"]["ranking"]}["static_friction"]
    assert look["levels"]["stribeck_friction"] == step["params"]["stribeck"]
    assert look["levels"]["static_friction"] == static["breakaway"]["excess"]
    # the rests measure the planted excess: 0.00549 ± 0.00028 N m (1.7 standard errors off)
    breakaway = static["breakaway"]
    assert abs(breakaway["excess"] - excess) < 3.0 * breakaway["standard_error"]
    line = (
        f"breakaway friction above the kinetic level {look['levels']['stribeck_friction']:.3g} N m: "
        f"stribeck_friction and static_friction fit alike (free-run gap {gaps['stribeck_friction']:.4g} "
        f"vs {gaps['static_friction']:.4g} rad/s, within {look['tolerance']:.3g} rad/s); named "
        "stribeck_friction by the lookalike rule"
    )
    assert line in err, err
