"""Wall time and peak memory of ``motorid doctor REC --json`` on 80 s at 200 Hz (16,000 samples),
beside the start-up floor every such command pays before any work.

Run: ``.venv/bin/python benchmarks/bench_doctor.py [--repeat 5]`` (or within ``make bench``).

Each figure is the median wall time [s] and the largest peak resident memory [MB] over
``--repeat`` fresh processes, the two commands alternated, after one warm-up run of each
(the compiled kernels' caches are then on disk, as after any first run). The floor is a
process that imports pandas and numba and runs one cached compiled function: the doctor reads
its record into pandas and runs compiled kernels, so it cannot start faster or smaller than
that. No peer does the doctor's work, so the rows have none. Not a test: it prints figures.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import doctor_large  # noqa: E402
from _table import Row, print_rows  # noqa: E402

#: One compiled function, cached on disk like motorid's kernels.
KERNEL = """
import numba


@numba.njit(cache=True)
def total(x):
    return x.sum()
"""
FLOOR = (
    "import sys; sys.path.insert(0, sys.argv[1]); import numpy, pandas, kernel; kernel.total(numpy.zeros(3))"
)


def measure_doctor(repeat: int = 5) -> list[Row]:
    """The doctor's and the floor's median wall time and largest peak RSS over ``repeat`` runs."""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        record = folder / "rig_16000.csv"
        doctor_large.make_record(record, 16_000, 0.005)
        (folder / "kernel.py").write_text(KERNEL)
        runs = {
            "doctor": [str(doctor_large.MOTORID), "doctor", str(record), "--json"],
            "floor": [sys.executable, "-c", FLOOR, str(folder)],
        }
        walls: dict[str, list[float]] = {name: [] for name in runs}
        peaks = dict.fromkeys(runs, 0.0)
        for attempt in range(repeat + 1):
            for name, argv in runs.items():
                wall, peak, _ = doctor_large.measure(argv)
                if attempt:  # the first run of each fills the compiled kernels' caches
                    walls[name].append(wall)
                    peaks[name] = max(peaks[name], peak)
    label = "80 s at 200 Hz (16,000 samples)"
    floor = "start-up floor (import pandas and numba, one cached kernel)"
    return [
        Row(
            f"motorid doctor --json, {label}, wall", statistics.median(walls["doctor"]), None, "s", "", False
        ),
        Row(f"motorid doctor --json, {label}, peak RSS", peaks["doctor"], None, "MB", "", False),
        Row(f"{floor}, wall", statistics.median(walls["floor"]), None, "s", "", False),
        Row(f"{floor}, peak RSS", peaks["floor"], None, "MB", "", False),
    ]


def measure() -> list[Row]:
    return measure_doctor()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="measured runs of each command")
    print_rows(measure_doctor(parser.parse_args().repeat), "motorid doctor")
