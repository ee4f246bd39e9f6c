"""``motorid demo`` and ``motorid simulate``: the simulated rig."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from motorid.errors import DataError

from .options import (
    add_json,
    add_low_speed_band,
    add_out_file,
    add_plant_seed,
    add_signal_options,
    add_wait,
    check_out_file,
    check_out_folder,
    excitation_from_args,
    hold_out_folder,
    non_negative,
    number,
    planned_samples,
    positive,
)
from .report import emit_json, say


def cmd_demo(args: argparse.Namespace) -> int:
    """The paper's experiment on the simulated rig: tables, figures, record."""
    from motorid.experiment import run_paper_experiment
    from motorid.io.records import write_record
    from motorid.outputs import write_file

    out = Path(args.out)
    check_out_folder(out)
    hold_out_folder(args, out)
    say(f"motorid demo: simulating the default rig for {args.duration:g} s and identifying online ...")
    experiment = run_paper_experiment(
        duration=args.duration, seed=args.seed, low_speed_rpm=args.low_speed_rpm
    )
    record_path = out / "demo_record.csv"
    write_record(experiment.record, record_path)
    table = experiment.table()
    write_file(out / "demo_table.csv", table.to_csv, overwrite=True)
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


#: The rig options of ``motorid simulate`` (dest names); none may be combined with --model.
#: Memory a simulated record takes while it is made and written [B per sample]: 280 measured
#: (tracemalloc's peak over 100,000 samples of the paper's rig, 9 columns, written as CSV), rounded up.
SIMULATED_BYTES_PER_SAMPLE = 300

RIG_OPTIONS = (
    "coulomb_motor", "coulomb_load", "stribeck", "stribeck_shape", "viscous", "friction", "dead_zone", "backlash",
    "cogging", "u_max",
)  # fmt: skip
#: The options that change the default rig's friction, which --friction sets whole.
FRICTION_OPTIONS = ("coulomb_motor", "coulomb_load", "stribeck", "stribeck_shape", "viscous")


def mass_parameters() -> list[str]:
    """The parameters of the effects a mass of the two-mass rig can hold (what ``--friction`` sets)."""
    from motorid.drive import effects as registry

    on_a_mass = [e for e in registry.names() if not registry.get(e).not_on_a_mass]
    return [p.name for e in on_a_mass for p in registry.get(e).parameters]


def friction_from_option(items: list[str]):
    """One ``--friction SIDE PARAM=VALUE ...``: a :class:`~motorid.drive.Friction` on SIDE with the
    effects whose parameters are given (``stribeck_shape=gaussian`` sets the decay's shape)."""
    from motorid.drive import Friction
    from motorid.drive import effects as registry

    side, *pairs = items
    where = f"--friction {side}"
    params: dict[str, float] = {}
    shape = "exponential"
    known = mass_parameters()
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep:
            raise DataError(f"{where}: {pair!r} is not PARAM=VALUE")
        if name == "stribeck_shape":
            shape = value
            continue
        if name not in known:
            raise DataError(f"{where}: unknown parameter {name!r}; a mass's effects have {', '.join(known)}")
        try:
            params[name] = float(value)
        except ValueError:
            raise DataError(f"{where}: {name} must be a number, got {value!r}") from None
    if not params:
        raise DataError(f"{where}: give the parameters of its effects as PARAM=VALUE (coulomb=0.004 ...)")
    effects = tuple(dict.fromkeys(map(registry.parameter_owner, params)))
    try:
        return Friction(effects, params, side, shape)
    except ValueError as exc:
        raise DataError(f"{where}: {exc}") from None


