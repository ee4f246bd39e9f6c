"""``motorid compare``: drive models and identified estimators on a record's own input."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd

from motorid.app.compare import CompareOptions, compare_file, load_model_files
from motorid.validation import divergence_words

from .options import (
    add_json,
    add_low_speed_band,
    add_record_input,
    add_skip,
    check_out_folder,
    record_options_from_args,
)
from .report import emit_json, say, say_warning


def cmd_compare(args: argparse.Namespace) -> int:
    """Each model simulated free on the record's input: FIT, RMSE and low-speed RMSE, and a figure."""
    files = load_model_files(args.model)  # a bad file stops before the record is read
    models = {name: file.model for name, file in files.items()}
    options = CompareOptions(low_speed_rpm=args.low_speed_rpm, skip=args.skip)
    comparison, band, units = compare_file(args.data, models, options, record_options_from_args(args),
                                          {name: file.card for name, file in files.items()})  # fmt: skip
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
            say_warning(f"{divergence_words(model.name, model.diverges_from, math.isfinite(model.mse))}")
    figure = None
    if args.out:
        input_unit = units.get("u") or "input units"
        figure = comparison.write_figure(args.out / "compare.png", input_unit)
        say(f"  wrote {figure}")
    if args.json:
        emit_json({"record": args.data, **comparison.to_dict(), "figure": figure})
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="models simulated on a record's own input: FIT, RMSE, a figure")
    add_record_input(p, "the most samples of a record compared whole (default: %(default)s): a span (--start, "
                        "--stop), a record of positions, one whose time stamps jitter, one through a friction "
                        "filter; any other is compared in blocks, whatever its length")  # fmt: skip
    p.add_argument("--model", type=Path, action="append", required=True, metavar="FILE",
                   help="a model file (repeatable): a drive model (motorid simulate/doctor --save-model) "
                        "or an identified estimator (motorid identify --save-model)")  # fmt: skip
    add_low_speed_band(p)
    add_skip(p)
    p.add_argument("--out", type=Path, help="folder for the figure compare.png (replaced if there)")
    add_json(p)
    p.set_defaults(func=cmd_compare)
