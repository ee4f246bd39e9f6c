"""``motorid identify`` end to end on a day logged at 1 kHz (86.4 M samples): samples/s and peak memory.

Run: ``.venv/bin/python benchmarks/bench_long_record.py [--hours 24] [--keep DIR]`` (or within
``make bench``). Targets: >= 1,000,000 samples/s, reading included, in < 500 MB.

The record is a CSV as a logger writes it (``t`` in s to the millisecond, ``u`` [V] and ``y``
[rad/s] to four decimals: about 25 bytes a sample, 87 MB an hour, 2.1 GB a day; the script
checks that the folder has the room before it writes). It is written in blocks, so writing
it holds a block, not the record: a cubic input nonlinearity followed by a second-order lag,
driven by two sines, with white noise on the output. ``motorid identify REC --json`` (the
default Hammerstein RLS, order 4, degree 3) then runs on it in a fresh process: it reads the
record in blocks twice (the filter, then the identified model's free run) and holds a few
blocks and the residual tests' window whatever the record's length. The figures are its wall
time (start-up and reading included) as samples per second, the same per second of CPU time
(steadier on a machine shared with other work, where waiting for a core is not counted), and
its peak resident memory (``ru_maxrss`` of the child, as ``doctor_large.py`` measures it),
first on one hour, then on ``--hours``: the same memory for both shows that it does not grow
with the record. Each is run once, after a warm-up run on a short record. No peer does the
same work. The files take 87 MB an hour in the folder (``--keep`` or a temporary one).
Not a test: it prints figures.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

import doctor_large  # noqa: E402
from _table import Row, print_rows  # noqa: E402

#: Samples a second of the logger.
RATE = 1000
#: Bytes a sample takes in the CSV, for the disk-space check (measured: 24.4; rounded up).
BYTES_PER_SAMPLE = 26
#: Rows generated and written at once.
WRITE_BLOCK = 1_000_000
#: Runs its arguments as the one child of a fresh process and prints that child's peak RSS [kB] and
#: CPU time [s] (``doctor_large.PEAK_OF_CHILD``, with the CPU time beside the peak).
PEAK_AND_CPU_OF_CHILD = """
import resource, subprocess, sys
subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, check=True)
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
print(usage.ru_maxrss, usage.ru_utime + usage.ru_stime)
"""


def write_long_record(path: Path, samples: int, seed: int = 0) -> None:
    """A CSV of ``samples`` rows at :data:`RATE`, written in blocks of :data:`WRITE_BLOCK` rows."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    state = np.zeros(2)  # the lag's state, carried from block to block
    options = pcsv.WriteOptions(include_header=False, quoting_style="none")
    with path.open("wb") as fh:
        fh.write(b"t,u,y\n")
        for start in range(0, samples, WRITE_BLOCK):
            k = np.arange(start, min(samples, start + WRITE_BLOCK))
            t = k / RATE
            u = 6.0 * np.sin(2 * np.pi * 0.05 * t) + 3.75 * np.sin(2 * np.pi * 0.37 * t)
            x = u - 0.01 * u**3
            y, state = lfilter([0.0, 0.05], [1.0, -1.9, 0.905], x, zi=state)
            y += 0.01 * rng.standard_normal(len(k))
            block = pa.table({"t": t, "u": np.round(u, 4), "y": np.round(y, 4)})
            pcsv.write_csv(block, fh, options)


def measure_identify(hours: float, folder: Path) -> list[Row]:
    """Rows for ``motorid identify`` on ``hours`` of record (and on one hour beside it), each run
    once after a warm-up run on a short record (numba's caches and Python's bytecode are then on
    disk, as after any first run)."""
    command = [sys.executable, "-c", PEAK_AND_CPU_OF_CHILD, str(doctor_large.MOTORID), "identify"]
    warm_up = folder / "warm_up.csv"
    write_long_record(warm_up, 10_000)
    run_timed([*command, str(warm_up), "--json"])
    rows = []
    for length in dict.fromkeys((1.0, hours)):
        samples = round(length * 3600 * RATE)
        path = folder / f"long_{samples}.csv"
        if not path.exists():
            need = samples * BYTES_PER_SAMPLE
            free = shutil.disk_usage(folder).free
            if free < need * 1.1:
                raise SystemExit(f"{folder}: {free / 1e9:.1f} GB free, the record needs {need / 1e9:.1f} GB")
            write_long_record(path, samples)
        wall, peak, cpu = run_timed([*command, str(path), "--json"])
        label = f"{length:g} h at {RATE} Hz ({samples:,} samples, {path.stat().st_size / 1e6:,.0f} MB CSV)"
        name = f"motorid identify, {label}"
        rows.append(Row(f"{name}, end to end", samples / wall, None, "samples/s", "", True))
        rows.append(Row(f"{name}, per CPU second", samples / cpu, None, "samples/s", "", True))
        rows.append(Row(f"{name}, wall", wall, None, "s", "", False))
        rows.append(Row(f"{name}, peak RSS", peak, None, "MB", "", False))
    return rows


def run_timed(argv: list[str]) -> tuple[float, float, float]:
    """Wall time [s], peak RSS [MB] and CPU time [s] of ``argv`` (:data:`PEAK_AND_CPU_OF_CHILD`)."""
    start = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, check=True)
    wall = time.perf_counter() - start
    peak_kb, cpu = done.stdout.split()[-2:]
    return wall, int(peak_kb) / 1024, float(cpu)


def measure(hours: float = 24.0, keep: Path | None = None) -> list[Row]:
    with tempfile.TemporaryDirectory() as tmp:
        folder = keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        return measure_identify(hours, folder)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=24.0, help="length of the record [h] (default: 24)")
    parser.add_argument("--keep", type=Path, help="folder for the records, kept (default: temporary)")
    options = parser.parse_args()
    print_rows(measure(options.hours, options.keep), "motorid identify on a long record")
