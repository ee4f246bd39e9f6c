"""Records that start badly: a held start and drop-out spikes are found, left out with a one-line
note, and the verdict is the clean record's; ``--start``/``--stop`` trim a record on the command
line."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid.diagnose import diagnose
from motorid.diagnose.artefacts import (
    MIN_DRIVEN_STOPS,
    clean_output,
    driven_stops,
    dropout_spikes,
    held_start,
    stale_start,
)
from motorid.diagnose.synthetic import planted_record
from motorid.io.records import write_record


@pytest.fixture(scope="module")
def planted():
    return planted_record("coulomb_friction", 7, sizes={"coulomb": 8e-3})


def with_held_start(record: pd.DataFrame, seconds: float, value: float = 0.0) -> pd.DataFrame:
    """``record`` after a logger's held start: ``seconds`` of output ``value`` while the input
    swings over its whole range."""
    dt = record.attrs["dt"]
    n = round(seconds / dt)
    u = float(record["u"].abs().max()) * np.sin(2 * np.pi * np.arange(n) / n)
    head = pd.DataFrame({"t": np.arange(n) * dt, "u": u, "y": np.full(n, value)})
    tail = record.assign(t=record["t"] + n * dt)
    out = pd.concat([head, tail], ignore_index=True)
    out.attrs = dict(record.attrs)
    return out


@pytest.mark.parametrize("value", [0.0, 12.5])
def test_a_held_start_is_left_out_with_a_note_and_the_verdict_is_the_clean_records(planted, value):
    clean = diagnose(planted.record, input_gain=planted.input_gain)
    bad = with_held_start(planted.record, 0.7, value)
    d = diagnose(bad, input_gain=planted.input_gain)
    assert d.notes == [
        f"the output holds {value:.4g} rad/s over the first 70 samples (0.7 s) while the input moves "
        f"(to {bad['u'].iloc[:70].abs().max():.3g} V): a logging artefact, left out"
    ]
    # the samples left are the clean record's: the same figures, bit for bit
    assert d.named == clean.named and d.final_gap == clean.final_gap and d.model.params == clean.model.params
    assert d.to_dict()["notes"] == d.notes and "notes" not in clean.to_dict()


@pytest.mark.parametrize("samples", [3, 8, 84])
def test_a_stale_start_is_left_out_with_a_note_and_the_verdict_is_the_clean_records(planted, samples):
    """The previous run's last speed, -205 rad/s, read for the first samples while the input is 0
    (the start of the planted record is at rest under 0 V)."""
    rec = planted.record
    dt = rec.attrs["dt"]
    head = pd.DataFrame({"t": np.arange(samples) * dt, "u": 0.0, "y": -205.0})
    start = rec.iloc[:1].assign(u=0.0, y=0.0)  # the drive at rest: the value the link reads next
    tail = rec.assign(t=rec["t"] + (samples + 1) * dt)
    bad = pd.concat([head, start.assign(t=samples * dt), tail], ignore_index=True)
    bad.attrs = dict(rec.attrs)
    u, y = bad["u"].to_numpy(), bad["y"].to_numpy()
    assert stale_start(u, y) == samples
    d = diagnose(bad, input_gain=planted.input_gain)
    assert d.notes == [
        f"the output reads -205 rad/s over the first {samples} samples ({samples * dt:.3g} s) under a constant "
        "input (0 V) and then leaves it at once: a stale value of an earlier run, left out"
    ]
    clean = pd.concat([start, rec.assign(t=rec["t"] + dt)], ignore_index=True)
    clean.attrs = dict(rec.attrs)
    clean = diagnose(clean, input_gain=planted.input_gain)
    assert d.named == clean.named and d.model.params == clean.model.params


def test_a_drive_turning_steadily_at_the_start_is_not_a_stale_start():
    """A quantised speed held over many samples under a constant input, then one count away, is a
    drive at speed; a drive slowing under 0 V from its first sample is too."""
    u = np.full(200, 3.0)
    y = np.concatenate([np.full(50, 120.0), np.full(150, 120.767)])
    assert stale_start(u, y) == 0
    y_slow = 100.0 * np.exp(-np.arange(200) * 0.05)
    assert stale_start(np.zeros(200), y_slow) == 0


def test_a_resting_start_under_a_small_input_is_kept():
    """A drive at rest under an input below its breakaway level is physics, not a logger."""
    n = 3000
    u = np.concatenate([np.linspace(0.0, 0.5, 50), 2.0 * np.sin(np.arange(n - 50) * 0.05)])
    y = np.concatenate([np.zeros(50), np.where(np.abs(u[50:]) > 0.6, u[50:] - 0.6 * np.sign(u[50:]), 0.0)])
    assert held_start(u, y) == 0  # rests later at inputs up to 0.6, the start reaches 0.5
    y_late = y
    u_high = u.copy()
    u_high[:50] = np.linspace(0.0, 1.5, 50)  # beyond 1.2 x the breakaway seen later: a logger's hold
    assert held_start(u_high, y_late) == np.flatnonzero(y_late)[0]  # up to the first motion


def test_drop_out_spikes_are_replaced_and_named(planted):
    rec = planted.record.copy()
    y = rec["y"].to_numpy().copy()
    spikes = [400, 1700]
    y[spikes] = -2.0 * np.abs(y).max()  # a serial link's drop-out lands far from the speed
    rec["y"] = y
    u2, y2, notes = clean_output(rec["u"].to_numpy(), y, 0.01, ("V", "rad/s"))
    assert u2.size == y.size  # a spike keeps every sample
    assert list(dropout_spikes(y)) == spikes
    np.testing.assert_array_equal(y2[spikes], 0.5 * (y[[399, 1699]] + y[[401, 1701]]))
    assert notes == [
        "2 drop-out spikes in the output (single samples far from both neighbours, the first at sample 400, "
        "t = 4 s from the start): replaced by the mean of the neighbours"
    ]
    d = diagnose(rec, input_gain=planted.input_gain)
    clean = diagnose(planted.record, input_gain=planted.input_gain)
    assert d.notes == notes and d.named == clean.named
    # two samples of 3000 replaced by their neighbours' mean: the gap moves by well under 1 %
    assert d.final_gap.overall == pytest.approx(clean.final_gap.overall, rel=0.01)


def test_records_without_artefacts_get_no_note(planted):
    for effect in ("coulomb_friction", "input_dead_zone", "static_friction", "backlash", None):
        for seed in range(4):
            rec = planted_record(effect, seed).record
            assert clean_output(rec["u"].to_numpy(), rec["y"].to_numpy(), 0.01, ("V", "rad/s"))[2] == []
    real = sorted(real_motor_file("README.md").parent.glob("*.csv"))
    for path in real:  # quantised encoders, one-sample blips at input steps, long rests in a dead zone
        rec = pd.read_csv(path)
        assert clean_output(rec["u"].to_numpy(), rec["y"].to_numpy(), 0.01)[2] == [], path.name


def test_start_and_stop_trim_the_record(capsys, planted, tmp_path):
    path = tmp_path / "rec.csv"
    write_record(with_held_start(planted.record, 0.7), path)
    code, out, err = run(capsys, "doctor", str(path), "--start", "0.7", "--stop", "25", "--json")
    assert code == 0, err
    # the held start is trimmed away by --start: nothing left to note, and the span is t in [0.7, 25]
    assert "notes" not in out and "(2431 samples)" in err
    trimmed = planted.record[planted.record["t"] <= 24.3 + 1e-9].reset_index(drop=True)
    trimmed.attrs = dict(planted.record.attrs)
    assert out["final_gap"] == pytest.approx(diagnose(trimmed).final_gap.to_dict(), rel=1e-12)
    code, out, err = run(capsys, "doctor", str(path), "--json")
    assert code == 0 and out["notes"][0].startswith("the output holds 0 rad/s over the first 70 samples")
    assert "note: the output holds 0 rad/s" in err


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--start", "5", "--stop", "4"], "--stop 4 must be after --start 5 [s]"),
        (["--start", "500"], "rec.csv: no sample within --start 500 s; the record runs from 0 to 30.69 s"),
        (["--start", "-1"], "argument --start: must be in [0, inf] [s], got -1"),
    ],
)
def test_a_bad_span_is_refused_with_one_line(capsys, planted, tmp_path, argv, words):
    path = tmp_path / "rec.csv"
    write_record(with_held_start(planted.record, 0.7), path)
    code, out, err = run(capsys, "doctor", str(path), *argv)
    assert code == 2 and out == ""
    assert words in err, err


def test_driven_stops_are_stops_in_one_direction_under_a_held_input():
    """A drive pulsed at 10 Hz under a held 6 V: the speed rises in each 50 ms on phase and decays
    to rest in the off phase, 20 times in 2 s (the first stop at the end of the first pulse); the
    same speed reversing with its input, or resting while the input is small, has none."""
    dt, n = 1e-3, 2000
    t = np.arange(n) * dt
    phase = (t * 10.0) % 1.0
    pulsed = np.where(phase < 0.5, 100.0 * (1 - np.exp(-phase / 0.01)), 0.0)  # back to 0 each period
    u = np.full(n, 6.0)
    stops = driven_stops(u, pulsed)
    assert stops.size == 19 and np.all(np.diff(stops) == 100)
    assert driven_stops(-u, -pulsed).size == 19
    # the same pulses while the input reverses every 100 ms: each stop is a reversal
    assert (
        driven_stops(np.where(phase < 0.5, 6.0, -6.0) * np.sign(np.sin(np.pi * t * 10 + 0.1)), pulsed).size
        < 19
    )
    # a drive that rests only while its input is within a dead zone (|u| < 1 V of 6 V) has none
    u_sine = 6.0 * np.sin(2 * np.pi * t)
    w = np.where(np.abs(u_sine) > 1.0, 20.0 * (u_sine - np.sign(u_sine)), 0.0)
    assert driven_stops(u_sine, w).size == 0
    # nor does a speed that reverses with its input
    assert driven_stops(u_sine, 20.0 * u_sine).size == 0


def test_a_pulsed_drive_is_refused_with_what_to_do(capsys, tmp_path):
    """A bench whose 19 Hz PWM stops the drive every period, logged at 10 ms: one line, exit 2."""
    from motorid.diagnose.bench import bench

    b = bench("pulsed_pwm", None, 2)
    assert driven_stops(b.record["u"].to_numpy(), b.record["y"].to_numpy()).size >= MIN_DRIVEN_STOPS
    path = tmp_path / "pulsed.csv"
    write_record(b.record, path)
    code, out, err = run(capsys, "doctor", str(path), "--input-unit", "%")
    assert code == 2 and out == ""
    assert "a pulsed drive, whose PWM is slower than the motor" in err and "average the speed" in err
    assert len(err.strip().splitlines()) == 1, err
    # the closest stops lie one PWM period apart, within two samples (each stop is found to a sample)
    apart = float(re.search(r"the closest two ([0-9.]+) ms apart", err).group(1)) * 1e-3
    assert abs(apart - 1.0 / b.notes["pwm_frequency"]) <= 2 * b.record.attrs["dt"]
