"""The doctor's final parameters fitted to the free run, against those fitted to the torque balance.

The doctor fits every model to the torque balance of a record (equation error) and judges it by
its free run. :func:`motorid.diagnose.model.fit_output_error` refits the final model's parameters
(the inertia and every level and coefficient of its effects; the input gain, the delay, the lag and
a static friction's breakaway stay) to the free-run speed error of the record, or of every record
of a joint run. This script measures what that does on real motors: for each run of
``scripts/realmotors_doctor.py`` (the kit motor's six records and four wheel motors' two, each alone
and jointly) the free-run gap [rad/s] before and after, and the inertia and kinetic friction level
of each; per motor, the spread of those over its records (largest minus smallest, over their
mean). For EMPS, the final model's free-run speed refit on the train set scored by the benchmark's
protocol (test-set position RMSE [mm]), beside the doctor's fit and the refit in position
(:func:`motorid.diagnose.position.refit_in_position`).

Usage::

    python scripts/free_run_refit.py [--motors kit wheel] [--emps]

Measured (``python scripts/free_run_refit.py --emps``, 80 s):

- the kit motor: the free-run gap shrinks by 0.8-12.0 % on its records alone (the 0.5 Hz sines
  12 %, the 1 Hz sines 2 %, the chirps 1 %), by 0.1 % on its joint run (3.096 -> 3.093 rad/s);
  its parameters agree no better: the inertia spreads 13.1 % over the six records before and
  13.8 % after (the four sines come together at 0.0065-0.0067, the chirps, with their 2 ms input
  delay, stay at 0.0058-0.0060), the kinetic friction 7.8 % before and 9.0 % after;
- the wheel motors: the gap shrinks by 0.3-1.9 % on the records, 0.0-1.0 % on the joint runs;
  the kinetic friction of train and validation comes 2-4 times closer (spreads 7.5-14.3 % before,
  3.0-5.3 % after), the inertia (0.2-2.1 % before) moves both ways (0.3-1.2 % after);
- EMPS: the final model (with asymmetric friction) refitted to the free-run speed of the train
  set scores 11.36 mm on the test set, against 9.06 mm as the doctor fits it and 7.02 mm refitted
  in position.

So the doctor keeps the torque balance's parameters (with their standard errors): the free run's
shrink the gaps by about 1 % on joint runs and do not make one motor's records agree.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import emps_benchmark
import realmotors_doctor


def refit(d):
    """The final model of diagnosis ``d`` with its parameters fitted to the free run of its records."""
    from motorid.diagnose.model import fit_output_error

    return fit_output_error(d.model, d._pool.free_run_error)


def kinetic(params: dict[str, float]) -> float:
    """The kinetic friction level [F] of a model's parameters (Coulomb, else a dead zone's)."""
    return params.get("coulomb", params.get("input_gain", 1.0) * params.get("dead_zone", float("nan")))


def spread(values: list[float]) -> float:
    """Largest minus smallest over the mean [%]."""
    return 100.0 * (max(values) - min(values)) / float(np.mean(values))


def motor_rows(motor: str) -> list[str]:
    """The rows of one motor: each record alone, its joint run, then the spreads over its records."""
    from motorid.diagnose import diagnose

    names, unit = realmotors_doctor.MOTORS[motor]
    records = [realmotors_doctor.read(n, unit) for n in names]
    runs = [(n, diagnose(r)) for n, r in zip(names, records, strict=True)]
    runs.append((realmotors_doctor.joint_label(len(names)), diagnose(records, labels=names)))
    rows, before, after = [], {"inertia": [], "kinetic": []}, {"inertia": [], "kinetic": []}
    for k, (name, d) in enumerate(runs):
        fitted = refit(d)
        g0, g1 = d._pool.gaps(d.model, None).overall, d._pool.gaps(fitted, None).overall
        p0, p1 = d.model.params, fitted.params
        rows.append(
            f"| {motor} | {name} | {g0:.3f} → {g1:.3f} ({100 * (g1 / g0 - 1):+.1f} %) | "
            f"{p0['inertia']:.4g} → {p1['inertia']:.4g} | {kinetic(p0):.4g} → {kinetic(p1):.4g} |"
        )
        if k < len(names):
            for out, p in ((before, p0), (after, p1)):
                out["inertia"].append(p["inertia"])
                out["kinetic"].append(kinetic(p))
    rows.append(
        f"| {motor} | spread over the records | | {spread(before['inertia']):.1f} % → "
        f"{spread(after['inertia']):.1f} % | {spread(before['kinetic']):.1f} % → {spread(after['kinetic']):.1f} % |"
    )
    return rows


def emps_row() -> str:
    """EMPS: the final model's test-set figure [mm] as fitted, refitted in speed and in position."""
    from motorid.datasets import emps_benchmark_rmse, load_emps_benchmark
    from motorid.diagnose.position import refit_in_position

    train, test = load_emps_benchmark()
    d = emps_benchmark.run_doctor(train)
    figures = [emps_benchmark_rmse(m, test) for m in (d.model, refit(d), refit_in_position(d.model, train))]
    return (
        "EMPS test-set RMSE [mm]: doctor's fit {:.2f}, refitted in speed {:.2f}, in position {:.2f}".format(
            *figures
        )
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--motors", nargs="+", choices=["kit", "wheel"], default=["kit", "wheel"])
    parser.add_argument("--emps", action="store_true", help="also the EMPS benchmark's figure")
    args = parser.parse_args(argv)
    print("| motor | run | free-run gap [rad/s] | inertia | kinetic friction |")
    print("| --- | --- | ---: | ---: | ---: |")
    for motor in realmotors_doctor.MOTORS:
        if motor.split()[0] in args.motors:
            for row in motor_rows(motor):
                print(row, flush=True)
    if args.emps:
        print(emps_row())
    return 0


if __name__ == "__main__":
    sys.exit(main())
