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
from motorid.errors import DataError
from motorid.estimators import Estimator, FrictionEKF, FrictionUKF, create
from motorid.models import load_model, model_to_dict
from motorid.plants import RigidDrive, TwoMassRig, paper_rig
from motorid.plants.signals import two_sine_signal
from motorid.records import ATTRS_MARKER, read_record, write_record

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
        assert model_to_dict(load_model(path)) == content, kind


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
