"""A rigid drive (the doctor's model) with every input-path memory: a whole record and a sample at a time.

Run: ``.venv/bin/python benchmarks/bench_rigid.py [--seconds 600]``

The drive has a dead zone, saturation, a fractional input delay, an input lag, a backlash dwell,
Coulomb, Stribeck, viscous and static friction, at 100 Hz. ``simulate`` runs the record in one
pass of the compiled maps; ``simulation().step`` runs the same record a sample at a time (what a
simulated DAQ and ``motorid rig serve --model`` do), giving the same speeds to the last bit. The
peer of the step is the default two-mass rig's ``step`` (the other plant a rig server hosts).
The friction EKF on the drive (whose input path it runs with the same memory) is timed online
(``predict`` + ``update`` per sample) beside the EKF on the drive without delay and lag.
Compilation is excluded (a warm-up first).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _table import Row, print_rows

from motorid.drive import RigidDrive, paper_rig
from motorid.estimators import FrictionEKF
from motorid.testing import every_input_memory_drive

TITLE = "Rigid drive: whole record and online steps"

DRIVE = every_input_memory_drive()


def without_memory(drive: RigidDrive) -> RigidDrive:
    """``drive`` without its input delay and lag (and the backlash the filters do not hold)."""
    effects = tuple(e for e in drive.effects if e not in ("input_delay", "input_lag", "backlash"))
    drop = ("input_delay", "lag_time_constant", "backlash_time")
    return drive.with_effects(effects, {k: v for k, v in drive.params.items() if k not in drop})


def online_ekf(drive: RigidDrive, u: np.ndarray) -> float:
    """Seconds per sample of the friction EKF's predict + update on ``drive`` (its backlash left
    out: the filters do not hold it), measuring the drive's own free run."""
    drive = drive.with_effects(
        tuple(e for e in drive.effects if e != "backlash"),
        {k: v for k, v in drive.params.items() if k != "backlash_time"},
    )
    y = drive.free_run(u)
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    ekf.predict(0.0)
    ekf.update(0.0)
    ekf.reset()
    t0 = time.perf_counter()
    for k in range(u.size):
        ekf.predict(u[k])
        ekf.update(y[k])
    return (time.perf_counter() - t0) / u.size


def measure(seconds: float = 600.0) -> list[Row]:
    rng = np.random.default_rng(0)
    n = round(seconds / DRIVE.dt)
    u = np.repeat(rng.uniform(-8.0, 8.0, n // 20 + 1), 20)[:n]
    DRIVE.simulate(u[:50])  # compile / load the cached kernels
    t0 = time.perf_counter()
    record = DRIVE.simulate(u)["y"].to_numpy()
    whole = (time.perf_counter() - t0) / n

    simulation = DRIVE.simulation()
    simulation.step(0.0)
    simulation.reset()
    t0 = time.perf_counter()
    steps = np.array([simulation.step(v) for v in u])
    per_step = (time.perf_counter() - t0) / n
    if not np.array_equal(steps, record):
        raise AssertionError("the steps differ from the record")

    rig = paper_rig().simulation(seed=0)
    rig.step(0.0)
    m = min(n, 20000)
    t0 = time.perf_counter()
    for v in u[:m]:
        rig.step(v)
    rig_step = (time.perf_counter() - t0) / m
    ekf_online = [online_ekf(d, u[:m]) for d in (DRIVE, without_memory(DRIVE))]
    return [
        Row(
            f"rigid drive simulate, per sample ({seconds:g} s at 100 Hz)", whole * 1e6, None, "us", "", False
        ),
        Row(
            "rigid drive step() online, one sample",
            per_step * 1e6,
            rig_step * 1e6,
            "us",
            "two-mass rig step() (40 ms sample, 40 internal steps)",
            False,
        ),
        Row(
            "friction EKF online on it (delay, lag, static friction), one sample",
            ekf_online[0] * 1e6,
            ekf_online[1] * 1e6,
            "us",
            "the same EKF on the drive without delay and lag",
            False,
        ),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=600.0)
    args = parser.parse_args()
    print_rows(measure(args.seconds), TITLE)


if __name__ == "__main__":
    main()
