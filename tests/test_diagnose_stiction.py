"""Stiction where the data show it: the rests of a drive (how long, the input it breaks away at),
static friction named from them on records of an encoder's speed (quantised, noise growing with
speed) and nowhere else, and the names the same whichever model the search starts from."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid.diagnose import diagnose
from motorid.diagnose.kinematics import kinematics, noise_bands, quantisation_step
from motorid.diagnose.rests import rests
from motorid.diagnose.synthetic import ENCODER_STEP, encoder_speed, planted_record
from motorid.io.records import write_record


def breakaway_level(d) -> float:
    """The final model's breakaway level [N m]: its kinetic level at 0 (mean of the directions)
    and its static friction ΔF_s."""
    t_pos, t_neg = d.model.friction(np.array([1e-9, -1e-9]))
    return 0.5 * float(t_pos - t_neg) + d.model.params.get("breakaway_excess", 0.0)


def test_the_rests_of_a_speed_are_found_with_their_breakaway_input_and_rate():
    """A speed built with two rests of known spans: each found with its length, the direction it
    breaks away in, the input there and the input's rate (the input a ramp of known slope)."""
    dt = 0.001
    t = np.arange(4000) * dt
    u = 2.0 * np.sin(2 * np.pi * 0.5 * t)  # rate 2 pi V/s at its zero crossings
    w = np.where(t < 1.0, 50.0 * np.sin(np.pi * t), 0.0)
    w[(t >= 1.2) & (t < 2.0)] = -40.0 * np.sin(np.pi * (t[(t >= 1.2) & (t < 2.0)] - 1.2) / 0.8)
    w[t >= 2.05] = 30.0 * np.sin(np.pi * (t[t >= 2.05] - 2.05) / 1.95)
    found = rests(u, w, dt, w_rest=0.5)
    assert found.count == 2
    # the speed leaves zero at 1.2 s and at 2.05 s, and falls below w_rest asin(0.01)/pi = 3.2 ms
    # before 1 s and asin(0.5/40) 0.8 s / pi = 3.2 ms before 2 s
    # (a quarter of w_rest is reached asin(0.125/40) 0.8 s / pi = 0.8 ms and asin(0.125/30)
    # 1.95 s / pi = 2.6 ms after the speed leaves zero: within one sample)
    stops = [1.2 + math.asin(0.125 / 40) * 0.8 / math.pi, 2.05 + math.asin(0.125 / 30) * 1.95 / math.pi]
    np.testing.assert_allclose(found.stop * dt, stops, atol=1.5e-3)
    np.testing.assert_allclose(
        found.start * dt,
        [1.0 - math.asin(0.01) / math.pi, 2.0 - 0.8 * math.asin(0.0125) / math.pi],
        atol=1.5e-3,
    )
    np.testing.assert_array_equal(found.direction, [-1, 1])
    k = found.stop
    np.testing.assert_allclose(found.breakaway_input, found.direction * u[k])
    np.testing.assert_allclose(found.input_rate, found.direction * np.gradient(u, dt)[k])
    summary = found.summary()
    assert summary["count"] == 2 and summary["median_length"] == pytest.approx(np.mean(found.lengths))
    # a speed that only passes through zero has no rest
    assert rests(u, 50.0 * np.sin(2 * np.pi * t), dt, w_rest=0.5).count == 0


def test_a_rest_crossed_by_its_noise_stays_one_rest_and_a_short_motion_still_ends_one():
    """A resting speed that crosses ``w_rest`` for a few samples and barely (the rest's own noise)
    is one rest, broken away from where the drive leaves for good, in that direction; a motion as
    short that rises past twice ``w_rest`` ends the rest it leaves."""
    dt = 0.002
    t = np.arange(2000) * dt
    u = np.zeros(t.size)
    w = np.where(t < 1.0, 40.0 * np.sin(np.pi * t), 0.0)
    w[t >= 2.0] = -30.0 * np.sin(np.pi * (t[t >= 2.0] - 2.0) / 2.0)
    dip = (t >= 1.4) & (t < 1.408)  # four samples at 1.2 w_rest, the other way
    w[dip] = 0.6
    found = rests(u, w, dt, w_rest=0.5, settle=5)
    assert found.count == 1
    assert found.stop[0] * dt == pytest.approx(2.0, abs=1.5 * dt) and found.direction[0] == -1
    # without the speed's memory given, the noise cuts the rest in two
    assert rests(u, w, dt, w_rest=0.5).count == 2
    w[dip] = 1.5  # a real jolt: past 2 w_rest
    jolted = rests(u, w, dt, w_rest=0.5, settle=5)
    assert jolted.count == 2 and jolted.direction.tolist() == [1, -1]
    w[dip] = 0.0
    w[(t >= 1.4) & (t < 1.44)] = 0.6  # twenty samples just above w_rest: a creep, not noise
    assert rests(u, w, dt, w_rest=0.5, settle=5).count == 2


