"""``motorid compare``: drive models and identified estimators on a record's own input."""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from .options import (
    add_json,
    add_low_speed_band,
    add_record_input,
    add_skip,
    check_out_folder,
    low_speed_band,
    read_record_from_args,
)
from .report import emit_json, say


def cmd_compare(args: argparse.Namespace) -> int:
    """Each model simulated free on the record's input: FIT, RMSE and low-speed RMSE, and a figure."""
    from motorid.comparison import MIN_SCORED_SAMPLES, compare_models
    from motorid.models import load_model

    models = {
        str(path): load_model(path) for path in args.model
    }  # a bad file stops before the record is read
    record = read_record_from_args(args, min_samples=args.skip + MIN_SCORED_SAMPLES)
    _, threshold, band = low_speed_band(record, args.low_speed_rpm)
    comparison = compare_models(record, models, threshold, args.skip)
    if args.out:
        check_out_folder(args.out)
    unit = comparison.output_unit
    say(f"motorid compare on {args.data} ({len(record)} samples, dt {comparison.dt:g} s, {comparison.timing} "
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
        input_unit = (record.attrs.get("units") or {}).get("u") or "input units"
        figure = comparison.write_figure(args.out / "compare.png", input_unit)
        say(f"  wrote {figure}")
    if args.json:
        emit_json({"record": args.data, **comparison.to_dict(), "figure": figure})
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("compare", help="models simulated on a record's own input: FIT, RMSE, a figure")
    add_record_input(p)
    p.add_argument("--model", type=Path, action="append", required=True, metavar="FILE",
                   help="a model file (repeatable): a drive model (motorid simulate/doctor --save-model) "
                        "or an identified estimator (motorid identify --save-model)")  # fmt: skip
    add_low_speed_band(p)
    add_skip(p)
    p.add_argument("--out", type=Path, help="folder for the figure compare.png (replaced if there)")
    add_json(p)
    p.set_defaults(func=cmd_compare)
