"""The doctor's results are typed: a step's :class:`Evidence` and its ranking of
:class:`CandidateEvidence`, the :class:`Rejected` candidates, the :class:`StructureCandidate` rows
and a joint run's :class:`RecordGap` rows are dataclasses read by attribute; their ``to_dict()`` is
the JSON of ``motorid doctor --json``, held key for key by ``tests/test_doctor_golden.py``.

The tests check a typed part against a figure the doctor computed another way (the stop reason's
sentence, the structure it took, the steps it added), and a rejected candidate's JSON keys in the
order the report has written them."""

from __future__ import annotations

import dataclasses

import pytest
from emps_fixtures import real_motor_file

from motorid.diagnose import diagnose
from motorid.diagnose.results import CandidateEvidence, Evidence, Rejected, StructureCandidate
from motorid.diagnose.synthetic import planted_record
from motorid.io.records import read_record


@pytest.fixture(scope="module")
def staircase():
    """The L298N staircase of ``realmotors/``: candidates rejected at two steps (one judged near
    rest), a search stopped on them, an input lag taken."""
    path = real_motor_file("l298n_staircase.csv")
    if not path.is_file():
        pytest.skip(f"{path} not found: set MOTORID_DATA to the folder holding realmotors/")
    return diagnose(read_record(path), input_unit="V", output_unit="rpm")


def test_the_rejected_candidates_are_those_the_stop_reason_names(staircase):
    d = staircase
    assert d.rejected and all(isinstance(r, Rejected) for r in d.rejected)
    last = [r for r in d.rejected if r.step == len(d.steps) + 1]
    assert [r.step for r in d.rejected] == sorted(r.step for r in d.rejected)
    said = ", ".join(f"{r.effect} ({r.reason})" for r in last)
    assert d.stop_reason.startswith(
        f"no candidate improves held-out data and shrinks the free-run gap beyond the noise: {said}; "
    ), d.stop_reason
    for r in d.rejected:
        assert r.delta_bic > d.settings.threshold  # each passed the evidence, not the checks
        # judged where it acts (near rest): the gaps there and the noise floor there; else none
        acting = (r.acting_gap_before, r.acting_gap_after, r.acting_noise_floor)
        assert (r.judged is None) == (acting == (None, None, None)), r
        assert r.judged is None or r.acting_noise_floor < d.noise_floor
    assert any(r.judged == "near rest" for r in d.rejected)


def test_the_structure_taken_is_the_row_tried_that_shrank_the_gap(staircase):
    s = staircase.structure
    assert s.effects == ("input_lag",)
    assert all(isinstance(c, StructureCandidate) for c in s.candidates)
    assert [c.effects for c in s.candidates] == [
        ("input_delay",),
        ("input_lag",),
        ("input_delay", "input_lag"),
    ]
    (taken,) = [c for c in s.candidates if c.effects == s.effects]
    assert taken.params == s.params and taken.gap == s.gap_after < s.gap_before
    assert taken.delta_bic > staircase.settings.threshold


@pytest.mark.parametrize("effect", ["coulomb_friction", "static_friction"])
def test_a_steps_evidence_is_its_candidates_row_of_the_ranking(effect):
    planted = planted_record(effect, seed=3)
    d = diagnose(planted.record, input_gain=planted.input_gain, base=planted.base)
    assert d.named[-1:] == [effect], d.named
    for step in d.steps:
        ev = step.evidence
        assert isinstance(ev, Evidence) and all(isinstance(r, CandidateEvidence) for r in ev.ranking)
        assert ev.candidate.effect == step.effect and any(r is ev.candidate for r in ev.ranking)
        assert [r.delta_bic for r in ev.ranking] == sorted((r.delta_bic for r in ev.ranking), reverse=True)
        assert ev.chosen_by == "evidence" and ev.ranking[0] is ev.candidate
        assert ev.delta_bic > ev.threshold and ev.held_out_error_after < ev.held_out_error_before
        assert ev.noise_floor == d.noise_floor
    static = next(r for r in d.steps[-1].evidence.ranking if r.effect == "static_friction")
    assert static.measure is not None  # judged on the rests, or on the free run with too few
    assert (static.breakaway is None) == static.measure.startswith("free run")
    # the table of the steps reads the same evidence
    assert list(d.table()["delta_bic"]) == [s.evidence.delta_bic for s in d.steps]


def test_a_rejected_candidate_writes_the_keys_of_the_report_in_their_order():
    """The JSON of ``rejected`` as ``motorid doctor --json`` has written it (the golden files of the
    L298N staircase and of EMPS hold both forms, where their data are present): the figures where
    it acts only when judged there, the held-out position errors only on a position record, the
    reason last."""
    common = ["step", "effect", "delta_bic", "held_out_error_before", "held_out_error_after", "gap_before",
              "gap_after", "gap_shrink_noise_floors", "explained_noise_floors"]  # fmt: skip
    near_rest = Rejected(
        step=1, effect="stribeck_friction", reason="held-out error 219.4 vs 87.3 rad/s/s", delta_bic=78.7,
        held_out_error_before=87.3, held_out_error_after=219.4, gap_before=3.10, gap_after=0.958,
        gap_shrink_noise_floors=1370.0, explained_noise_floors=1410.2, judged="near rest",
        acting_gap_before=3.51, acting_gap_after=0.101, acting_noise_floor=0.00248,
    )  # fmt: skip
    assert list(near_rest.to_dict()) == [
        *common,
        "judged",
        "acting_gap_before",
        "acting_gap_after",
        "acting_noise_floor",
        "reason",
    ]
    in_position = dataclasses.replace(
        near_rest, judged=None, acting_gap_before=None, acting_gap_after=None, acting_noise_floor=None,
        held_out_position_error_before=6.45e-3, held_out_position_error_after=6.51e-3,
    )  # fmt: skip
    assert list(in_position.to_dict()) == [
        *common,
        "held_out_position_error_before",
        "held_out_position_error_after",
        "reason",
    ]
    assert in_position.to_dict()["reason"] == near_rest.reason
