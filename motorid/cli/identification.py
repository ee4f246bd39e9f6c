"""``motorid identify`` and ``motorid sweep``: estimators on a record."""

from __future__ import annotations

import argparse
import itertools
import logging
from collections.abc import Callable, Iterable, Iterator
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
    band_words,
    check_out_file,
    check_out_folder,
    create_estimator,
    hold_out_folder,
    int_range,
    iter_record_from_args,
    low_speed_band,
    number,
    output_band,
    read_record_from_args,
)
from .report import emit_json, frame_records, say, say_params, show_progress

logger = logging.getLogger(__name__)


def require_finite_estimate(
    name: str, x: np.ndarray, u: np.ndarray, y: np.ndarray, first_row: int = 0
) -> None:
    """Refuse an estimate that stopped being finite, naming the first sample where it did
    (``first_row``: the record's row of ``x[0]``, when ``x`` is a block of it).

    A result with NaN or inf is never reported as a success: it means the record
    drove the estimator out of floating-point range (an outlier, a unit mistake).
    """
    bad = ~np.isfinite(x).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        row = first_row + k
        raise DataError(f"estimator {name!r}: its estimate is not finite from sample {row} on "
                        f"(u = {u[k]:.6g}, y = {y[k]:.6g} there); check the record around row {row}")  # fmt: skip


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
    the single-record command's output. An estimator that runs in blocks (:func:`runs_in_blocks`)
    is run over the record in the blocks ``motorid identify`` reads a file in
    (:func:`identify_blocks`), so the numbers are those of the file read in blocks.
    """
    from motorid.comparison import holds_input
    from motorid.estimators.base import first_bad_index
    from motorid.record_chunks import CHUNK_ROWS
    from motorid.records import record_timing
    from motorid.validation import (
        RPM_PER_RAD_S,
        check_signals,
        residual_tests,
        score_predictions,
    )

    est, notes = estimator_for_record(record, args)
    if runs_in_blocks(est):
        u_all, y_all = record["u"].to_numpy(), record["y"].to_numpy()
        unit, threshold, _ = low_speed_band(record, args.low_speed_rpm)
        return identify_blocks(
            lambda: (
                (u_all[k : k + CHUNK_ROWS], y_all[k : k + CHUNK_ROWS])
                for k in range(0, len(record), CHUNK_ROWS)
            ),
            args, est, notes, unit, threshold,
        )  # fmt: skip
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
        "residual_tests_samples": len(record) - args.skip,
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


def runs_in_blocks(estimator: Any) -> bool:
    """Whether ``estimator`` is identified on a record in blocks (:func:`identify_blocks`): an RLS
    on a lagged regression, whose state (estimate, covariance, past outputs and inputs) carries
    from one ``batch_filter`` call to the next and whose free run carries its own
    (:class:`motorid.estimators.rls.FreeRun`). The friction filters need the whole record."""
    from motorid.estimators.rls import LaggedRegressionRLS

    return isinstance(estimator, LaggedRegressionRLS)


def identify_blocks(
    blocks: Callable[[], Iterable[tuple[np.ndarray, np.ndarray]]],
    args: argparse.Namespace,
    est: Any,
    notes: list[str],
    unit: str | None,
    threshold: float,
) -> tuple[dict[str, Any], list, Any]:
    """:func:`identify_record` over a record given in consecutive blocks, in memory that does not
    grow with the record.

    ``blocks()`` yields the record's ``(u, y)`` blocks from its start; it is called twice. ``est``
    is the estimator to identify (:func:`runs_in_blocks`), ``notes`` what it assumes, ``unit``
    the record's output unit and ``threshold`` its low-speed threshold in it
    (:func:`.options.low_speed_band`).

    1. The first pass runs ``batch_filter`` block after block (the estimator carries its state,
       so the estimate is that of one call on the whole record, bit for bit) and scores the
       one-step prediction with running sums (:class:`motorid.validation.RunningScore`). Each
       block is checked as :func:`motorid.validation.check_signals` checks a record, against the
       block's own median and spread (a corrupt cell stops the work at once); a strided sample
       of each signal (:class:`motorid.validation.StridedSample`, the whole signal up to
       :data:`motorid.validation.REFERENCE_SAMPLES` samples) gives the record's median and spread.
    2. The second pass checks every block against the record's median and spread (what
       :func:`~motorid.validation.check_signals` does on a whole record: it catches a unit slip
       that fills most of a block), and runs and scores the identified model's free run
       (:class:`motorid.estimators.rls.FreeRun`), up to the samples the first pass saw (a logger
       may still be appending to the file).

    The residual tests are computed on the last :data:`motorid.validation.RESIDUAL_WINDOW`
    samples of the one-step residual (the whole record when it is no longer;
    ``residual_tests_samples`` in the payload says how many). Returns what
    :func:`identify_record` returns.
    """
    from motorid.estimators.base import first_bad_index
    from motorid.estimators.rls import FreeRun
    from motorid.validation import (
        REFERENCE_SAMPLES,
        RESIDUAL_WINDOW,
        RPM_PER_RAD_S,
        ResidualWindow,
        RunningScore,
        StridedSample,
        check_outliers,
        check_signal_block,
        outlier_reference,
        raise_constant,
        residual_tests,
    )

    one_step, window = RunningScore(threshold), ResidualWindow(RESIDUAL_WINDOW)
    names = (args.input, args.output)
    strided = (StridedSample(REFERENCE_SAMPLES), StridedSample(REFERENCE_SAMPLES))
    first: tuple[float, float] | None = None  # the first sample, to tell a constant column
    varies = [False, False]
    samples = 0
    for u, y in blocks():
        for name, values, sample in zip(names, (u, y), strided, strict=True):
            check_signal_block(name, values, samples)
            sample.add(values)
        if first is None and len(u):
            first = (float(u[0]), float(y[0]))
        if first is not None:
            varies = [v or bool(np.any(x != x0)) for v, x, x0 in zip(varies, (u, y), first, strict=True)]
        result = est.batch_filter(u, y)
        if len(u) and not np.isfinite(result.x[-1]).all():  # a non-finite estimate stays so: the last tells
            require_finite_estimate(args.estimator, result.x, u, y, samples)
        scored = slice(max(0, args.skip - samples), None)
        one_step.add(y[scored], result.y_hat[scored])
        window.add(u[scored], (y - result.y_hat)[scored])
        samples += len(u)
    if not 0 <= args.skip < samples:
        raise ValueError(f"skip must be in [0, {samples}), got {args.skip}")
    for name, changes, value in zip(names, varies, first or (0.0, 0.0), strict=True):
        if not changes:
            raise_constant(name, value, samples)
    references = [outlier_reference(sample.values) for sample in strided]
    free_run, simulate = RunningScore(threshold), FreeRun(est)
    diverged = None
    start = 0
    for u, y in blocks():
        if start >= samples:  # a file still being written has grown since the first pass
            break
        u, y = u[: samples - start], y[: samples - start]
        for name, values, reference in zip(names, (u, y), references, strict=True):
            check_outliers(name, values, start, reference)
        if diverged is None:
            y_sim = simulate(u)
            bad = first_bad_index(y_sim)
            if bad is not None:
                diverged = start + bad
            else:
                scored = slice(max(0, args.skip - start), None)
                free_run.add(y[scored], y_sim[scored])
        start += len(u)
    scores = {
        "one_step": one_step.result(),
        **({} if diverged is not None else {"free_run": free_run.result()}),
    }
    tests = residual_tests(*window.arrays(), max_lag=args.max_lag)
    in_rpm = unit == "rad/s"
    payload = {
        "estimator": args.estimator,
        "samples": samples,
        "residual_tests_samples": min(window.samples, window.size),
        "params": est.params,
        "scores": {
            kind: {**vars(row), **({"mse_rpm2": row.mse * RPM_PER_RAD_S**2} if in_rpm else {})}
            for kind, row in scores.items()
        },
        "free_run_diverges_from_sample": diverged,
        "output_unit": unit,
        ("low_speed_threshold_rad_s" if in_rpm else "low_speed_threshold"): threshold,
        "residual_tests": {
            t.name: {"passed": t.passed, "fraction_outside": t.fraction_outside} for t in tests
        },
        "notes": notes,
    }
    param_units = getattr(est, "param_units", None)
    if param_units:
        payload["units"] = {"params": dict(param_units)}
    return payload, tests, est


def identify_file_in_blocks(args: argparse.Namespace) -> tuple[dict[str, Any], list, Any]:
    """:func:`identify_blocks` on the record file of ``args``, read in blocks
    (:func:`.options.iter_record_from_args`): memory does not grow with the record.

    The first block gives the record's attrs (its units, whether it is motorid's simulation);
    an output in another unit than rad/s takes one more pass, for its largest magnitude (the
    low-speed band, :func:`.options.low_speed_band`). A record whose time stamps jitter is put
    on a uniform grid, which takes it whole: it is then read and identified as
    :func:`identify_record` does (within ``--max-samples``); the reader's one line says how
    the stamps were resampled, and ``-v`` logs why the record is held whole.
    """
    from motorid.errors import UniformGridError

    try:
        passes: Iterator[pd.DataFrame] | None = iter_record_from_args(args)
        first = next(passes)
        est, notes = estimator_for_record(first, args)
        unit = (first.attrs.get("units") or {}).get("y")
        largest = None
        if unit != "rad/s":
            largest = max(
                float(np.max(np.abs(block["y"].to_numpy()))) for block in iter_record_from_args(args)
            )
        _, threshold, _ = output_band(unit, args.low_speed_rpm, largest)

        def blocks() -> Iterator[tuple[np.ndarray, np.ndarray]]:
            nonlocal passes
            source = iter_record_from_args(args) if passes is None else itertools.chain([first], passes)
            passes = None
            for block in source:
                yield block["u"].to_numpy(), block["y"].to_numpy()

        return identify_blocks(blocks, args, est, notes, unit, threshold)
    except UniformGridError as exc:
        logger.info("%s: identify reads it whole (--max-samples %d)", exc, args.max_samples)
        return identify_record(read_record_from_args(args), args)


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

    # a span (--start/--stop) is cut from the record read whole; an RLS otherwise streams the file
    spanned = args.start is not None or args.stop is not None
    in_blocks = runs_in_blocks(create_estimator(args.estimator, args)) and not spanned
    record = None if in_blocks else read_record_from_args(args)
    if record is not None:
        estimator_for_record(record, args)  # a bad estimator option or model stops before the folder is made
    else:
        start_model_from_args(args)  # --model with an RLS estimator is refused before anything is read
    validation_record = None
    if args.validate is not None:
        # the same record options (columns, dt, units) as the record the model is identified on
        validation_record = read_record_from_args(argparse.Namespace(**{**vars(args), "data": args.validate}))
    if args.out and (record is not None or args.out.exists()):  # else made once the record has passed
        check_out_folder(args.out)
        hold_out_folder(args, args.out)
    if args.save_model:
        check_out_file(args.save_model, args.overwrite, "--save-model")
    payload, tests, est = identify_file_in_blocks(args) if record is None else identify_record(record, args)
    if args.out and getattr(args, "out_lock", None) is None:
        check_out_folder(args.out)
        hold_out_folder(args, args.out)
    diverged = payload["free_run_diverges_from_sample"]
    unit = payload["output_unit"]
    threshold = payload["low_speed_threshold_rad_s" if unit == "rad/s" else "low_speed_threshold"]
    band = band_words(unit, threshold, args.low_speed_rpm)
    say(f"{args.estimator} on {args.data} ({payload['samples']} samples)")
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
    if payload["residual_tests_samples"] < payload["samples"] - args.skip:
        say(f"  residual tests on the last {payload['residual_tests_samples']} samples of the record "
            "(a bounded window: a record read in blocks is not held whole)")  # fmt: skip
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
    p.add_argument("--prediction", choices=("one_step", "free_run"), default="one_step")
    add_low_speed_band(p)
    add_skip(p)
    add_json(p)
    p.set_defaults(func=cmd_sweep)
