"""``motorid compare``: drive models and identified estimators on a record's own input."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from motorid.errors import DataError

from .options import (
    add_json,
    add_low_speed_band,
    add_record_input,
    add_skip,
    check_out_folder,
    iter_record_from_args,
    low_speed_band,
    output_band,
    read_record_from_args,
    record_options_from_args,
)

if TYPE_CHECKING:
    from motorid.comparison import Comparison
from .report import emit_json, say


def cmd_compare(args: argparse.Namespace) -> int:
    """Each model simulated free on the record's input: FIT, RMSE and low-speed RMSE, and a figure."""
    from motorid.comparison import MIN_SCORED_SAMPLES, compare_models
    from motorid.models import load_model
    from motorid.record_chunks import read_head

    models = {
        str(path): load_model(path) for path in args.model
    }  # a bad file stops before the record is read
    min_samples = args.skip + MIN_SCORED_SAMPLES
    if args.start is not None or args.stop is not None:  # a span is cut from the record read whole
        record = read_record_from_args(args, min_samples=min_samples)
        more = False
    else:
        record, more = read_head(
            args.data, args.max_samples, min_samples=min_samples, **record_options_from_args(args)
        )
    if more:
        comparison, band = compare_in_blocks(args, models, min_samples)
    else:
        _, threshold, band = low_speed_band(record, args.low_speed_rpm)
        comparison = compare_models(record, models, threshold, args.skip)
    if args.out:
        check_out_folder(args.out)
    unit = comparison.output_unit
    samples = comparison.to_dict()["samples"]
    say(f"motorid compare on {args.data} ({samples} samples, dt {comparison.dt:g} s, {comparison.timing} "
        f"timing): free run from rest on the recorded input, scored after the first {args.skip} samples")  # fmt: skip
    for model in comparison.models:
        for note in model.notes:
            say(f"  note: {note}")
    table = comparison.table().rename(columns={
        "fit_percent": "FIT [%]", "rmse": f"RMSE [{unit}]",
        "low_speed_rmse": f"low-speed RMSE [{unit}]", "n_low_speed": "low-speed samples",
    })  # fmt: skip
    with pd.option_context("display.width", 160, "display.max_colwidth", 40):
        say(table.to_string(float_format=lambda v: f"{v:.4g}"))
    say(f"  low speed: {band}")
    for model in comparison.models:
        if model.diverges_from is not None:
            say(f"  {model.name}: its free run diverges from sample {model.diverges_from} on (unstable on this "
                "input), so it has no score")  # fmt: skip
    figure = None
    if args.out:
        input_unit = (record.attrs.get("units") or {}).get("u") or "input units"  # the first rows' attrs
        figure = comparison.write_figure(args.out / "compare.png", input_unit)
        say(f"  wrote {figure}")
    if args.json:
        emit_json({"record": args.data, **comparison.to_dict(), "figure": figure})
    return 0


def compare_in_blocks(
    args: argparse.Namespace, models: dict[str, Any], min_samples: int
) -> tuple[Comparison, str]:
    """:func:`motorid.comparison.compare_blocks` on the record of ``args``, longer than
    ``--max-samples``, read in blocks (:func:`.options.iter_record_from_args`): memory does not
    grow with the record. An output in another unit than rad/s takes one more pass, for its
    largest magnitude (the low-speed band, :func:`.options.output_band`). Returns the
    comparison and the band in words.

    Raises
    ------
    DataError
        For a model whose free run takes the record whole (a friction filter), a record of
        positions, or one whose time stamps jitter: each is compared whole, within
        ``--max-samples``.
    """
    from motorid.comparison import POSITION_UNITS, compare_blocks, model_kind, runs_in_blocks
    from motorid.errors import UniformGridError

    limit = f"longer than --max-samples {args.max_samples}"
    for name, model in models.items():
        if not runs_in_blocks(model):
            raise DataError(
                f"{args.data}: {limit}, and the free run of {name} ({model_kind(model)}) takes the record whole: "
                "raise --max-samples"
            )
    try:
        first = next(iter_record_from_args(args, min_samples=min_samples))
        unit = (first.attrs.get("units") or {}).get("y")
        if unit in POSITION_UNITS:
            raise DataError(
                f"{args.data}: {limit}, and a record of positions is compared whole (on the speed derived "
                "from them): raise --max-samples"
            )
        largest = None
        if unit != "rad/s":
            largest = max(float(np.max(np.abs(b["y"].to_numpy()))) for b in iter_record_from_args(args))
        _, threshold, band = output_band(unit, args.low_speed_rpm, largest)
        comparison = compare_blocks(
            iter_record_from_args(args, min_samples=min_samples), models, threshold, args.skip
        )
    except UniformGridError as exc:
        raise DataError(f"{exc}; {limit}: raise --max-samples") from None
    return comparison, band


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="models simulated on a record's own input: FIT, RMSE, a figure")
    add_record_input(p, "a longer record is read and compared in blocks, in memory that does not grow with it "
                        "(default: %(default)s); a span (--start, --stop), a record of positions, one whose time "
                        "stamps jitter and a friction filter take it whole, within this limit")  # fmt: skip
    p.add_argument("--model", type=Path, action="append", required=True, metavar="FILE",
                   help="a model file (repeatable): a drive model (motorid simulate/doctor --save-model) "
                        "or an identified estimator (motorid identify --save-model)")  # fmt: skip
    add_low_speed_band(p)
    add_skip(p)
    p.add_argument("--out", type=Path, help="folder for the figure compare.png (replaced if there)")
    add_json(p)
    p.set_defaults(func=cmd_compare)