def test_the_breakaway_is_read_again_on_the_measured_speed_where_the_shaft_moves():
    """A drive that stops at sample 100 and rests while a ramping force rises to its breakaway
    level, 3 mN m above the 5 mN m it then moves against (static friction), which it crosses in
    sample 380; from there it runs free (the drive simulated alone), with white noise of 0.5 % of
    its top speed. The zero-phase filtered speed (at rest within 5 of its noise's deviations)
    leaves rest 2-4 samples before the shaft does. Read again on the measured speed
    (:func:`first_moving`), the shaft moves in sample 380 on the noise of each of seeds 0-9.
    A 10-sample lag in place of the static friction: the drive breaks away at the kinetic level
    in sample 285 and its speed grows from zero, under the noise's deviation for 11 samples; the
    filtered reading lies 1-9 samples late, the reading again 0-7, never before the shaft moves
    nor after the filtered reading (the lag's force is not the model's: the rise's shape holds)."""
    from motorid.diagnose.kinematics import lowpass
    from motorid.diagnose.rests import first_moving
    from motorid.drive.rigid import RigidDrive

    dt, n, inertia, viscous = 0.002, 800, 2e-5, 4e-4
    drive = RigidDrive(("viscous_friction", "coulomb_friction"), {
        "inertia": inertia, "input_gain": 1.0, "viscous": viscous, "coulomb": 5e-3}, dt)  # fmt: skip
    force = np.concatenate([np.zeros(100), np.linspace(0.0, 0.02, n - 100)])  # N m, 0.05 N m/s
    lagged = np.concatenate([np.zeros(10), force[:-10]])
    for acting, level in ((force, 8e-3), (lagged, 5e-3)):
        moves = int(np.flatnonzero(acting > level)[0])  # the first sample the held force exceeds it
        truth = np.concatenate([-np.linspace(20.0, 0.0, 100), np.zeros(n - 100)])
        truth[moves:] = drive.free_run(acting[moves:])
        for seed in range(10):
            y = truth + 0.005 * float(np.max(truth)) * np.random.default_rng(seed).standard_normal(n)
            w = lowpass(y, dt, 25.0)  # cut-off 25 Hz: 20 samples a period
            found = rests(force, w, dt, w_rest=5.0 * float(np.std(w[150:280])))
            filtered = int(found.stop[-1]) + 1  # the first sample off rest on the filtered speed
            read = int(first_moving(y, found, force, inertia, viscous, reach=20)[-1])
            if acting is force:
                assert filtered < moves and read == moves, (seed, filtered, read)
            else:
                assert moves <= read <= filtered, (seed, moves, read, filtered)


def test_a_drive_far_faster_than_its_sample_time_is_read_where_it_breaks_away():
    """A drive whose time constant J / B is a 40th of the sample time follows its force within each
    sample: w = (F - F_k) / B from the sample it breaks away in, here 50 (a held force stepping
    up there, then ramping). The rise's closed form a^j underflows over the reading's stretch,
    and the reading takes the recursion itself: sample 50, where the shaft moves."""
    from motorid.diagnose.rests import Rests, first_moving

    dt, inertia, viscous, n = 0.01, 1e-5, 0.04, 120  # J / B = 0.25 ms
    force = np.concatenate([np.full(50, 0.01), 0.03 + 0.001 * np.arange(70)])  # N m
    y = np.where(np.arange(n) >= 50, (force - 0.02) / viscous, 0.0)  # kinetic level 0.02 N m
    found = Rests(np.array([10]), np.array([47]), np.array([1]), np.array([0.0]), np.array([0.0]), dt, 0.1)
    assert math.exp(-viscous * dt / inertia) ** 13 < 1e-200  # the stretch's a^j, reach 4
    assert first_moving(y, found, force, inertia, viscous, reach=4).tolist() == [50]


