"""``motorid doctor``: find the effect missing from a drive model and show the gap shrink."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from motorid.app.doctor import DoctorOptions, save_doctor_model, start_model_from_file
from motorid.errors import DataError
from motorid.io.records import RecordOptions
from motorid.outputs import write_file

from .options import (
    RECORD_FILES,
    add_json,
    add_record_columns,
    add_wait,
    check_out_file,
    check_out_folder,
    hold_out_folder,
    number,
    positive,
    record_options_from_args,
    with_flags,
)
from .report import emit_json, say, show_progress

if TYPE_CHECKING:
    from motorid.diagnose.results import Diagnosis, RestSummary


def effect_list(text: str | None, option: str) -> list[str]:
    """Comma-separated effect names, each checked against the library (none for None)."""
    from motorid.drive.effects import names as effect_names

    if text is None:
        return []
    names = [n.strip() for n in text.split(",") if n.strip()]
    for name in names:
        if name not in effect_names():
            raise DataError(f"{option}: unknown effect {name!r}; known effects: {', '.join(effect_names())}")
    return names


def doctor_options_from_args(args: argparse.Namespace) -> DoctorOptions:
    """``motorid doctor``'s options as :class:`motorid.app.DoctorOptions` (effect names checked)."""
    base = effect_list(args.base, "--base") if args.base is not None else None
    candidates = effect_list(args.candidates, "--candidates") if args.candidates else None
    model = args.model
    if model is not None and base is not None:
        raise DataError("--base cannot be combined with --model: the model's effects are the base")
    return DoctorOptions(
        output_kind=args.output_kind, input_gain=args.input_gain, base=base, candidates=candidates,
        holdout=args.holdout, max_steps=args.max_steps, timing=args.timing, structure=not args.no_structure,
        align=args.align, model=model,
        reference_column=getattr(args, "reference_column", None),  # motorid doctor only: a fleet reads t, u, y
    )  # fmt: skip


def with_reference(
    record: pd.DataFrame, path: Path, reading: RecordOptions, given: str | None, segment: bool
) -> pd.DataFrame:
    """``record`` with its closed loop's reference column: ``--reference-column``, else the one its
    attributes name (``attrs["loop"]["reference"]``, as ``motorid control --out`` writes), read with
    the same options and span; the record itself where neither names one, or where it is a segment
    of a longer record (said)."""
    from motorid.io.records import read_record

    column = given if given is not None else (record.attrs.get("loop") or {}).get("reference")
    if column is None or column in record.columns:
        return record
    if segment:
        if given is not None:
            raise DataError(f"--reference-column {column}: {path} is longer than --max-samples; the reference "
                            "of a segment is not read (raise --max-samples, or cut it with --start/--stop)")  # fmt: skip
        say(f"  note: {path} is longer than --max-samples: its reference {column!r} is not read, and the "
            "segment is fitted as an open loop")  # fmt: skip
        return record
    whole = read_record(path, reading, other_columns=True)  # the same columns, units and span
    if column not in whole.columns:
        raise DataError(f"--reference-column {column}: {path} has no such column (it has "
                        f"{', '.join(map(str, whole.columns))})")  # fmt: skip
    out = record.assign(**{column: whole[column].to_numpy()})
    out.attrs = dict(record.attrs)
    return out


