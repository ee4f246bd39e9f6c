"""Stiction told from lag (issue 31, item 4): a breakaway excess is a level of the input, a lag a
time. Rests at spread input rates tell them apart themselves; rests at one rate (a sine's
reversals all alike) read their excess both ways, and the free run of the moving drive tells them,
or the report says they look alike with both figures. Known truths on a kit-like motor at 1 kHz:
stiction only, a lag only, both."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from motorid.diagnose import diagnose
from motorid.diagnose.measures import Breakaway
from motorid.diagnose.search import LagTest, breakaway_sentence, paired_z
from motorid.drive.rigid import RigidDrive

KINETIC = 0.73  # V: the kinetic friction level (input gain 1 in the doctor's force unit: volts)
BREAKAWAY = 1.25  # V: the breakaway level of the stiction truth
LAG = 0.010  # s: the input lag of the lag truth (an armature's L/R)
AMPLITUDE = 6.0  # V


def kit_like(signal: str, truth: str, seed: int = 0, duration: float = 30.0) -> pd.DataFrame:
    """A kit-like motor (K_m 0.0298 V s/rad, R 3.6 ohm, J 6.7e-6 kg m², so τ = J/B = 27 ms) on a
    6 V sine of ``signal`` Hz or a 0.05-2 Hz chirp, at 1 kHz, its encoder's speed quantised in
    0.767 rad/s with noise of 2 % of the speed. ``truth``: ``stiction`` (breakaway 1.25 V against
    0.73 V kinetic), ``lag`` (a 10 ms input lag, no stiction) or ``both``."""
    from motorid.signals import chirp

    dt = 0.001
    gain = 0.0298 / 3.6  # K_m / R [N m/V]
    params = {"inertia": 6.7e-6, "input_gain": gain, "viscous": 0.0298 * gain, "coulomb": KINETIC * gain,
              "offset": 0.0}  # fmt: skip
    effects = ["viscous_friction", "coulomb_friction", "offset"]
    if truth in ("stiction", "both"):
        effects.append("static_friction")
        params["breakaway_excess"] = (BREAKAWAY - KINETIC) * gain
    if truth in ("lag", "both"):
        effects.append("input_lag")
        params["lag_time_constant"] = LAG
    t = np.arange(round(duration / dt)) * dt
    if signal == "chirp":
        u = chirp(duration, dt, f0=0.05, f1=2.0, amplitude=AMPLITUDE, method="linear", seed=seed)[1]
    else:
        u = AMPLITUDE * np.sin(2 * np.pi * float(signal) * t)
    w = RigidDrive(tuple(effects), params, dt).free_run(u, substeps=10)
    noisy = w + 0.02 * np.abs(w) * np.random.default_rng(seed).standard_normal(w.size)
    record = pd.DataFrame({"t": t, "u": u, "y": 0.767 * np.round(noisy / 0.767)})
    record.attrs.update(dt=dt, units={"t": "s", "u": "V", "y": "rad/s"})
    return record


def excess(d) -> float:
    """The final model's static friction ΔF_s [V]."""
    return d.model.params.get("breakaway_excess", 0.0)


def rule(d) -> dict:
    """The evidence of the static friction candidate at its step."""
    step = d.steps[d.named.index("static_friction")]
    return next(c for c in step.evidence.ranking if c.effect == "static_friction")


@pytest.mark.parametrize("signal", ["0.25", "1", "chirp"])
def test_stiction_is_named_on_sines_and_a_chirp_at_its_breakaway_level(signal):
    """Named on each; at one input rate the free run rules the lag out (the lag the excess would
    need, 56 ms at 0.25 Hz and 14 ms at 1 Hz, runs the drive far from the record)."""
    d = diagnose(kit_like(signal, "stiction"))
    assert d.named == ["coulomb_friction", "static_friction"], (d.named, d.notes)
    # the level within 15 % of the 0.52 V planted (measured 0.513, 0.505, 0.519 V: each breakaway
    # read where the shaft is seen to move, :func:`~motorid.diagnose.rests.first_moving`)
    assert excess(d) == pytest.approx(BREAKAWAY - KINETIC, rel=0.15)
    ev = rule(d)
    if signal == "chirp":  # the rates spread: the rests tell the level from the lag themselves
        assert not ev.breakaway.one_rate and ev.breakaway.reading == "static_friction"
    else:
        assert ev.breakaway.one_rate and ev.breakaway.reading == "lookalike"
        told = ev.lag_test
        # the lag the excess would need (measured 56 and 14 ms) runs the drive far from the
        # record: at 0.25 Hz its free run does not stay finite, at 1 Hz z = -43
        assert told.reading == "static_friction" and told.lag > 0.011
        assert not np.isfinite(told.gap_lag) or (told.z < -3.0 and told.gap_level < told.gap_lag)