def simulated_stiction(u: np.ndarray, dt: float, seed: int) -> pd.DataFrame:
    """A drive with static friction (breakaway 8 mN m, kinetic 5 mN m, 0.01 N m/V) under ``u`` [V],
    its speed with white noise of 0.5 % of its top."""
    from motorid.drive.rigid import RigidDrive

    drive = RigidDrive(("viscous_friction", "coulomb_friction", "static_friction"), {
        "inertia": 2e-5, "input_gain": 0.01, "viscous": 4e-4, "coulomb": 5e-3, "breakaway_excess": 3e-3}, dt)  # fmt: skip
    w = drive.free_run(u)
    y = w + 0.005 * float(np.max(np.abs(w))) * np.random.default_rng(seed).standard_normal(u.size)
    return pd.DataFrame({"t": np.arange(u.size) * dt, "u": u, "y": y})


def test_a_step_of_the_input_brackets_the_breakaway_and_a_slow_quantised_input_reads_it():
    """Under held levels stepping past the breakaway (0.5 s each, 0.3-2 V, the breakaway at 0.8 V),
    each rest rests under one level and moves under the next: it brackets the breakaway, and too
    few read it to measure. A sine of 2 V at 0.25 Hz rounded to 10 mV (its force rises 6 mV a sample at the
    breakaway) reads it at each rest: static friction named, within 15 % of the planted 3 mN m,
    its standard error never below the input's rounding, 0.01 V x 0.01 N m/V / sqrt(12 n)."""
    from motorid.diagnose.measures import breakaway

    dt = 0.002
    rng = np.random.default_rng(4)
    levels = rng.choice([-1.0, 1.0], 80) * rng.uniform(0.3, 2.0, 80)
    stair = diagnose(simulated_stiction(np.repeat(levels, 250), dt, 0), input_gain=0.01)
    found = breakaway(stair._pool, stair.model)
    assert stair._pool.parts[0].rests.count >= 5
    # a level can step from within 25 % of the one that moves the drive: that rest reads it (10 of 11 bracketed)
    assert found.bracketed >= 0.8 * stair._pool.parts[0].rests.count and math.isnan(found.excess)
    t = np.arange(20000) * dt
    q = 0.01
    sine = diagnose(
        simulated_stiction(q * np.round(2.0 * np.sin(2 * np.pi * 0.25 * t) / q), dt, 1), input_gain=0.01
    )
    assert sine._pool.input_quantisation == pytest.approx(q, rel=1e-6)
    found = breakaway(sine._pool, sine.model)
    assert found.bracketed == 0 and found.rests >= 5
    assert found.standard_error >= 0.01 * q / math.sqrt(12.0 * found.rests)
    assert "static_friction" in sine.named, sine.stop_reason
    assert sine.model.params["breakaway_excess"] == pytest.approx(3e-3, rel=0.15)


def test_an_encoders_speed_is_quantised_and_noisier_at_speed():
    rng = np.random.default_rng(0)
    dt, n = 0.01, 6000
    w = 100.0 * np.sin(2 * np.pi * 0.2 * np.arange(n) * dt)
    y = encoder_speed(w, rng)
    step = ENCODER_STEP * 100.0
    assert quantisation_step(y) == pytest.approx(step, rel=1e-6)
    kin = kinematics(np.zeros(n), y, dt)
    speed = np.abs(kin.w[kin.valid])
    bands = noise_bands(speed, kin.hf[kin.valid], np.array([0.0, 10.0, 60.0, 100.0]), kin.band, dt)
    # σ grows from 0.1 (at rest) to 1.1 rad/s (at 100 rad/s): the top band's floor is several
    # times the one near rest
    assert bands[-1].noise_floor > 3 * bands[0].noise_floor


