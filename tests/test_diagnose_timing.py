"""A logger's time base (issue 31): the input delay's search reaches a logger's delays and says
when it hits its end; a delay that drifts along the record is measured per segment and said, and
``align`` puts the output back on the input's time. Benches of :mod:`motorid.diagnose.bench`."""

from __future__ import annotations

import numpy as np
import pytest
from cli_fixtures import run

from motorid.diagnose import diagnose
from motorid.diagnose.bench import bench, delay_error_samples
from motorid.diagnose.model import DELAY_LONGEST, DELAY_SAMPLES, delay_reach
from motorid.io.records import write_record


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
    # each segment's delay is fitted within about a sample; the line through five of them
    # within two samples at its ends
    assert drift.first == pytest.approx(first, abs=2 * dt) and drift.last == pytest.approx(last, abs=2 * dt)
    assert np.all(np.diff(drift.delays) > 0)
    said = f"the input delay grows from {1e3 * drift.first:.3g} to {1e3 * drift.last:.3g} ms over the record"
    assert any(n.startswith(said) and n.endswith("the logger's time base drifts, and one delay fits neither end")
               for n in d.notes)  # fmt: skip
    assert np.all(drift.delay_std < 2 * dt)  # each segment's delay determined within two samples
    assert d.to_dict()["delay_drift"][0]["drifts"] is True


def test_align_puts_the_output_back_on_the_inputs_time(drifting):
    plain = diagnose(drifting.record)
    aligned = diagnose(drifting.record, align=True)
    # one delay for the whole record leaves 18 noise floors; aligned, the gap is near the floor
    assert plain.final_gap.overall > 10 * plain.noise_floor
    assert aligned.final_gap.overall < 4 * aligned.noise_floor
    assert aligned.named == ["coulomb_friction"]
    # the delay at the start is left for the structure search: within a sample of the truth
    assert delay_error_samples(aligned.model.params["input_delay"], drifting) > 1.0  # the mean delay...
    start = drifting.logging_delay[0]
    assert (
        abs(aligned.model.params["input_delay"] - start) <= drifting.record.attrs["dt"]
    )  # ...but the start's
    assert any("put back on the input's time (align)" in n for n in aligned.notes)


def test_records_without_a_logging_delay_say_no_drift():
    for seed in range(6):
        d = diagnose(bench("none", None, seed).record)
        assert not d.delay_drift and not any("drifts" in n for n in d.notes)


def test_the_command_line_says_the_drift_and_aligns(capsys, drifting, tmp_path):
    path = tmp_path / "drifting.csv"
    write_record(drifting.record, path)
    code, out, err = run(capsys, "doctor", str(path), "--align", "--json")
    assert code == 0, err
    assert any("put back on the input's time" in n for n in out["notes"])
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
    said = DelayDrift("record 1", np.arange(5.0), np.zeros(5), np.ones(5), 0.0, 0.06, True)
    monkeypatch.setattr(workflow, "delay_drift", lambda pool, model: [said])
    kept = diagnose(b.record, align=True)
    assert kept.named == plain.named and kept.model.params == plain.model.params
    assert kept.final_gap == plain.final_gap
    assert kept.notes[-1].startswith("align: the output put back on the input's time fits no better")
    assert kept.notes[-1].endswith("the record's own time kept")
