"""``motorid compare``: drive models and identified estimators on a record's own input."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from motorid.app.identify import low_speed_band, output_band
from motorid.errors import DataError

from .options import (
    add_json,
    add_low_speed_band,
    add_record_input,
    add_skip,
    check_out_folder,
    iter_record_from_args,
    read_record_from_args,
    record_options_from_args,
)
from .report import emit_json, say

if TYPE_CHECKING:
    from motorid.comparison import Comparison

logger = logging.getLogger(__name__)


def cmd_compare(args: argparse.Namespace) -> int:
    """Each model simulated free on the record's input: FIT, RMSE and low-speed RMSE, and a figure."""
    from motorid.comparison import MIN_SCORED_SAMPLES, compare_models
    from motorid.estimators import load_model

    models = {
        str(path): load_model(path) for path in args.model
    }  # a bad file stops before the record is read
    min_samples = args.skip + MIN_SCORED_SAMPLES
    streamed = compare_in_blocks(args, models, min_samples)
    if streamed is not None:
        comparison, band, units = streamed
    else:
        record = read_whole(args, models, min_samples)
        units = record.attrs.get("units") or {}
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
        input_unit = units.get("u") or "input units"
        figure = comparison.write_figure(args.out / "compare.png", input_unit)
        say(f"  wrote {figure}")
    if args.json:
        emit_json({"record": args.data, **comparison.to_dict(), "figure": figure})
    return 0


def compare_in_blocks(
    args: argparse.Namespace, models: dict[str, Any], min_samples: int
) -> tuple[Comparison, str, dict[str, str]] | None:
    """:func:`motorid.comparison.compare_blocks` on the record of ``args`` read in blocks
    (:func:`.options.iter_record_from_args`), in memory that does not grow with the record:
    the comparison, the low-speed band in words and the record's units. An output in another
    unit than rad/s takes one more pass, for its largest magnitude (the low-speed band,
    :func:`.options.output_band`).

    None when the record is compared whole instead (:func:`read_whole`): a span (``--start``,
    ``--stop``), a model whose free run takes the record whole (a friction filter), a record
    of positions (its band is judged on the speed derived from them) or one whose time stamps
    jitter (it is put on a uniform grid, whole); ``-v`` says why.
    """
    from motorid.comparison import POSITION_UNITS, compare_blocks, runs_in_blocks
    from motorid.errors import UniformGridError

    if args.start is not None or args.stop is not None or not all(map(runs_in_blocks, models.values())):
        return None
    try:
        first = next(iter_record_from_args(args, min_samples=min_samples))
        units = dict(first.attrs.get("units") or {})
        unit = units.get("y")
        if unit in POSITION_UNITS:
            logger.info(
                "%s: a record of positions, compared whole (--max-samples %d)", args.data, args.max_samples
            )
            return None
        largest = None
        if unit != "rad/s":
            largest = max(float(np.max(np.abs(b["y"].to_numpy()))) for b in iter_record_from_args(args))
        _, threshold, band = output_band(unit, args.low_speed_rpm, largest)
        blocks = iter_record_from_args(args, min_samples=min_samples)
        return compare_blocks(blocks, models, threshold, args.skip), band, units
    except UniformGridError as exc:
        logger.info("%s: compare reads it whole (--max-samples %d)", exc, args.max_samples)
        return None


def read_whole(args: argparse.Namespace, models: dict[str, Any], min_samples: int) -> pd.DataFrame:
    """The record of ``args`` read whole, for a comparison that cannot be made in blocks
    (:func:`compare_in_blocks`): a span of it (``--start``, ``--stop``) or, within
    ``--max-samples``, the record.

    Raises
    ------
    DataError
        For a record longer than ``--max-samples``, naming what takes it whole.
    """
    from motorid.comparison import model_kind, runs_in_blocks
    from motorid.record_chunks import read_head

    if args.start is not None or args.stop is not None:
        return read_record_from_args(args, min_samples=min_samples)
    record, more = read_head(
        args.data, args.max_samples, min_samples=min_samples, **record_options_from_args(args)
    )
    if more:
        whole = [
            f"the free run of {name} ({model_kind(m)})" for name, m in models.items() if not runs_in_blocks(m)
        ]
        raise DataError(
            f"{args.data}: longer than --max-samples {args.max_samples}, and "
            f"{whole[0] if whole else 'a record of positions'} takes the record whole: raise --max-samples"
        )
    return record


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
