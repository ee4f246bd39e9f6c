"""The bank of benches (issue 31): records with the imperfections real benches have, drawn at
random within stated ranges; a bounded part of the calibration the doctor's rules are measured on
(``python -m motorid.diagnose.calibration --bank`` runs it whole)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motorid.app.doctor import save_doctor_model
from motorid.diagnose.bench import IMPERFECTIONS, OVERSAMPLE, bench
from motorid.diagnose.calibration import _bank_report, _noise_report, bank, noise_estimates, planted_shows
from motorid.diagnose.kinematics import CUTOFF_PER_BAND, lowpass
from motorid.diagnose.measures import (
    breakaway_cross_check,
    breakaway_holdout,
    fit_static_friction,
    free_run_error,
)
from motorid.diagnose.model import fit_model
from motorid.diagnose.prepare import held_out
from motorid.diagnose.search import NOISE_EXPLAINED, ONE_PLACE
from motorid.diagnose.synthetic import BASE_FOR
from motorid.diagnose.workflow import diagnose
from motorid.drive.files import read_model_file
from motorid.drive.rigid import RigidDrive


@pytest.mark.parametrize("imperfection", IMPERFECTIONS)
def test_each_bench_is_drawn_within_its_stated_ranges(imperfection):
    for seed in range(3):
        b = bench(imperfection, "stribeck_friction", seed)
        dt = b.record.attrs["dt"]
        if imperfection == "slow_sampling":
            assert 0.02 <= dt <= 0.04
        else:
            assert dt in ((1e-3, 2e-3) if imperfection == "pwm_ripple" else (1e-3, 2e-3, 5e-3, 1e-2))
        assert np.all(np.isfinite(b.record[["u", "y"]].to_numpy()))
        tau = b.params["inertia"] / b.params["viscous"]
        assert 0.01 <= tau <= 0.06
        first, last = b.logging_delay
        if imperfection == "constant_delay":
            assert first == last and max(0.002, 2 * dt) <= first <= 0.2
        elif imperfection == "drifting_delay":
            assert 0.0 <= first <= 0.02 and 1e-3 <= (last - first) / b.record["t"].iloc[-1] <= 3e-3
        else:
            assert first == last == 0.0
        if imperfection == "stale_start":
            k = b.stale_samples
            assert 0.008 <= k * dt or k == 3
            assert (
                np.all(b.record["y"].iloc[:k] == b.record["y"].iloc[0])
                and 100 <= abs(b.record["y"].iloc[0]) <= 250
            )
            assert np.all(b.record["u"].iloc[: k + 1] == 0.0)
        if imperfection == "pulsed_pwm":
            assert 5.0 <= b.notes["pwm_frequency"] <= 20.0 and b.record.attrs["units"]["u"] == "%"
        if imperfection == "pwm_ripple":
            assert 100.0 <= b.notes["pwm_frequency"] <= 490.0 and np.max(np.abs(b.record["u"])) <= 12.0
        if imperfection == "torque_ripple":
            amplitude = math.hypot(b.params["cogging_sin"], b.params["cogging_cos"])
            assert 0.03 <= amplitude / (12.0 * b.params["input_gain"]) <= 0.08
            assert b.params["cogging_periods"] == 1.0
        else:
            assert "cogging_sin" not in b.params
        if imperfection == "closed_loop":
            assert list(b.record.columns) == ["t", "reference", "u", "y", "clamped"]
            assert np.max(np.abs(b.record["u"])) <= 12.0 and b.notes["compensated"] in (0.0, 1.0)


def test_a_logging_delay_is_the_drives_speed_read_late():
    """Without noise the logged speed at t is the simulated speed at t - d: a constant delay of a
    whole number of simulation steps is exact (the reference: the drive simulated again, alone)."""
    b = bench("constant_delay", None, 4, logging_delay=(0.05, 0.05), dt=5e-3)
    drive = RigidDrive(("viscous_friction", "coulomb_friction", "offset"), b.params, 5e-3 / OVERSAMPLE)
    w = drive.free_run(np.repeat(b.record["u"].to_numpy(), OVERSAMPLE))
    late = w[OVERSAMPLE - 1 :: OVERSAMPLE][: len(b.record) - 10]  # the speed 10 samples (50 ms) before
    noise = 0.002 * float(np.max(np.abs(w)))
    # what is left is the white noise of 0.2 % of the largest speed: 5 of its sigmas
    assert np.max(np.abs(b.record["y"].to_numpy()[10:] - late)) < 5 * noise


def test_the_bank_is_run_and_tabled():
    """A chirp at 2 ms with nothing hidden (seed 1) and a held-levels stair at 5 ms whose logger's
    delay drifts from 14.5 to 48.3 ms (seed 0). Other seeds miss: seed 0's chirp names an input dead
    zone beside the Coulomb level (then 52 % off), and seed 3's drifting two sines leave the delay
    1.7 samples off the start's after align, as the same drive logged with a constant delay does
    (its structure search's): the bank's figures, counted by the calibration."""
    rows = bank([1], ["none"], [None]) + bank([0], ["drifting_delay"], [None])
    assert [(r.imperfection, r.effect) for r in rows] == [("none", None), ("drifting_delay", None)]
    clean, drifting = rows
    # a bench that hides nothing: its Coulomb level within 15 %, no delay to judge (what it names
    # beside is the bank's false-name figure, measured by the calibration)
    assert clean.parameter_error <= 0.15 and clean.first_right == (not clean.named)
    assert math.isnan(clean.delay_error) and not clean.drift_said
    # the drifting logger's delay is said, and the delay left after align within a sample of its start
    assert drifting.drift_said and drifting.delay_error <= 1.0 and drifting.parameter_error <= 0.15
    lines = _bank_report(rows).splitlines()
    assert lines[2].startswith(f"| none | 1 | - | - | {int(bool(clean.named))}/1 | 1/1 | - | - | 0/1 |")
    assert lines[3].startswith(
        f"| drifting_delay | 1 | - | - | {int(bool(drifting.named))}/1 | 1/1 | 1/1 | 1/1 | 0/1 |"
    )


def test_the_bank_at_one_seed_meets_the_issues_bounds():
    """Seed 0 of every imperfection and effect (55 benches; the calibration runs seeds 0-2, the
    table in the docs). The issue's bounds: the planted effect named first on at least 90 % of the
    benches where it shows (:func:`planted_shows`; measured 31 of 32), false names on at most 2 %
    of those that hide nothing (0 of 10), the logging delay within one sample (10 of 10), a
    drifting one said; nothing named where the planted effect does not show (0 of 12) and every
    pulsed drive refused (5 of 5). At one seed an imperfection's row holds 3-4 benches where the
    effect shows, where 90 % allows no miss: each row is held to at most one (the bank's three
    seeds, 7-11 a row, meet 90 % on every row; the docs' table). The one: a torque ripple's held
    levels with static friction, whose rests disagree on one level (held out rest by rest, the
    level the other rests need stops the drive at the held-out one), unnamed; it had been named 66 %
    high when the free run drifted out of the ripple's phase. The planted parameter within 15 %
    where named first: on 29 of 31, held to 85 % (a closed loop's static friction 21 %, a torque
    ripple's dead zone 15.1 %)."""
    rows = bank([0])
    by = {i: [r for r in rows if r.imperfection == i] for i in IMPERFECTIONS}
    every = [r for r in rows if r.effect is not None and r.shows > NOISE_EXPLAINED]
    assert sum(r.first_right for r in every) >= 0.9 * len(every)
    for imperfection, group in by.items():
        shown = [r for r in group if r.effect is not None and r.shows > NOISE_EXPLAINED]
        assert sum(not r.first_right for r in shown) <= 1, (imperfection, shown)
        hidden = [r for r in group if r.effect is None and r.refused is None]
        assert sum(bool(r.named) for r in hidden) <= 0.02 * len(hidden), (imperfection, hidden)
        unseen = [r for r in group if r.effect is not None and not r.shows > NOISE_EXPLAINED]
        assert all(r.named == [] for r in unseen), (imperfection, unseen)
    assert all(r.refused is not None and "a pulsed drive" in r.refused for r in by["pulsed_pwm"])
    delayed = by["constant_delay"] + by["drifting_delay"]
    assert all(r.delay_error <= 1.0 for r in delayed), delayed
    assert all(r.drift_said for r in by["drifting_delay"]) and not any(
        r.drift_said for r in by["constant_delay"]
    )
    first = [r for r in rows if r.effect is not None and r.first_right]
    assert sum(r.parameter_error <= 0.15 for r in first) >= 0.85 * len(first)


def test_the_closed_loop_benches_name_what_their_loop_shows():
    """A bounded part of the bank's closed loops: seed 2 (a chirp at 10 ms) of Stribeck friction,
    quadratic drag and none. Nothing named where nothing is hidden; the planted effect named first,
    its parameter within 15 % (the issue's bound), the final gap within 3.5 noise floors
    (MISSING_FACTOR). Measured on seeds 0-9 (50 benches) before the free run was filtered: named
    first on 10/10 for Stribeck friction and quadratic drag, 7/10 for the dead zone, no false name
    on 10, parameters within 15 % wherever named, final gaps 0.89-1.79 floors. Static friction is
    named on 4/10 since the breakaways are read on the measured speed (1/10 before, read where the
    zero-phase filtered speed leaves rest, a few samples early on the loop's ramp); on the four
    compensated loops that never rest the record does not show it (the drive's free run without it
    within 0.1 noise floors RMS of the truth)."""
    rows = bank([2], ["closed_loop"], [None, "stribeck_friction", "quadratic_drag"])
    assert [r.effect for r in rows] == [None, "stribeck_friction", "quadratic_drag"]
    for row in rows:
        assert row.refused is None and row.first_right, row
        assert row.named == ([] if row.effect is None else [row.effect]), row
        assert row.parameter_error <= 0.15 and row.final_floors < 3.5, row


def test_a_closed_loops_dead_zone_the_coulomb_level_holds_is_one_kinetic_level():
    """Seed 2 of the closed loop's dead zone: the loop crosses the dead zone only where the speed
    reverses, so Coulomb friction alone runs free within 1.13 noise floors of the record (the dead
    zone would account for less than one noise floor of it, the noise rule's bound). Nothing is
    named, and the kinetic level the Coulomb friction takes is the truth's Coulomb level and the
    force the dead zone withholds together, within 15 %."""
    b = bench("closed_loop", "input_dead_zone", 2)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == [] and d.final_gap.overall < math.hypot(1.0, NOISE_EXPLAINED) * d.noise_floor
    lump = b.params["coulomb"] + b.params["input_gain"] * b.params["dead_zone"]
    assert d.model.params["coulomb"] == pytest.approx(lump, rel=0.15)


def test_pwm_average_is_the_supplys_mean_over_each_step():
    """Against a brute-force reference: the PWM's on/off wave sampled 2,000 times a step and
    averaged (its error is under one fine sample's share, 1/2000 of the supply, per edge)."""
    from motorid.diagnose.bench import SUPPLY, pwm_average

    volts = np.array([6.0, 6.0, -3.0, 0.0, 11.0, 20.0, -7.5])  # 20 V asks for more than the supply
    step, frequency, fine = 1e-3, 350.0, 2000
    applied = pwm_average(volts, step, frequency)
    t = (np.arange(volts.size * fine) + 0.5) * step / fine
    duty = np.repeat(np.clip(np.abs(volts) / SUPPLY, 0, 1), fine)
    wave = np.repeat(np.sign(volts), fine) * SUPPLY * ((t * frequency) % 1.0 < duty)
    assert applied == pytest.approx(wave.reshape(-1, fine).mean(axis=1), abs=2 * SUPPLY / fine)
    # over whole periods the mean is the voltage asked for (the supply at most)
    held = pwm_average(np.full(2000, -4.0), 1e-5, 500.0)  # 10 periods of 200 steps
    # (1e-9 V: the rounding of t mod P, some 1e-12 V here)
    assert held.mean() == pytest.approx(-4.0, rel=1e-12) and np.all((held >= -12.0 - 1e-9) & (held <= 1e-9))
    # a step within an on or an off phase sees the supply or nothing: the ripple is there
    assert np.sum(np.isclose(held, -12.0)) >= 10 * 60 and np.sum(np.isclose(held, 0.0)) >= 10 * 130


def test_a_closed_loop_bench_is_its_drive_under_the_logged_commands():
    """The drive simulated again, alone, under the record's commands gives the record's speed to
    within its noise (0.2 % of the largest reference: 5 sigmas), each speed read at the start of
    the sample its command is held over (the speed at the end of sample k is y[k + 1]), and the
    loop follows its reference (RMS error under 15 % of the largest reference: the PI at 0.2 / dt
    rad/s). The record is the one ``motorid control --out`` writes: its columns, the loop's timing
    and the PI's gains."""
    b = bench("closed_loop", None, 3)
    record = b.record
    dt = record.attrs["dt"]
    drive = RigidDrive(("viscous_friction", "coulomb_friction", "offset"), b.params, dt / OVERSAMPLE)
    w = drive.free_run(np.repeat(record["u"].to_numpy(), OVERSAMPLE))[OVERSAMPLE - 1 :: OVERSAMPLE]
    peak = float(np.max(np.abs(record["reference"])))
    assert np.max(np.abs(record["y"].to_numpy()[1:] - w[:-1])) < 5 * 0.002 * peak
    assert np.sqrt(np.mean((record["reference"] - record["y"]) ** 2)) < 0.15 * peak
    assert list(record.columns) == ["t", "reference", "u", "y", "clamped"]
    assert record.attrs["timing"] == "sampled" and record.attrs["units"]["reference"] == "rad/s"
    loop = record.attrs["loop"]
    assert (
        loop["reference"] == "reference" and loop["kp"] > 0.0 and loop["ki"] > 0.0 and loop["u_max"] == 12.0
    )
    assert loop["compensation"] == ("reference" if b.notes["compensated"] else None)
    # the commands within the PI's limit, marked where it clipped them
    assert np.all(np.abs(record["u"]) <= 12.0) and set(record["clamped"]) <= {0, 1}


def test_a_two_mass_bench_turns_at_its_lumped_drives_steady_speed():
    """Held at 8 V, the rig's steady speed is the lumped drive's (g u - F_c) / B (the shaft
    carries no torque difference at a steady speed); 0.5 % covers the tachogenerator's noise
    averaged over 250 samples and its A/D step."""
    from motorid.diagnose.bench import _two_mass

    params = {"inertia": 8e-6, "input_gain": 3.3e-3, "viscous": 2e-4, "coulomb": 3.5e-3, "offset": 0.0}
    record, truth = _two_mass(dict(params), None, np.full(1000, 8.0), 2e-3, np.random.default_rng(0))
    steady = (truth["input_gain"] * 8.0 - truth["coulomb"]) / truth["viscous"]
    assert truth["inertia"] == params["inertia"] and truth["coulomb"] == params["coulomb"]
    assert record["y"].iloc[-250:].mean() == pytest.approx(steady, rel=5e-3)


def test_a_sample_time_near_the_motors_time_constant_is_said():
    """The note's rule on a model (τ = J / B = 20 ms: 11 ms is said, 9 ms is not, and nothing without
    viscous friction), and on the bench it was found on: a no-effect chirp at 10 ms of a 12 ms motor."""
    from motorid.diagnose import diagnose
    from motorid.diagnose.results import slow_sampling_note

    model = RigidDrive(("viscous_friction",), {"inertia": 2e-6, "input_gain": 2e-3, "viscous": 1e-4}, 0.01)
    assert slow_sampling_note(model, 0.011).startswith("the sample time 11 ms is 0.55 of the fitted")
    assert slow_sampling_note(model, 0.009) is None
    assert slow_sampling_note(RigidDrive(("coulomb_friction",), {"inertia": 2e-6, "input_gain": 2e-3,
                                                                   "coulomb": 1e-3}, 0.01), 0.04) is None  # fmt: skip
    b = bench("none", None, 0)
    d = diagnose(b.record, input_gain=b.params["input_gain"])
    assert any(n.startswith("the sample time 10 ms is 0.") and "record at 2." in n for n in d.notes), d.notes


def test_a_planted_effect_shows_where_it_accounts_for_the_noise_floor():
    """What the bank counts as shown (:func:`planted_shows`): a quadratic drag the doctor names
    accounts for many noise floors of the free-run gap (measured 11.5); a dead zone under the two
    sines, whose speed reverses only where the input does, for none (measured -0.03: Coulomb
    friction alone runs free as close), and the doctor names nothing there."""
    rows = bank([2], ["none"], ["input_dead_zone", "quadratic_drag"])
    dead_zone, drag = rows
    assert drag.named == ["quadratic_drag"] and drag.shows > 5.0 * NOISE_EXPLAINED
    assert dead_zone.signal == "two_sine" and dead_zone.named == [] and dead_zone.shows < NOISE_EXPLAINED
    report = _bank_report(rows).splitlines()
    assert report[2].startswith(
        "| none | 2 | 1/2 | 1/1 | - |"
    )  # named first on 1 of 2, on the 1 where it shows


def test_what_shows_is_measured_on_the_records_as_the_doctor_read_them():
    """A drifting logger's bench is measured on its aligned time, where the doctor diagnosed it
    (quadratic drag under two sines, seed 1: it accounts for 17.0 noise floors at speed, named).
    A slow record's noise is the one the one-step prediction measured (0.18 rad/s, not 1.56 near
    Nyquist): below that rest speed the chirp of seed 2 never rests, and its static friction,
    which the doctor measures on the whole free run then, shows there (2.5 floors) and is named
    within 15 % of the truth; at the rests the doctor does not see, it measured nothing."""
    drifting = bank([1], ["drifting_delay"], ["quadratic_drag"])[0]
    assert drifting.drift_said and drifting.named == ["quadratic_drag"]
    assert drifting.shows > 5.0 * NOISE_EXPLAINED
    b = bench("slow_sampling", "static_friction", 2)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert [r.count for r in d.rests] == [0] and d.named == ["static_friction"]
    assert d.model.params["breakaway_excess"] == pytest.approx(b.params["breakaway_excess"], rel=0.15)
    assert planted_shows(d, "static_friction") > NOISE_EXPLAINED


def test_the_noise_calibration_measures_both_figures_against_the_truth():
    """``python -m motorid.diagnose.calibration --noise`` on one seed: a bench sampled at 0.61 of
    its time constant (slow_sampling, seed 0) has signal near Nyquist (measured 2.1 times its
    noise) and the base model's one-step prediction measures its noise (1.06 of it; 10 %: 1000
    samples and the fitted model's error); the report tables them by dt / τ."""
    rows = noise_estimates([0], ["slow_sampling"])
    clean = next(r for r in rows if r.effect is None)
    assert clean.sample_share == pytest.approx(0.61, abs=0.01)
    assert clean.near_nyquist > 1.5 * clean.truth
    assert clean.one_step == pytest.approx(clean.truth, rel=0.1)
    report = _noise_report(rows).splitlines()
    assert report[2].startswith(f"| 0.45-inf | {len(rows)} |")


def test_the_delay_is_read_on_the_final_models_free_run():
    """Two sines logged 10.6 samples late, quadratic drag planted: the structure search's balance,
    on the base without the drag, took 6 samples and an inertia 2.4 times the truth (final gap
    8.1 noise floors). Read again on the final model's free run, the delay is found within half a
    sample (measured 0.08), the inertia within 15 % (measured 1.3 %) and the final gap at the
    noise (measured 0.92 floors). Without the structure search nothing is read again."""
    from motorid.diagnose.bench import delay_error_samples

    b = bench("constant_delay", "quadratic_drag", 0)
    assert b.logging_delay[0] / b.record.attrs["dt"] > 10.0
    gain = b.params["input_gain"]
    d = diagnose(b.record, input_gain=gain, base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["quadratic_drag"]
    assert delay_error_samples(d.model.params["input_delay"], b) < 0.5
    assert d.model.params["inertia"] == pytest.approx(b.params["inertia"], rel=0.15)
    assert d.final_gap.overall < 1.2 * d.noise_floor
    assert d.structure.params["input_delay"] == d.model.params["input_delay"]
    assert "; on the final model's free run the delay is" in d.structure.reason
    plain = diagnose(b.record, input_gain=gain, base=BASE_FOR["input_lag"], structure=False)
    assert "input_delay" not in plain.model.effects


def test_a_delay_the_base_hid_is_taken_on_the_final_model():
    """A drifting logger's record aligned: the delay left at its start, 0.96 samples, hid behind
    the drag the base lacked (the structure's ΔBIC -6.7: no delay, the inertia 1.4 times the truth,
    final gap 4.5 noise floors). On the final model's balance it passes ΔBIC, and its free run takes
    it: within half a sample of the logger's (measured 0.08), the final gap at the noise (measured
    1.14 floors). A bench without a delay is given none (the same rules on the final model)."""
    b = bench("drifting_delay", "quadratic_drag", 2)
    dt = b.record.attrs["dt"]
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["quadratic_drag"] and d.delay_drift
    assert abs(d.model.params["input_delay"] - b.logging_delay[0]) < 0.5 * dt
    assert "an input delay of" in d.structure.reason and "taken on the final model" in d.structure.reason
    assert d.final_gap.overall < 1.3 * d.noise_floor
    for effect in (None, "quadratic_drag"):
        none = bench("none", effect, 0)
        found = diagnose(none.record, input_gain=none.params["input_gain"], base=BASE_FOR["input_lag"])
        assert "input_delay" not in found.model.effects, found.structure.reason


@pytest.mark.parametrize(("seed", "rests"), [(0, 3), (2, 7)])
def test_static_friction_the_rests_do_not_read_is_held_out_rest_by_rest(seed, rests, tmp_path):
    """An encoder's held levels whose rests do not read the breakaway (seed 0: 3 rests at 5 ms, 2
    bracketed by a step of the input; seed 2: 7 at 2 ms, 6 bracketed): static friction is fitted on
    the free run, and the few held levels the drive does not break away from carry its whole gap.
    The search's held-out blocks seldom hold them: on seed 2 their free run shrank 0.4 % (1 %
    asked) while the whole free run went from 1.04 to 0.60 rad/s, and on seed 0 it was the base's to
    the last bit. Held out rest by rest (each fold of rests fitted on the rest of the record), it
    shrinks 39 % and 74 % (measured) and is named, judged at the rests.

    Its level: the free run is flat over every level that leaves each rest's breakaway in the same
    sample, and the fit takes the middle of that stretch: 6 % high on seed 0, 6 % low on seed 2
    (measured; the bounded search inside it had ended 6 % low and 26 % high), held to 12 %. The
    stretch checked against a brute-force scan of 161 levels over the lower quarter of the range:
    the level the fit returns lies within one scan step of the middle of the scanned minimum, and
    its standard error is the stretch's width over √12."""
    b = bench("encoder", "static_friction", seed)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["static_friction"] and d.rests[0].count == rests
    ev = d.steps[0].evidence
    assert (
        ev.candidate.measure.startswith("free run (")
        and "bracketed by a step of the input" in ev.candidate.measure
    )
    assert ev.held_out_error_after < 0.7 * ev.held_out_error_before
    assert ev.explained_noise_floors > NOISE_EXPLAINED
    assert d.model.params["breakaway_excess"] == pytest.approx(b.params["breakaway_excess"], rel=0.12)
    # the reading is the middle of the levels the free run cannot tell apart, against a scan
    pool = d._pool
    bare = d.model.without("static_friction")
    level = fit_static_friction(pool, bare, None).params["breakaway_excess"]
    top = 0.5 * pool.data.scale["u_max"] * abs(bare.input_gain)
    scan = np.linspace(0.0, top / 4, 161)

    def cost(x):
        err = pool.free_run_error(
            bare.with_effects((*bare.effects, "static_friction"), {**bare.params, "breakaway_excess": x}),
            None,
        )
        return float(np.nanmean(err**2))

    costs = np.array([cost(x) for x in scan])
    flat = scan[costs <= costs.min() * (1 + 1e-9)]
    assert np.ptp(flat) > 0 and flat[-1] - flat[0] <= np.ptp(scan) * 0.5  # a bounded stretch of the scan
    assert abs(level - 0.5 * (flat[0] + flat[-1])) <= scan[1]
    # its standard error: the stretch as a level equally likely anywhere in it; the truth within two
    # (measured -0.22 and 0.17 of one)
    std = d.param_std["breakaway_excess"]
    assert std == pytest.approx(np.ptp(flat) / math.sqrt(12.0), abs=2 * scan[1] / math.sqrt(12.0))
    assert abs(d.model.params["breakaway_excess"] - b.params["breakaway_excess"]) < 2 * std
    save_doctor_model(d, tmp_path / "m.json", [b.record], [None])  # the model file carries it
    assert read_model_file(tmp_path / "m.json").card.parameters["breakaway_excess"]["standard_error"] == std
    # the folds: each rest whole in fold j mod 5, together every rest and breakaway
    folds = pool.rest_folds(5)
    spans = list(zip(pool.parts[0].rests.start, pool.parts[0].rests.stop, strict=True))
    assert len(folds) == min(5, len(spans)) and len(spans) == rests
    for j, (a, b_) in enumerate(spans):
        assert folds[j % len(folds)][0][a : b_ + 1].all()
    assert np.array_equal(np.logical_or.reduce([f[0] for f in folds]), pool.acting_samples("rests")[0])


def test_static_friction_the_rests_read_is_held_out_rest_by_rest():
    """A two-sine record sampled at 36 ms (slow sampling, seed 5, beyond the calibration's seeds
    0-2): 10 rests, 5 of which read the breakaway, 0.51, 0.33, 0.51, 0.32 and 0.45 of the Coulomb
    level (the truth 0.52). The search's held-out blocks (30 % of the record) hold none of the
    rests that read it: checked there, the level had no held-out figure ("diverges vs diverges")
    and was refused, the final gap at 6.2 noise floors. Held out rest by rest (each fold's
    breakaways predicted from the other folds' rests), the level misses them by 1.8 % of itself
    (measured 32 µN m), none by 57 % (1.77 mN m): named, 5 % high, the final gap at 2.0 floors."""
    b = bench("slow_sampling", "static_friction", 5)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    truth = b.params["breakaway_excess"]
    pool, bare = d._pool, d.model.without("static_friction")
    blocks = held_out(pool, 0.3, {}).samples
    assert all(e.size == 0 for e in breakaway_holdout(pool, [~m for m in blocks], pool, blocks, bare))
    without, with_level = breakaway_cross_check(pool, bare)
    assert without == pytest.approx(truth, rel=0.6) and with_level < 0.1 * truth
    assert d.named == ["static_friction"] and d.steps[0].evidence.candidate.measure == "rests"
    assert d.model.params["breakaway_excess"] == pytest.approx(truth, rel=0.15)
    assert d.final_gap.overall < 3.0 * d.noise_floor


def test_a_rest_by_rest_check_blind_to_the_last_bits_is_judged_by_the_noise_rule():
    """A torque ripple's held levels with static friction (seed 5, beyond the calibration's seeds
    0-2): 3 rests, all bracketed. Held out rest by rest, no fold's other rests fit a level that
    moves the held-out free run beyond its last bits (4.41331693831 against 4.41331693830 rad/s):
    no evidence either way, so it is judged at the rests by the noise rule (the gap there
    4.41 to 0.23 rad/s, 21 noise floors explained) and named. A check that asked the two to be
    equal to the bit had refused it, and the final gap stood at 10.1 noise floors. Its level within
    two standard errors of the truth (measured 0.65 of one, 7 % low), the final gap at the floor
    (measured 1.10)."""
    b = bench("torque_ripple", "static_friction", 5)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["cogging", "static_friction"]
    ev = d.steps[1].evidence
    assert ev.held_out_error_after == pytest.approx(ev.held_out_error_before, rel=1e-9)
    assert ev.explained_noise_floors > NOISE_EXPLAINED
    std = d.param_std["breakaway_excess"]
    assert abs(d.model.params["breakaway_excess"] - b.params["breakaway_excess"]) < 2 * std
    assert d.final_gap.overall < 1.5 * d.noise_floor


def test_a_static_friction_the_final_model_reads_none_of_is_taken_back():
    """A closed loop's Stribeck decay (seed 2, a chirp at 10 ms): the step's least squares fitted
    its level 42 % low and static friction came second, 0.98 mN m above it. The final model (the
    loop's reference as an instrument) puts the Stribeck level within 5 % of the truth, and there
    static friction's level reads none: the step is taken back, said in a note, and the free run
    stands at 1.33 noise floors (1.71 with the stale level)."""
    b = bench("closed_loop", "stribeck_friction", 2)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["stribeck_friction"] and "static_friction" not in d.model.effects
    assert any(n.startswith("static_friction, named at step 2") and "is left out" in n for n in d.notes)
    assert d.model.params["stribeck"] == pytest.approx(b.params["stribeck"], rel=0.15)
    assert d.final_gap.overall < 1.5 * d.noise_floor


def test_an_effect_that_acts_near_rest_is_held_out_near_rest():
    """A Stribeck decay on a PWM drive's held levels (seed 4, beyond the calibration's seeds 0-2):
    the PWM's ripple fills the balance's every row with noise, and the decay changes only the
    rows near rest. Over every held-out row it lowered the error by 0.8 % (1 % asked) and was
    refused, the final gap at 11.6 noise floors. Held out where it acts (the held-out rows below a
    tenth of the top speed, as its free-run gap is judged), it lowers the error there by 3.8 %
    (measured) and over every row too: named."""
    b = bench("pwm_ripple", "stribeck_friction", 4)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["stribeck_friction"]
    step = d.steps[0].evidence
    assert step.held_out_error_after < 0.98 * step.held_out_error_before
    # against the balance refitted here on the training rows, every held-out row and near rest
    pool = d._pool
    held = held_out(pool, 0.3, {})
    base = tuple(e for e in d.model.effects if e != "stribeck_friction")
    residual = {}
    for effects in (base, d.model.effects):
        fit = fit_model(pool.data, effects, rows=held.train).model
        residual[effects] = held.balance_residual(pool, fit) / fit.params["inertia"]
    near = pool.acting_rows(held.speeds(pool), "rest")
    assert 0 < near.sum() < 0.2 * near.size
    every = [float(np.sqrt(np.mean(r**2))) for r in residual.values()]
    there = [float(np.sqrt(np.mean(r[near] ** 2))) for r in residual.values()]
    assert 0.98 * every[0] < every[1] < every[0] and there[1] < 0.98 * there[0]
    with pytest.raises(ValueError, match="acts must be 'rest' or 'speed'"):
        pool.acting_rows(held.speeds(pool), "rests")


def test_a_band_of_a_few_held_out_rows_does_not_judge_alone():
    """A Stribeck decay on held levels sampled at 36 ms (slow sampling, seed 5): 2 of the 44
    held-out rows lie near rest, and there the decay raises the error (0.63 to 0.76 rad/s²,
    measured) while over every row it lowers it from 6.4 to 2.1 rad/s². Judged near rest alone, it
    was refused and static friction named in its place; judged over every row first, it is named,
    its level within 15 %, and the final gap is at the noise floor (measured 1.03)."""
    b = bench("slow_sampling", "stribeck_friction", 5)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["stribeck_friction"]
    pool = d._pool
    held = held_out(pool, 0.3, {})
    near = pool.acting_rows(held.speeds(pool), "rest")
    assert near.sum() <= 3
    step = d.steps[0].evidence
    assert step.held_out_error_after < 0.5 * step.held_out_error_before
    assert d.model.params["stribeck"] == pytest.approx(b.params["stribeck"], rel=0.15)
    assert d.final_gap.overall < 1.5 * d.noise_floor


def test_a_free_run_with_an_input_delay_starts_where_its_delayed_input_is_the_records():
    """A chirp from rest at 9.6 V, logged 180 ms late at 2 ms (constant delay, seed 4), and one at
    1 ms logged 147 ms late with quadratic drag (seed 8): what came before the record is not
    known, and a delay line filled with the first input had driven the model 90 and 147 samples
    before the drive moved. The true model stood 56 noise floors from the second record, and the
    doctor read its delay 13.6 samples short (a final gap of 52 floors). The free run now starts at
    the first sample whose delayed input is the record's: the delays within a sample (measured 0.13
    and 0.12), the final gaps at the floor (1.05 and 1.11). The base without the delay runs away on
    the first record (its gap 1.7e34 rad/s), and its reason says it diverges. The free-run error
    low-passes the run from where it starts, as the measured speed is (unfiltered from the settled
    span's start, a record logged 22 samples late had stood at 1.30 floors for 0.87)."""
    for seed, effect in ((4, None), (8, "quadratic_drag")):
        b = bench("constant_delay", effect, seed)
        dt, late = b.record.attrs["dt"], b.logging_delay[0]
        d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
        assert d.named == ([effect] if effect else [])
        assert abs(d.structure.params["input_delay"] - late) < dt
        assert d.final_gap.overall < 1.5 * d.noise_floor
        truth = RigidDrive(
            tuple(e for e in ("viscous_friction", "coulomb_friction", "offset", effect, "input_delay") if e),
            {**b.params, "input_delay": late}, d.model.dt,
        )  # fmt: skip
        part = d._pool.parts[0]
        run = part.simulate(truth)
        first = math.ceil(late / dt)
        assert np.isnan(run[:first]).all() and np.isfinite(run[first:]).all()
        # the free-run error: the run low-passed from where it starts, as the measured speed is
        filtered = part.kin.w[first:] - lowpass(run[first:], dt, CUTOFF_PER_BAND * part.kin.band)
        error = free_run_error(part, truth)
        valid = part.kin.valid[first:]
        # the same filter on the same samples: equal but for rounding
        np.testing.assert_allclose(error[first:][valid], filtered[valid], rtol=1e-12, atol=1e-12)
        assert np.sqrt(np.nanmean(error**2)) < 1.5 * d.noise_floor
        if effect is None:
            assert "coulomb_friction + viscous_friction + offset diverges ->" in d.structure.reason
            assert "(it accounts for all of it)" in d.structure.reason


def test_a_speed_band_of_a_quarter_of_the_rows_or_more_is_not_one_place():
    """A two-mass rig's chirp with a dead zone (seed 6): 49 % of its held-out rows lie at speed.
    There quadratic drag lowers the balance's error 4.2 %, over every row 0.8 % (measured): what
    the lumped drive misses of the rig's shaft, not a drag. A band that holds a quarter of the rows
    or more is the record, not one place of it (:data:`ONE_PLACE`, which parts a sine's bands):
    the dead zone alone is named, within 15 %."""
    b = bench("two_mass", "input_dead_zone", 6)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"], align=True)
    assert d.named == ["input_dead_zone"]
    assert d.model.params["dead_zone"] == pytest.approx(b.params["dead_zone"], rel=0.15)
    drag = next(r for r in d.rejected if r.effect == "quadratic_drag")
    assert drag.reason.startswith("held-out error ") and drag.judged == "at speed"
    pool = d._pool
    share = pool.acting_rows(held_out(pool, 0.3, {}).speeds(pool), "speed").mean()
    assert ONE_PLACE <= share < 0.5
    t = np.linspace(0.0, 1.0, 100_001)
    sine = np.abs(np.sin(2 * np.pi * t))
    assert np.mean(sine < 0.1) < ONE_PLACE < np.mean(sine >= 0.6)
