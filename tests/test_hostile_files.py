"""Fuzzing the files motorid reads back: model files and record attributes.

Each test starts from a file motorid itself wrote (a two-mass rig, the rigid drive
the doctor saves, each saved estimator after filtering a record, a simulated
record's attributes), changes one value (a type swapped, a huge, tiny, negative or
NaN number, an integer of 400 digits, nesting 100,000 deep, a key dropped or
added) and reads it again. The read either gives a working object (a model that
saves again, a record with a sample time) or raises motorid's DataError, one line
naming the file: no other exception escapes as a bug.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import examples
from hypothesis import HealthCheck, given
from hypothesis import strategies as st

from motorid.cli import main
from motorid.drive import RigidDrive, TwoMassRig, paper_rig
from motorid.drive.files import model_to_dict, read_model_file
from motorid.errors import DataError
from motorid.estimators import Estimator, FrictionEKF, FrictionUKF, create, load_model
from motorid.io.records import ATTRS_MARKER, read_record, write_record
from motorid.signals import two_sine_signal

#: A JSON token put in place of a value: (raw JSON text, what it is).
_RAW = "@@hostile@@"
REPLACEMENTS = [
    "1e308", "-1e308", "5e-324", "-1", "0", "0.5", "NaN", "Infinity", "-Infinity",
    str(10**400), str(-(10**400)), str(2**63), "9007199254740993", "1e400",
    "true", "false", "null", '""', '"abc"', '"' + "x" * 10_000 + '"', "[]", "{}", "[1, 2]",
    '{"kind": "coulomb_friction"}', "[" * 100_000 + "]" * 100_000, "[" * 40 + "]" * 40,
]  # fmt: skip


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    """Every key path in a JSON value, the root excluded."""
    out = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        out.append((*prefix, key))
        out.extend(_paths(value, (*prefix, key)))
    return out


def _mutated_text(data: dict, draw: Any) -> str:
    """The JSON text of ``data`` with one change drawn: a value replaced, a key dropped or added."""
    data = json.loads(json.dumps(data))
    paths = _paths(data)
    path = draw(st.sampled_from(paths), label="path")
    node = data
    for key in path[:-1]:
        node = node[key]
    action = draw(st.sampled_from(["replace", "replace", "replace", "drop", "add"]), label="action")
    if action == "drop":
        del node[path[-1]]
    elif action == "add" and isinstance(node, dict):
        node["extra_key"] = 1.0
    elif action == "add":
        node.append(node[-1])
    else:
        node[path[-1]] = _RAW
    return json.dumps(data).replace(f'"{_RAW}"', draw(st.sampled_from(REPLACEMENTS), label="value"))


def _check_refusal(exc: DataError, path: Path) -> None:
    text = str(exc)
    assert str(path) in text, text
    assert "\n" not in text and len(text) < 2000, text[:2000]


# --------------------------------------------------------------------------- model files
@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, dict]:
    """The model files motorid writes: a rig, the doctor's rigid drive, each estimator after a record."""
    folder = tmp_path_factory.mktemp("written")
    _, u = two_sine_signal(duration=20.0, dt=0.04, seed=3)
    record = paper_rig().simulate(u, seed=3)
    y = record["y"].to_numpy()
    write_record(record[["t", "u", "y"]], folder / "rec.csv")
    assert main(["doctor", str(folder / "rec.csv"), "--save-model", str(folder / "drive.json")]) == 0
    files = {"rig": model_to_dict(paper_rig()), "doctor": json.loads((folder / "drive.json").read_text())}
    drive = load_model(folder / "drive.json")
    estimators = {
        "arx-rls": create("arx-rls", na=2, nb=2),
        "hammerstein-rls": create("hammerstein-rls", na=2, nb=2, degree=3),
        "friction-ekf": FrictionEKF.from_rig(paper_rig(), nis_window=10, on_divergence="ignore"),
        "friction-ukf": FrictionUKF.from_rig(paper_rig(), nis_window=10, on_divergence="ignore"),
        "friction-ekf on the doctor's drive": FrictionEKF.from_rig(
            drive, R=0.01, nis_window=10, on_divergence="ignore"
        ),
    }
    for name, est in estimators.items():
        for u_t, y_t in zip(u[:100], y[:100], strict=True):
            est.predict(u_t)
            est.update(y_t)
        files[name] = model_to_dict(est)
    return files


def _loads_or_refuses(path: Path) -> None:
    try:
        model = load_model(path)
    except DataError as exc:
        _check_refusal(exc, path)
        return
    assert isinstance(model, TwoMassRig | RigidDrive | Estimator)
    model_to_dict(model)  # a model read is one motorid can save again
    if isinstance(model, Estimator):
        assert np.all(np.isfinite(model.x)) and np.all(np.isfinite(model.P))
        np.testing.assert_array_equal(model.P, model.P.T)


