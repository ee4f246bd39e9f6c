"""The doctor's report holds still: ``Diagnosis.to_dict()`` (``motorid doctor --json``) of a few
records against the files in ``tests/data/doctor_golden/`` (``scripts/doctor_golden.py`` says which
records and writes them): every key, name and sentence exactly, every number within
:data:`RELATIVE`.

The tolerance: the fits are least-squares solves and bounded scalar searches in floating point;
another BLAS or CPU sums in another order and moves the last bits (about 1e-13 relative), and a
bounded search stopping on a tolerance carries that to about 1e-9 of its argument. 1e-6 passes
those and fails any change of what is computed: a different row, sample or step moves the
figures by 1e-4 or more. The sentences hold figures to 3-4 significant digits, far above both.
"""

from __future__ import annotations

import importlib.util
import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Relative tolerance of every number (see the module notes).
RELATIVE = 1e-6
#: Absolute tolerance for a number that should be zero (a dropped parameter, a gap of nothing).
ABSOLUTE = 1e-12


def golden_script():
    """scripts/doctor_golden.py, imported from its path (scripts/ is not a package)."""
    spec = importlib.util.spec_from_file_location("doctor_golden", ROOT / "scripts" / "doctor_golden.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


GOLDEN = golden_script()


def differences(expected: Any, actual: Any, where: str = "") -> list[str]:
    """Where ``actual`` differs from ``expected``: keys (and their order), list lengths, strings,
    bools and None exactly, numbers within :data:`RELATIVE` (or :data:`ABSOLUTE`) and of the same
    JSON kind (a count stays an integer)."""
    if isinstance(expected, dict) and isinstance(actual, dict):
        if list(expected) != list(actual):
            return [f"{where}: keys {list(actual)} instead of {list(expected)}"]
        return [d for k in expected for d in differences(expected[k], actual[k], f"{where}.{k}")]
    if isinstance(expected, list) and isinstance(actual, list):
        if len(expected) != len(actual):
            return [f"{where}: {len(actual)} items instead of {len(expected)}"]
        return [
            d
            for k, (e, a) in enumerate(zip(expected, actual, strict=True))
            for d in differences(e, a, f"{where}[{k}]")
        ]
    numbers = (int, float)
    if (
        isinstance(expected, numbers) and isinstance(actual, numbers)
        and not isinstance(expected, bool) and not isinstance(actual, bool)
    ):  # fmt: skip
        if type(expected) is type(actual) and math.isclose(
            expected, actual, rel_tol=RELATIVE, abs_tol=ABSOLUTE
        ):
            return []
        return [f"{where}: {actual!r} instead of {expected!r}"]
    if type(expected) is not type(actual) or expected != actual:
        return [f"{where}: {actual!r} instead of {expected!r}"]
    return []


@pytest.mark.parametrize("case", list(GOLDEN.CASES))
def test_the_doctor_reports_what_it_reported(case):
    why = GOLDEN.missing_data(case)
    if why:
        pytest.skip(why)
    path = GOLDEN.GOLDEN / f"{case}.json"
    regenerate = f"python scripts/doctor_golden.py {case}"
    assert path.is_file(), f"{path} is missing: write it with `{regenerate}`"
    expected = json.loads(path.read_text(encoding="utf-8"))
    found = differences(expected, GOLDEN.report(case))
    assert not found, (
        f"the doctor's report on {case} changed ({len(found)} differences):\n  "
        + "\n  ".join(found[:20])
        + f"\nIf the change is intended, rewrite the file with `{regenerate}` and say why in the commit."
    )


def test_the_comparison_fails_on_a_changed_name_or_number():
    """:func:`differences` itself: a name, a number beyond the tolerance, a key and a length."""
    report = {"steps": [{"effect": "coulomb_friction", "gap": 1.0}], "note": None}
    assert differences(report, json.loads(json.dumps(report))) == []
    assert (
        differences(report, {"steps": [{"effect": "coulomb_friction", "gap": 1.0 + 1e-9}], "note": None})
        == []
    )
    assert differences(report, {"steps": [{"effect": "input_dead_zone", "gap": 1.0}], "note": None})
    assert differences(report, {"steps": [{"effect": "coulomb_friction", "gap": 1.0 + 1e-5}], "note": None})
    assert differences(report, {"steps": [{"effect": "coulomb_friction", "gap": 1}], "note": None})
    assert differences(report, {"note": None, "steps": [{"effect": "coulomb_friction", "gap": 1.0}]})
    assert differences(report, {"steps": [], "note": None})
    assert differences(report, {"steps": [{"effect": "coulomb_friction", "gap": 1.0}], "note": 0.0})
    assert differences(report, {"steps": [{"effect": "coulomb_friction", "gap": 1.0}]})


def sentence_pattern(template: str) -> str:
    """A sentence of :data:`~motorid.diagnose.results.STOP_SENTENCES` as a regular expression:
    its words exactly, each figure any text."""
    parts = re.split(r"\{[^}]*\}", template)
    return ".+?".join(re.escape(p) for p in parts)


def test_every_stop_reason_of_the_golden_records_is_a_sentence_of_the_table():
    """A stop reason is the search's sentence, then the final gap's, both from the one table."""
    from motorid.diagnose.results import STOP_SENTENCES

    finals = ("final_at_floor", "final_missing")
    search = "|".join(sentence_pattern(t) for k, t in STOP_SENTENCES.items() if k not in finals)
    final = "|".join(sentence_pattern(STOP_SENTENCES[k]) for k in finals)
    reasons = [
        json.loads(path.read_text(encoding="utf-8"))["stop_reason"]
        for path in sorted(GOLDEN.GOLDEN.glob("*.json"))
    ]
    assert len(reasons) == len(GOLDEN.CASES)
    for reason in reasons:
        assert re.fullmatch(f"(?:{search}); (?:{final})", reason), reason


def test_a_stop_sentence_names_its_figures():
    from motorid.diagnose.results import Stop

    stop = Stop("no_evidence", {"effect": "quadratic_drag", "delta_bic": 3.14159, "threshold": 10.0})
    assert stop.sentence() == (
        "no candidate passes the evidence threshold: the best, quadratic_drag, has ΔBIC = 3.1 <= 10"
    )
    assert Stop("max_steps", {"max_steps": 2}).sentence() == "max_steps = 2 reached"
