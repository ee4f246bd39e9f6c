"""A fresh ``motorid`` process: what the doctor loads (the libraries it does not use stay out of
its start-up) and how the console script loads the command line (the collector off).
benchmarks/bench_doctor_startup.py measures the time; these check the causes, which a loaded
machine does not make flaky."""

from __future__ import annotations

import json
import subprocess
import sys

from motorid.diagnose.synthetic import planted_record
from motorid.io.records import write_record

#: The console script's path into the command (motorid.console.run) on ``argv[1:]`` up to
#: ``--``, its output to strings; then what the process saw: the exit status, which of the modules
#: after ``--`` were loaded, the collections made before motorid.cli was loaded whole, whether the
#: collector is on, how many objects are frozen, and the argument types each compiled kernel was
#: called with.
PROBE = """
import contextlib, gc, io, json, sys
end = sys.argv.index("--")
watched, sys.argv = sys.argv[end + 1 :], ["motorid", *sys.argv[1:end]]
early = []
def note(phase, info):
    cli = sys.modules.get("motorid.cli")
    if phase == "start" and not hasattr(cli, "run"):
        early.append(info["generation"])
from motorid.console import run
gc.callbacks.append(note)
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        run()
    except SystemExit as done:
        code = done.code
from numba.core.registry import CPUDispatcher
kernels = {f"{module}.{name}": [str(s) for s in f.signatures]
           for module in ("motorid.drive.kernels", "motorid.iir") if module in sys.modules
           for name, f in vars(sys.modules[module]).items() if isinstance(f, CPUDispatcher) and f.signatures}
print(json.dumps({"code": code, "loaded": sorted(m for m in watched if m in sys.modules),
                  "early_collections": early, "collecting": gc.isenabled(),
                  "frozen": gc.get_freeze_count(), "kernels": kernels}))
"""


def probe(*argv: str, watched: tuple[str, ...] = ()) -> dict:
    done = subprocess.run([sys.executable, "-c", PROBE, *argv, "--", *watched],
                          capture_output=True, text=True, check=True)  # fmt: skip
    return json.loads(done.stdout)


def test_the_doctor_loads_neither_scipy_signal_nor_scipy_stats(tmp_path):
    """``scipy.signal`` imports ``scipy.stats`` and ``scipy.interpolate`` with it (some 0.35 s of
    CPU time): the doctor's filters are :mod:`motorid.iir`'s."""
    path = tmp_path / "rec.csv"
    write_record(planted_record("coulomb_friction", 3).record, path)
    seen = probe("doctor", str(path), "--json", watched=("scipy.signal", "scipy.stats", "scipy.interpolate"))
    assert seen["code"] == 0 and seen["loaded"] == []


def test_the_doctor_calls_each_kernel_with_one_set_of_argument_types(tmp_path):
    """Each set is loaded from numba's cache on its own (3-8 ms of CPU time): the values of a
    pandas column are read-only, and a kernel called with them and with a writable array was
    loaded twice."""
    path = tmp_path / "rec.csv"
    write_record(planted_record(("coulomb_friction", "input_dead_zone"), 3).record, path)
    seen = probe("doctor", str(path), "--json")
    assert seen["code"] == 0
    assert "motorid.drive.kernels.reversal_clock" in seen["kernels"]
    assert {name: types for name, types in seen["kernels"].items() if len(types) > 1} == {}


def test_the_console_script_loads_the_command_line_without_collecting():
    """No collection while numpy, pandas, SciPy, numba and the commands' modules load (0.1 s of
    CPU time on the doctor's path); then the collector is on again, those objects frozen."""
    seen = probe("--help", watched=("numpy", "pandas", "numba"))
    assert seen["code"] == 0 and seen["loaded"] == ["numba", "numpy", "pandas"]
    assert seen["early_collections"] == []
    assert seen["collecting"] is True
    assert seen["frozen"] > 50_000  # the loaded modules' objects (some 150,000)
