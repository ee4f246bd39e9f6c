"""Where ``motorid doctor REC --json`` spends its time on 80 s at 200 Hz (16,000 samples), in a
fresh process: the interpreter's start, the imports, numba's loading of compiled kernels from its
on-disk cache, the work and the process's exit.

Run: ``.venv/bin/python benchmarks/bench_doctor_startup.py [--repeat 5]`` (or within ``make bench``).

Each run is a fresh ``python -c`` process that times itself (:data:`CHILD`) and does what the
``motorid`` console script does: ``from motorid.console import run``, then ``run()`` with
``sys.argv = ["motorid", "doctor", REC, "--json"]``, its output to ``/dev/null`` (``run`` loads
:mod:`motorid.cli` with the collector off, the first import of numpy: the command line's defaults
that must precede numpy's, such as one BLAS thread, apply as they do for a user):

- *interpreter start*: from the parent's start of the process to the child's first statement
  (Python's start-up and ``site``: the ``.pth`` files of the environment, the editable install's);
- *imports*: the time spent loading modules (importlib's ``_find_and_load``, which every
  ``import`` statement and ``importlib.import_module`` call of a module not yet loaded goes
  through: those inside functions and SciPy's and pandas' lazy ones included; nested imports
  counted once, in their outermost), numba's first calls inside them left out;
- *numba first calls*: each kernel's first call in the process (numba's
  ``Dispatcher._compile_for_args``: its typing set-up, the first of them installing numba's
  typing registries, and the loading of the kernel's machine code from numba's cache), and *of
  which cache loads*, ``Cache.load_overload`` alone; compilations (none after the warm-up run)
  are counted apart; both are timed from the moment numba's modules are loaded, before any
  kernel runs;
- *work*: what is left of the child's own wall time, to the end of ``run()``;
- *exit*: from the end of ``run()`` to the parent's seeing the process end (the interpreter's
  finalisation: the collector's last pass, the modules' teardown).

The parent times the process by the wall clock and by its CPU time (all its threads, from
``getrusage``; steadier than the wall time on a loaded machine, where the wall time of a phase
includes waiting for a core); the child times each of its phases by both clocks. Each figure is
the median over ``--repeat`` runs after one warm-up run (which fills numba's cache and writes the
bytecode of every module), with the load average read before each run. Not a test: it prints
figures.

``--blas-threads N`` runs the same processes with OpenBLAS (and OpenMP, MKL) on N threads (the
command line sets one OpenBLAS thread unless the environment says otherwise): the doctor's
least-squares problems are small (16,000 rows of a few columns), and on a machine whose cores are
busy the BLAS threads wait for cores and for each other; compare the runs' *work*.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import doctor_large  # noqa: E402
from _table import Row, print_rows  # noqa: E402

#: The timed child: argv[1] is the record, argv[2] the file its figures go to (JSON).
CHILD = r"""
import time
started = time.time()  # the clock the parent reads too
import _frozen_importlib, json, sys  # the standard library's only: numpy comes with motorid.cli
clocks = {"wall": time.perf_counter, "cpu": time.process_time}
start = {c: f() for c, f in clocks.items()}
spent = {f"{what}_{c}": 0.0 for what in ("imports", "cache", "dispatch", "dispatch_in_imports") for c in clocks}
spent.update(loads=0)
depth = [0]
compilations = []  # numba's TimingListener of its compile events, once numba is loaded
real_find_and_load = _frozen_importlib._find_and_load


def timed(real, *names):
    def call(self, *args, **kwargs):
        t0 = {c: f() for c, f in clocks.items()}
        try:
            return real(self, *args, **kwargs)
        finally:
            spent["loads"] += names[0] == "cache"
            for c, f in clocks.items():
                for name in names if depth[0] else names[:1]:
                    spent[f"{name}_{c}"] += f() - t0[c]

    return call


def time_numba():
    # numba is loaded: time its first calls from here, before any kernel runs
    from numba.core import caching, dispatcher, event

    caching.Cache.load_overload = timed(caching.Cache.load_overload, "cache")
    dispatcher.Dispatcher._compile_for_args = timed(
        dispatcher.Dispatcher._compile_for_args, "dispatch", "dispatch_in_imports"
    )
    compilations.append(event.TimingListener())
    event.register("numba:compile", compilations[0])


def timed_find_and_load(*args, **kwargs):
    if depth[0]:
        found = real_find_and_load(*args, **kwargs)
    else:
        depth[0] = 1
        t0 = {c: f() for c, f in clocks.items()}
        try:
            found = real_find_and_load(*args, **kwargs)
        finally:
            for c, f in clocks.items():
                spent[f"imports_{c}"] += f() - t0[c]
            depth[0] = 0
    if not compilations and args[0] == "numba":  # numba's package loaded whole
        time_numba()
    return found


