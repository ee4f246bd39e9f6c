"""Closed-loop records: ``motorid control --out`` writes a record every command reads as it is, and
the doctor recognises a closed loop, reads it with the loop's timing and refits its balance with the
reference as instrument (:mod:`motorid.diagnose.closed_loop`).

The truths: the rig's rigid equivalent has input gain g = K_m / R_a = 0.02142 N m/V, so without
``--input-gain`` a Coulomb torque of 0.005 + 0.002 N m (motor and load) is 0.327 V of input, and
a dead zone of 0.5 V adds 0.5 V to the level that holds a moving drive back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid.diagnose import diagnose
from motorid.diagnose.closed_loop import input_feedback
from motorid.diagnose.synthetic import planted_record
from motorid.drive import Amplifier, Friction, RigidDrive, paper_rig
from motorid.errors import DataError
from motorid.io.records import read_record
from motorid.signals import two_sine_signal
from motorid.speed_control import SpeedController, design_speed_pi, reversing_reference

#: The rig's input gain K_m / R_a [N m/V] (paper_rig: K_m = 0.04284 N m/A, R_a = 2 ohm).
GAIN = 0.04284 / 2.0
#: The rig's Coulomb torque, motor 0.005 + load 0.002 N m, in volts of input.
COULOMB_V = 0.007 / GAIN
#: The rig's inertia, motor 2.5e-5 + load 7.5e-5 kg m², per input gain [V s/(rad/s)].
INERTIA_V = 1e-4 / GAIN
#: The dead zone [V].
DEAD_ZONE = 0.5
#: The 15 % the issue asks of the friction found on a closed loop.
WITHIN = 0.15
DT = 0.04


@pytest.fixture(scope="module")
def loops(tmp_path_factory) -> Path:
    """drive.json: the doctor's model of a 60 s open-loop record of the rig (Coulomb 0.005 N m on
    the motor, dead zone 0.5 V); loop.csv and plain_loop.csv: ``motorid control`` (PI with friction
    compensation from the reference, designed on drive.json) on that rig and on the rig without
    its dead zone; pi_loop.csv: the PI alone on the first rig."""
    root = tmp_path_factory.mktemp("closed_loop")
    friction = (Friction(("coulomb_friction",), {"coulomb": 5e-3}, side="motor"),
                Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="load"))  # fmt: skip
    rig = paper_rig(friction=friction, amplifier=Amplifier(dead_zone=DEAD_ZONE, v_max=12.0))
    _, u = two_sine_signal(duration=60.0, dt=rig.dt, seed=0)
    diagnose(rig.simulate(u, seed=1), max_steps=2).model.save(root / "drive.json")
    for name, dead_zone, options in (("loop.csv", DEAD_ZONE, []), ("plain_loop.csv", 0.0, []),
                                     ("pi_loop.csv", DEAD_ZONE, ["--no-compensation"])):  # fmt: skip
        argv = ["control", "--design", str(root / "drive.json"), "--coulomb-motor", "0.005",
                "--dead-zone", str(dead_zone), "--out", str(root / name), *options]  # fmt: skip
        from motorid.cli import main

        assert main(argv) == 0
    return root


def test_the_control_record_names_its_timing_units_and_reference(loops):
    record = read_record(loops / "loop.csv")
    assert record.attrs["dt"] == DT and record.attrs["timing"] == "sampled"
    assert record.attrs["units"] == {"t": "s", "reference": "rad/s", "u": "V", "y": "rad/s"}
    assert (
        record.attrs["loop"]["reference"] == "reference"
        and record.attrs["loop"]["compensation"] == "reference"
    )
    assert list(record.columns) == ["t", "reference", "u", "y", "clamped"] and len(record) == 300
    # pandas reads it too, the attribute line as a comment
    assert pd.read_csv(loops / "loop.csv", comment="#")["y"].equals(record["y"])


def test_identify_and_compare_read_the_control_record_with_no_options(capsys, loops):
    code, out, err = run(capsys, "identify", str(loops / "loop.csv"), "--estimator", "arx-rls", "--json")
    assert code == 0, err
    assert out["samples"] == 300 and out["output_unit"] == "rad/s"
    code, out, err = run(
        capsys, "compare", str(loops / "loop.csv"), "--model", str(loops / "drive.json"), "--json"
    )
    assert code == 0, err
    (scores,) = out["models"].values()
    assert scores["fit_percent"] > 90.0  # the open-loop model predicts the loop's speed from its commands


def test_the_doctor_on_a_loop_with_coulomb_friction_and_a_dead_zone(capsys, loops):
    code, out, err = run(capsys, "doctor", str(loops / "loop.csv"), "--json")
    assert code == 0, err
    # no invented delay (it took 55 ms, 1.4 samples, when the record was read with the open loop's timing)
    assert "input_delay" not in out["structure"]["effects"]
    assert out["units"]["velocity"] == "rad/s" and out["units"]["input"] == "V"
    (loop,) = out["closed_loop"]
    assert loop["reference"] == "reference" and loop["method"] == "instrumental variables"
    assert "closed loop: the reference is column 'reference'" in err
    # the compensation jumps across the dead zone at each reversal: the input is never inside it while the
    # drive moves, so Coulomb friction and the dead zone are one level here, named once, the other its lookalike
    (step,) = out["steps"]
    assert step["effect"] == "coulomb_friction"
    assert set(step["lookalike"]["effects"]) == {"coulomb_friction", "input_dead_zone"}
    kinetic = out["model"]["params"]["coulomb"]
    assert kinetic == pytest.approx(COULOMB_V + DEAD_ZONE, rel=WITHIN)
    # no delay set free by least squares (it took 14.6 ms of the loop's correlation and called the inertia
    # undetermined): the instrumental inertia holds the rig's 1e-4 kg m² within 3 of its standard errors
    assert out["model"]["delay_trade"] is None and "inertia" not in out["model"]["params_undetermined"]
    inertia, std = out["model"]["params"]["inertia"], out["model"]["params_std"]["inertia"]
    assert abs(inertia - INERTIA_V) < 3.0 * std


def test_the_doctor_on_a_loop_without_a_dead_zone(capsys, loops):
    code, out, err = run(capsys, "doctor", str(loops / "plain_loop.csv"), "--json")
    assert code == 0, err
    assert "input_delay" not in out["structure"]["effects"]
    assert out["closed_loop"][0]["reference"] == "reference"
    assert out["model"]["params"]["coulomb"] == pytest.approx(COULOMB_V, rel=WITHIN)


def test_a_pi_loop_takes_coulomb_friction_and_the_dead_zone_as_one_level_their_sum(capsys, loops):
    """The PI alone (no compensation) on the rig with the dead zone: the loop's input crosses the
    dead zone only where the drive reverses, so the record determines the level that holds the
    moving drive back, Coulomb friction and dead zone together (0.818 V measured against 0.827 V):
    one is named, the other its lookalike, at the noise floor."""
    code, out, err = run(capsys, "doctor", str(loops / "pi_loop.csv"), "--json")
    assert code == 0, err
    assert "input_delay" not in out["structure"]["effects"]
    (step,) = out["steps"]
    assert step["effect"] == "coulomb_friction"
    assert set(step["lookalike"]["effects"]) == {"coulomb_friction", "input_dead_zone"}
    assert out["model"]["params"]["coulomb"] == pytest.approx(COULOMB_V + DEAD_ZONE, rel=WITHIN)


def test_a_loop_model_with_both_coulomb_friction_and_a_dead_zone_says_their_sum():
    from motorid.diagnose.closed_loop import kinetic_split

    units = {"F": "N m", "u": "V", "v": "rad/s"}
    both = RigidDrive(("coulomb_friction", "input_dead_zone"),
                      {"inertia": 1e-4, "input_gain": 0.02, "coulomb": 0.004, "dead_zone": 0.5}, 0.01)  # fmt: skip
    sentence = kinetic_split(both, units)
    assert "as one level, 0.014 N m" in sentence  # 0.004 + 0.02 x 0.5
    assert kinetic_split(both.without("input_dead_zone"), units) is None


def test_a_loop_record_without_attributes_is_read_with_the_loops_timing(loops):
    plain = pd.read_csv(loops / "loop.csv", comment="#")  # a PLC's log of the loop: no dt, units or timing
    plain.attrs = {}
    d = diagnose(plain, max_steps=1)
    (loop,) = d.closed_loop
    assert loop.timing_set and d.settings.timing == "sampled"
    assert "input_delay" not in d.structure.effects
    assert "read with timing 'sampled'" in loop.sentence()
    # the same log read with the open loop's timing takes the loop's one-sample shift for a delay
    held = diagnose(plain, max_steps=1, timing="hold")
    assert held.structure.params["input_delay"] > DT


def test_a_loop_log_that_names_no_timing_is_read_with_the_timing_its_feedback_shows():
    """A bench's loop logged without its attributes, once as ``motorid control`` logs it (the speed read,
    then the command: the input answers the output in the same row) and once with each speed the one at
    the end of the sample (the open loop's convention: the command answers it in the next row). The
    feedback's lag tells them apart, and each is read with its own timing: at the noise floor with the
    drive's Coulomb friction, where reading the second as 'sampled' left a final gap of 20 noise floors
    (measured on this bench from the bank's base, the timing rule before the lag)."""
    from motorid.diagnose.bench import bench
    from motorid.diagnose.closed_loop import loop_timing

    b = bench("closed_loop", None, 1)  # a compensated loop on held levels at 2 ms
    sampled = b.record[["t", "reference", "u", "y"]].copy()
    held = sampled.iloc[:-1].copy()
    held["y"] = sampled["y"].to_numpy()[1:]  # y[k]: the speed at the end of the sample u[k] is held over
    for log, timing, lag in ((sampled, "sampled", 0), (held, "hold", 1)):
        log.attrs = {"dt": b.record.attrs["dt"]}
        feedback = input_feedback(log["u"].to_numpy(), log["y"].to_numpy())
        assert feedback.looks_closed and feedback.lag == lag and loop_timing(feedback) == timing
        d = diagnose(log, input_gain=b.params["input_gain"], max_steps=1)
        (loop,) = d.closed_loop
        assert loop.timing == timing and d.settings.timing == timing
        assert (
            f"read with timing {timing!r}" in loop.sentence()
            and d.to_dict()["closed_loop"][0]["timing"] == timing
        )
        # the default base has no Coulomb friction: the drive's own is named, nothing else
        assert "input_delay" not in d.structure.effects and d.named == ["coulomb_friction"]
        # 3.5: the doctor's MISSING_FACTOR, "at the noise floor"; the Coulomb level within the 15 %
        assert d.final_gap.overall < 3.5 * d.noise_floor
        assert d.model.params["coulomb"] == pytest.approx(b.params["coulomb"], rel=WITHIN)


def test_a_loops_dead_zone_is_found_where_the_base_took_a_lag_for_it():
    """A bench of the bank: the compensated loop at 1 ms on a drive with a 1.01 V dead zone (seed 4). The
    structure search, on the base without the dead zone, took a 5 ms input lag, and the dead zone found
    beside it was 13 % low with a final gap of 12.6 noise floors. Run again without the structure, the
    lag accounts for nothing of the final gap and is left out: the dead zone named, within 0.4 % (15 %,
    the issue's bound), at the noise floor (MISSING_FACTOR, 3.5)."""
    from motorid.diagnose.bench import bench
    from motorid.diagnose.synthetic import BASE_FOR

    b = bench("closed_loop", "input_dead_zone", 4)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"])
    assert d.named == ["input_dead_zone"] and not d.structure.effects
    assert d.model.params["dead_zone"] == pytest.approx(b.params["dead_zone"], rel=WITHIN)
    assert d.final_gap.overall < 3.5 * d.noise_floor
    assert d.structure.reason.startswith(
        "closed loop: the input_lag taken on the base makes the final gap larger"
    )
    assert d.structure.reason in d.notes and d.structure.candidates  # what the search tried stays on record


def test_least_squares_stand_where_their_free_run_lies_closer_than_the_instruments():
    """A bench of the bank: the compensated loop at 10 ms on a drive with Stribeck friction (seed 5). The
    instrumental fit, its Stribeck velocity held, takes the Stribeck level 55 % high (± 51 %) and runs free
    1.98 noise floors from the record; least squares 13 % high at 1.07 floors. Least squares are kept and
    said; the Stribeck level within the issue's 15 %, at the noise floor (3.5, MISSING_FACTOR)."""
    from motorid.diagnose.bench import bench
    from motorid.diagnose.synthetic import BASE_FOR

    b = bench("closed_loop", "stribeck_friction", 5)
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE_FOR["input_lag"])
    (loop,) = d.closed_loop
    assert d.named == ["stribeck_friction"] and loop.method == "least squares"
    assert loop.least_squares_kept.startswith("least squares kept: its free run lies closer to the record")
    assert loop.least_squares_kept in loop.sentence() and loop.to_dict()["method"] == "least squares"
    stribeck = loop.instrumental["stribeck"]
    assert d.model.params["stribeck"] == stribeck["least_squares"] != stribeck["value"]
    assert d.param_std["stribeck"] != stribeck["standard_error"]  # least squares' own error
    assert d.model.params["stribeck"] == pytest.approx(b.params["stribeck"], rel=WITHIN)
    assert d.final_gap.overall < 3.5 * d.noise_floor


def simulated_loop(noise: float, seed: int) -> tuple[RigidDrive, pd.DataFrame]:
    """A PI loop (bandwidth 40 rad/s, no compensation) at 10 ms on a drive with viscous and Coulomb
    friction, its speed read with white noise of ``noise`` rad/s RMS: t, reference, u, y, sampled."""
    dt = 0.01
    drive = RigidDrive(("viscous_friction", "coulomb_friction"),
                       {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.04, "coulomb": 0.3}, dt=dt)  # fmt: skip
    rng = np.random.default_rng(seed)
    _, r = reversing_reference("sine", 30.0, 4.0, 40.0, dt)
    controller = SpeedController(design_speed_pi(drive, dt, bandwidth=40.0), dt, None)
    sim, w, rows = drive.simulation(), 0.0, []
    for k in range(r.size):
        y = w + noise * rng.standard_normal()
        u = controller.step(r[k], y)
        rows.append((k * dt, r[k], u, y))
        w = sim.step(u)
    record = pd.DataFrame(rows, columns=["t", "reference", "u", "y"])
    record.attrs.update(dt=dt, timing="sampled")
    return drive, record


def test_the_reference_as_instrument_removes_the_loops_bias():
    drive, record = simulated_loop(noise=1.0, seed=0)
    d = diagnose(record, base=("viscous_friction", "coulomb_friction"), max_steps=0, structure=False)
    (loop,) = d.closed_loop
    for name in ("inertia", "coulomb", "viscous"):
        entry, truth = loop.instrumental[name], drive.params[name]
        # the instrumental estimate holds the truth within 3 of its standard errors
        assert abs(entry["value"] - truth) < 3.0 * entry["standard_error"], name
        assert d.model.params[name] == entry["value"] and d.param_std[name] == entry["standard_error"]
    # least squares, which the noise fed back through the PI reaches, misses the inertia by more than 25 % (40 %)
    ls = loop.instrumental["inertia"]["least_squares"]
    assert abs(ls - drive.params["inertia"]) > 0.25 * drive.params["inertia"]
    assert (
        abs(loop.instrumental["inertia"]["value"] - drive.params["inertia"]) < 0.1 * drive.params["inertia"]
    )


def test_an_input_that_answers_the_outputs_noise_looks_closed():
    _, record = simulated_loop(noise=0.5, seed=1)
    assert input_feedback(record["u"].to_numpy(), record["y"].to_numpy()).looks_closed
    log = record.drop(columns="reference")
    log.attrs = {"dt": record.attrs["dt"]}  # a log that names no timing
    d = diagnose(log, max_steps=0)
    (loop,) = d.closed_loop
    assert loop.reference is None and "looks like a closed loop" in loop.sentence()
    assert loop.timing_set and d.settings.timing == "sampled"  # the loop's timing: no one-sample shift
    assert "input_delay" not in d.structure.effects
    assert "closed_loop" in d.to_dict()
    # an open loop's input never sees the output's noise
    for effect, seed in (("coulomb_friction", 3), (None, 4)):
        open_loop = planted_record(effect, seed).record
        assert not input_feedback(open_loop["u"].to_numpy(), open_loop["y"].to_numpy()).looks_closed
        assert "closed_loop" not in diagnose(open_loop, max_steps=0).to_dict()


@pytest.mark.parametrize("name", ["loop.csv", "plain_loop.csv", "pi_loop.csv"])
def test_a_loop_logged_without_its_reference_looks_closed_with_or_without_compensation(loops, name):
    """A PLC's log of ``motorid control``'s loop, its reference and attributes dropped: the compensated
    loops (from the reference: the Coulomb term switches at each reversal) are recognised as the PI alone
    is. Their correlations, reversals left out: -0.46 (loop.csv), -0.49, -0.83 (the old test, reversals in,
    gave +0.05 on loop.csv: 98 % of its input innovation's energy lies in the rows near its 6 reversals)."""
    plain = pd.read_csv(loops / name, comment="#").drop(columns="reference")
    plain.attrs = {}
    feedback = input_feedback(plain["u"].to_numpy(), plain["y"].to_numpy())
    assert feedback.looks_closed, feedback
    (loop,) = diagnose(plain, max_steps=0).closed_loop
    assert loop.reference is None and loop.closed and "looks like a closed loop" in loop.sentence()


def test_the_compensated_benches_look_closed_and_the_open_ones_open():
    """The bank's closed loops (the true friction fed forward from the reference on about half of them),
    their reference dropped, against its open-loop benches of every imperfection: a bounded part of the
    measurement in :data:`motorid.diagnose.closed_loop.FEEDBACK_CORRELATION`'s notes, 15 s records. Measured
    -0.60 to -0.92 on these 8 closed loops (4 compensated; the compensated chirp at 10 ms, seed 5, -0.62,
    which looked open before reversals were left out), -0.05 to 0 on the 20 open ones."""
    from motorid.diagnose.bench import IMPERFECTIONS, bench

    compensated = 0
    for seed in range(8):
        b = bench("closed_loop", "input_dead_zone", seed, duration=15.0)
        compensated += b.notes["compensated"] == 1.0
        feedback = input_feedback(b.record["u"].to_numpy(), b.record["y"].to_numpy())
        assert feedback.looks_closed, (seed, b.notes, feedback)
    assert compensated == 4
    for imperfection in IMPERFECTIONS:
        if imperfection == "closed_loop":
            continue
        for effect, seed in ((None, 0), ("static_friction", 1)):
            record = bench(imperfection, effect, seed, duration=15.0).record
            feedback = input_feedback(record["u"].to_numpy(), record["y"].to_numpy())
            assert not feedback.looks_closed and feedback.correlation > -0.2, (imperfection, effect, feedback)


REAL_MOTORS = sorted(real_motor_file("README.md").parent.glob("*.csv"))


@pytest.mark.skipif(len(REAL_MOTORS) < 15, reason="the realmotors records are absent (set MOTORID_DATA)")
def test_the_real_motors_open_loop_records_look_open():
    """The 15 records of ``realmotors`` read as they are (all open loop): none looks closed (their
    correlations measured -0.05 to 0)."""
    for path in REAL_MOTORS:
        record = read_record(path)
        feedback = input_feedback(record["u"].to_numpy(), record["y"].to_numpy())
        assert not feedback.looks_closed and feedback.correlation > -0.2, (path.name, feedback)


def test_a_reference_column_that_is_not_there_is_refused_by_name(capsys, loops):
    _, record = simulated_loop(noise=0.5, seed=1)
    with pytest.raises(DataError, match="reference_column='setpoint': the record has no such column"):
        diagnose(record, reference_column="setpoint", max_steps=0)
    code, _, err = run(capsys, "doctor", str(loops / "loop.csv"), "--reference-column", "setpoint")
    assert code == 2 and "--reference-column setpoint" in err and "no such column" in err


def test_a_full_disk_in_the_first_write_counts_the_rows_after_the_attribute_line(small_disk):
    from motorid.errors import OutputError
    from motorid.io.online import RunRecorder
    from motorid.io.records import attrs_line

    line = attrs_line({"dt": DT, "units": {"t": "s", "u": "V", "y": "rad/s"}, "timing": "sampled"})
    recorder = RunRecorder(small_disk / "run.csv", flush_every=100_000, preamble=[line])  # one write: 4 MB
    with pytest.raises(OutputError, match=r"the file holds the first \d+ of 100000 samples") as info:
        for k in range(100_000):
            recorder.append({"t": k * DT, "seq": k + 1, "u": 1.0 / 3.0, "y": float(k) / 7.0})
    recorder.close()
    table = read_record(small_disk / "run.csv")
    assert table.attrs["timing"] == "sampled"
    assert len(table) == recorder.on_disk == int(str(info.value).split("first ")[1].split(" of")[0])
    assert table["seq"].tolist() == list(range(1, len(table) + 1))