def cmd_doctor(args: argparse.Namespace) -> int:
    """Find the missing effect: where model and measurement disagree, which effect, how much better."""
    options = doctor_options_from_args(args)  # bad effect names stop the command before anything is read
    if args.model is not None:
        start_model_from_file(args.model)
    if args.save_model is not None:
        check_out_file(args.save_model, True, "--save-model")
    from motorid.io.records import read_head

    reading = record_options_from_args(args)
    read = [read_head(path, reading, min_samples=20, speed=True) for path in args.data]
    read = [(with_reference(r, path, reading, args.reference_column, segment), segment)
            for path, (r, segment) in zip(args.data, read, strict=True)]  # fmt: skip
    records = [record for record, _ in read]
    labels = [str(path) for path in args.data]
    validation = None
    if args.validate is not None:
        # the same record options (columns, dt, units, span) as the records the models are fitted on
        validation, _ = read_head(args.validate, reading, min_samples=20, speed=True)
    if args.out:
        check_out_folder(args.out)
        hold_out_folder(args, args.out)
    diagnosis = options.diagnose(records[0] if len(records) == 1 else records, labels, show_progress())
    units, param_units = diagnosis.units, diagnosis.param_units
    start = f"the model in {args.model}" if args.model is not None else "inertia, input gain"
    if len(records) == 1:
        on = f"{args.data[0]} ({len(records[0])} samples)"
    else:
        on = f"{len(records)} records of one drive ({sum(len(r) for r in records)} samples), one model"
    say(f"motorid doctor on {on}, base model: {start}" + "".join(f", {b}" for b in diagnosis.settings.base))
    for note in diagnosis.notes:
        say(f"  note: {note}")
    for loop in diagnosis.closed_loop:
        say(f"  {loop.label + ': ' if len(records) > 1 else ''}{with_flags(loop.sentence())}")
    for path, (record, segment) in zip(args.data, read, strict=True):
        if segment:
            say(f"  a segment: {path} is longer than --max-samples; the doctor works on its first "
                f"{len(record)} samples ({len(record) * record.attrs['dt']:g} s) and holds no more")  # fmt: skip
    if diagnosis.refitted_gap is not None:
        say(f"  gap of the given model {diagnosis.initial_gap.overall:.4g} {units['v']}, "
            f"refitted {diagnosis.refitted_gap.overall:.4g} {units['v']}")  # fmt: skip
    if args.input_gain is None and args.model is None:
        say(f"  no --input-gain: forces are per input unit, in {units['F']}")
    structure = diagnosis.structure
    say(f"  base structure: {structure.describe(diagnosis.model.dt)} ({structure.reason})")
    say(f"  located: {diagnosis.region.description}")
    table = diagnosis.table()
    if len(table):
        with pd.option_context("display.width", 160, "display.max_columns", 12, "display.max_colwidth", 48):
            say(f"  gaps [{units['v']}] and force error [%] per step:")
            say(table.round(4).to_string())
    for step in diagnosis.steps:
        params = ", ".join(f"{k} = {v:.5g} {param_units[k]}" for k, v in step.params.items())
        say(f"  + {step.effect}: {params} at this step (ΔBIC {step.evidence.delta_bic:.1f})")
        if step.lookalike is not None:
            say(f"    {step.lookalike.describe(units)}")
    say(
        f"  gap {diagnosis.initial_gap.overall:.4g} -> {diagnosis.final_gap.overall:.4g} {units['v']}, "
        f"force error {diagnosis.initial_gap.force_error_percent:.2f} % -> "
        f"{diagnosis.final_gap.force_error_percent:.2f} %"
    )
    if diagnosis.records:
        say(f"  gaps per record [{units['v']}] (above: pooled over the records):")
        say(record_table(diagnosis).to_string())
        if diagnosis.agreement:
            say("  each record fitted alone with the joint model's structure (± one standard error):")
        for agreement in diagnosis.agreement:
            say(f"    {agreement.describe(param_units[agreement.unit_of])}")
    bands = ", ".join(
        f"{b.noise_floor:.3g} "
        + (f"below {b.speed_to:.3g}" if k == 0 else f"at {b.speed_from:.3g}-{b.speed_to:.3g}")
        for k, b in enumerate(diagnosis.noise_bands)
    )
    step = diagnosis.quantisation_step
    say(
        f"  noise floor by speed [{units['v']}]: {bands}"
        + (f"; the output steps by {step:.4g}" if step else "")
    )
    for rest in diagnosis.rests:
        label = f"{rest.record}: " if len(diagnosis.rests) > 1 else ""
        if not rest.count:
            say(f"  rests: {label}none (the speed never stays at zero between motions)")
            continue
        say(
            f"  rests: {label}{rest.count}, median {1000 * rest.median_length:.0f} ms, breaking away at a "
            f"median {rest.median_breakaway_input:.3g} {units['u']}; {breakaway_words(rest, diagnosis.model.dt, units, diagnosis.model.params.get('breakaway_excess', 0.0))}"
        )
    say(f"  stopped: {diagnosis.stop_reason}")
    final = ", ".join(
        f"{k} = {v:.5g}"
        + (f" ± {diagnosis.param_std[k]:.2g}" if k in diagnosis.param_std else "")
        + f" {param_units[k]}"
        for k, v in diagnosis.model.params.items()
    )
    say(f"  final model, every parameter refitted with the effects found (± one standard error): {final}")
    if diagnosis.position_error is not None:
        pe = diagnosis.position_error
        say(
            f"  free-run position error {pe.fitted:.4g} {pe.unit}; the final model's parameters refitted "
            f"in position: {pe.refitted:.4g} {pe.unit}"
        )
    for name, why in diagnosis.undetermined.items():
        which = "these records" if diagnosis.records else "this record"
        say(f"  {name}: not determined by {which} ({why}); its fitted value is kept for the free run only")
    scores = None
    if validation is not None:
        scores = diagnosis.evaluate(validation)
        say(f"  on {args.validate} ({len(validation)} samples), the models above without refitting:")
        with pd.option_context("display.width", 160):
            say(scores.round(4).to_string())
    if args.save_model is not None:
        kind = save_doctor_model(diagnosis, args.save_model, records, args.data,
                                 supply_voltage=reading.supply_voltage, input_full_scale=reading.input_full_scale)  # fmt: skip
        say(f"  wrote {args.save_model}: {kind}, with its units, timing, sensor and records "
            "(motorid simulate --model reads it)")  # fmt: skip
    figures = []
    if args.out:
        say(f"  writing figures in {args.out}/")
        figures = diagnosis.write_figures(args.out)
        write_file(args.out / "doctor_table.csv", table.to_csv, overwrite=True)
        say(f"  wrote {len(figures)} figures and doctor_table.csv in {args.out}/")
    if args.json:
        out = {**diagnosis.to_dict(), "figures": figures, "segment": any(segment for _, segment in read)}
        if scores is not None:
            out["validation"] = {"record": str(args.validate), "models": scores.to_dict(orient="index")}
        emit_json(out)
    return 0


