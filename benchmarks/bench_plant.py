"""One hour of the default rig at 1 kHz internal steps: fast path beside the reference.

Run: ``.venv/bin/python benchmarks/bench_plant.py [--reference-seconds 20]``

The fast path simulates the full hour (90 000 samples of 40 ms, 40 internal
steps each = 3.6 million steps) in one compiled call; compilation is excluded
(warm-up call first; numba also caches it on disk). The solve_ivp reference is
too slow for an hour, so it runs a shorter record of the same signal and its
time is extrapolated linearly to one hour; the output says so.
"""

from __future__ import annotations

import argparse
import time

from motorid.plants import paper_rig
from motorid.plants.signals import two_sine_signal


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0)
    parser.add_argument("--reference-seconds", type=float, default=20.0)
    args = parser.parse_args()

    rig = paper_rig()
    duration = 3600.0 * args.hours
    _, u = two_sine_signal(duration=duration, dt=rig.dt, seed=0)
    n_steps = u.size * rig.substeps

    rig.simulate(u[:10], seed=0)  # compile / load the cached kernels
    t0 = time.perf_counter()
    rig.simulate(u, seed=0)
    fast = time.perf_counter() - t0

    n_ref = round(args.reference_seconds / rig.dt)
    t0 = time.perf_counter()
    rig.simulate(u[:n_ref], seed=0, integrator="reference")
    ref_short = time.perf_counter() - t0
    ref = ref_short * u.size / n_ref

    t0 = time.perf_counter()
    rig.reset(seed=0)
    n_online = min(u.size, 20000)
    for v in u[:n_online]:
        rig.step(v)
    per_step = (time.perf_counter() - t0) / n_online

    print(
        f"plant benchmark: default rig, {duration:.0f} s record, dt = {rig.dt} s, "
        f"{rig.substeps} internal steps per sample (h = {rig.h * 1e3:.3g} ms), "
        f"{u.size} samples, {n_steps} internal steps"
    )
    print(
        f"  fast (numba, fixed step)       {fast:9.3f} s   "
        f"({fast / n_steps * 1e9:.0f} ns per internal step; target <= 5 s)"
    )
    print(
        f"  reference (solve_ivp, events)  {ref:9.1f} s   "
        f"(extrapolated from {ref_short:.2f} s for {n_ref} samples = "
        f"{args.reference_seconds:g} s of record)"
    )
    print(f"  ratio reference / fast         {ref / fast:9.0f} x")
    print(f"  online rig.step()              {per_step * 1e6:9.1f} us per sample (mean of {n_online} calls)")


if __name__ == "__main__":
    main()