@pytest.mark.parametrize("signal", ["0.25", "1", "chirp"])
def test_a_lag_is_not_named_static_friction(signal):
    """A 10 ms lag and no stiction: nothing named at the rests; on the sines the note gives both
    readings of the excess, and that the lag runs the drive closer (a smaller level beside it
    cannot be ruled out at one rate)."""
    d = diagnose(kit_like(signal, "lag"))
    assert "static_friction" not in d.named, d.named
    said = [n for n in d.notes if "rests break away" in n]
    assert len(said) == 1, d.notes
    if signal == "chirp":  # the structure takes the lag (as an 8 ms delay); the rests read the rest
        assert d.structure.effects and said[0].endswith("not static friction")
        lag_ms = float(re.search(r"a lag of ([0-9.]+) ±", said[0]).group(1))
        assert 0.0 < lag_ms < 5.0  # measured 2.9 ms beside the 8 ms delay
        return
    lag_ms = float(re.search(r"a lag of ([0-9.]+) ms", said[0]).group(1))
    # the lag the rests need lies a little above the 10 ms planted (measured 14.2 and 12.8 ms): the
    # lag's speed grows from zero under the encoder's step and noise for a few samples, and the
    # breakaway, read where the shaft is seen to move, reads as more lag
    assert 10.0 <= lag_ms <= 16.0
    level = float(re.search(r"static friction of ([0-9.]+) V", said[0]).group(1))
    assert level == pytest.approx(float(re.search(r"break away ([0-9.]+) ±", said[0]).group(1)))
    assert "runs the drive closer than static friction" in said[0] and "rests at other input rates" in said[0]
    z = float(re.search(r"z = ([-0-9.e+]+)\)", said[0]).group(1))
    assert z > 3.0


def test_both_on_one_sine_name_the_level_that_holds_the_lags_share():
    """Stiction and a 10 ms lag on a 1 Hz sine: one excess at one rate (36 V/s), 0.85 V or 23 ms.
    The lag alone that would hold it runs the drive further from the record than the level does
    (z = -12.5 on this seed): static friction, which the truth holds, is named, at a level that
    holds the lag's share too (0.52 V planted and 10 ms x 36 V/s = 0.36 V: one rate cannot take
    them apart; a chirp or a joint run with another sine does, see below)."""
    d = diagnose(kit_like("1", "both", seed=0))
    assert d.named == ["coulomb_friction", "static_friction"]
    ev = rule(d)
    assert ev.breakaway.one_rate and ev.lag_test.reading == "static_friction" and ev.lag_test.z < -3.0
    rate = (
        2 * np.pi * AMPLITUDE * 1.0 * np.cos(np.arcsin(KINETIC / AMPLITUDE))
    )  # the sine's slope at breakaway
    assert excess(d) == pytest.approx(BREAKAWAY - KINETIC + LAG * rate, rel=0.1)


def test_a_lookalike_sentence_gives_both_figures():
    found = Breakaway(12, 0.5, 0.01, 0.02, 0.0004, one_rate=True)
    told = LagTest(0.02, 0.0, 1.0, 1.01, 1.2)
    units = {"F": "V", "v": "rad/s"}
    said = breakaway_sentence(found, told, units)
    assert said == (
        "12 rests break away 0.5 ± 0.01 V above the kinetic level, all at one input rate (25 V/s): static "
        "friction of 0.5 V and a lag of 20 ms between input and force fit alike (free-run gap 1 vs 1.01 rad/s, "
        "z = 1.2); rests at other input rates (a chirp, or records at other frequencies in one run) tell them apart"
    )
    page = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "doctor.md").read_text(encoding="utf-8")
    assert f"```text\n{said}\n```" in page


def test_both_on_a_chirp_and_on_a_joint_run_of_two_sines_name_the_level_beside_the_lag():
    """Stiction and a 10 ms lag: the rates spread on a chirp, and across a joint run of a 0.25 Hz
    and a 1 Hz sine (each alone at one rate): the level at an input rising infinitely slowly is the
    stiction planted, the lag taken apart."""
    chirp = diagnose(kit_like("chirp", "both"))
    joint = diagnose([kit_like("0.25", "both"), kit_like("1", "both", seed=1)])
    for d in (chirp, joint):
        assert d.named == ["coulomb_friction", "static_friction"], d.named
        # within 15 % of the 0.52 V planted (measured 0.510 and 0.513 V)
        assert excess(d) == pytest.approx(BREAKAWAY - KINETIC, rel=0.15)
        assert not rule(d).breakaway.one_rate
    # each sine alone breaks away at one rate: the report says so and reads its excess both ways
    assert all(r.breakaway_one_rate for r in joint.rests)
    # the faster sine breaks away higher: the lag, 0.54 V at 9 V/s and 0.64 V at 36 V/s
    assert joint.rests[1].breakaway_excess > joint.rests[0].breakaway_excess


