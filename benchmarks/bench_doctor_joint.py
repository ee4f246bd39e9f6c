"""Wall time of ``motorid doctor A.csv ... F.csv --json``: one joint run over six 30 s records of
one drive at 1 kHz (180,000 samples), beside the six single-record runs it replaces.

Run: ``.venv/bin/python benchmarks/bench_doctor_joint.py [--repeat 3]`` (or within ``make bench``).

The records are six excitations of one simulated drive (the paper's rig with Coulomb friction,
``planted_record(..., dt=0.001, excitation_seed=k)``), written as CSV. Each figure is the median
wall time [s] over ``--repeat`` fresh processes after one warm-up run (numba's caches and
Python's bytecode on disk, as after any first run), and the peak resident memory [MB] of the
largest. The peer row is the same six records diagnosed one at a time, each in its own process
(what a user ran before the joint run): the joint run does one search over the pooled rows, so
its ratio says what pooling costs or saves beside it. Not a test: it prints figures.
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

RECORDS, SECONDS, DT = 6, 30.0, 0.001


def make_records(folder: Path) -> list[Path]:
    """Six 30 s records of one drive at 1 kHz, as CSV files in ``folder``."""
    from motorid.diagnose.synthetic import planted_record
    from motorid.io.records import write_record

    paths = []
    for k in range(RECORDS):
        planted = planted_record("coulomb_friction", 3, duration=SECONDS, dt=DT, excitation_seed=k)
        paths.append(folder / f"run{k + 1}.csv")
        write_record(planted.record, paths[-1])
    return paths


def measure_joint(repeat: int = 3) -> list[Row]:
    """The joint run's and the six single runs' median wall time and largest peak RSS."""
    with tempfile.TemporaryDirectory() as tmp:
        paths = [str(p) for p in make_records(Path(tmp))]
        joint = [str(doctor_large.MOTORID), "doctor", *paths, "--json"]
        singles = [[str(doctor_large.MOTORID), "doctor", p, "--json"] for p in paths]
        walls: dict[str, list[float]] = {"joint": [], "singles": []}
        peaks = {"joint": 0.0, "singles": 0.0}
        for attempt in range(repeat + 1):
            wall, peak, _, _ = doctor_large.measure(joint)
            runs = [doctor_large.measure(argv) for argv in singles]
            if attempt:  # the first run fills numba's caches and writes bytecode
                walls["joint"].append(wall)
                peaks["joint"] = max(peaks["joint"], peak)
                walls["singles"].append(sum(r[0] for r in runs))
                peaks["singles"] = max([peaks["singles"], *(r[1] for r in runs)])
    label = f"{RECORDS} records of {SECONDS:g} s at {1 / DT:g} Hz ({RECORDS * round(SECONDS / DT):,} samples)"
    peer = f"{RECORDS} single-record runs, one after the other"
    return [
        Row(f"motorid doctor, one joint run, {label}, wall", statistics.median(walls["joint"]),
            statistics.median(walls["singles"]), "s", peer, False),
        Row(f"motorid doctor, one joint run, {label}, peak RSS", peaks["joint"], peaks["singles"], "MB",
            "the largest single-record run", False),
    ]  # fmt: skip


def measure() -> list[Row]:
    return measure_joint()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="measured runs of each command")
    print_rows(measure_joint(parser.parse_args().repeat), "motorid doctor, several records of one drive")
