"""Bad input on the command line: one line naming what is wrong and where, exit 2, nothing on disk changed.

One table: each row is a command a user might type, the words its error must
contain, and the check that no traceback is shown and that every file in the
folder is byte for byte what it was. A last pair of tests tells user errors
(exit 2) from motorid's own bugs (exit 1, the traceback only with -v).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from motorid.cli import main
from motorid.plants import paper_rig
from motorid.plants.signals import two_sine_signal
from motorid.records import write_record


def _write_csv(path: Path, df: pd.DataFrame) -> None:
    df.to_csv(path, index=False)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """A folder of good and bad records, made from one simulated record of 20 s."""
    root = tmp_path_factory.mktemp("bad_input")
    _, u = two_sine_signal(duration=20.0, seed=3)
    record = paper_rig().simulate(u, seed=3)
    write_record(record, root / "rec.csv")
    plain = record[["t", "u", "y"]].copy()
    _write_csv(root / "good.csv", plain)
    (root / "empty.csv").write_bytes(b"")
    (root / "header_only.csv").write_text("t,u,y\n")
    (root / "folder.csv").mkdir()
    text = plain.astype(object)
    text.loc[123, "y"] = "fast"
    _write_csv(root / "text_in_y.csv", text)
    nan = plain.copy()
    nan.loc[321, "u"] = np.nan
    _write_csv(root / "nan_in_u.csv", nan)
    backwards = plain.copy()
    backwards.loc[200, "t"] = backwards.loc[198, "t"]
    _write_csv(root / "backwards.csv", backwards)
    gap = plain.drop(index=range(300, 303)).reset_index(drop=True)
    _write_csv(root / "gap.csv", gap)
    _write_csv(root / "one_row.csv", plain.iloc[:1])
    zero = plain.copy()
    zero["u"] = 0.0
    _write_csv(root / "zero_input.csv", zero)
    huge_y = plain.copy()
    huge_y.loc[250, "y"] = 1e300
    _write_csv(root / "huge_y.csv", huge_y)
    huge_u = plain.copy()
    huge_u.loc[250, "u"] = 1e300
    _write_csv(root / "huge_u.csv", huge_u)
    (root / "existing.csv").write_text("keep me\n")
    return root


def _snapshot(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        for p in sorted(root.rglob("*"))
    }


def _run(capsys, argv: list[str]) -> tuple[int, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out + captured.err


# (case, argv with {d} for the folder, words the message must hold)
BAD_INPUT = [
    ("missing file", "identify {d}/missing.csv", ["missing.csv"]),
    ("folder as file", "identify {d}/folder.csv", ["folder.csv", "folder"]),
    ("empty file", "identify {d}/empty.csv", ["empty.csv", "empty"]),
    ("header only", "identify {d}/header_only.csv", ["header_only.csv", "no data"]),
    ("text in a column", "identify {d}/text_in_y.csv", ["'y'", "'fast'", "row 123"]),
    ("NaN in a column", "sweep {d}/nan_in_u.csv --orders 2", ["'u'", "row 321"]),
    ("missing column", "identify {d}/good.csv --output speed", ["'speed'", "'t', 'u', 'y'"]),
    ("time goes backwards", "identify {d}/backwards.csv", ["'t'", "row 200"]),
    ("time has a gap", "identify {d}/gap.csv", ["'t'", "gap", "row 300"]),
    ("single row", "identify {d}/one_row.csv", ["one_row.csv", "1 sample"]),
    ("doctor on a single row", "doctor {d}/one_row.csv", ["one_row.csv", "1 sample"]),
    ("--dt 0", "identify {d}/good.csv --dt 0", ["--dt", "got 0"]),
    ("--dt negative", "doctor {d}/good.csv --dt -0.04", ["--dt", "got -0.04"]),
    ("--duration 0", "simulate --out {d}/new.csv --duration 0", ["--duration", "got 0"]),
    ("--duration negative", "run --estimator arx-rls --duration -1 --out {d}/new.csv", ["--duration"]),
    ("--nb 0 for Hammerstein", "identify {d}/good.csv --nb 0", ["hammerstein-rls", "nb must be >= 1"]),
    ("--na negative", "identify {d}/good.csv --na -1", ["--na", "got -1"]),
    ("--lam 0", "identify {d}/good.csv --lam 0", ["--lam", "got 0"]),
    ("--lam above 1", "sweep {d}/good.csv --lam 1.5", ["--lam", "got 1.5"]),
    ("unknown estimator", "identify {d}/good.csv --estimator nope", ["'nope'", "arx-rls", "hammerstein-rls"]),
    ("option the estimator lacks", "identify {d}/good.csv --estimator arx-rls --degree 3", ["--degree"]),
    (
        "unknown effect",
        "doctor {d}/good.csv --base viscous,offset",
        ["--base", "'viscous'", "viscous_friction"],
    ),
    ("unknown candidate", "doctor {d}/good.csv --candidates friction", ["--candidates", "coulomb_friction"]),
    ("--out folder missing", "simulate --out {d}/no/such/folder/rec.csv", ["--out", "does not exist"]),
    ("--out is a folder", "simulate --out {d}/folder.csv", ["--out", "folder"]),
    ("--out exists", "simulate --out {d}/existing.csv", ["--out", "exists", "--overwrite"]),
    (
        "run --out exists",
        "run --estimator arx-rls --duration 1 --out {d}/existing.csv",
        ["exists", "--overwrite"],
    ),
    ("doctor --out is a file", "doctor {d}/good.csv --out {d}/existing.csv", ["--out", "is a file"]),
    ("empty order range", "sweep {d}/good.csv --orders 6-1", ["--orders", "empty"]),
    ("negative Coulomb", "simulate --out {d}/new.csv --coulomb-motor -1", ["--coulomb-motor", "got -1"]),
    ("port out of range", "rig serve --port 99999", ["--port", "99999"]),
    (
        "--plant-seed on Modbus",
        "run --daq modbus://127.0.0.1:9 --estimator arx-rls --duration 1 --out {d}/new.csv --plant-seed 3",
        ["--plant-seed", "sim"],
    ),
    ("input all zero, identify", "identify {d}/zero_input.csv", ["'u'", "constant"]),
    ("input all zero, doctor", "doctor {d}/zero_input.csv", ["'u'", "constant"]),
    ("1e300 in y, identify", "identify {d}/huge_y.csv", ["'y'", "250"]),
    ("1e300 in y, sweep", "sweep {d}/huge_y.csv --orders 1-2 --degrees 2", ["'y'", "250"]),
    ("1e300 in y, doctor", "doctor {d}/huge_y.csv", ["'y'", "250"]),
    ("1e300 in u, doctor", "doctor {d}/huge_u.csv", ["'u'", "250"]),
    ("time column as output", "doctor {d}/good.csv --output t", ["'t'"]),
    ("unknown output unit", "identify {d}/good.csv --output-unit rpms", ["--output-unit", "'rpms'", "rpm"]),
    ("supply voltage without duty", "identify {d}/good.csv --supply-voltage 12", ["--supply-voltage", "%"]),
]


@pytest.mark.parametrize(("case", "command", "words"), BAD_INPUT, ids=[row[0] for row in BAD_INPUT])
def test_bad_input_exits_2_with_one_line_naming_it(capsys, folder, case, command, words):
    before = _snapshot(folder)
    argv = [part.replace("{d}", str(folder)) for part in command.split()]
    code, text = _run(capsys, argv)
    lines = [line for line in text.splitlines() if line.strip()]
    assert code == 2, f"{case}: exit {code}\n{text}"
    assert "Traceback" not in text and len(lines) == 1, f"{case}: not one line:\n{text}"
    missing = [w for w in words if w not in lines[0]]
    assert not missing, f"{case}: {missing} not in {lines[0]!r}"
    assert _snapshot(folder) == before, f"{case}: the folder changed"


def test_a_bug_in_motorid_is_not_reported_as_a_user_error(capsys, folder, monkeypatch):
    import motorid.validation

    def broken(*args, **kwargs):
        raise ValueError("operands could not be broadcast together with shapes (3,) (4,)")

    monkeypatch.setattr(motorid.validation, "residual_tests", broken)
    argv = ["identify", str(folder / "good.csv"), "--estimator", "arx-rls"]
    code, text = _run(capsys, argv)
    assert code == 1
    assert "bug in motorid" in text and "-v" in text and "Traceback" not in text
    code, text = _run(capsys, ["-v", *argv])
    assert code == 1 and "Traceback" in text and "broadcast" in text


def test_a_good_record_still_identifies(capsys, folder):
    code, text = _run(capsys, ["identify", str(folder / "good.csv"), "--estimator", "arx-rls"])
    assert code == 0, text
    assert "FIT" in text


def test_rig_serve_on_a_port_in_use_names_it(capsys):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, text = _run(capsys, ["rig", "serve", "--port", str(port)])
    lines = [line for line in text.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1, text
    assert f"--port {port}" in lines[0] and "in use" in lines[0]