@pytest.mark.parametrize("seed", [0, 1])
def test_planted_static_friction_on_an_encoder_is_named_at_the_breakaway_the_rests_show(seed):
    """60 s records (the excitation's pauses give 10-15 rests a minute), from the default base."""
    planted = planted_record("static_friction", seed, duration=60.0, sensor="encoder")
    d = diagnose(planted.record, input_gain=planted.input_gain)
    assert "static_friction" in d.named, d.stop_reason
    truth = planted.notes["coulomb"] + planted.effects["static_friction"]["breakaway_excess"]
    # the breakaway level within 15 % of the planted one (measured 0.90-1.01 on 8 seeds)
    assert breakaway_level(d) == pytest.approx(truth, rel=0.15)
    step = d.steps[d.named.index("static_friction")]
    ranked = next(c for c in step.evidence.ranking if c.effect == "static_friction")
    assert ranked.measure == "rests" and ranked.breakaway.shown
    assert step.evidence.held_out_error_after < step.evidence.held_out_error_before
    rest = d.rests[0]
    assert rest.count >= 5 and rest.breakaway_excess > 2 * rest.breakaway_excess_std


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_static_friction_is_named_where_the_rests_break_away_at_the_kinetic_level(seed):
    planted = planted_record(None, seed, duration=60.0, sensor="encoder")
    d = diagnose(planted.record, input_gain=planted.input_gain)
    assert "static_friction" not in d.named, d.named
    # the rests are there, and break away near the kinetic level: the two-mass rig's load side
    # sticks a little behind its motor side, measured 0.19-0.35 of the kinetic level on these
    # seeds, against 2-4 times it where static friction is planted
    rest = d.rests[0]
    assert rest.count >= 5
    assert rest.breakaway_excess < 0.5 * rest.kinetic_level


def test_the_names_do_not_depend_on_the_model_the_search_starts_from(capsys, tmp_path):
    """From the default base the doctor names Coulomb friction, then static friction; from a saved
    model that holds Coulomb friction (``--model``) it names static friction, and both runs end in
    the same model."""
    planted = planted_record("static_friction", 1, duration=60.0, sensor="encoder")
    path = tmp_path / "rec.csv"
    write_record(planted.record, path)
    gain = str(planted.input_gain)
    code, plain, err = run(capsys, "doctor", str(path), "--input-gain", gain, "--max-steps", "1",
                           "--save-model", str(tmp_path / "coulomb.json"), "--json")  # fmt: skip
    assert code == 0, err
    assert [s["effect"] for s in plain["steps"]] == ["coulomb_friction"]
    code, full, err = run(capsys, "doctor", str(path), "--input-gain", gain, "--json")
    assert code == 0, err
    code, started, err = run(capsys, "doctor", str(path), "--model", str(tmp_path / "coulomb.json"), "--json")
    assert code == 0, err
    names = [s["effect"] for s in full["steps"]]
    assert names[:2] == ["coulomb_friction", "static_friction"], names
    assert [s["effect"] for s in started["steps"]] == names[1:]
    assert set(full["model"]["effects"]) == set(started["model"]["effects"])
    # the same rests, so the same breakaway above the same kinetic level: to 1 % (the refit of a
    # saved model starts its search elsewhere, and a bounded search stops within its tolerance)
    assert started["model"]["params"]["breakaway_excess"] == pytest.approx(
        full["model"]["params"]["breakaway_excess"], rel=0.01
    )
    # the JSON reports the rests and the factor "at the noise floor" is said within
    assert started["rests"][0]["count"] == full["rests"][0]["count"] >= 5
    assert math.isfinite(full["rests"][0]["median_breakaway_input"])
    assert full["at_noise_floor_factor"] == full["settings"]["missing_factor"]


KIT_CHIRP = real_motor_file("kit_chirp_run1.csv")