def rig_from_args(args: argparse.Namespace):
    """The default rig (:func:`~motorid.drive.paper_rig`) with what the rig options change.

    An option not given keeps the default rig's value, so every default is the
    rig's own and written once, in :mod:`motorid.drive.two_mass`.
    """
    from motorid.drive import Friction, paper_rig
    from motorid.drive.effects import parameter_owner

    rig = paper_rig()
    if args.friction is not None:
        given = [name for name in FRICTION_OPTIONS if getattr(args, name) is not None]
        if given:
            flag = "--" + given[0].replace("_", "-")
            raise DataError(
                f"{flag} cannot be combined with --friction, which sets the masses' friction whole"
            )
        return _rig_parts_from_args(
            rig.replace(friction=tuple(map(friction_from_option, args.friction))), args
        )
    side_params: dict[str, dict[str, float]] = {"motor": {}, "load": {}}
    for f in rig.friction:  # the default rig's friction: one entry per mass
        side_params[f.side].update(f.params)
    for side, given in (("motor", args.coulomb_motor), ("load", args.coulomb_load)):
        if given is not None:
            side_params[side]["coulomb"] = given
    if args.stribeck_shape is not None and args.stribeck is None:
        raise DataError("--stribeck-shape needs --stribeck F_S V_S: the shape of which Stribeck friction?")
    if args.stribeck is not None:
        excess, velocity = args.stribeck
        if not velocity > 0.0:
            raise DataError(f"--stribeck: V_S, the Stribeck velocity [rad/s], must be > 0, got {velocity:g}")
        side_params["motor"].update(stribeck=excess, stribeck_velocity=velocity)
    if args.viscous:
        side_params["motor"]["viscous"] = args.viscous
    friction = []
    for side, params in side_params.items():
        params = {n: v for n, v in params.items() if v or n == "stribeck"}  # a level of 0 is no friction
        if params:
            effects = tuple(dict.fromkeys(map(parameter_owner, params)))
            friction.append(Friction(effects, params, side, args.stribeck_shape or "exponential"))
    return _rig_parts_from_args(rig.replace(friction=tuple(friction)), args)


def _rig_parts_from_args(rig, args: argparse.Namespace):
    """``rig`` with the amplifier, backlash and cogging the rig options give."""
    amplifier = rig.amplifier
    changes = {k: v for k, v in (("dead_zone", args.dead_zone), ("v_max", args.u_max)) if v is not None}
    if changes:
        amplifier = dataclasses.replace(amplifier, **changes)
    backlash = rig.backlash if args.backlash is None else args.backlash
    ripple = {}
    if args.cogging is not None:
        a_s, a_c, periods = args.cogging
        if not periods > 0.0:
            raise DataError(
                f"--cogging: PERIODS must be > 0 [1/rad, periods per revolution], got {periods:g}"
            )
        ripple = {"cogging_sin": a_s, "cogging_cos": a_c, "cogging_periods": periods}
    return rig.replace(amplifier=amplifier, backlash=backlash, **ripple)


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate the rig on an excitation signal and write the record and/or the rig's model file."""
    from motorid.app.identify import drive_model_from_file
    from motorid.drive import RigidDrive
    from motorid.drive.files import read_model_file
    from motorid.io.records import write_record

    if args.out is None and args.save_model is None:
        raise DataError("give --out (the record to write), --save-model (the rig's model file) or both")
    for option, path in (("--out", args.out), ("--save-model", args.save_model)):
        if path is not None:
            check_out_file(path, args.overwrite, option)
    if args.model is not None:
        given = [name for name in RIG_OPTIONS if getattr(args, name) is not None]
        if given:
            flag = "--" + given[0].replace("_", "-")
            raise DataError(f"{flag} cannot be combined with --model: the model file describes the rig")
        rig = drive_model_from_file(args.model)
        card = read_model_file(args.model).card
    else:
        rig, card = rig_from_args(args), None
    if args.out is None:
        rig.save(args.save_model, overwrite=args.overwrite)
        say(f"wrote {args.save_model}: the rig's model file")
        if args.json:
            emit_json({"model": args.save_model, "rig": rig.to_dict()})
        return 0
    planned_samples(args.duration, rig.dt, SIMULATED_BYTES_PER_SAMPLE, "the record")
    u = excitation_from_args(args, rig.dt)
    if isinstance(rig, RigidDrive):  # a rigid drive has no sensor: its record is noise free
        record = rig.simulate(u)
    else:
        record = rig.simulate(u, seed=args.plant_seed, integrator=args.integrator)
    if card is not None:  # the record in the units the model was fitted on, as its card says
        units = {**record.attrs.get("units", {}), **({"u": card.input_unit} if card.input_unit else {}),
                 **({"y": card.output_unit} if card.output_unit else {})}  # fmt: skip
        record.attrs["units"] = units
        if card.input_unit and card.input_unit != "V":
            say(f"  note: {args.model.name} was fitted on {card.input_words()}: the excitation (--amplitude) is "
                f"in {card.input_unit}")  # fmt: skip
    if args.save_model is not None:
        rig.save(args.save_model, overwrite=args.overwrite)
    try:
        write_record(record, args.out, overwrite=args.overwrite)
    except Exception:  # a refused command changes nothing: the model file written a moment ago goes too
        if args.save_model is not None and not args.overwrite:
            args.save_model.unlink()
        raise
    if args.save_model is not None:
        say(f"wrote {args.save_model}: the rig's model file")
    y = record["y"].to_numpy()
    say(f"wrote {args.out}: {len(record)} samples at dt = {rig.dt:g} s, |y| max {np.abs(y).max():.1f} rad/s")
    if args.json:
        emit_json(
            {
                "out": args.out,
                "model": args.save_model,
                "samples": len(record),
                "dt": rig.dt,
                "rig": rig.to_dict(),
            }
        )
    return 0