_frozen_importlib._find_and_load = timed_find_and_load
from motorid.console import run  # as the console script does; run() loads motorid.cli and numpy

figures = sys.argv[2]
sys.argv = ["motorid", "doctor", sys.argv[1], "--json"]
try:
    run()
except SystemExit as done:
    spent["code"] = done.code
for c, f in clocks.items():
    spent[f"total_{c}"] = f() - start[c]
spent["compile"] = compilations[0].duration if compilations and compilations[0].done else 0.0
spent["started"] = started
spent["ended"] = time.time()
with open(figures, "w") as f:
    json.dump(spent, f)
"""


def run_child(record: Path, figures: Path, env: dict[str, str]) -> dict[str, float]:
    """One fresh process: its own figures (``total_wall``, ``imports_cpu``, ``cache_wall``, ...),
    its wall time ``wall`` and its CPU time ``cpu`` [s] seen from here."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0, launched = time.perf_counter(), time.time()
    done = subprocess.run([sys.executable, "-c", CHILD, str(record), str(figures)], env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)  # fmt: skip
    wall, ended = time.perf_counter() - t0, time.time()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"the timed process exited with {done.returncode}: {done.stderr.strip()}")
    out = json.loads(figures.read_text(encoding="utf-8"))
    if out["code"] not in (0, 1):
        raise RuntimeError(f"motorid doctor exited with {out['code']}: {done.stderr.strip()}")
    out["wall"] = wall
    out["start"] = out["started"] - launched
    out["exit"] = ended - out["ended"]
    out["cpu"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return out


#: The environment variables that set the BLAS libraries' thread count (OpenBLAS, OpenMP, MKL).
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def measure_startup(repeat: int = 5, blas_threads: int | None = None) -> list[Row]:
    """The median split of the doctor's wall time over ``repeat`` fresh processes, with the BLAS
    libraries' threads limited to ``blas_threads`` (None: as this environment leaves them)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    if blas_threads is not None:
        env.update(dict.fromkeys(BLAS_THREADS, str(blas_threads)))
    runs: list[dict[str, float]] = []
    loads: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "rig_16000.csv"
        doctor_large.make_record(record, 16_000, 0.005)
        for attempt in range(repeat + 1):
            load = os.getloadavg()[0]
            out = run_child(record, Path(tmp) / "figures.json", env)
            if attempt:  # the first run fills numba's cache and writes the bytecode
                runs.append(out)
                loads.append(load)

    label = "motorid doctor --json, 80 s at 200 Hz (16,000 samples)"
    if blas_threads is not None:
        label += f", {blas_threads} BLAS thread{'s' if blas_threads > 1 else ''}"
    rows = [Row(f"{label}, wall", statistics.median(r["wall"] for r in runs), None, "s", "", False)]
    rows.append(Row(f"{label}, CPU", statistics.median(r["cpu"] for r in runs), None, "s", "", False))
    for clock in ("wall", "cpu"):

        def own(r: dict[str, float], what: str, clock: str = clock) -> float:
            return r[f"{what}_{clock}"]

        splits = {
            "imports": [own(r, "imports") - own(r, "dispatch_in_imports") for r in runs],
            "numba first calls": [own(r, "dispatch") for r in runs],
            "of which cache loads": [own(r, "cache") for r in runs],
            "work": [own(r, "total") - own(r, "imports") + own(r, "dispatch_in_imports") - own(r, "dispatch")
                     for r in runs],
        }  # fmt: skip
        if clock == "wall":
            splits = {"interpreter start": [r["start"] for r in runs], **splits,
                      "exit": [r["exit"] for r in runs]}  # fmt: skip
        else:  # the process's CPU time outside the child's own clock: its start and its exit
            splits["start and exit"] = [r["cpu"] - r["total_cpu"] for r in runs]
        for name, values in splits.items():
            rows.append(Row(f"  {name} ({clock})", statistics.median(values), None, "s", "", False))
    rows.append(
        Row("  numba compilations", statistics.median(r["compile"] for r in runs), None, "s", "", False)
    )
    rows.append(Row("  kernels loaded from numba's cache", statistics.median(r["loads"] for r in runs),
                    None, "", "", False))  # fmt: skip
    rows.append(Row(f"load average (1 min) during the runs, {os.cpu_count()} cores",
                    statistics.median(loads), None, "", "", False))  # fmt: skip
    return rows


def measure() -> list[Row]:
    return measure_startup()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="measured runs")
    parser.add_argument("--blas-threads", type=int, default=None,
                        help="limit the BLAS libraries' threads in the measured processes (default: as set here)")  # fmt: skip
    args = parser.parse_args()
    print_rows(measure_startup(args.repeat, args.blas_threads), "motorid doctor: start-up and work")