@pytest.mark.skipif(
    not KIT_CHIRP.exists(), reason=f"kit motor data not found at {KIT_CHIRP.parent} (set MOTORID_DATA)"
)
def test_the_kit_motors_rests_break_away_at_its_kinetic_level_once_the_lag_is_taken(capsys):
    """The kit motor's chirp breaks away at a median 9.1 % duty against a kinetic level of 7 %,
    but the faster the input rises at a breakaway, the higher it is: fitted against the input's
    rate, the breakaway at a slowly rising input lies at the kinetic level (within its standard
    error), so static friction is not named. The doctor's page shows the line."""
    code, out, err = run(capsys, "doctor", str(KIT_CHIRP), "--input-unit", "%", "--json")
    assert code == 0, err
    assert "static_friction" not in [s["effect"] for s in out["steps"]]
    rest = out["rests"][0]
    assert rest["median_breakaway_input"] > 1.2 * rest["kinetic_level"]
    assert abs(rest["breakaway_excess"]) < 2 * rest["breakaway_excess_std"]
    assert rest["breakaway_lag"] > 0  # the input leads the force
    line = next(x.strip() for x in err.splitlines() if x.strip().startswith("rests: "))
    kinetic = f"{rest['kinetic_level']:.3g} %"
    assert line == (
        f"rests: {rest['count']}, median {1000 * rest['median_length']:.0f} ms, breaking away at a median "
        f"{rest['median_breakaway_input']:.3g} %; no static friction shown: at a slowly rising input it breaks "
        f"away {rest['breakaway_excess']:.3g} ± {rest['breakaway_excess_std']:.2g} % from the kinetic level "
        f"{kinetic}, within two standard errors (the input at breakaway is higher where it rises faster: a lag "
        f"of {1000 * rest['breakaway_lag']:.2g} ms between input and force); a compensation should use the "
        f"kinetic level: +{kinetic} forwards, -{kinetic} backwards"
    )
    page = (Path(__file__).resolve().parents[1] / "docs" / "guide" / "doctor.md").read_text(encoding="utf-8")
    assert f"`{line}`" in " ".join(page.split())


KIT_SINE = real_motor_file("kit_sine_1hz_run1.csv")


@pytest.mark.skipif(
    not KIT_SINE.exists(), reason=f"kit motor data not found at {KIT_SINE.parent} (set MOTORID_DATA)"
)
def test_the_kit_motor_gets_the_same_model_from_a_saved_coulomb_model(capsys, tmp_path):
    """The kit motor's 1 Hz sine: from the default base the doctor names Coulomb friction, then the
    direction asymmetry; started from the saved model of its first step (``--model``) it names the
    asymmetry alone (static friction, which a start from a Coulomb model once added, is judged by
    the same rules either way) and ends in the same effects."""
    saved = tmp_path / "coulomb.json"
    opts = ("--input-unit", "%", "--json")
    code, first, err = run(
        capsys, "doctor", str(KIT_SINE), "--max-steps", "1", "--save-model", str(saved), *opts
    )
    assert code == 0, err
    assert [s["effect"] for s in first["steps"]] == ["coulomb_friction"]
    code, full, err = run(capsys, "doctor", str(KIT_SINE), *opts)
    assert code == 0, err
    code, started, err = run(capsys, "doctor", str(KIT_SINE), "--model", str(saved), *opts)
    assert code == 0, err
    names = [s["effect"] for s in full["steps"]]
    assert names == ["coulomb_friction", "asymmetric_friction"]
    assert [s["effect"] for s in started["steps"]] == names[1:]
    assert set(started["model"]["effects"]) == set(full["model"]["effects"])


def test_the_stiction_calibration_prints_what_it_measured(capsys):
    """``python -m motorid.diagnose.calibration --stiction`` (the doctor page's command) on one seed:
    the no-effect record and the planted one, each line from the records it ran."""
    from motorid.diagnose.calibration import main, stiction

    assert main(["--stiction", "--seeds", "1", "--first", "1"]) == 0
    text = capsys.readouterr().out
    st = stiction([1])
    assert st.planted == [(), ("static_friction",)]
    assert "static_friction" not in st.named[0] and "static_friction" in st.named[1]
    assert "no-effect records (encoder): 1, static_friction named on 0 (0.0 %)" in text
    assert f"named on 1; breakaway level / planted: median {st.level_ratio[1]:.3f}" in text
    assert abs(st.level_ratio[1] - 1.0) <= 0.15
    assert main(["--seeds", "1", "--first", "5000", "--sensor", "encoder"]) == 0
    assert "no-effect records: 1, named something on 0" in capsys.readouterr().out


WHEEL = real_motor_file("wheel_free_validation_motor2.csv")
WHEEL_TRAIN = real_motor_file("wheel_free_train_motor1.csv")


