"""The kernels compiled ahead of time (:mod:`motorid.compiled`): the same numbers as numba's JIT
on the same source, arguments checked at the door, a stale build left unused, and the doctor
started without numba."""

from __future__ import annotations

import importlib.machinery
import importlib.util
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from motorid import compiled
from motorid.plants import physics

PHYSICS = "motorid.plants.physics"


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> dict[str, compiled.BuiltModule]:
    """The extension built afresh into a temporary folder, as each module's kernels."""
    folder = tmp_path_factory.mktemp("kernels")
    path = compiled.build(folder)
    assert path.parent == folder and compiled.status(folder) == "built"
    spec = importlib.util.spec_from_file_location(compiled.EXTENSION, path)
    extension = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(extension)
    record = json.loads((folder / compiled.BUILD_RECORD.name).read_text())
    return {PHYSICS: compiled.built_module(PHYSICS, extension, record)}


def run_both(built: dict[str, compiled.BuiltModule], module: str, name: str, *args: object) -> tuple:
    """``name`` run from the extension and by numba's JIT on copies of the same arguments;
    (results, arguments after) of each, so in-place writes are compared too."""
    runs = []
    for kernels in (built[module], physics):
        copies = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
        runs.append((getattr(kernels, name)(*copies), copies))
    return runs[0], runs[1]


