"""A logger's time base (issue 31): the input delay's search reaches a logger's delays and says
when it hits its end; a delay that drifts along the record is measured per segment and said, and
``align`` puts the input on the output's time. Benches of :mod:`motorid.diagnose.bench`."""

from __future__ import annotations

import numpy as np
import pytest
from cli_fixtures import run

from motorid.diagnose import diagnose
from motorid.diagnose.bench import bench, delay_error_samples
from motorid.diagnose.calibration import BASE_FOR
from motorid.diagnose.model import DELAY_LONGEST, DELAY_SAMPLES, delay_reach
from motorid.io.records import write_record

#: The base the bank runs the doctor from (:func:`motorid.diagnose.calibration.bank`).
BASE = BASE_FOR["input_lag"]


def test_the_delay_search_reaches_a_share_of_the_record_within_stated_limits():
    assert delay_reach(1e-3, 1000) == pytest.approx(DELAY_SAMPLES * 1e-3)  # 1 s: 20 samples
    assert delay_reach(1e-3, 30_000) == pytest.approx(0.3)  # 30 s at 1 kHz: 1 % of it
    assert delay_reach(1e-3, 10**7) == DELAY_LONGEST


def test_a_constant_logging_delay_is_taken_within_one_sample():
    """A logger's delay of 2-200 ms (up to 40 samples at 5 ms, beyond the 20 samples the search
    once stopped at), on 6 benches: within one sample on at least 5 (the calibration over the bank
    gives the rate; a chirp's delay trades with a lag by a sample or so)."""
    within = []
    for seed in range(6):
        b = bench("constant_delay", None, seed)
        d = diagnose(b.record)
        assert not d.delay_drift
        within.append(delay_error_samples(d.model.params.get("input_delay", 0.0), b) <= 1.0)
    assert sum(within) >= 5, within


def test_a_delay_at_the_end_of_its_search_is_said():
    b = bench("constant_delay", None, 0, duration=10.0, dt=1e-3, logging_delay=(0.2, 0.2))
    d = diagnose(b.record)
    reach = delay_reach(1e-3, 10_000)  # 0.1 s, below the 0.2 s planted
    assert d.structure.reach == pytest.approx(reach, rel=0.05)  # the settled span, a little short of 10 s
    assert d.structure.at_reach and d.to_dict()["structure"]["delay_at_reach"] is True
    assert "the delay sits at the end of its search" in d.structure.describe(1e-3)


@pytest.fixture(scope="module")
def drifting():
    """A held-levels bench at 5 ms whose logger's delay grows from 14.5 to 48.3 ms in 30 s."""
    return bench("drifting_delay", None, 0)


def test_a_drifting_delay_is_measured_per_segment_and_said(drifting):
    first, last = drifting.logging_delay
    d = diagnose(drifting.record)
    (drift,) = d.delay_drift
    dt = drifting.record.attrs["dt"]
    span = drifting.record["t"].iloc[-1]
    # each segment's delay within a sample of the logger's at the segment's middle (measured:
    # within 0.3 samples), and the line through them within a sample at its ends
    truth = first + (last - first) * drift.times / span
    assert np.all(np.abs(drift.delays - truth) < dt), (drift.delays - truth) / dt
    assert drift.first == pytest.approx(first, abs=dt) and drift.last == pytest.approx(last, abs=dt)
    # the rate within 5 % of the logger's 1.13 ms a second (measured 0.5 %)
    assert drift.rate == pytest.approx((last - first) / span, rel=0.05)
    said = f"the input delay grows from {1e3 * drift.first:.3g} to {1e3 * drift.last:.3g} ms over the record"
    assert any(n.startswith(said) and n.endswith("the logger's time base drifts, and one delay fits neither end")
               for n in d.notes)  # fmt: skip
    assert np.all(drift.delay_std < dt)  # each segment's delay determined within a sample
    assert d.to_dict()["delay_drift"][0]["drifts"] is True


@pytest.mark.parametrize("effect", ["input_dead_zone", "static_friction"])
def test_a_drift_under_held_levels_is_said_where_its_segments_scatter_beyond_their_errors(effect):
    """Held levels at 5 ms whose logger's delay grows from 1.3 to 41 ms: the segments' delays lie
    within a sample of the logger's but scatter about their line beyond their standard errors
    (the model's own error is no white noise); the rule once asked them to lie on it within their
    errors and said no drift on these two. Now the scatter widens the line's error instead. The
    rate is the first pass's, against a model fitted to the drifting record: within 20 % (measured
    10 % and 17 % high; ``align`` measures it again on the aligned record), each segment within
    1.5 samples (measured 1.35 at most)."""
    b = bench("drifting_delay", effect, 0)
    first, last = b.logging_delay
    dt, span = b.record.attrs["dt"], b.record["t"].iloc[-1]
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE)
    (drift,) = d.delay_drift
    assert drift.drifts and drift.rate == pytest.approx((last - first) / span, rel=0.2)
    truth = first + (last - first) * drift.times / span
    assert np.all(np.abs(drift.delays - truth) < 1.5 * dt), (drift.delays - truth) / dt


