"""``motorid identify`` and ``motorid sweep``: estimators on a record."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motorid.errors import DataError

from .options import (
    add_estimator_options,
    add_json,
    add_lam,
    add_low_speed_band,
    add_record_input,
    add_skip,
    add_wait,
    check_out_file,
    check_out_folder,
    create_estimator,
    hold_out_folder,
    int_range,
    low_speed_band,
    number,
    read_record_from_args,
)
from .report import emit_json, frame_records, say, say_params, show_progress


def require_finite_estimate(name: str, x: np.ndarray, u: np.ndarray, y: np.ndarray) -> None:
    """Refuse an estimate that stopped being finite, naming the first sample where it did.

    A result with NaN or inf is never reported as a success: it means the record
    drove the estimator out of floating-point range (an outlier, a unit mistake).
    """
    bad = ~np.isfinite(x).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise DataError(f"estimator {name!r}: its estimate is not finite from sample {k} on "
                        f"(u = {u[k]:.6g}, y = {y[k]:.6g} there); check the record around row {k}")  # fmt: skip


#: The key of a record's attrs that holds the simulated rig (:meth:`motorid.plants.TwoMassRig.simulate`
#: writes it): a record that has it is motorid's own simulation.
SIMULATED_RIG_ATTR = "rig"


def start_model_from_args(args: argparse.Namespace) -> Any:
    """The drive model of ``--model`` a friction filter starts from (None without ``--model``),
    checked before any record is read: the estimator must start from a model (have
    ``from_rig``), the file must hold a drive model, and a rigid drive needs ``--param R=``."""
    from motorid.estimators import available, factory
    from motorid.plants import RigidDrive

    from .simulation import drive_model_from_file

    model_file = getattr(args, "model", None)
    if model_file is None:
        return None
    if args.estimator not in available() or not hasattr(factory(args.estimator), "from_rig"):
        create_estimator(args.estimator, args)  # an unknown name is named first
        raise DataError(
            f"--model: estimator {args.estimator!r} identifies its model from the record alone; "
            "--model starts a friction filter (friction-ekf, friction-ukf) from a drive model"
        )
    model = drive_model_from_file(model_file)
    if isinstance(model, RigidDrive) and not any(p.partition("=")[0] == "R" for p in args.param):
        raise DataError(
            f"--model {model_file} is a rigid drive, which has no sensor model: give the variance of the "
            "speed measurement with --param R=VALUE [(output unit)^2]"
        )
    return model


def estimator_for_record(record: pd.DataFrame, args: argparse.Namespace) -> tuple[Any, list[str]]:
    """The estimator ``--estimator`` names, for this record, and what it assumes (notes for the user).

    An estimator that starts from a drive model (a friction filter, which has ``from_rig``)
    takes the constants and friction of ``--model FILE`` (a two-mass rig or the doctor's rigid
    drive: :func:`start_model_from_args`). Without ``--model`` it runs on the default rig's
    constants, which only motorid's own simulation (a record whose attrs carry its rig) is
    known to share: any other record is refused, naming ``--model``. The record's input unit
    must be what the model takes (:func:`motorid.comparison.input_unit_note`): duty in % is
    refused by a model in volts; its output a velocity (:func:`motorid.comparison.check_output_unit`).
    """
    from motorid.comparison import check_output_unit, input_unit_note
    from motorid.estimators import available, factory
    from motorid.plants import paper_rig

    model = start_model_from_args(args)
    units = record.attrs.get("units")
    if model is not None:
        check_output_unit(model, units, f"--model {args.model}")
        note = input_unit_note(model, units, f"--model {args.model}")
        return create_estimator(args.estimator, args, rig=model), [note] if note else []
    if args.estimator not in available() or not hasattr(factory(args.estimator), "from_rig"):
        return create_estimator(args.estimator, args), []
    if SIMULATED_RIG_ATTR not in record.attrs:
        raise DataError(
            f"{args.data}: the {args.estimator} needs the drive's model, and this record (not motorid's own "
            "simulation) carries none: give it with --model FILE (motorid doctor --save-model writes one)"
        )
    check_output_unit(paper_rig(), units, "the default rig")
    note = input_unit_note(paper_rig(), units, "the default rig")
    notes = [note] if note else []
    notes.append(
        "no --model: the filter runs on the default rig's constants (the record is motorid's simulation)"
    )
    return create_estimator(args.estimator, args), notes


def identify_record(record: pd.DataFrame, args: argparse.Namespace) -> tuple[dict[str, Any], list, Any]:
    """What ``motorid identify`` computes on a record with columns ``t``, ``u``, ``y``.

    Returns the ``--json`` payload (without ``figure``), the residual tests (for the figure) and
    the identified estimator (for ``--save-model``).
    ``motorid fleet identify`` calls this very function on each record, so a fleet's rows equal
    the single-record command's output.
    """
    from motorid.comparison import holds_input
    from motorid.estimators.base import first_bad_index
    from motorid.records import record_timing
    from motorid.validation import (
        RPM_PER_RAD_S,
        check_signals,
        residual_tests,
        score_predictions,
    )

    est, notes = estimator_for_record(record, args)
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    check_signals({args.input: u, args.output: y})
    if holds_input(est) and record_timing(record.attrs) == "sampled":
        # a physical model's output is at the end of the sample its input is held over
        u, y = u[:-1], y[1:]
        notes.append("the record's timing is sampled: u[k] is paired with y[k+1], the output it drives")
    result = est.batch_filter(u, y)
    require_finite_estimate(args.estimator, result.x, u, y)
    predictions = {"one_step": result.y_hat}
    free_run = est.simulate(u)
    diverged = first_bad_index(free_run)
    if diverged is None:
        predictions["free_run"] = free_run
    unit, threshold, _ = low_speed_band(record, args.low_speed_rpm)
    scores = score_predictions(y, predictions, threshold, args.skip)
    in_rpm = unit == "rad/s"
    tests = residual_tests(u[args.skip :], (y - result.y_hat)[args.skip :], max_lag=args.max_lag)
    payload = {
        "estimator": args.estimator,
        "samples": len(record),
        "params": est.params,
        "scores": {
            kind: {**row, **({"mse_rpm2": row["mse"] * RPM_PER_RAD_S**2} if in_rpm else {})}
            for kind, row in scores.to_dict("index").items()
        },
        "free_run_diverges_from_sample": diverged,
        "output_unit": unit,
        ("low_speed_threshold_rad_s" if in_rpm else "low_speed_threshold"): threshold,
        "residual_tests": {
            t.name: {"passed": t.passed, "fraction_outside": t.fraction_outside} for t in tests
        },
        "notes": notes,
    }
    param_units = getattr(est, "param_units", None)  # declared by the friction filters
    if param_units:
        payload["units"] = {"params": dict(param_units)}
    return payload, tests, est


def validate_on_record(est: Any, record: pd.DataFrame, args: argparse.Namespace) -> dict[str, Any]:
    """The identified model ``est`` on a second record, without refitting: its free run on that
    record's input scored as ``identify`` scores its own (``validation`` of the ``--json`` output).

    The free run is :func:`motorid.comparison.compare_models`'s (the record's timing and the
    model's input unit minded, the first ``--skip`` samples left out).
    """
    from motorid.comparison import compare_models
    from motorid.validation import RPM_PER_RAD_S

    unit, threshold, _ = low_speed_band(record, args.low_speed_rpm)
    run = compare_models(record, {args.estimator: est}, threshold, args.skip)
    model = run.models[0]
    scores = {}
    if model.diverges_from is None:
        row = {"mse": model.mse, "rmse": model.rmse, "fit_percent": model.fit_percent,
               "low_speed_mse": model.low_speed_mse, "n_low_speed": model.n_low_speed}  # fmt: skip
        scores["free_run"] = {
            **row,
            **({"mse_rpm2": row["mse"] * RPM_PER_RAD_S**2} if unit == "rad/s" else {}),
        }
    return {
        "record": args.validate,
        "samples": len(record),
        "scores": scores,
        "free_run_diverges_from_sample": model.diverges_from,
        "output_unit": unit,
        "notes": list(model.notes),
    }


def write_identify_figure(tests: list, folder: Path, estimator: str) -> Path:
    """The residual-test figure of :func:`identify_record` as ``folder/residual_tests.png``."""
    from motorid.validation import plot_residual_tests

    figure = folder / "residual_tests.png"
    plot_residual_tests(tests, str(figure), f"Residuals of {estimator} (one-step)")
    return figure


def cmd_identify(args: argparse.Namespace) -> int:
    """Identify one estimator on a record; report params, MSE, FIT and residual tests."""
    from motorid.validation import RPM_PER_RAD_S

    record = read_record_from_args(args)
    estimator_for_record(record, args)  # a bad estimator option or model stops before the folder is made
    validation_record = None
    if args.validate is not None:
        # the same record options (columns, dt, units) as the record the model is identified on
        validation_record = read_record_from_args(argparse.Namespace(**{**vars(args), "data": args.validate}))
    if args.out:
        check_out_folder(args.out)
        hold_out_folder(args, args.out)
    if args.save_model:
        check_out_file(args.save_model, args.overwrite, "--save-model")
    payload, tests, est = identify_record(record, args)
    diverged = payload["free_run_diverges_from_sample"]
    unit, _, band = low_speed_band(record, args.low_speed_rpm)
    say(f"{args.estimator} on {args.data} ({len(record)} samples)")
    for note in payload["notes"]:
        say(f"  note: {note}")
    say_params("", payload["params"])
    for kind, row in payload["scores"].items():
        if unit == "rad/s":
            mse = f"MSE {row['mse']:.4g} (rad/s)^2 = {row['mse'] * RPM_PER_RAD_S**2:.4g} rpm^2"
            low = f"low-speed MSE {row['low_speed_mse'] * RPM_PER_RAD_S**2:.4g} rpm^2"
        else:  # the record's own unit, or none named: no rpm is invented
            square = f"({unit or 'output units'})^2"
            mse, low = f"MSE {row['mse']:.4g} {square}", f"low-speed MSE {row['low_speed_mse']:.4g} {square}"
        say(f"  {kind:<9} {mse}, {low}, FIT {row['fit_percent']:.2f} %")
    if unit != "rad/s":
        say(f"  low speed: {band}")
    if diverged is not None:
        say(f"  free_run  diverges from sample {diverged} on: the identified model is unstable on this input, "
            "so it has no free-run score")  # fmt: skip
    for test in tests:
        say(f"  residual test {test.formula:<22} {'pass' if test.passed else 'FAIL'}")
    validation = None
    if validation_record is not None:
        validation = validate_on_record(est, validation_record, args)
        say_validation(validation)
    if args.save_model:
        try:
            est.save(args.save_model, overwrite=args.overwrite)
        except ValueError as exc:
            raise DataError(f"--save-model {args.save_model}: {exc}") from None
        say(f"  wrote {args.save_model}: the identified model (motorid.load_model reads it)")
    figure = None
    if args.out:
        figure = write_identify_figure(tests, args.out, args.estimator)
        say(f"  wrote {figure}")
    if args.json:
        extra = {} if validation is None else {"validation": validation}
        emit_json({**payload, "figure": figure, "model": args.save_model, **extra})
    return 0


def say_validation(validation: dict[str, Any]) -> None:
    """The human text of :func:`validate_on_record`."""
    from motorid.validation import RPM_PER_RAD_S

    say(
        f"  on {validation['record']} ({validation['samples']} samples), the identified model without refitting:"
    )
    for note in validation["notes"]:
        say(f"  note: {note}")
    row = validation["scores"].get("free_run")
    if row is None:
        say(f"  free_run  diverges from sample {validation['free_run_diverges_from_sample']} on: no score")
        return
    unit = validation["output_unit"]
    if unit == "rad/s":
        mse = f"MSE {row['mse']:.4g} (rad/s)^2 = {row['mse_rpm2']:.4g} rpm^2"
        low = f"low-speed MSE {row['low_speed_mse'] * RPM_PER_RAD_S**2:.4g} rpm^2"
    else:  # the record's own unit, or none named
        square = f"({unit or 'output units'})^2"
        mse, low = f"MSE {row['mse']:.4g} {square}", f"low-speed MSE {row['low_speed_mse']:.4g} {square}"
    say(f"  free_run  {mse}, {low}, FIT {row['fit_percent']:.2f} %")


def cmd_sweep(args: argparse.Namespace) -> int:
    """The paper's Tables 1 and 2 on a record."""
    from motorid.validation import check_signals, order_sweep

    record = read_record_from_args(args)
    check_signals({args.input: record["u"], args.output: record["y"]})
    unit, threshold, band = low_speed_band(record, args.low_speed_rpm)
    tables = order_sweep(
        record["u"].to_numpy(), record["y"].to_numpy(), args.orders, args.degrees,
        degree=args.degree, order=args.order, lam=args.lam, prediction=args.prediction,
        low_speed_threshold=threshold, skip=args.skip, progress=show_progress(), output_unit=unit,
    )  # fmt: skip
    mse_unit = tables.orders.attrs["units"]["mse"]
    with pd.option_context("display.width", 140, "display.max_columns", 12):
        say(f"Table 1: MSE [{mse_unit}] per model order (degree {args.degree}), {args.prediction} prediction"
            f"; low speed: {band}")  # fmt: skip
        say(tables.orders.round(3).to_string())
        say(f"\nTable 2: MSE [{mse_unit}] and gamma per polynomial degree (order {args.order})")
        say(tables.degrees.to_string(float_format=lambda v: f"{v:.5g}"))
    if not all(
        np.isfinite(table.filter(like="mse").to_numpy()).all() for table in (tables.orders, tables.degrees)
    ):
        say("inf: that model's free run diverges (it is unstable on this input); null in --json")
    if args.json:
        emit_json(
            {
                "table1": frame_records(tables.orders),
                "table2": frame_records(tables.degrees),
                ("low_speed_threshold_rad_s" if unit == "rad/s" else "low_speed_threshold"): threshold,
                "mse_unit": mse_unit,
                "prediction": tables.prediction,
            }
        )
    return 0


