"""One hour of the default rig at 1 kHz internal steps: fast path beside the reference.

Run: ``.venv/bin/python benchmarks/bench_plant.py [--hours 1] [--reference-seconds 20]``

The fast path simulates the full hour (90 000 samples of 40 ms, 40 internal
steps each = 3.6 million steps) in one compiled call; compilation is excluded
(warm-up call first; numba also caches it on disk). The peer is SciPy's
``solve_ivp`` with events at every friction switch (our reference integrator);
too slow for an hour, it runs a shorter record of the same signal and its time
is extrapolated linearly to the hour; the row's peer name says so.
Target: the fast path <= 5 s for the hour.
"""

from __future__ import annotations

import argparse
import time

from _table import Row, print_rows

from motorid.drive import paper_rig
from motorid.signals import two_sine_signal

TITLE = "Plant simulation: default rig, 40 ms samples, 1 ms internal steps"


def measure(hours: float = 1.0, reference_seconds: float = 20.0) -> list[Row]:
    rig = paper_rig()
    duration = 3600.0 * hours
    _, u = two_sine_signal(duration=duration, dt=rig.dt, seed=0)

    rig.simulate(u[:10], seed=0)  # compile / load the cached kernels
    t0 = time.perf_counter()
    rig.simulate(u, seed=0)
    fast = time.perf_counter() - t0

    n_ref = round(reference_seconds / rig.dt)
    t0 = time.perf_counter()
    rig.simulate(u[:n_ref], seed=0, integrator="reference")
    ref = (time.perf_counter() - t0) * u.size / n_ref

    sim = rig.simulation(seed=0)
    n_online = min(u.size, 20000)
    t0 = time.perf_counter()
    for v in u[:n_online]:
        sim.step(v)
    per_step = (time.perf_counter() - t0) / n_online

    record = f"{duration / 3600:g} h of record"
    return [
        Row(
            f"plant simulate, {record}",
            fast,
            ref,
            "s",
            f"SciPy solve_ivp + events (from {reference_seconds:g} s, extrapolated)",
            False,
        ),
        Row("plant step() online, one 40 ms sample", per_step * 1e6, None, "us", "", False),
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--reference-seconds", type=float, default=20.0)
    args = parser.parse_args()
    print_rows(measure(args.hours, args.reference_seconds), TITLE)
    print("target: the fast path <= 5 s for one hour")


if __name__ == "__main__":
    main()
