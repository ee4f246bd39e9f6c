"""Bad input on the command line: one line naming what is wrong and where, exit 2, nothing on disk changed.

One table: each row is a command a user might type, the words its error must
contain, and the check that no traceback is shown and that every file in the
folder is byte for byte what it was. A last pair of tests tells user errors
(exit 2) from motorid's own bugs (exit 1, the traceback only with -v).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from motorid.cli import main
from motorid.drive import RigidDrive, paper_rig
from motorid.estimators import create
from motorid.io.records import write_record
from motorid.signals import two_sine_signal


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
    _write_csv(root / "short.csv", plain.iloc[:30])
    paper_rig().save(root / "rig.json")
    RigidDrive(effects=("coulomb_friction",), params={"inertia": 2e-4, "input_gain": 0.02, "coulomb": 0.004},
               dt=0.04).save(root / "rigid.json")  # fmt: skip
    create("arx-rls", na=2, nb=2).save(root / "arx.json")
    create("friction-ekf").save(root / "ekf.json")
    (root / "spaceship.json").write_text(
        '{"format": "motorid-model", "version": 1, "kind": "spaceship", "model": {}}'
    )
    # as loggers write them: millis() stamps, ';' with decimal commas, ':' (no separator known), counts
    ms = pd.DataFrame({"time_ms": 1000 + np.arange(len(plain)) * 40, "pwm": plain["u"], "rpm": plain["y"]})
    _write_csv(root / "ms.csv", ms)
    plain.rename(columns={"t": "zeit"}).to_csv(root / "semicolon.csv", sep=";", decimal=",", index=False)
    plain.to_csv(root / "colon.csv", sep=":", index=False)
    counts = plain.copy()
    counts["u"] = np.round(counts["u"] * 40)  # beyond ±100 where |u| > 2.5 V
    _write_csv(root / "counts.csv", counts)
    lines = (root / "good.csv").read_text().splitlines()
    lines[6] += ",1.5"
    (root / "extra_field.csv").write_text("\n".join(lines) + "\n")
    (root / "bad_map.toml").write_text("[[[\n")
    if hasattr(os, "mkfifo"):
        os.mkfifo(root / "fifo.csv")
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
    ("duty into a model in volts", "compare {d}/rec.csv --model {d}/rig.json --input-unit %",
     ["the model's input is the amplifier's command in V, the record's is in %", "(--supply-voltage)"]),
    ("compare: missing model file", "compare {d}/rec.csv --model {d}/missing.json", ["missing.json"]),
    (
        "compare: unknown model kind",
        "compare {d}/rec.csv --model {d}/spaceship.json",
        ["kind", "'spaceship'"],
    ),
    (
        "compare: not a model file",
        "compare {d}/rec.csv --model {d}/good.csv",
        ["good.csv", "not a model file"],
    ),
    ("compare: too few samples", "compare {d}/short.csv --model {d}/rig.json", ["short.csv", "30 samples"]),
    ("compare: no model", "compare {d}/rec.csv", ["--model"]),
    (
        "compare: duty to a rig in volts",
        "compare {d}/good.csv --input-unit % --model {d}/rig.json",
        ["rig.json", "%", "--supply-voltage"],
    ),
    (
        "compare: a friction filter on a record longer than --max-samples",
        "compare {d}/rec.csv --model {d}/ekf.json --max-samples 100",
        ["rec.csv", "--max-samples 100", "ekf.json", "takes the record whole"],
    ),
    (
        "compare: positions longer than --max-samples",
        "compare {d}/good.csv --output-unit deg --model {d}/rigid.json --max-samples 100",
        ["good.csv", "--max-samples 100", "positions"],
    ),
    ("identify --validate missing", "identify {d}/rec.csv --validate {d}/missing.csv", ["missing.csv"]),
    (
        "friction filter without a model",
        "identify {d}/good.csv --estimator friction-ekf",
        ["good.csv", "--model"],
    ),
    (
        "--model for an estimator without one",
        "identify {d}/rec.csv --estimator arx-rls --model {d}/rig.json",
        ["--model", "'arx-rls'"],
    ),
    (
        "rigid drive without R",
        "identify {d}/good.csv --estimator friction-ekf --model {d}/rigid.json",
        ["rigid.json", "--param R="],
    ),
    (
        "identify --model of an unknown kind",
        "identify {d}/good.csv --estimator friction-ukf --model {d}/spaceship.json",
        ["spaceship"],
    ),
    (
        "fleet identify --model missing",
        "fleet identify {d} --out {d}/fleet --estimator friction-ekf --model {d}/missing.json",
        ["missing.json"],
    ),
    (
        "friction filter on a position record",
        "identify {d}/good.csv --output-unit deg --estimator friction-ekf --model {d}/rigid.json --param R=1",
        ["rigid.json", "position"],
    ),
    (
        "identify --model an estimator file",
        "identify {d}/good.csv --estimator friction-ekf --model {d}/arx.json",
        ["arx.json", "ARXRLS", "not a drive model"],
    ),
    ("time in ms read as s", "identify {d}/ms.csv --time time_ms --input pwm --output rpm",
     ["'time_ms'", "40 s", "--time-unit"]),
    ("wrong --time-unit", "doctor {d}/ms.csv --time time_ms --time-unit ns --input pwm --output rpm",
     ["'time_ms'", "4e-08 s", "--time-unit"]),
    ("--time-unit unknown", "identify {d}/ms.csv --time time_ms --time-unit min", ["--time-unit", "'min'"]),
    ("--dt contradicts the time column", "identify {d}/good.csv --dt 0.02",
     ["dt = 20 ms (--dt)", "contradicts", "'t'", "40 ms"]),
    ("--dt contradicts millis()", "sweep {d}/ms.csv --time time_ms --time-unit ms --input pwm --output rpm --dt 0.01",
     ["--dt", "'time_ms'", "40 ms"]),
    ("wrong --sep", "identify {d}/semicolon.csv --time zeit --sep ,", ["'zeit'", "one column", "--sep"]),
    ("no separator known", "identify {d}/colon.csv", ["colon.csv", "one column", "--sep"]),
    ("--sep of two characters", "identify {d}/good.csv --sep ;;", ["--sep", "';;'"]),
    ("--sep as --decimal", "identify {d}/semicolon.csv --time zeit --sep , --decimal ,", ["--sep", "--decimal"]),
    ("decimal comma read with '.'", "identify {d}/semicolon.csv --time zeit --decimal .",
     ["'zeit'", "row 0", "--decimal ,"]),
    ("duty beyond 100 %", "identify {d}/counts.csv --input-unit %", ["'u'", "row", "100 %", "--input-unit counts"]),
    ("counts without a full scale", "identify {d}/counts.csv --input-unit counts", ["--input-full-scale"]),
    ("counts beyond the full scale", "doctor {d}/counts.csv --input-unit counts --input-full-scale 100",
     ["'u'", "row", "100 counts"]),
    ("full scale without counts", "identify {d}/good.csv --input-full-scale 255", ["--input-full-scale", "counts"]),
    ("a row with an extra field", "identify {d}/extra_field.csv", ["row 5", "line 7", "4 fields", "3"]),
    ("a FIFO named like a record", "identify {d}/fifo.csv", ["fifo.csv", "FIFO"]),
    # the messages speak of the command's options, never of Python calls (ARXRLS.__init__(), ValueError)
    ("--param the estimator does not take", "run --estimator arx-rls --duration 1 --out {d}/new.csv -p foo=1",
     ["--param foo=1", "'arx-rls' takes no argument 'foo'", "it takes na, nb"]),
    ("--param the filter does not take", "identify {d}/good.csv --estimator friction-ekf --model {d}/rig.json -p Q=1",
     ["--param Q=1", "takes no argument 'Q'", "coulomb0"]),
    ("--daq of no known kind", "run --estimator arx-rls --duration 1 --out {d}/new.csv --daq bogus://x",
     ["--daq bogus://x: expected 'sim'", "modbus://HOST:PORT"]),
    ("--daq with an unknown query", "run --estimator arx-rls --duration 1 --out {d}/new.csv --daq modbus://127.0.0.1:9?foo=2",
     ["--daq 'modbus://127.0.0.1:9?foo=2': unknown query parameter"]),
    ("--map that is no TOML", "run --estimator arx-rls --duration 1 --out {d}/new.csv --daq modbus://127.0.0.1:9 "
     "--map {d}/bad_map.toml", ["--map", "bad_map.toml", "not valid TOML"]),
    ("rig map --map that is no TOML", "rig map --map {d}/bad_map.toml", ["--map", "bad_map.toml", "not valid TOML"]),
    ("--map with the simulated rig", "run --estimator arx-rls --duration 1 --out {d}/new.csv --map {d}/bad_map.toml",
     ["--map", "Modbus --daq only", "--daq sim"]),
    ("--dt the simulated rig cannot take", "run --estimator arx-rls --duration 1 --out {d}/new.csv --dt 1e-9",
     ["--dt 1e-09", "whole multiple", "0.04 s"]),
    ("compare --skip beyond the record", "compare {d}/rec.csv --model {d}/rig.json --skip 100000",
     ["rec.csv", "500 samples", "at least 100"]),
    ("fleet trend on no folder", "fleet trend {d}/nowhere", ["nowhere", "no such folder"]),
    # a model file goes through the checks of every small file a command reads: refused before it is read
    ("simulate --model a FIFO", "simulate --out {d}/new.csv --model {d}/fifo.csv",
     ["model file", "fifo.csv", "is a FIFO, not a regular file"]),
    ("simulate --model /dev/zero", "simulate --out {d}/new.csv --model /dev/zero",
     ["model file /dev/zero", "is a device or socket, not a regular file"]),
    ("compare --model a FIFO", "compare {d}/rec.csv --model {d}/fifo.csv", ["fifo.csv", "is a FIFO"]),
    ("identify --model /dev/zero", "identify {d}/good.csv --estimator friction-ekf --model /dev/zero",
     ["model file /dev/zero", "not a regular file"]),
    ("doctor --model a FIFO", "doctor {d}/good.csv --model {d}/fifo.csv", ["fifo.csv", "is a FIFO"]),
    ("control --design /dev/zero", "control --design /dev/zero", ["model file /dev/zero", "not a regular file"]),
    ("fleet doctor --model /dev/zero", "fleet doctor {d}/good.csv --out {d}/fleet --model /dev/zero",
     ["/dev/zero", "not a regular file"]),
    ("--start beyond the end, identify", "identify {d}/good.csv --start 500",
     ["good.csv", "no sample within --start 500 s", "from 0 to 19.96 s"]),
    ("--start beyond the end, sweep", "sweep {d}/good.csv --start 20", ["good.csv", "--start 20 s", "19.96 s"]),
    ("--start beyond the end, compare", "compare {d}/good.csv --model {d}/rig.json --start 19.9",
     ["good.csv", "only 2 samples", "--start 19.9 s"]),
    ("--stop before --start, identify", "identify {d}/good.csv --start 5 --stop 4", ["--stop 4", "--start 5"]),
    ("--stop at --start, sweep", "sweep {d}/good.csv --start 3 --stop 3", ["--stop 3", "--start 3"]),
    ("--stop before --start, compare", "compare {d}/good.csv --model {d}/rig.json --start 5 --stop 1",
     ["--stop 1", "--start 5"]),
    ("--stop before --start, fleet", "fleet identify {d}/good.csv --out {d}/fleet --start 5 --stop 4",
     ["--stop 4", "--start 5"]),
    ("--stop 0", "identify {d}/good.csv --stop 0", ["--stop", "got 0"]),
    ("--start negative", "compare {d}/good.csv --model {d}/rig.json --start -2", ["--start", "got -2"]),
    ("identify --validate beyond --stop", "identify {d}/good.csv --validate {d}/short.csv --start 2",
     ["short.csv", "--start 2 s", "1.16 s"]),
]  # fmt: skip


@pytest.mark.parametrize(("case", "command", "words"), BAD_INPUT, ids=[row[0] for row in BAD_INPUT])
def test_bad_input_exits_2_with_one_line_naming_it(capsys, folder, case, command, words):
    if "fifo" in command and not (folder / "fifo.csv").exists():
        pytest.skip("this system has no FIFOs")
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


# --------------------------------------------------------------------------- hostile files
def _model_file(path: Path, make, *keys_and_value) -> None:
    """Write the model file of ``make()`` with the value at ``keys`` replaced (JSON text for a raw token)."""
    import json

    from motorid.drive.files import model_to_dict

    data = model_to_dict(make())
    *keys, value = keys_and_value
    node = data
    for key in keys[:-1]:
        node = node[key]
    node[keys[-1]] = "@@"
    text = json.dumps(data).replace('"@@"', value if isinstance(value, str) else json.dumps(value))
    path.write_text(text)


@pytest.fixture(scope="module")
def hostile(tmp_path_factory) -> Path:
    """Model files and records whose values are out of any range, mistyped, nested or huge."""
    import json

    import h5py
    import pyarrow as pa
    import pyarrow.parquet as pq

    from motorid.drive import RigidDrive
    from motorid.estimators import FrictionEKF, create
    from motorid.io.records import ATTRS_KEY, ATTRS_MARKER

    root = tmp_path_factory.mktemp("hostile")
    rigid = lambda: RigidDrive(("viscous_friction", "coulomb_friction"), {"inertia": 2e-3, "input_gain": 0.05, "viscous": 1e-3, "coulomb": 0.02}, dt=0.01)  # noqa: E731  # fmt: skip
    ekf = lambda: FrictionEKF(nis_window=5)  # noqa: E731
    arx = lambda: create("arx-rls", na=2, nb=1)  # noqa: E731
    _model_file(root / "nis_window.json", ekf, "model", "settings", "nis_window", 10**9)
    _model_file(root / "deep.json", rigid, "model", "params", "[" * 100_000 + "]" * 100_000)
    _model_file(root / "big_int.json", paper_rig, "model", "J_m", str(10**400))
    _model_file(root / "dt_1e308.json", paper_rig, "model", "dt", 1e308)
    _model_file(root / "viscous_1e308.json", rigid, "model", "params", "viscous", 1e308)
    _model_file(root / "noise_1e308.json", ekf, "model", "settings", "speed_noise", 1e308)
    _model_file(root / "sample_index.json", arx, "model", "state", "sample_index", str(10**400))
    _model_file(root / "not_symmetric.json", arx, "model", "state", "P", 0, 1, 1.0)
    _model_file(root / "negative_P.json", arx, "model", "state", "P", json.dumps((-np.eye(4)).tolist()))
    _model_file(root / "huge_P.json", arx, "model", "state", "P", json.dumps((1e300 * np.eye(4)).tolist()))

    _, u = two_sine_signal(duration=4.0, seed=3)
    plain = paper_rig().simulate(u, seed=3)[["t", "u", "y"]]
    body = plain.to_csv(index=False)
    (root / "good.csv").write_text(body)
    for name, attrs in [
        ("dt_text.csv", '{"dt": "abc"}'),
        ("units_list.csv", '{"dt": 0.04, "units": [1]}'),
        ("furlongs.csv", '{"dt": 0.04, "units": {"t": "s", "u": "V", "y": "furlongs"}}'),
        ("deep_attrs.csv", '{"note": ' + "[" * 100_000 + "]" * 100_000 + "}"),
        ("big_seed.csv", '{"dt": 0.04, "seed": ' + "9" * 400 + "}"),
    ]:
        (root / name).write_text(ATTRS_MARKER + attrs + "\n" + body)
    table = pa.table({c: plain[c].to_numpy() for c in plain.columns})
    pq.write_table(
        table.replace_schema_metadata({ATTRS_KEY: json.dumps({"dt": [1, 2]})}), root / "dt_list.parquet"
    )
    with h5py.File(root / "flipped.h5", "w") as fh:
        for c in plain.columns:
            fh[c] = plain[c].to_numpy()
    raw = bytearray((root / "flipped.h5").read_bytes())
    for i in np.random.default_rng(1).integers(200, len(raw), 200):  # past the superblock: it opens
        raw[i] ^= 0xFF
    (root / "flipped.h5").write_bytes(bytes(raw))
    return root


# (case, argv with {d} for the folder, words the one line must hold)
HOSTILE_FILES = [
    ("NIS window of 1e9", "simulate --model {d}/nis_window.json --out {d}/new.csv", ["nis_window.json", "nis_window", "100000"]),
    ("model nested 100,000 deep", "doctor {d}/good.csv --model {d}/deep.json", ["deep.json", "nested deeper than 32"]),
    ("10**400 in a model", "simulate --model {d}/big_int.json --out {d}/new.csv", ["big_int.json", "model.J_m", "401 digits"]),
    ("dt = 1e308", "simulate --model {d}/dt_1e308.json --out {d}/new.csv", ["dt_1e308.json", "dt must be within", "3600"]),
    ("viscous = 1e308", "simulate --model {d}/viscous_1e308.json --out {d}/new.csv", ["viscous_1e308.json", "model.params.viscous", "1e+12"]),
    ("filter noise 1e308", "simulate --model {d}/noise_1e308.json --out {d}/new.csv", ["noise_1e308.json", "speed_noise", "1e+12"]),
    ("sample index 10**400", "simulate --model {d}/sample_index.json --out {d}/new.csv", ["sample_index.json", "model.state.sample_index"]),
    ("P not symmetric", "simulate --model {d}/not_symmetric.json --out {d}/new.csv", ["not_symmetric.json", "model.state.P", "symmetric"]),
    ("P negative definite", "simulate --model {d}/negative_P.json --out {d}/new.csv", ["negative_P.json", "model.state.P", "semi-definite"]),
    ("P = 1e300 I", "simulate --model {d}/huge_P.json --out {d}/new.csv", ["huge_P.json", "P", "at most 1e+100"]),
    ('attrs "dt": "abc"', "identify {d}/dt_text.csv", ["dt_text.csv", "attrs.dt", "'abc'"]),
    ('attrs "units": [1]', "identify {d}/units_list.csv", ["units_list.csv", "attrs.units"]),
    ("attrs unit furlongs", "doctor {d}/furlongs.csv", ["furlongs.csv", "column 'y'", "'furlongs'"]),
    ("attrs nested 100,000 deep", "identify {d}/deep_attrs.csv", ["deep_attrs.csv", "nested deeper than 32"]),
    ("attrs 10**400", "identify {d}/big_seed.csv", ["big_seed.csv", "attrs.seed", "400 digits"]),
    ('Parquet "dt": [1, 2]', "identify {d}/dt_list.parquet", ["dt_list.parquet", "attrs.dt", "[1, 2]"]),
    ("HDF5 with flipped bytes", "identify {d}/flipped.h5", ["flipped.h5", "HDF5", "cannot be read"]),
]  # fmt: skip


@pytest.mark.parametrize(("case", "command", "words"), HOSTILE_FILES, ids=[row[0] for row in HOSTILE_FILES])
def test_hostile_file_exits_2_with_one_line_naming_it(capsys, hostile, case, command, words):
    before = _snapshot(hostile)
    argv = [part.replace("{d}", str(hostile)) for part in command.split()]
    code, text = _run(capsys, argv)
    lines = [line for line in text.splitlines() if line.strip()]
    assert code == 2, f"{case}: exit {code}\n{text}"
    assert "Traceback" not in text and len(lines) == 1, f"{case}: not one line:\n{text}"
    missing = [w for w in words if w not in lines[0]]
    assert not missing, f"{case}: {missing} not in {lines[0]!r}"
    assert _snapshot(hostile) == before, f"{case}: the folder changed"