def add_identify_options(parser: argparse.ArgumentParser) -> None:
    """The options of ``motorid identify`` besides the record and --out (``fleet identify`` takes them too)."""
    add_estimator_options(parser)
    add_low_speed_band(parser)
    add_skip(parser)
    parser.add_argument("--max-lag", type=number(int, low=1), default=25,
                        help="largest lag of the residual tests [samples] (default: 25)")  # fmt: skip
    parser.add_argument("--model", type=Path, metavar="FILE",
                        help="friction-ekf/ukf: start from this drive model file (a two-mass rig, or the "
                             "doctor's rigid drive, which needs --param R=...); needed on a record that is "
                             "not motorid's own simulation")  # fmt: skip


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("identify", help="identify an estimator on a record")
    add_record_input(p)
    add_identify_options(p)
    p.add_argument("--out", type=Path, help="folder for the residual-test figure (replaced if there)")
    add_wait(p)
    p.add_argument("--save-model", type=Path, metavar="FILE",
                   help="write the identified estimator as a model file (JSON; motorid.load_model reads it)")  # fmt: skip
    p.add_argument("--overwrite", action="store_true", help="replace an existing --save-model file")
    p.add_argument("--validate", type=Path, metavar="FILE",
                   help="a second record of the same drive (read with the same options): the identified "
                        "model's free run is scored on it without refitting")  # fmt: skip
    add_json(p)
    p.set_defaults(func=cmd_identify)

    p = sub.add_parser("sweep", help="the paper's Tables 1 and 2 on a record")
    add_record_input(p)
    p.add_argument("--orders", type=int_range, default=list(range(1, 7)), help="model orders (default: 1-6)")
    p.add_argument("--degrees", type=int_range, default=list(range(2, 6)), help="degrees (default: 2-5)")
    p.add_argument("--order", type=number(int, low=1), default=4, help="model order of Table 2 (default: 4)")
    p.add_argument("--degree", type=number(int, low=1), default=3,
                   help="polynomial degree of Table 1 (default: 3)")  # fmt: skip
    add_lam(p, default=1.0)
    p.add_argument("--prediction", choices=("one_step", "free_run"), default="one_step")
    add_low_speed_band(p)
    add_skip(p)
    add_json(p)
    p.set_defaults(func=cmd_sweep)