def breakaway_words(rest: RestSummary, dt: float, units: dict[str, str], model_excess: float = 0.0) -> str:
    """What a record's rests say of the breakaway, and the level a friction compensation should use
    with its sign.

    The level the rests measure is ΔF_s, the force at breakaway above the kinetic level at an input
    rising infinitely slowly (:class:`~motorid.diagnose.measures.Breakaway`): shown where above two
    standard errors; within two of zero, the higher input at breakaway is the input's lag; below
    zero by more, the measure does not hold (no friction breaks away below its kinetic level): the
    sample taken as the breakaway comes before the force that broke the drive away, as where the
    input steps past the breakaway level within a sample (the steps' size is said where the
    input's rate there, times ``dt`` [s], is larger than the kinetic level). Not measured where
    fewer than 3 rests read it, as where the input's force stepped past the breakaway within a
    sample (:data:`~motorid.diagnose.prepare.BRACKET_SHARE`): the rests bracket it, and the
    sentence says at how many.

    The compensation: the kinetic level once the drive moves, and to break it away the kinetic level
    plus the final model's static friction ``model_excess`` [F] (the model saved), or, in a model
    without it, plus the rests' ΔF_s where they show it. Its sign is the speed's it drives:
    + forwards, - backwards.
    """
    force = units["F"]
    kinetic = rest.kinetic_level
    excess, error = rest.breakaway_excess, rest.breakaway_excess_std
    shown = math.isfinite(excess) and excess > 2.0 * error
    above = model_excess if model_excess > 0 else (excess if shown else 0.0)
    signed = f"+{kinetic:.3g} {force} forwards, -{kinetic:.3g} {force} backwards"
    if above > 0:
        whose = "the model's static friction" if model_excess > 0 else "the rests'"
        breakaway = kinetic + above
        compensation = (f"a compensation should break it away with the kinetic level plus {whose}, "
                        f"+{breakaway:.3g} {force} forwards, -{breakaway:.3g} {force} backwards, and use the "
                        f"kinetic level once it moves: {signed}")  # fmt: skip
    else:
        compensation = f"a compensation should use the kinetic level: {signed}"
    if not math.isfinite(excess):
        if error == math.inf:
            why = "not told from a lag (the input rises alike at each)"
        elif rest.breakaway_bracketed:
            from motorid.diagnose.prepare import BRACKET_SHARE

            why = (f"not measured: at {rest.breakaway_bracketed} of them the input steps past the breakaway "
                   f"within a sample (by more than {100 * BRACKET_SHARE:g} % of the input the drive moved under), "
                   "which brackets it but does not read it")  # fmt: skip
        else:
            why = "not measured: fewer than 3 of them break away under a rising input"
        return f"its level above the kinetic one {why}; {compensation}"
    measured = f"{excess:.3g} ± {error:.2g} {force} from the kinetic level {kinetic:.3g} {force}"
    if rest.breakaway_one_rate and math.isfinite(
        rest.breakaway_lag
    ):  # one excess at one rate, read both ways
        measured += f", or a lag of {1e3 * rest.breakaway_lag:.3g} ms (the input rises alike at each)"
    if shown:
        return f"static friction: at a slowly rising input it breaks away {measured}; {compensation}"
    if excess >= -2.0 * error:
        lag = (
            f" (the input at breakaway is higher where it rises faster: a lag of {1000 * rest.breakaway_lag:.2g} "
            "ms between input and force)"
            if rest.breakaway_lag > 0
            else ""
        )
        return (f"no static friction shown: at a slowly rising input it breaks away {measured}, within two "
                f"standard errors{lag}; {compensation}")  # fmt: skip
    step = rest.median_input_rate * dt
    steps = (
        f": its input steps past the breakaway level within a sample (a median {step:.3g} {units['u']} a "
        "sample there)"
        if step > kinetic
        else ""
    )
    return (f"the force at breakaway measures {measured}, below it, which no friction does: the sample "
            f"taken as the breakaway comes before the force that broke the drive away{steps}, so the rests "
            f"do not measure the breakaway level; {compensation}")  # fmt: skip