def add_rig_options(group: argparse._ActionsContainer, model_help: str) -> None:
    """The simulated drive: ``--model FILE``, or the default rig changed by the rig options
    (:data:`RIG_OPTIONS` but ``--u-max``, which each command declares with its own meaning)."""
    group.add_argument("--model", type=Path, metavar="FILE", help=model_help)
    group.add_argument("--coulomb-motor", type=non_negative, help="Coulomb torque, motor side [N m]")
    group.add_argument("--coulomb-load", type=non_negative, help="Coulomb torque, load side [N m]")
    group.add_argument("--stribeck", type=non_negative, nargs=2, metavar=("F_S", "V_S"),
                       help="Stribeck friction, motor side: the excess F_s [N m] at rest over the Coulomb "
                       "level and the Stribeck velocity v_s [rad/s] (stribeck, stribeck_velocity)")  # fmt: skip
    group.add_argument("--stribeck-shape", choices=("exponential", "gaussian"),
                       help="the Stribeck decay: exp(-|w|/V_S) (eq. 9, the default) or exp(-(w/V_S)^2)")  # fmt: skip
    group.add_argument("--viscous", type=non_negative, help="extra viscous friction, motor side [N m s/rad]")
    group.add_argument("--friction", nargs="+", action="append", metavar=("SIDE", "PARAM=VALUE"),
                       help="the friction on a mass (SIDE motor, load or both) in the effects' parameters, SI units, "
                       "e.g. --friction motor coulomb=0.004 breakaway_excess=0.002 (stribeck_shape=gaussian sets "
                       "the decay); repeat it per mass; it replaces the default rig's friction and the options "
                       f"above. PARAM is one of: {', '.join(mass_parameters())}")  # fmt: skip
    group.add_argument("--dead-zone", type=non_negative, help="amplifier dead zone half-width [V]")
    group.add_argument("--backlash", type=non_negative, help="shaft backlash, half-width of the gap [rad]")
    group.add_argument("--cogging", type=number(float), nargs=3, metavar=("SIN", "COS", "PERIODS"),
                       help="the motor's cogging ripple SIN sin(PERIODS θ_m) + COS cos(PERIODS θ_m) [N m], "
                       "PERIODS per revolution")  # fmt: skip


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("demo", help="the paper's experiment on the simulated rig: tables and figures")
    p.add_argument("--out", type=Path, default=Path("out"),
                   help="folder for figures, tables and the record, replaced if there (default: out)")  # fmt: skip
    add_wait(p)
    p.add_argument("--duration", type=positive, default=120.0, help="record length [s] (default: 120)")
    p.add_argument("--seed", type=number(int, low=0), default=0,
                   help="seed of the experiment: test signal and sensor noise (default: 0)")  # fmt: skip
    add_low_speed_band(p)
    add_json(p)
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("simulate", help="simulate the rig and write a record CSV and/or its model file")
    add_out_file(p, "record CSV to write", required=False)
    p.add_argument("--save-model", type=Path, metavar="FILE",
                   help="write the rig as a model file (JSON; motorid simulate/rig serve --model read it)")  # fmt: skip
    add_signal_options(p, duration=120.0)
    add_plant_seed(p, default=0)
    rig = p.add_argument_group("rig (default: the default rig's value, as --save-model writes it)")
    add_rig_options(rig, "the drive from a model file, instead of the options below: a two-mass rig, "
                         "or a rigid drive (motorid doctor --save-model; its record is noise free)")  # fmt: skip
    rig.add_argument("--u-max", type=positive, help="amplifier saturation [V]")
    rig.add_argument("--integrator", choices=("fast", "reference"), default="fast",
                     help="fast: the compiled fixed-step stick/slip integrator; reference: SciPy's solve_ivp "
                          "(slow, for checking)")  # fmt: skip
    add_json(p)
    p.set_defaults(func=cmd_simulate)
