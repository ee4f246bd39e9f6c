"""``--start``/``--stop`` on every command that reads a record: the command on the span equals the
command on a file that holds only that span's samples (cut with pandas here, independently).

The refusals (a span beyond the record, ``--stop`` not after ``--start``) are rows of
tests/test_cli_bad_input.py; ``fleet`` with a span is in tests/test_fleet_per_drive.py; the
doctor's own in tests/test_diagnose_artefacts.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from motorid.cli import main
from motorid.drive import paper_rig
from motorid.io.records import read_record, trim_record
from motorid.signals import two_sine_signal

START, STOP = 4.0, 12.0


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> tuple[Path, Path, Path]:
    """A 20 s record (dt 0.04 s), the same samples with START <= t <= STOP, and a drive model."""
    root = tmp_path_factory.mktemp("span")
    _, u = two_sine_signal(duration=20.0, seed=5)
    record = paper_rig().simulate(u, seed=5)[["t", "u", "y"]]
    record.to_csv(root / "whole.csv", index=False)
    span = record[(record["t"] >= START) & (record["t"] <= STOP)]
    span.to_csv(root / "span.csv", index=False)
    paper_rig().save(root / "rig.json")
    return root / "whole.csv", root / "span.csv", root / "rig.json"


def output(capsys, argv: list[str]) -> dict:
    assert main([*argv, "--json"]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


COMMANDS = {
    "identify": ["identify", "{record}", "--na", "2", "--nb", "2"],
    "sweep": ["sweep", "{record}", "--orders", "1-2", "--degrees", "2-3"],
    "compare": ["compare", "{record}", "--model", "{model}"],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_command_on_a_span_equals_it_on_the_span_cut_out(capsys, files, command):
    whole, span, model = files

    def argv(record: Path) -> list[str]:
        return [a.format(record=record, model=model) for a in COMMANDS[command]]

    trimmed = output(capsys, [*argv(whole), "--start", str(START), "--stop", str(STOP)])
    cut = output(capsys, argv(span))
    trimmed.pop("record", None), cut.pop("record", None)
    # the same samples through the same code: equal to the last bit
    assert trimmed == cut
    if command == "identify":
        assert trimmed["samples"] == 201  # t = 4.00, 4.04, ..., 12.00 s


def test_the_first_sample_after_the_trim_is_the_first_at_or_after_start(files):
    whole, _, _ = files
    record = read_record(whole)
    trimmed = trim_record(record, START, STOP, whole)
    first = int(np.argmax(record["t"].to_numpy() >= START))
    assert trimmed["t"].iloc[0] == record["t"].iloc[first] == pytest.approx(START)
    assert trimmed["u"].iloc[0] == record["u"].iloc[first]
    assert trimmed["t"].iloc[-1] <= STOP < trimmed["t"].iloc[-1] + record.attrs["dt"]
    assert trimmed.attrs == record.attrs
    # only --stop: from the record's first sample
    assert trim_record(record, None, STOP, whole)["t"].iloc[0] == 0.0