@pytest.mark.skipif(not WHEEL_TRAIN.exists(), reason=f"real motor data not found at {WHEEL_TRAIN.parent}")
def test_rests_whose_input_steps_past_the_breakaway_say_so_and_the_level_to_use(capsys):
    """A wheel motor's duty steps between held levels (a median 11 % in one sample at its breakaways,
    against a kinetic level of 3.86 %): each rest rests at one level and breaks away under the
    next, so it brackets the breakaway and reads nothing. The line says so at how many, and gives
    the level a compensation should use with its sign; the step lines and the final model say which
    value is which."""
    code, out, err = run(capsys, "doctor", str(WHEEL_TRAIN), "--input-unit", "%", "--output-unit", "rev/s",
                         "--json")  # fmt: skip
    assert code == 0, err
    rest = out["rests"][0]
    assert rest["breakaway_excess"] is None and rest["breakaway_reading"] == "none"  # JSON null, never NaN
    assert rest["breakaway_bracketed"] == rest["count"] > 5
    assert rest["median_breakaway_input"] > rest["kinetic_level"]
    line = next(x.strip() for x in err.splitlines() if x.strip().startswith("rests: "))
    kinetic = f"{rest['kinetic_level']:.3g} %"
    assert (f"not measured: at {rest['count']} of them the input steps past the breakaway within a sample "
            "(by more than 25 % of the input the drive moved under), which brackets it but does not read it") in line  # fmt: skip
    assert line.endswith(
        f"a compensation should use the kinetic level: +{kinetic} forwards, -{kinetic} backwards"
    )
    steps = [x.strip() for x in err.splitlines() if x.strip().startswith("+ ")]
    assert len(steps) == len(out["steps"]) and all(" at this step (ΔBIC " in x for x in steps)
    assert any(
        x.strip().startswith("final model, every parameter refitted with the effects found")
        for x in err.splitlines()
    )
    # static friction left to the free run, and the doctor's page quotes both as printed
    ranked = [c for s in out["steps"] for c in s["evidence"]["ranking"] if c["effect"] == "static_friction"]
    measure = f"free run (0 rests read, fewer than 5, {rest['count']} bracketed by a step of the input)"
    assert ranked and all(c["measure"] == measure for c in ranked)
    page = " ".join(
        (Path(__file__).resolve().parents[1] / "docs" / "guide" / "doctor.md").read_text("utf-8").split()
    )
    said = line[line.index("its level above") : line.index("; a compensation")]
    assert f"`{said}`" in page and f"`{measure}`" in page


def test_a_breakaway_read_below_the_kinetic_level_is_said_not_to_hold():
    """Rests whose breakaway reads more than two standard errors below the kinetic level (which no
    friction breaks away at) do not measure it: the line says so, with the steps' size where the
    input's rate there times the sample time exceeds the kinetic level, and the compensation uses
    the kinetic level."""
    from motorid.cli.doctor import breakaway_words
    from motorid.diagnose.results import RestSummary

    rest = RestSummary("r", 12, 0.2, 10.5, 1100.0, 3.5, 3.86, -5.5, 1.2, 0.0125, 0.001, "none", True)
    line = breakaway_words(rest, 0.01, {"F": "%", "u": "%"})
    assert line == (
        "the force at breakaway measures -5.5 ± 1.2 % from the kinetic level 3.86 %, or a lag of 12.5 ms (the "
        "input rises alike at each), below it, which no friction does: the sample taken as the breakaway comes "
        "before the force that broke the drive away: its input steps past the breakaway level within a sample "
        "(a median 11 % a sample there), so the rests do not measure the breakaway level; a compensation should "
        "use the kinetic level: +3.86 % forwards, -3.86 % backwards"
    )


