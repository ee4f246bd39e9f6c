"""``motorid identify`` and ``motorid sweep``: estimators on a record."""

from __future__ import annotations

import argparse
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motorid.app.identify import (
    IdentifyOptions,
    band_words,
    create_estimator,
    estimator_for_record,
    identify_file,
    identify_record,
    low_speed_band,
    runs_in_blocks,
    start_model,
    validate_on_record,
    write_identify_figure,
)
from motorid.drive.files import save_model
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
    hold_out_folder,
    int_range,
    iter_record_from_args,
    number,
    read_record_from_args,
    record_options_from_args,
    with_flags,
)
from .report import emit_json, frame_records, say, say_params, say_warning, show_progress


def identify_options_from_args(args: argparse.Namespace) -> IdentifyOptions:
    """``motorid identify``'s options (:func:`add_identify_options`) as :class:`motorid.app.IdentifyOptions`."""
    return IdentifyOptions(**{f.name: getattr(args, f.name) for f in fields(IdentifyOptions)})


def cmd_identify(args: argparse.Namespace) -> int:
    """Identify one estimator on a record; report params, MSE, FIT and residual tests."""
    from motorid.validation import RPM_PER_RAD_S

    options = identify_options_from_args(args)
    # a span (--start/--stop) is cut from the record read whole; an RLS otherwise streams the file
    spanned = args.start is not None or args.stop is not None
    in_blocks = runs_in_blocks(create_estimator(args.estimator, options)) and not spanned
    record = None if in_blocks else read_record_from_args(args)
    if record is not None:
        # a bad estimator option or model stops before the folder is made
        estimator_for_record(record, options, str(args.data))
    else:
        start_model(options)  # --model with an RLS estimator is refused before anything is read
    validation_record = None
    if args.validate is not None:
        # the same record options (columns, dt, units) as the record the model is identified on
        validation_record = read_record_from_args(argparse.Namespace(**{**vars(args), "data": args.validate}))
    if args.out and (record is not None or args.out.exists()):  # else made once the record has passed
        check_out_folder(args.out)
        hold_out_folder(args, args.out)
    if args.save_model:
        check_out_file(args.save_model, args.overwrite, "--save-model")
    if record is None:
        payload, tests, est = identify_file(args.data, options, record_options_from_args(args))
    else:
        payload, tests, est = identify_record(record, options, source=str(args.data), input=args.input,
                                              output=args.output)  # fmt: skip
    if args.out and getattr(args, "out_lock", None) is None:
        check_out_folder(args.out)
        hold_out_folder(args, args.out)
    unit = payload["output_unit"]
    threshold = payload["low_speed_threshold_rad_s" if unit == "rad/s" else "low_speed_threshold"]
    band = band_words(unit, threshold, args.low_speed_rpm)
    say(f"{args.estimator} on {args.data} ({payload['samples']} samples)")
    for note in payload["notes"]:
        say(f"  note: {with_flags(note)}")
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
    for warning in payload["free_run_warnings"]:
        say_warning(warning)
    if payload["residual_tests_samples"] < payload["samples"] - args.skip:
        say(f"  residual tests on the last {payload['residual_tests_samples']} samples of the record "
            "(a bounded window: a record read in blocks is not held whole)")  # fmt: skip
    for test in tests:
        say(f"  residual test {test.formula:<22} {'pass' if test.passed else 'FAIL'}")
    validation = None
    if validation_record is not None:
        validation = validate_on_record(est, validation_record, options, args.validate)
        say_validation(validation)
    if args.save_model:
        try:
            save_model(
                est,
                args.save_model,
                overwrite=args.overwrite,
                card=identified_card(args, record, payload, est),
            )
        except ValueError as exc:
            raise DataError(f"--save-model {args.save_model}: {exc}") from None
        say(f"  wrote {args.save_model}: the identified model, with its units, timing, record and its "
            "parameters' standard errors (motorid.load_model reads it)")  # fmt: skip
    figure = None
    if args.out:
        figure = write_identify_figure(tests, args.out, args.estimator)
        if figure is not None:
            say(f"  wrote {figure}")
    if args.json:
        extra = {} if validation is None else {"validation": validation}
        emit_json({**payload, "figure": figure, "model": args.save_model, **extra})
    return 0


def identified_card(
    args: argparse.Namespace, record: pd.DataFrame | None, payload: dict[str, Any], est: Any
) -> Any:
    """The card of the model ``motorid identify`` fitted (:func:`motorid.app.model_cards.record_card`):
    the record held whole, or, read in blocks, its first block with the span of the ``samples``
    the payload counts; each parameter's standard error from the estimator's covariance and the
    one-step MSE (:func:`motorid.app.model_cards.estimator_parameters`)."""
    import dataclasses

    from motorid.app.model_cards import estimator_parameters, record_card

    read = record_options_from_args(args)
    if record is None:
        first = next(iter_record_from_args(args))
        card = record_card([first], [args.data], supply_voltage=read.supply_voltage,
                           input_full_scale=read.input_full_scale)  # fmt: skip
        samples = payload["samples"]
        records = tuple(
            {**entry, "samples": samples, "stop": entry["start"] + (samples - 1) * card.dt}
            for entry in card.records
        )
        card = dataclasses.replace(card, records=records)
    else:
        card = record_card([record], [args.data], supply_voltage=read.supply_voltage,
                           input_full_scale=read.input_full_scale)  # fmt: skip
    parameters = estimator_parameters(est, payload["scores"]["one_step"]["mse"])
    return dataclasses.replace(card, parameters=parameters)


def say_validation(validation: dict[str, Any]) -> None:
    """The human text of :func:`validate_on_record`."""
    from motorid.validation import RPM_PER_RAD_S, divergence_words

    say(
        f"  on {validation['record']} ({validation['samples']} samples), the identified model without refitting:"
    )
    for note in validation["notes"]:
        say(f"  note: {with_flags(note)}")
    diverged = validation["free_run_diverges_from_sample"]
    row = validation["scores"].get("free_run")
    if diverged is not None:
        say_warning(f"on {validation['record']}, {divergence_words('the model', diverged, row is not None)}")
    if row is None:
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
    from motorid.validation import check_scored_samples, check_signals, order_sweep

    record = read_record_from_args(args)
    check_scored_samples(len(record), args.skip, str(args.data))
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
    add_record_input(p, "with --estimator friction-ekf or friction-ukf, which hold the record whole: refuse a "
                     "longer record (default: %(default)s); the RLS estimators read a record of any length "
                     "in blocks, in memory that does not grow with it")  # fmt: skip
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
    p.add_argument("--prediction", choices=("one_step", "free_run"), default="one_step",
                   help="score each model by its one-step prediction (the paper's tables) or its free run")  # fmt: skip
    add_low_speed_band(p)
    add_skip(p)
    add_json(p)
    p.set_defaults(func=cmd_sweep)