def test_align_puts_the_input_on_the_outputs_time(drifting):
    plain = diagnose(drifting.record)
    aligned = diagnose(drifting.record, align=True)
    # one delay for the whole record leaves 18 noise floors; aligned, the gap is near the floor
    assert plain.final_gap.overall > 10 * plain.noise_floor
    assert aligned.final_gap.overall < 2 * aligned.noise_floor
    assert aligned.named == ["coulomb_friction"]
    # the delay at the start is left for the structure search: within a sample of the truth
    assert delay_error_samples(aligned.model.params["input_delay"], drifting) > 1.0  # the mean delay...
    start, end = drifting.logging_delay
    dt = drifting.record.attrs["dt"]
    assert abs(aligned.model.params["input_delay"] - start) <= dt  # ...but the start's
    # the drift taken out is said from there: the line within a sample of the logger's at both ends
    (taken,) = aligned.delay_drift
    assert taken.first == aligned.model.params["input_delay"] and taken.last == pytest.approx(end, abs=dt)
    assert any("the input put on the output's time (align)" in n for n in aligned.notes)
    # the aligned record fits as the same drive logged with a constant delay does (its final gap
    # in noise floors within half a floor of that twin's)
    twin = diagnose(bench("drifting_delay", None, 0, logging_delay=(start, start)).record)
    assert aligned.final_gap.overall / aligned.noise_floor == pytest.approx(
        twin.final_gap.overall / twin.noise_floor, abs=0.5
    )


@pytest.mark.parametrize(("effect", "seed"), [("static_friction", 2), ("input_dead_zone", 1)])
def test_align_measures_the_drift_again_on_the_aligned_record(effect, seed):
    """A 10 ms chirp and a 2 ms two-sine bench whose models on the drifting record took the delay
    into their inertia: the first pass's drift is 1.34 and 1.18 times the logger's; measured again
    on the aligned record it comes within 2 % (measured: 0.2 % and 0.3 %), and the delay left at the
    start is found within a sample."""
    b = bench("drifting_delay", effect, seed)
    first, last = b.logging_delay
    dt, span = b.record.attrs["dt"], b.record["t"].iloc[-1]
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE, align=True)
    (taken,) = d.delay_drift
    assert taken.rate == pytest.approx((last - first) / span, rel=0.02)
    assert abs(d.model.params.get("input_delay", 0.0) - first) <= dt
    assert d.final_gap.overall < 2 * d.noise_floor


@pytest.mark.parametrize(("effect", "seed"), [("stribeck_friction", 1), (None, 3)])
def test_the_start_delay_two_readings_agree_on_is_taken_near_the_noise_floor(effect, seed):
    """Two sines at 2 ms whose logger starts 2.2 and 1.7 samples late and drifts: on the aligned
    record the final model without a delay stands at 1.3 noise floors, and the delay brings it to
    the floor, less than a floor of its own (0.82 and 0.70). The balance (ΔBIC 66 and 32) and the
    free run read the same delay (1.9 and 2.1, 1.8 and 1.6 samples): it is taken, within a sample
    of the logger's, and the inertia no longer holds it (1.14 and 1.05 times the truth without)."""
    b = bench("drifting_delay", effect, seed)
    dt = b.record.attrs["dt"]
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE, align=True)
    assert abs(d.model.params.get("input_delay", 0.0) - b.logging_delay[0]) <= dt
    assert d.model.params["inertia"] == pytest.approx(b.params["inertia"], rel=0.03)  # measured 1.2 %, 0.2 %
    assert "input_delay" in d.structure.params and "taken on the final model" in d.structure.reason


def test_a_lag_the_base_took_for_a_missing_effect_is_dropped_on_the_final_model():
    """A 1 ms chirp logged 7.8 samples late, with a Stribeck decay: chosen on the base, before the
    decay is named, the structure took a 4.2-sample delay and a 5.0 ms lag the drive does not have.
    With the decay named, the free run without the lag, its delay read again, comes closer (0.176
    against 0.212 rad/s, the floor 0.171): the lag is dropped, the delay within a sample of the
    logger's (measured 7.79 samples) and the inertia within 3 % (measured 0.4 %)."""
    b = bench("drifting_delay", "stribeck_friction", 6)
    dt = b.record.attrs["dt"]
    d = diagnose(b.record, input_gain=b.params["input_gain"], base=BASE, align=True)
    assert "input_lag" not in d.model.effects and "lag_time_constant" not in d.structure.params
    assert abs(d.model.params["input_delay"] - b.logging_delay[0]) <= dt
    assert d.model.params["inertia"] == pytest.approx(b.params["inertia"], rel=0.03)
    assert "no lag: it comes closer without the lag the base took" in d.structure.reason