@pytest.mark.skipif(not WHEEL.exists(), reason=f"real motor data not found at {WHEEL.parent}")
def test_breakaways_under_a_held_duty_are_bracketed_and_static_friction_left_to_the_free_run():
    """A wheel motor's duty is an integer %, held 30 samples: its rests break away on the steps of
    the duty (through the model's 14 ms delay), each resting at the level held before the step the
    shaft moved under. Each rest brackets its breakaway and reads none, so the rests do not
    measure it, and static friction is fitted where the free run comes closest. The kit motor's
    input is not quantised."""
    from motorid.diagnose.measures import breakaway, fit_static_friction
    from motorid.io.records import read_record

    d = diagnose(read_record(WHEEL), input_unit="%", output_unit="rev/s")
    pool = d._pool
    assert pool.input_quantisation == pytest.approx(1.0, rel=1e-9)
    found = breakaway(pool, d.model)
    assert math.isnan(found.excess) and d.rests[0].breakaway_bracketed == found.bracketed
    # each rest read on a sample the force rose into: the held level before the step is the last at rest
    part = pool.parts[0]
    force = d.model.input_force(part.kin.u)
    moves = part.first_moving(d.model, part.rests, force)
    assert np.all(part.rests.direction * (force[moves] - force[moves - 1]) > 0.0)
    # bracketed by the duty's steps, the rests do not measure the breakaway: the free run fits it
    assert found.bracketed == part.rests.count and not found.measures and found.reading == "none"
    fitted = fit_static_friction(pool, d.model, None).params["breakaway_excess"]

    def free_run_mse(excess: float) -> float:
        model = d.model.with_effects(
            (*d.model.effects, "static_friction"), {**d.model.params, "breakaway_excess": excess}
        )
        err = pool.free_run_error(model)
        return float(np.mean(err[np.isfinite(err)] ** 2))

    best = free_run_mse(fitted)
    assert all(best <= free_run_mse(fitted + h) for h in (0.01, 0.1, 0.5, 1.0))  # [% duty]
    kit = diagnose(read_record(KIT_CHIRP), input_unit="%", max_steps=1)
    assert kit._pool.input_quantisation == 0.0


L298N = real_motor_file("l298n_staircase.csv")


@pytest.mark.skipif(not L298N.exists(), reason=f"real motor data not found at {L298N.parent}")
def test_a_model_with_static_friction_gives_the_compensation_its_breakaway_level(capsys):
    """The L298N staircase rests twice, too few for the rests to measure a breakaway, and the doctor
    fits static friction from the free run (measured 3.82 V above a kinetic level near 0): the
    rests line says the rests do not measure it and gives a compensation the model's level, signed."""
    code, out, err = run(capsys, "doctor", str(L298N), "--input-unit", "V", "--output-unit", "rpm", "--json")
    assert code == 0, err
    params, rest = out["model"]["params"], out["rests"][0]
    assert "static_friction" in out["model"]["effects"] and rest["count"] < 3
    level = rest["kinetic_level"] + params["breakaway_excess"]
    line = next(x.strip() for x in err.splitlines() if x.strip().startswith("rests: "))
    assert "not measured: fewer than 3 of them break away under a rising input" in line
    assert (
        f"break it away with the kinetic level plus the model's static friction, +{level:.3g} V forwards, "
        f"-{level:.3g} V backwards" in line
    )


def test_static_friction_is_held_out_on_a_second_records_rests():
    """With a second record of the drive as the held-out check, static friction read on the
    pool's rests predicts that record's breakaways (measured 1.2 against 8.8 mN m off without
    the level), and is named; the check's figures are the medians over the second record's rests
    against those of the fits on the first's (:func:`breakaway_cross_check` with ``other``)."""
    from motorid.diagnose.measures import breakaway_cross_check, breakaway_holdout
    from motorid.diagnose.prepare import Pool, prepare

    first = planted_record("static_friction", 1)
    second = planted_record("static_friction", 1, excitation_seed=99)  # the same drive, another run
    d = diagnose(first.record, input_gain=first.input_gain, base=first.base, holdout=second.record)
    assert d.named == ["static_friction"]
    ev = d.steps[0].evidence
    assert ev.candidate.measure == "rests" and ev.held_out_error_after < 0.3 * ev.held_out_error_before
    pool, bare = d._pool, d.model.without("static_friction")
    other = prepare(second.record, input_gain=first.input_gain, timing=pool.parts[0].timing)
    without, with_level = breakaway_holdout(pool, None, Pool([other], ["held out"]), None, bare)
    assert without.size >= 3
    held = Pool([other], ["held out"])
    assert breakaway_cross_check(pool, bare, other=held) == (np.median(without), np.median(with_level))