@pytest.mark.parametrize("truth", ["lag", "stiction"])
def test_a_joint_run_of_two_sines_tells_stiction_from_lag(truth):
    """A 0.25 Hz and a 1 Hz sine of one drive, each breaking away at one rate of its own (9.3 and 37 V/s):
    the line through the two clusters of rests is not trusted on the rests' own scatter (none: a sine's
    reversals are identical, and a 10 ms lag alone left a level of 0.043 V "± 7e-14 V", named static
    friction); the level and the lag that would hold the whole excess are told apart by the free run of
    both records, as at one rate. Lag only: not named, the note gives both readings, the lag the
    closer (z = +2.3, a lookalike below the test's 3); stiction only: named at its level (0.518 V
    against 0.52 V planted, z = -29)."""
    joint = diagnose([kit_like("0.25", truth), kit_like("1", truth, seed=1)])
    # the candidate at the last step (the lag truth's only one: before Coulomb friction, its lag test then
    # undecided at z = -1.5; the note is the final model's, with Coulomb friction)
    ev = [c for s in joint.steps for c in s.evidence.ranking if c.effect == "static_friction"][-1]
    assert ev.breakaway.rate_per_record and not ev.breakaway.one_rate
    assert ev.breakaway.reading == "lookalike" and ev.lag_test is not None
    rates = ev.breakaway.record_rates
    assert max(rates) > 3.0 * min(rates)  # the sines' rates: 9.3 and 37 V/s
    if truth == "lag":
        assert "static_friction" not in joint.named, joint.named
        (said,) = [n for n in joint.notes if "rests break away" in n]
        assert "each record's at one input rate of its own" in said
        z = float(re.search(r"z = ([-0-9.e+]+)\)", said).group(1))
        assert z > 1.0  # the free run favours the lag (measured +2.3)
    else:
        assert joint.named == ["coulomb_friction", "static_friction"], joint.named
        assert excess(joint) == pytest.approx(BREAKAWAY - KINETIC, rel=0.15)
        assert rule(joint).lag_test.reading == "static_friction"


def test_the_reading_of_the_rests_follows_the_rule():
    """The rule on figures: a level shown is static friction; at spread rates a slope above two
    standard errors is a lag, unless the level lies more than two below the kinetic one (the rests
    do not measure the breakaway); at one rate an excess above two standard errors a lookalike."""
    assert Breakaway(10, 0.5, 0.01, 0.0, 0.001, False, True).reading == "static_friction"
    assert Breakaway(10, 0.01, 0.01, 0.01, 0.001, False, False).reading == "lag"
    # a level below the kinetic one by more than two standard errors: no friction breaks away there
    assert Breakaway(10, -0.05, 0.01, 0.01, 0.001, False, False).reading == "none"
    assert Breakaway(10, 0.01, 0.01, 0.001, 0.001, False, False).reading == "none"
    assert Breakaway(10, 0.5, 0.01, 0.02, 0.0004, True, False).reading == "lookalike"
    assert Breakaway(10, 0.01, 0.01, 0.001, 0.001, True, False).reading == "none"
    assert Breakaway(4, 0.5, 0.01, 0.0, 0.001, False, True).reading == "none"  # too few rests
    assert LagTest(0.01, 0.0, 1.0, 1.2, -4.0).reading == "static_friction"
    assert LagTest(0.01, 0.0, 1.2, 1.0, 4.0).reading == "lag"
    assert LagTest(0.01, 0.0, 1.0, 1.01, 1.0).reading == "lookalike"
    assert LagTest(0.01, 0.0, 1.0, float("nan"), float("nan")).reading == "static_friction"
    # a joint run at one rate per record: a level above two standard errors is read both ways, as at one rate
    per_record = Breakaway(10, 0.5, 0.01, 0.02, float("nan"), rate_per_record=True, record_rates=(9.0, 36.0))
    assert per_record.reading == "lookalike"
    assert per_record.rates_words("V") == "each record's at one input rate of its own (9 to 36 V/s)"
    assert Breakaway(10, 0.01, 0.01, 0.02, float("nan"), rate_per_record=True).reading == "none"


def test_the_paired_test_of_two_free_runs():
    """Equal errors: z near 0; the second model's errors smaller by a constant: z of the block
    means' t statistic, computed here independently; a sign flip changes its sign."""
    rng = np.random.default_rng(0)
    e = rng.standard_normal(3000)
    assert abs(paired_z(e, e + 1e-12 * rng.standard_normal(e.size))) < 3.0
    second = 0.5 * e
    d = (e**2 - second**2).reshape(30, 100).mean(axis=1)
    expected = d.mean() / (d.std(ddof=1) / np.sqrt(30))
    assert paired_z(e, second) == pytest.approx(expected, rel=1e-12)
    assert paired_z(second, e) == pytest.approx(-expected, rel=1e-12)
    assert np.isnan(paired_z(e[:2], e[:2]))
