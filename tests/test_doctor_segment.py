"""``motorid doctor`` on a record longer than ``--max-samples``: it works on the record's first
``--max-samples`` samples (a segment, read in blocks so that no more is held) and says so.

The reference is the doctor on a file that holds exactly those samples: the same diagnosis,
number for number.
"""

from __future__ import annotations

import pytest
from cli_fixtures import run

from motorid.diagnose.synthetic import planted_record
from motorid.io.records import read_record, write_record


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """A record with a planted Coulomb friction, and a file of its first 1500 samples."""
    planted = planted_record("coulomb_friction", 7, sizes={"coulomb": 8e-3})
    folder = tmp_path_factory.mktemp("segment")
    write_record(planted.record, folder / "long.csv")
    head = planted.record.iloc[:1500].copy()
    head.attrs = dict(planted.record.attrs)
    write_record(head, folder / "head.csv")
    return folder / "long.csv", folder / "head.csv"


def test_the_doctor_on_a_long_record_works_on_its_first_max_samples_and_says_so(capsys, records):
    long, head = records
    assert len(read_record(long)) > 1500
    code, out, err = run(capsys, "doctor", str(long), "--max-samples", "1500", "--max-steps", "1", "--json")
    assert code == 0, err
    assert out["segment"] is True
    assert (
        f"a segment: {long} is longer than --max-samples; the doctor works on its first 1500 samples" in err
    )
    code, reference, err = run(
        capsys, "doctor", str(head), "--max-samples", "1500", "--max-steps", "1", "--json"
    )
    assert code == 0 and reference["segment"] is False and "a segment" not in err
    # the same figures: the record's own name (in rests) aside
    for run_ in (out, reference):
        run_["segment"] = None
        for rests in run_.get("rests", []):
            rests["record"] = None
    assert out == reference


def test_a_bad_row_after_the_segment_does_not_stop_the_doctor(capsys, records, tmp_path):
    long, _ = records
    text = long.read_text().splitlines()
    text[2 + 1700] = "0.0,nan,nan"  # data row 1700 (after the attribute line and the header)
    bad = tmp_path / "bad_after.csv"
    bad.write_text("\n".join(text) + "\n")
    code, out, err = run(capsys, "doctor", str(bad), "--max-samples", "1500", "--max-steps", "1", "--json")
    assert code == 0, err
    assert out["segment"] is True
    code, _, err = run(capsys, "doctor", str(bad), "--max-samples", "1800", "--max-steps", "1")
    assert code == 2 and "at row 1700" in err
