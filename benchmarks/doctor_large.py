"""Wall time and peak memory of ``motorid doctor`` and ``diagnose()`` on long records.

Run: ``.venv/bin/python benchmarks/doctor_large.py [--samples 2000000] [--dt 0.005] [--keep DIR]``

Two records of the default rig (:func:`motorid.plants.paper_rig` at ``dt``, driven by
:func:`motorid.plants.signals.two_sine_signal`): an 80 s one and one of ``--samples``
samples. Each is diagnosed in a fresh process, once by ``motorid doctor REC --json --out
DIR`` and once by ``diagnose()`` in Python (read with :func:`motorid.records.read_record`),
and the script prints the wall time [s] (start-up and reading included), the peak resident
memory [MB] (``ru_maxrss`` of that process) and whether the progress bar reached stderr. Not a test: it prints figures.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from motorid.plants import paper_rig
from motorid.plants.signals import two_sine_signal
from motorid.records import write_record

MOTORID = Path(sys.executable).with_name("motorid")
PYTHON_RUN = """
import sys
from motorid.diagnose import diagnose
from motorid.records import read_record
d = diagnose(read_record(sys.argv[1], max_samples=10**8))
print(d.named)
"""
#: Runs its arguments as the one child of a fresh process and prints that child's peak RSS [kB].
PEAK_OF_CHILD = """
import resource, subprocess, sys
subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, check=True)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
"""


def make_record(path: Path, samples: int, dt: float) -> None:
    """A record of the default rig: columns t [s], u [V], y [rad/s]."""
    _, u = two_sine_signal(duration=samples * dt, dt=dt, seed=0)
    record = paper_rig(dt=dt).simulate(u[:samples], seed=0)[["t", "u", "y"]]
    record.attrs = {"dt": dt, "units": {"t": "s", "u": "V", "y": "rad/s"}, "timing": "hold"}
    write_record(record, path)


def measure(argv: list[str]) -> tuple[float, float, str]:
    """Wall time [s], peak RSS [MB] and stderr of ``argv`` run in a fresh process."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", PEAK_OF_CHILD, *argv], capture_output=True, text=True, check=True
    )
    wall = time.perf_counter() - t0
    return wall, int(done.stdout.split()[-1]) / 1024, done.stderr


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2_000_000)
    parser.add_argument("--dt", type=float, default=0.005, help="sample time [s]")
    parser.add_argument("--keep", type=Path, help="folder for the records and figures (default: temporary)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        print(f"{'record':>28} {'run':>16} {'wall [s]':>9} {'peak RSS [MB]':>14} {'progress on stderr':>19}")
        for samples in (round(80.0 / args.dt), args.samples):
            path = folder / f"rig_{samples}.csv"
            if not path.exists():
                make_record(path, samples, args.dt)
            label = f"{samples} samples, {samples * args.dt:g} s"
            runs = {
                "motorid doctor": [str(MOTORID), "doctor", str(path), "--max-samples", str(samples),
                                   "--json", "--out", str(folder / f"doctor_{samples}")],
                "diagnose()": [sys.executable, "-c", PYTHON_RUN, str(path)],
            }  # fmt: skip
            for name, argv in runs.items():
                wall, peak, err = measure(argv)
                shown = "yes" if "doctor:" in err and "stage" in err else "-"
                print(f"{label:>28} {name:>16} {wall:9.1f} {peak:14.0f} {shown:>19}", flush=True)


if __name__ == "__main__":
    main()
