"""``motorid demo`` and ``motorid simulate``: the simulated rig."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from .options import (
    add_json,
    add_low_speed_band,
    add_out_file,
    add_plant_seed,
    add_signal_options,
    add_u_max,
    check_out_file,
    check_out_folder,
    excitation_from_args,
    non_negative,
    number,
    positive,
)
from .report import emit_json, say


def cmd_demo(args: argparse.Namespace) -> int:
    """The paper's experiment on the simulated rig: tables, figures, record."""
    from motorid.experiment import run_paper_experiment
    from motorid.records import write_record

    out = Path(args.out)
    check_out_folder(out)
    say(f"motorid demo: simulating the default rig for {args.duration:g} s and identifying online ...")
    experiment = run_paper_experiment(
        duration=args.duration, seed=args.seed, low_speed_rpm=args.low_speed_rpm
    )
    record_path = out / "demo_record.csv"
    write_record(experiment.record, record_path)
    table = experiment.table()
    table.to_csv(out / "demo_table.csv")
    figures = experiment.write_figures(out)
    with pd.option_context("display.width", 140, "display.max_columns", 10):
        say(f"\nMSE [rpm^2] over the whole record and at low speed (|y| < {args.low_speed_rpm:g} rpm):")
        say(table.round(2).to_string())
    say(f"\nwrote {record_path}, {out / 'demo_table.csv'} and {len(figures)} figures in {out}/")
    if args.json:
        emit_json(
            {
                "table": [
                    {"model": m, "prediction": p, **row}
                    for (m, p), row in zip(table.index, table.to_dict("records"), strict=True)
                ],
                "params": {label: run.estimator.params for label, run in experiment.runs.items()},
                "record": record_path,
                "figures": figures,
            }
        )
    return 0


def rig_from_args(args: argparse.Namespace):
    """The default rig with the friction, dead zone, backlash and rating the options give."""
    from motorid.plants import Amplifier, CoulombFriction, StribeckFriction, ViscousFriction, paper_rig

    friction = []
    if args.coulomb_motor > 0:
        friction.append(CoulombFriction(alpha=args.coulomb_motor, side="motor"))
    if args.coulomb_load > 0:
        friction.append(CoulombFriction(alpha=args.coulomb_load, side="load"))
    if args.stribeck is not None:
        a1, a2 = args.stribeck
        friction.append(StribeckFriction(alpha0=0.0, alpha1=a1, alpha2=a2, side="motor"))
    if args.viscous > 0:
        friction.append(ViscousFriction(B=args.viscous, side="motor"))
    return paper_rig(
        friction=tuple(friction),
        amplifier=Amplifier(gain=1.0, dead_zone=args.dead_zone, v_max=args.u_max),
        backlash=args.backlash,
    )


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate the rig on an excitation signal and write the record."""
    from motorid.records import write_record

    check_out_file(args.out, args.overwrite)
    rig = rig_from_args(args)
    u = excitation_from_args(args, rig.dt)
    record = rig.simulate(u, seed=args.plant_seed, integrator=args.integrator)
    write_record(record, args.out)
    y = record["y"].to_numpy()
    say(f"wrote {args.out}: {len(record)} samples at dt = {rig.dt:g} s, |y| max {np.abs(y).max():.1f} rad/s")
    if args.json:
        emit_json({"out": args.out, "samples": len(record), "dt": rig.dt, "rig": record.attrs.get("rig")})
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the paper's experiment on the simulated rig: tables and figures")
    p.add_argument("--out", type=Path, default=Path("out"),
                   help="folder for figures, tables and the record, replaced if there (default: out)")  # fmt: skip
    p.add_argument("--duration", type=positive, default=120.0, help="record length [s] (default: 120)")
    p.add_argument("--seed", type=number(int, low=0), default=0,
                   help="seed of the experiment: test signal and sensor noise (default: 0)")  # fmt: skip
    add_low_speed_band(p)
    add_json(p)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("simulate", help="simulate the rig and write a record CSV")
    add_out_file(p, "record CSV to write")
    add_signal_options(p, duration=120.0)
    add_plant_seed(p, default=0)
    rig = p.add_argument_group("rig")
    rig.add_argument("--coulomb-motor", type=non_negative, default=4e-3,
                     help="Coulomb torque, motor side [N m] (default: 0.004)")  # fmt: skip
    rig.add_argument("--coulomb-load", type=non_negative, default=2e-3,
                     help="Coulomb torque, load side [N m] (default: 0.002)")  # fmt: skip
    rig.add_argument("--stribeck", type=non_negative, nargs=2, metavar=("ALPHA1", "ALPHA2"),
                     help="Stribeck excess [N m] and decay [s/rad], motor side")  # fmt: skip
    rig.add_argument("--viscous", type=non_negative, default=0.0,
                     help="extra viscous friction, motor side [N m s/rad] (default: 0)")  # fmt: skip
    rig.add_argument("--dead-zone", type=non_negative, default=0.6,
                     help="amplifier dead zone half-width [V] (default: 0.6)")  # fmt: skip
    rig.add_argument("--backlash", type=non_negative, default=0.0,
                     help="shaft backlash, total play [rad] (default: 0)")  # fmt: skip
    add_u_max(rig, "amplifier saturation")
    rig.add_argument("--integrator", choices=("fast", "reference"), default="fast")
    add_json(p)
    p.set_defaults(func=cmd_simulate)