def test_an_aligned_record_holds_the_exact_mean_of_the_held_input_over_each_outputs_span():
    """Against a brute-force reference: each held input sample repeated 1,000 times and the fine
    samples averaged over the output sample's span on the input's time, ``[(1 - r) k, (1 - r)(k + 1))``
    (the reference errs by a fine sample's share of a step per edge, 1/1000 of the largest step);
    the output and the time column as logged."""
    import pandas as pd

    from motorid.diagnose.timing import DelayDrift
    from motorid.diagnose.workflow import aligned_record

    rng = np.random.default_rng(3)
    n, fine, rate = 400, 1000, 0.003
    record = pd.DataFrame({"t": np.arange(n) * 0.01, "u": rng.uniform(-12, 12, n), "y": rng.normal(size=n)})
    record["reference"] = np.cumsum(rng.normal(size=n))
    record.attrs["dt"] = 0.01
    drift = DelayDrift("r", np.zeros(3), np.zeros(3), np.ones(3), 0.0, rate * 3.99, True, rate, (0.0, 3.99))
    aligned = aligned_record(record, drift)
    assert list(aligned.columns) == list(record.columns) and aligned.attrs["dt"] == 0.01
    kept = len(aligned)
    assert kept == n  # a growing delay reads older inputs: every sample's span lies inside
    assert np.array_equal(aligned["y"], record["y"]) and np.array_equal(aligned["t"], record["t"])
    for column in ("u", "reference"):
        x = np.repeat(record[column].to_numpy(), fine)
        edges = np.round((1 - rate) * np.arange(kept + 1) * fine).astype(int)
        summed = np.concatenate(([0.0], np.cumsum(x)))
        reference = (summed[edges[1:]] - summed[edges[:-1]]) / np.diff(edges)
        step = np.max(np.abs(np.diff(record[column])))
        assert aligned[column].to_numpy() == pytest.approx(reference, abs=2 * step / fine)
    # a shrinking delay runs the input ahead: the samples whose span passes its end are left out
    shrinking = aligned_record(record, DelayDrift("r", np.zeros(3), np.zeros(3), np.ones(3), 0.01, 0.0, True,
                                                  -rate, (0.0, 3.99)))  # fmt: skip
    assert len(shrinking) == int(n / (1 + rate)) and np.array_equal(
        shrinking["y"], record["y"][: len(shrinking)]
    )
    # no drift, the record itself
    still = aligned_record(record, DelayDrift("r", np.zeros(3), np.zeros(3), np.ones(3), 0.0, 0.0, False, 0.0,
                                              (0.0, 3.99)))  # fmt: skip
    assert np.allclose(still["u"], record["u"], rtol=0, atol=1e-12) and len(still) == n


def test_records_without_a_logging_delay_say_no_drift():
    for seed in range(6):
        d = diagnose(bench("none", None, seed).record)
        assert not d.delay_drift and not any("drifts" in n for n in d.notes)


def test_the_command_line_says_the_drift_and_aligns(capsys, drifting, tmp_path):
    path = tmp_path / "drifting.csv"
    write_record(drifting.record, path)
    code, out, err = run(capsys, "doctor", str(path), "--align", "--json")
    assert code == 0, err
    assert any("the input put on the output's time" in n for n in out["notes"])
    assert out["delay_drift"][0]["drifts"] is True
    assert "the logger's time base drifts" in err


def test_align_keeps_the_records_own_time_where_the_aligned_record_fits_no_better(monkeypatch):
    """A drift said where there is none (here put in the doctor's mouth: 0 to 60 ms on a bench whose
    logger has no delay) is taken out, the aligned record fits worse, and the diagnosis on the
    record's own time is kept, with a note."""
    import motorid.diagnose.workflow as workflow
    from motorid.diagnose.timing import DelayDrift

    b = bench("none", None, 1)
    plain = diagnose(b.record)
    said = DelayDrift(
        "record 1", np.arange(5.0), np.zeros(5), np.ones(5), 0.0, 0.06, True, 0.002, (0.0, 30.0)
    )
    monkeypatch.setattr(workflow, "delay_drift", lambda pool, model: [said])
    kept = diagnose(b.record, align=True)
    assert kept.named == plain.named and kept.model.params == plain.model.params
    assert kept.final_gap == plain.final_gap
    assert kept.notes[-1].startswith("align: the input put on the output's time fits no better")
    assert kept.notes[-1].endswith("the record's own time kept")