@pytest.mark.parametrize(
    "kind",
    [
        "rig",
        "doctor",
        "arx-rls",
        "hammerstein-rls",
        "friction-ekf",
        "friction-ukf",
        "friction-ekf on the doctor's drive",
    ],
)
@examples(60, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_a_mutated_model_file_loads_or_is_refused_naming_the_file(tmp_path, written, kind, data):
    path = tmp_path / "model.json"
    path.write_text(_mutated_text(written[kind], data.draw))
    _loads_or_refuses(path)


def test_the_unmutated_files_load(tmp_path, written):
    for kind, content in written.items():
        path = tmp_path / f"{kind}.json"
        path.write_text(json.dumps(content))
        read = read_model_file(path)  # the model and its card (the doctor's file has one)
        assert model_to_dict(read.model, read.card) == content, kind


# --------------------------------------------------------------------------- record attributes
@pytest.fixture(scope="module")
def record_attrs() -> tuple[dict, str]:
    """The attributes of a simulated record (dt, units, rig, integrator, seed, timing) and its CSV rows."""
    _, u = two_sine_signal(duration=2.0, dt=0.04, seed=3)
    record = paper_rig().simulate(u, seed=3)[["t", "u", "y"]]
    record.attrs = {
        **paper_rig().simulate(u[:3], seed=3).attrs,
        "drive": "axis-7",
        "time": "2025-01-01T00:00:00",
    }
    return json.loads(json.dumps(record.attrs)), record.to_csv(index=False)


@examples(200, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_mutated_record_attributes_read_or_are_refused_naming_the_file(tmp_path, record_attrs, data):
    attrs, rows = record_attrs
    path = tmp_path / "rec.csv"
    path.write_text(ATTRS_MARKER + _mutated_text(attrs, data.draw) + "\n" + rows)
    try:
        record = read_record(path)
    except DataError as exc:
        _check_refusal(exc, path)
        return
    assert math.isclose(record.attrs["dt"], 0.04, rel_tol=1e-3)
    assert list(record.columns) == ["t", "u", "y"]


# --------------------------------------------------------------------------- the bounds themselves
def test_json_depth_and_integers_are_bounded_at_the_stated_limits():
    from motorid.json_input import MAX_DEPTH, MAX_INTEGER, parse_json

    deepest = parse_json("[" * MAX_DEPTH + "]" * MAX_DEPTH, "f.json")
    for _ in range(MAX_DEPTH - 1):
        (deepest,) = deepest
    assert deepest == []
    with pytest.raises(DataError, match=r"f.json: .*nested deeper than 32 levels"):
        parse_json("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), "f.json")
    with pytest.raises(DataError, match=r"^f.json: the JSON is nested deeper than 32 levels$"):
        parse_json("[" * 100_000 + "]" * 100_000, "f.json")
    assert parse_json(f'{{"n": [{MAX_INTEGER}, {-MAX_INTEGER}]}}', "f.json") == {
        "n": [MAX_INTEGER, -MAX_INTEGER]
    }
    with pytest.raises(DataError, match=r"^f.json: n\[1\]: an integer of 16 digits is beyond ±2\*\*53"):
        parse_json(f'{{"n": [1, {MAX_INTEGER + 1}]}}', "f.json")
    with pytest.raises(DataError, match=r"^f.json: a.b: an integer of 5000 digits"):
        parse_json('{"a": {"b": ' + "9" * 5000 + "}}", "f.json")
    with pytest.raises(DataError, match=r"^f.json: invalid JSON at line 1 column 2"):
        parse_json("{", "f.json")


def test_a_covariance_is_accepted_within_the_stated_tolerance_and_symmetrised():
    from motorid.estimators.base import COVARIANCE_RTOL, check_covariance

    P = np.array([[2.0, 0.5], [0.5, 1.0]])
    assert check_covariance("P", P) is not P
    np.testing.assert_array_equal(check_covariance("P", P), P)  # exactly symmetric: the same bits
    # written with 10 significant digits by another program: off by 5e-11 relative, accepted
    rounded = P.copy()
    rounded[0, 1] = 0.5 * (1 + 5e-11)
    back = check_covariance("P", rounded)
    np.testing.assert_array_equal(back, back.T)
    assert abs(back[0, 1] - 0.5) <= COVARIANCE_RTOL
    # an edit: asymmetric by order 1, refused
    edited = P.copy()
    edited[0, 1] = 0.6
    with pytest.raises(ValueError, match="P must be symmetric"):
        check_covariance("P", edited)
    # singular (a parameter the data fixed exactly) passes; an eigenvalue of -1e-3 relative does not
    np.testing.assert_array_equal(check_covariance("P", np.ones((2, 2))), np.ones((2, 2)))
    with pytest.raises(ValueError, match="positive semi-definite"):
        check_covariance("P", np.array([[1.0, 1.001], [1.001, 1.0]]))
    with pytest.raises(ValueError, match="at most 1e\\+100"):
        check_covariance("P", 1e300 * np.eye(2))


def test_each_parameter_is_refused_outside_its_physical_range():
    from motorid.drive import Amplifier, Encoder, Friction, Tachogenerator
    from motorid.drive.ranges import LARGEST, SMALLEST, check_parameter

    assert check_parameter("J", LARGEST, "kg m²", sign="> 0") == LARGEST
    assert check_parameter("J", SMALLEST, "kg m²", sign="> 0") == SMALLEST
    for sign, value in [
        ("> 0", SMALLEST / 2),
        ("> 0", 2 * LARGEST),
        (">= 0", 2 * LARGEST),
        ("any", -2 * LARGEST),
    ]:
        with pytest.raises(ValueError, match=r"J must be within \[.*\] kg m²"):
            check_parameter("J", value, "kg m²", sign=sign)
    for make, message in [
        (lambda: paper_rig(dt=1e308), "dt must be within"),
        (lambda: paper_rig(dt=1e-10), "dt must be within"),
        (lambda: paper_rig(J_m=1e300), "J_m must be within"),
        (lambda: paper_rig(substeps=10**9), "substeps must be an integer in"),
        (lambda: Friction(("coulomb_friction",), {"coulomb": 1e13}), "coulomb must be within"),
        (lambda: Amplifier(gain=1e300), "gain must be within"),
        (lambda: Tachogenerator(noise_std=1e300), "noise_std must be within"),
        (lambda: Encoder(counts_per_rev=2**40), "counts_per_rev must be an integer in"),
        (lambda: RigidDrive(("viscous_friction",), {"inertia": 1.0, "input_gain": 1.0, "viscous": 1e308}, dt=0.01).check_physical(), "viscous must be within"),
        (lambda: RigidDrive(("input_delay",), {"inertia": 1.0, "input_gain": 1.0, "input_delay": 1e6}, dt=1e-3), "input_delay must be at most 100000 samples"),
        (lambda: FrictionEKF(nis_window=10**9), r"nis_window must be an integer in \[1, 100000\]"),
        (lambda: FrictionEKF(speed_noise=1e308), "speed_noise must be within"),
        (lambda: create("arx-rls", na=10**7, nb=1), "more than 1000"),
        (lambda: create("arx-rls", na=2, nb=1, delta=1e300), "delta must be at most 1e\\+100"),
    ]:  # fmt: skip
        with pytest.raises(ValueError, match=message):
            make()


def test_record_attributes_are_checked_naming_the_key(tmp_path):
    rows = "t,u,y\n0,0,0\n0.04,1,1\n0.08,1,2\n"
    cases = [
        ('{"dt": "abc"}', "attrs.dt must be a sample time"),
        ('{"dt": true}', "attrs.dt must be a sample time"),
        ('{"dt": 1e308}', "attrs.dt must be a sample time"),
        ('{"units": [1]}', "attrs.units must be an object"),
        ('{"units": {"y": 3}}', "the unit of column 'y' must be text"),
        ('{"units": {"y": "furlongs"}}', "column 'y' has the unknown unit 'furlongs'"),
        ('{"converted_from": {"u": "furlongs"}}', "attrs.converted_from: column 'u' has the unknown unit"),
        ('{"timing": "soon"}', "attrs\\['timing'\\] must be one of"),
        ('{"drive": 7}', "attrs.drive must be text"),
        ('{"samples": -1}', "attrs.samples must be an integer >= 0"),
        ('{"seed": 1.5}', "attrs.seed must be an integer >= 0"),
        ('{"rig": []}', "attrs.rig must be an object"),
        ("[1]", "are not a JSON object"),
    ]
    for attrs, message in cases:
        path = tmp_path / "rec.csv"
        path.write_text(ATTRS_MARKER + attrs + "\n" + rows)
        with pytest.raises(
            DataError, match=f"^{path}: the record attributes in the attribute line .*{message}"
        ):
            read_record(path)
    path.write_text(
        ATTRS_MARKER
        + '{"dt": 0.04, "units": {"t": "s", "u": "%", "y": "rpm", "i": "A"}, "seed": null}\n'
        + rows
    )
    attrs = read_record(path).attrs  # known units are read and the output converted to SI
    assert attrs["units"]["y"] == "rad/s" and attrs["converted_from"]["y"] == "rpm"
