"""Wall time and peak memory of ``motorid doctor`` and ``diagnose()`` on long records.

Run: ``.venv/bin/python benchmarks/doctor_large.py [--samples 2000000] [--dt 0.005] [--repeat 1] [--keep DIR]``

Two records of the default rig (:func:`motorid.drive.paper_rig` at ``dt``, driven by
:func:`motorid.signals.two_sine_signal`): an 80 s one and one of ``--samples``
samples (``--samples 0``: the 80 s one only). Each is diagnosed in a fresh process by
``motorid doctor REC --json`` (no figures: matplotlib is not imported), by ``motorid doctor
REC --json --out DIR`` and by ``diagnose()`` in Python (read with
:func:`motorid.io.records.read_record`), ``--repeat`` times each, the runs alternated; the script
prints the median and the smallest wall time [s] (start-up and reading included) and the largest
peak resident memory [MB] (``ru_maxrss`` of that process). Not a test: it prints figures.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from motorid.drive import paper_rig
from motorid.io.records import write_record
from motorid.signals import two_sine_signal

MOTORID = Path(sys.executable).with_name("motorid")
PYTHON_RUN = """
import sys
from motorid.diagnose import diagnose
from motorid.io.records import read_record
d = diagnose(read_record(sys.argv[1], max_samples=10**8))
print(d.named)
"""
#: Runs its arguments as the one child of a fresh process and prints that child's peak RSS [kB]
#: and CPU time (user + system) [s].
PEAK_OF_CHILD = """
import resource, subprocess, sys
subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, check=True)
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
print(usage.ru_maxrss, usage.ru_utime + usage.ru_stime)
"""


def make_record(path: Path, samples: int, dt: float) -> None:
    """A record of the default rig: columns t [s], u [V], y [rad/s]."""
    _, u = two_sine_signal(duration=samples * dt, dt=dt, seed=0)
    record = paper_rig(dt=dt).simulate(u[:samples], seed=0)[["t", "u", "y"]]
    record.attrs = {"dt": dt, "units": {"t": "s", "u": "V", "y": "rad/s"}, "timing": "hold"}
    write_record(record, path)


def measure(argv: list[str], env: dict[str, str] | None = None) -> tuple[float, float, float, str]:
    """Wall time [s], peak RSS [MB], CPU time [s] and stderr of ``argv`` run in a fresh process
    (environment ``env``, default this one's)."""
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", PEAK_OF_CHILD, *argv], capture_output=True, text=True, check=True, env=env
    )
    wall = time.perf_counter() - t0
    peak_kb, cpu = done.stdout.split()[-2:]
    return wall, int(peak_kb) / 1024, float(cpu), done.stderr


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=2_000_000)
    parser.add_argument("--dt", type=float, default=0.005, help="sample time [s]")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each command (alternated)")
    parser.add_argument("--keep", type=Path, help="folder for the records and figures (default: temporary)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        print(f"{'record':>28} {'run':>22} {'median wall [s]':>16} {'min wall [s]':>13} "
              f"{'peak RSS [MB]':>14}")  # fmt: skip
        for samples in dict.fromkeys(s for s in (round(80.0 / args.dt), args.samples) if s > 0):
            path = folder / f"rig_{samples}.csv"
            if not path.exists():
                make_record(path, samples, args.dt)
            label = f"{samples} samples, {samples * args.dt:g} s"
            doctor = [str(MOTORID), "doctor", str(path), "--max-samples", str(samples), "--json"]
            runs = {
                "motorid doctor --json": doctor,
                "motorid doctor --out": [*doctor, "--out", str(folder / f"doctor_{samples}")],
                "diagnose()": [sys.executable, "-c", PYTHON_RUN, str(path)],
            }
            walls: dict[str, list[float]] = {name: [] for name in runs}
            peaks: dict[str, float] = dict.fromkeys(runs, 0.0)
            for _ in range(args.repeat):
                for name, argv in runs.items():
                    wall, peak, _, _ = measure(argv)
                    walls[name].append(wall)
                    peaks[name] = max(peaks[name], peak)
            for name in runs:
                print(f"{label:>28} {name:>22} {statistics.median(walls[name]):16.2f} {min(walls[name]):13.2f} "
                      f"{peaks[name]:14.0f}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
