"""Fleet throughput: ``motorid fleet doctor`` records per second on 1 and 2 Dask workers.

Run: ``.venv/bin/python benchmarks/bench_fleet.py [--drives 8] [--days 5] [--duration 30]``

A generated fleet (:mod:`motorid.fleet.synthetic`, 30 s records of 750 samples by
default) is diagnosed three ways, each timing only the records (compilation and
the cluster's start are left out: a warm-up record runs first, and the start is
its own row; each figure is the best of 3 runs):

- the single-process loop: the same per-record task called in this process, one
  record after the other (the peer of the 1-worker run: what the cluster adds);
- a LocalCluster of 1 worker process, through ``run_fleet`` (results stored as
  they complete, as the command does);
- a LocalCluster of 2 worker processes (the peer: 1 worker, so the ratio is the
  scaling on this machine's cores);
- 1 worker again, writing each record's figures (the peer: without figures).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from _table import Row, print_rows

from motorid.fleet import DoctorJob, RecordOptions, fleet_client, run_fleet
from motorid.fleet.jobs import RecordTask
from motorid.fleet.synthetic import make_fleet, write_fleet

TITLE = "Fleet: motorid fleet doctor, records per second"
DOCTOR = DoctorJob(base=("coulomb_friction", "viscous_friction", "offset"))
#: Each figure is the best of this many runs (the machine is shared: the best run is the least disturbed).
REPEATS = 3


def _task(figures: Path | None = None) -> RecordTask:
    return RecordTask(DOCTOR, RecordOptions(), figures=figures)


def _cluster_rate(
    paths: list[Path], workers: int, folder: Path, figures: bool = False
) -> tuple[float, float]:
    """(records/s through run_fleet on ``workers`` processes, cluster start [s])."""
    task = _task(folder / f"figures{workers}" if figures else None)
    t0 = time.perf_counter()
    with fleet_client(workers=workers) as client:
        start = time.perf_counter() - t0
        warm = [str(paths[0])] * workers
        client.gather(client.map(task, warm, [{}] * workers, pure=False))  # each worker compiles once
        best = float("inf")
        for repeat in range(REPEATS):
            t0 = time.perf_counter()
            out = folder / f"w{workers}{'f' if figures else ''}-{repeat}"
            run = run_fleet(paths, task, out, client, progress=False)
            best = min(best, time.perf_counter() - t0)
            if run.failed:
                raise RuntimeError(f"{run.failed} records failed on {workers} workers")
    return len(paths) / best, start


def measure(drives: int = 8, days: int = 5, duration: float = 30.0) -> list[Row]:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        paths = write_fleet(folder / "records", make_fleet(drives, seed=0), days, duration=duration)
        task = _task()
        task(str(paths[0]), {})  # compile
        best = float("inf")
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            for path in paths:
                row = task(str(path), {})
                if row["status"] != "ok":
                    raise RuntimeError(f"{path}: {row['error']}")
            best = min(best, time.perf_counter() - t0)
        loop = len(paths) / best
        one, start1 = _cluster_rate(paths, 1, folder)
        two, start2 = _cluster_rate(paths, 2, folder)
        drawn, _ = _cluster_rate(paths, 1, folder, figures=True)
    n = f"{len(paths)} records of {duration:g} s"
    return [
        Row(f"fleet doctor, single-process loop, {n}", loop, None, "records/s", "", True),
        Row(f"fleet doctor, 1 Dask worker, {n}", one, loop, "records/s", "the single-process loop", True),
        Row(
            f"fleet doctor, 2 Dask workers ({os.cpu_count()} cores), {n}",
            two,
            one,
            "records/s",
            "1 worker",
            True,
        ),
        Row(
            "fleet doctor, per record on 1 worker",
            1e3 / one,
            1e3 / loop,
            "ms",
            "the single-process loop",
            False,
        ),
        Row(
            "fleet doctor with its figures, per record on 1 worker",
            1e3 / drawn,
            1e3 / one,
            "ms",
            "without figures",
            False,
        ),
        Row("LocalCluster start, 1 / 2 workers", start1, start2, "s", "2 workers' start", False),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=8)
    parser.add_argument("--days", type=int, default=5)
    parser.add_argument("--duration", type=float, default=30.0, help="record length [s]")
    args = parser.parse_args()
    print_rows(measure(args.drives, args.days, args.duration), TITLE)


if __name__ == "__main__":
    main()