def record_table(diagnosis: Diagnosis) -> pd.DataFrame:
    """Each record's noise floor and gaps [v], initial and final model, and the final gap in noise floors."""
    rows = {
        r.record: {
            "samples": r.samples,
            "noise_floor": round(r.noise_floor, 4),
            "gap_initial": round(r.initial_gap.overall, 4),
            "gap_final": round(r.final_gap.overall, 4),
            "floors": round(r.final_gap_noise_floors, 2),
            "force_error_final_percent": round(r.final_gap.force_error_percent, 3),
        }
        for r in diagnosis.records
    }
    table = pd.DataFrame.from_dict(rows, orient="index")
    table.index.name = "record"
    return table


def add_doctor_options(parser: argparse.ArgumentParser) -> None:
    """The options of ``motorid doctor`` besides the record and --out (``fleet doctor`` takes them too)."""
    parser.add_argument("--output-kind", choices=("velocity", "position"), default="velocity",
                        help="what the output column is (default: velocity)")  # fmt: skip
    parser.add_argument("--input-gain", type=positive,
                        help="force or torque per input unit [N/V, N m/V] (default: unknown; the "
                             "model's forces are then per input unit, e.g. in V)")  # fmt: skip
    from motorid.drive.effects import names as effect_names

    known = ", ".join(effect_names())
    parser.add_argument("--base", metavar="EFFECT,...",
                        help=f"effects already in the model, comma-separated, of: {known} "
                             "(default: viscous_friction,offset)")  # fmt: skip
    parser.add_argument("--candidates", metavar="EFFECT,...",
                        help="effects to try, comma-separated, of the same names (default: the others; "
                             "position_friction only on a position record)")  # fmt: skip
    parser.add_argument("--holdout", type=number(float, low=0.0, high=0.9, low_open=True), default=0.3,
                        help="share of the record held out, in (0, 0.9] (default: 0.3)")  # fmt: skip
    parser.add_argument(
        "--max-steps", type=number(int, low=0), default=3, help="most effects added (default: 3)"
    )
    parser.add_argument(
        "--timing", choices=("hold", "sampled", "auto"), default=None,
        help="input/output timing: hold (y[k] at the end of the interval u[k] is held over; the "
        "default, or the record's own), sampled (a controller reads y[k], then holds u[k]), auto",
    )  # fmt: skip
    parser.add_argument("--no-structure", action="store_true",
                        help="keep the base as given: do not choose an input delay and lag from the record "
                             "before judging friction")  # fmt: skip
    parser.add_argument("--align", action="store_true",
                        help="where a record's input delay drifts along it (a logger's time base: the "
                             "report says so either way), put its input on its output's time and "
                             "diagnose again")  # fmt: skip
    parser.add_argument("--model", type=Path, metavar="FILE",
                        help="start from your own drive model file, a rigid drive or a two-mass rig (searched "
                             "on its rigid equivalent): the first gap is it as given")  # fmt: skip


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("doctor", help="find the effect missing from a drive model and show the gap shrink")
    p.add_argument("data", type=Path, nargs="+",
                   help=f"record file ({RECORD_FILES}); several records of one drive are fitted as one model "
                        "(shared parameters, each record its own start) and judged on the pooled evidence")  # fmt: skip
    add_record_columns(p, "work on the first this many samples of a longer record (a segment, said in the "
                       "output); the doctor's memory grows with it, 0.9 GB at the default (%(default)s)")  # fmt: skip
    add_doctor_options(p)
    p.add_argument("--reference-column", metavar="COL",
                   help="the column of a closed loop's reference: the record is then read with timing "
                        "'sampled' where it names none, and the balance refitted with the reference as "
                        "instrument (default: the column a motorid control record names)")  # fmt: skip
    p.add_argument("--out", type=Path, help="folder for the figures and the table (replaced if there)")
    add_wait(p)
    p.add_argument("--validate", type=Path, metavar="FILE",
                   help="a second record of the same drive (read with the same options): the models "
                        "found are scored on it without refitting")  # fmt: skip
    p.add_argument("--save-model", type=Path, metavar="FILE",
                   help="write the improved model as a model file (replaced if there): a rigid drive, or a "
                        "two-mass rig when --model gave one")  # fmt: skip
    add_json(p)
    p.set_defaults(func=cmd_doctor)