def assert_same(a: object, b: object) -> None:
    # The same source compiled by the same LLVM, without fast-math: every operation is the same
    # IEEE operation in the same order, and exp/pow are the same libm calls, so equal bit for bit.
    if isinstance(a, tuple | list):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert_same(x, y)
    else:
        np.testing.assert_array_equal(a, b, strict=True)


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize("seed", range(4))
def test_every_kernel_built_ahead_equals_numba_jit_bit_for_bit(built, seed):
    rng = np.random.default_rng(seed)
    n = 400
    dt = float(rng.uniform(0.001, 0.02))
    x = np.repeat(rng.normal(0.0, 2.0, n // 8), 8)  # held steps with reversals
    x[rng.integers(0, n, 20)] = 0.0
    shape = int(seed % 2)
    coef = rng.uniform(0.0, 0.5, physics.N_TERMS)
    delay = float(rng.uniform(0.0, 5.0)) * dt
    m, _ = physics.rigid_delay_samples(dt, delay)
    clock = np.array([0.0, -1.0, 0.0])
    cases = [
        ("armature_voltages", x, 1.5, 0.3, 2.5),
        ("rigid_columns", np.arange(physics.N_TERMS, dtype=np.int64), x, 2.0, shape),
        ("rigid_delay_samples", dt, delay),
        ("rigid_input_dynamics", x, dt, delay, 0.03, np.zeros(m + 2), np.zeros(2)),
        ("reversal_clock", x, dt, math.nan, clock),
        ("reversal_clock", x, dt, 0.25, clock),
        ("backlash_dwell", x, dt, 0.05, clock),
        ("rigid_free_run", x, dt, 3, 0.02, coef, 2.0, shape, 0.0, 0.1),
    ]
    for name, *args in cases:
        ahead, jit = run_both(built, PHYSICS, name, *args)
        assert_same(ahead, jit)


def test_defaults_and_keywords_are_the_modules(built):
    kernels = built[PHYSICS]
    force = np.linspace(-1.0, 1.0, 50)
    coef = np.zeros(physics.N_TERMS)
    coef[physics.TERM_COULOMB] = 0.2
    args = (force, 0.01, 2, 0.05, coef, 1.0, 0)  # all but w0 and breakaway_excess (default 0.0)
    np.testing.assert_array_equal(kernels.rigid_free_run(*args, 0.5), physics.rigid_free_run(*args, 0.5, 0.0))
    np.testing.assert_array_equal(
        kernels.rigid_free_run(*args, breakaway_excess=0.3, w0=0.5), physics.rigid_free_run(*args, 0.5, 0.3)
    )
    with pytest.raises(TypeError, match="missing argument 'w0'"):
        kernels.rigid_free_run(*args)
    with pytest.raises(TypeError, match="unexpected or repeated argument 'dt'"):
        kernels.rigid_free_run(*args, 0.5, dt=0.01)


def test_arguments_are_converted_or_refused_by_name(built):
    kernels = built[PHYSICS]
    values = np.array([[3.0, -1.0], [0.0, 2.0], [0.5, -4.0]])
    strided = values[:, 0]  # not contiguous: the kernel would read the wrong samples unconverted
    expected = physics.armature_voltages(np.ascontiguousarray(strided), 1.0, 0.5, 2.0)
    np.testing.assert_array_equal(kernels.armature_voltages(strided, 1.0, 0.5, 2.0), expected)
    np.testing.assert_array_equal(kernels.armature_voltages([3, 0, 1], 1, 0.5, 2.0), [1.5, 0.0, 0.5])
    with pytest.raises(TypeError, match=r"armature_voltages\(\) argument 'u': expected 1 dimension"):
        kernels.armature_voltages(values, 1.0, 0.5, 2.0)
    with pytest.raises(TypeError):  # a float parameter takes what float() takes
        kernels.armature_voltages(strided, None, 0.5, 2.0)
    with pytest.raises(TypeError):  # an int parameter refuses a float rather than truncate it
        kernels.rigid_columns(np.zeros(1, dtype=np.int64), values[:, 1].copy(), 1.0, 0.5)
    # an array the kernel writes into is never silently copied: its writes would be lost
    with pytest.raises(
        TypeError, match=r"reversal_clock\(\) argument 'clock': the kernel writes into it.*int64"
    ):
        kernels.reversal_clock(strided, 0.01, math.nan, np.array([0, -1, 0]))
    clock = np.array([0.0, -1.0, 0.0])
    clock.flags.writeable = False
    with pytest.raises(TypeError, match="read-only"):
        kernels.reversal_clock(strided, 0.01, math.nan, clock)


def test_a_stale_or_missing_build_is_left_unused(tmp_path, monkeypatch):
    assert compiled.status(tmp_path) == "not built"
    record = tmp_path / compiled.BUILD_RECORD.name
    record.write_text(json.dumps({"digest": compiled.source_digest()}))
    assert compiled.status(tmp_path) == "not built"  # the record of a build, but no extension for this Python
    (tmp_path / f"{compiled.EXTENSION}.cpython-399-x86_64-linux-gnu.so").touch()  # another Python's
    assert compiled.status(tmp_path) == "not built"
    (tmp_path / f"{compiled.EXTENSION}{importlib.machinery.EXTENSION_SUFFIXES[0]}").touch()
    assert compiled.status(tmp_path) == "built"
    record.write_text(json.dumps({"digest": "0" * 64}))  # built from another source
    assert compiled.status(tmp_path) == "stale"
    record.write_text(json.dumps({"digest": compiled.source_digest()}))
    monkeypatch.setenv("MOTORID_JIT_ONLY", "1")
    assert compiled.status(tmp_path) == "off"
    monkeypatch.setenv("MOTORID_JIT_ONLY", "0")
    monkeypatch.setenv("NUMBA_DISABLE_JIT", "1")
    assert compiled.status(tmp_path) == "off: NUMBA_DISABLE_JIT"


def test_an_extension_that_does_not_load_leaves_the_jit(monkeypatch, caplog):
    monkeypatch.setattr(compiled, "status", lambda folder=None: "built")
    monkeypatch.setattr(compiled, "EXTENSION", "_no_such_extension")  # as if built against another numpy
    monkeypatch.setattr(compiled, "_loaded", {})
    with caplog.at_level("WARNING", logger="motorid.compiled"):
        assert compiled.load(PHYSICS) is physics
    assert "do not load" in caplog.text and "python -m motorid.compiled --force" in caplog.text


def test_the_digest_covers_each_kernels_source():
    files = {compiled.module_file(k.module) for k in compiled.KERNELS}
    assert files == {Path(physics.__file__)}
    with pytest.raises(ValueError, match="not a module of motorid"):
        compiled.module_file("numpy.linalg")


def doctor_probe(path: Path) -> str:
    return (
        "import contextlib, io, json, sys\n"
        "from motorid.cli import main\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):\n"
        f"    code = main(['doctor', {str(path)!r}, '--json'])\n"
        "loaded = sorted(m for m in ('numba', 'llvmlite') if m in sys.modules)\n"
        "print(json.dumps([code, loaded, json.loads(out.getvalue())]))\n"
    )


def test_the_doctor_starts_without_numba_and_gives_the_jits_numbers(tmp_path):
    """A fresh ``motorid doctor`` process runs every kernel from the extension: numba and LLVM
    stay unloaded (SciPy designs the doctor's filters and runs its scalar searches), and the report is the one the same
    command gives with every kernel through numba's JIT."""
    assert compiled.status() == "built", (
        f"the kernels are {compiled.status()}: `make` builds them (python -m motorid.compiled)"
    )
    from motorid.diagnose.synthetic import planted_record
    from motorid.records import write_record

    planted = planted_record("coulomb_friction", seed=3, duration=20.0, dt=0.005)
    path = tmp_path / "planted.csv"
    write_record(planted.record, path)
    reports = {}
    for jit_only in ("0", "1"):
        env = {**os.environ, "MOTORID_JIT_ONLY": jit_only}
        done = subprocess.run(
            [sys.executable, "-c", doctor_probe(path)], capture_output=True, text=True, check=True, env=env
        )
        reports[jit_only] = json.loads(done.stdout.splitlines()[-1])
    code, loaded, report = reports["0"]
    assert (code, loaded) == (0, [])
    assert "numba" in reports["1"][1]
    assert report == reports["1"][2]
    assert [step["effect"] for step in report["steps"]] == ["coulomb_friction"]


def test_the_build_command_keeps_a_current_build():
    """``python -m motorid.compiled`` as the README and make run it: a current build is kept (a
    build from scratch is the ``built`` fixture's), and a bad option exits 2 naming it."""
    assert compiled.status() == "built"
    before = next(compiled.BUILD_RECORD.parent.glob(f"{compiled.EXTENSION}.*.so")).stat().st_mtime_ns
    done = subprocess.run(
        [sys.executable, "-m", "motorid.compiled"], capture_output=True, text=True, check=True
    )
    assert "current" in done.stderr
    assert next(compiled.BUILD_RECORD.parent.glob(f"{compiled.EXTENSION}.*.so")).stat().st_mtime_ns == before
    bad = subprocess.run([sys.executable, "-m", "motorid.compiled", "--fast"], capture_output=True, text=True)
    assert bad.returncode == 2 and "--fast" in bad.stderr
