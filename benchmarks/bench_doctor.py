"""Wall time and peak memory of ``motorid doctor REC --json`` on 80 s at 200 Hz (16,000 samples),
beside the start-up floor every such command pays before any work.

Run: ``.venv/bin/python benchmarks/bench_doctor.py [--repeat 5]`` (or within ``make bench``).

Each figure is the median wall time [s], the median CPU time (user + system, steadier than
the wall time on a loaded machine) [s] and the largest peak resident memory [MB] over
``--repeat`` fresh processes, the commands alternated, after one warm-up run of each: numba's
caches and Python's bytecode are then on disk, as after any first run (the processes write
bytecode even where ``PYTHONDONTWRITEBYTECODE`` is set here, as a user's Python does). The floor is a process that
imports pandas and the part of SciPy the doctor uses (``scipy.optimize``) and runs one of the
drive's kernels from numba's cache: the doctor reads its record into pandas, searches with SciPy
and runs those kernels, so it cannot start faster or
smaller than that. A last row is the load average over the runs (the median of the 1-minute
figure read before each run): on a machine shared with other work the wall times grow with it.
No peer does the doctor's work, so the rows have none. Not a test: it prints figures.

Peak RSS counts the resident pages of the shared libraries each process maps (pyarrow's,
which pandas imports, are the largest). Right after the libraries are installed, their pages
sit in the page cache as written, and a process maps more of them at each fault: every row
then reads 20-40 MB more (``import pandas``: 123 MB instead of 106 MB), until those pages are
read back from disk. The process's own memory is the same.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import doctor_large  # noqa: E402
from _table import Row, print_rows  # noqa: E402

#: pandas, SciPy's least squares and scalar searches, and one kernel of the drive from numba's cache,
#: loaded as the console script loads the command line (motorid.console: one BLAS thread, the
#: collector off while the modules load, everything frozen before the exit).
FLOOR = (
    "import gc, os; os.environ.setdefault('OPENBLAS_NUM_THREADS', '1'); gc.disable(); "
    "import numpy, pandas, scipy.optimize; from motorid.drive import kernels; gc.freeze(); gc.enable(); "
    "kernels.reversal_clock(numpy.zeros(3), 1.0, 0.0, numpy.zeros(3)); gc.freeze()"
)


def measure_doctor(repeat: int = 5) -> list[Row]:
    """The doctor's and the floor's median wall and CPU time and largest peak RSS over ``repeat``
    runs, and the median load average."""
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "rig_16000.csv"
        doctor_large.make_record(record, 16_000, 0.005)
        runs = {
            "motorid doctor --json": [str(doctor_large.MOTORID), "doctor", str(record), "--json"],
            "start-up floor (import pandas and SciPy, one cached kernel run)": [sys.executable, "-c", FLOOR],
        }
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        walls: dict[str, list[float]] = {name: [] for name in runs}
        cpus: dict[str, list[float]] = {name: [] for name in runs}
        peaks = dict.fromkeys(runs, 0.0)
        loads: list[float] = []
        for attempt in range(repeat + 1):
            for name, argv in runs.items():
                load = os.getloadavg()[0]
                wall, peak, cpu, _ = doctor_large.measure(argv, env)
                if attempt:  # the first run of each fills numba's caches
                    walls[name].append(wall)
                    cpus[name].append(cpu)
                    peaks[name] = max(peaks[name], peak)
                    loads.append(load)
    label = "80 s at 200 Hz (16,000 samples)"
    rows = []
    for name in runs:
        where = f"{name}, {label}" if name.startswith("motorid") else name
        rows.append(Row(f"{where}, wall", statistics.median(walls[name]), None, "s", "", False))
        rows.append(Row(f"{where}, CPU", statistics.median(cpus[name]), None, "s", "", False))
        rows.append(Row(f"{where}, peak RSS", peaks[name], None, "MB", "", False))
    cores = os.cpu_count()
    rows.append(
        Row(
            f"load average (1 min) during the runs, {cores} cores",
            statistics.median(loads),
            None,
            "",
            "",
            False,
        )
    )
    return rows


def measure() -> list[Row]:
    return measure_doctor()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="measured runs of each command")
    print_rows(measure_doctor(parser.parse_args().repeat), "motorid doctor")
