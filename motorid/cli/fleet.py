"""``motorid fleet identify|doctor|trend|generate``: many records on a Dask cluster.

``identify`` and ``doctor`` take the single-record commands' options, build the
typed job from them (:class:`motorid.fleet.IdentifyJob`, :class:`motorid.fleet.DoctorJob`)
and run it with :func:`motorid.fleet.run`: the same computation as the single command on
each record, one Dask task per record (``doctor --per-drive``: per drive, on all its
records as one model); their rows hold the single command's ``--json`` output flattened.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from motorid.errors import DataError
from motorid.fleet.runner import TASK_TIMEOUT

from .doctor import add_doctor_options, doctor_options_from_args
from .identification import add_identify_options, identify_options_from_args
from .options import (
    RECORD_FILES,
    add_json,
    add_record_columns,
    add_wait,
    check_out_folder,
    hold_out_folder,
    number,
    positive,
    record_options_from_args,
)
from .report import emit_json, frame_records, say, say_error, show_progress


def _run(args: argparse.Namespace, command: str) -> int:
    from motorid.fleet import FilenamePattern, find_records, run
    from motorid.fleet.runner import check_run_kind

    if command == "identify":
        from motorid.app.identify import create_estimator, start_model

        job: Any = identify_options_from_args(args)
        create_estimator(job.estimator, job)  # a bad option stops before any work
        start_model(job)  # and a bad --model
    else:
        job = doctor_options_from_args(args)
        job.start_model()  # a bad --model stops before any work
    read = record_options_from_args(args)  # a bad span stops before any work too
    per_drive = getattr(args, "per_drive", False)
    paths = find_records(args.records)
    if args.pattern:  # a bad pattern, or a file it does not fit, stops before the folder is made
        pattern = FilenamePattern(args.pattern)
        for path in paths:
            pattern.parse(path)
    check_out_folder(args.out)
    hold_out_folder(args, args.out)
    check_run_kind(args.out, per_drive)
    where = args.scheduler or f"a local cluster of {args.workers or os.cpu_count()} worker processes"
    say(f"motorid fleet {command}{' --per-drive' if per_drive else ''}: {len(paths)} records on {where}; "
        f"results in {args.out}/")  # fmt: skip
    fleet_run = run(paths, args.out, job, read=read, per_drive=per_drive,
                    pattern=args.pattern, scheduler=args.scheduler, workers=args.workers, figures=args.figures,
                    retry_failed=args.retry_failed, lock=False, progress=show_progress(),
                    task_timeout=args.task_timeout)  # fmt: skip
    what = (
        "records"
        if fleet_run.drives is None
        else f"drives (of {fleet_run.drives}; {fleet_run.records} records)"
    )
    say(
        f"  {fleet_run.done} done, {fleet_run.failed} failed, {fleet_run.skipped} already in the results "
        f"({fleet_run.seconds:.1f} s; counted in {what}); results: {args.out / 'results.parquet'}/ and "
        f"{args.out / 'results.csv'}"
    )
    if fleet_run.failed:
        # also with --quiet: a run that lost records says so
        say_error(f"motorid fleet {command}: {fleet_run.failed} {what.split(' ')[0]} failed: their errors are in "
                  f"the 'error' column of {args.out / 'results.csv'}")  # fmt: skip
    if args.json:
        emit_json({"records": fleet_run.records, "skipped": fleet_run.skipped, "done": fleet_run.done,
                   "failed": fleet_run.failed, "seconds": fleet_run.seconds, "results": args.out / "results.parquet",
                   **({} if fleet_run.drives is None else {"drives": fleet_run.drives})})  # fmt: skip
    return 0


def cmd_fleet_identify(args: argparse.Namespace) -> int:
    """``motorid identify`` on every record of a fleet."""
    return _run(args, "identify")


def cmd_fleet_doctor(args: argparse.Namespace) -> int:
    """``motorid doctor`` on every record of a fleet."""
    return _run(args, "doctor")


def cmd_fleet_trend(args: argparse.Namespace) -> int:
    """Friction against time per drive; the drives whose friction rose or that grew an effect."""
    import pandas as pd

    from motorid.fleet.results import load_results
    from motorid.fleet.trend import flag_drives, friction_trends, plot_trends
    from motorid.outputs import spreadsheet_safe, write_file

    if not args.results.is_dir():  # before its lock: a missing folder is not a lock that failed
        raise DataError(
            f"results {args.results}: no such folder (the --out of motorid fleet identify or doctor)"
        )
    hold_out_folder(args, args.results, "results")  # no run writes its rows while they are read
    results = load_results(args.results)
    trends = friction_trends(results)
    flags = flag_drives(trends, results, threshold=args.threshold, window_days=args.window)
    flagged = flags[flags["flagged"]]
    say(f"motorid fleet trend on {args.results}: {trends['drive'].nunique()} drives, {len(results)} records")
    if len(flagged):
        with pd.option_context("display.width", 160, "display.max_columns", 12, "display.max_colwidth", 60):
            say(
                f"flagged drives (friction rise > {args.threshold:.0%} over {args.window:g} days, or a new effect):"
            )
            say(flagged.drop(columns="flagged").to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    else:
        say(
            f"no drive flagged (friction rise > {args.threshold:.0%} over {args.window:g} days, or a new effect)"
        )
    out = args.out or args.results / "trend"
    check_out_folder(out)
    figures = plot_trends(trends, flags, out)
    flags_csv = spreadsheet_safe(flags)
    write_file(out / "flags.csv", lambda fh: flags_csv.to_csv(fh, index=False), overwrite=True)
    say(f"  wrote flags.csv and {len(figures)} figures in {out}/")
    if args.json:
        emit_json({"flagged": frame_records(flagged.set_index("drive")), "drives": len(flags),
                   "figures": figures, "flags": out / "flags.csv"})  # fmt: skip
    return 0


def cmd_fleet_generate(args: argparse.Namespace) -> int:
    """Write a synthetic fleet's records (``motorid.fleet.synthetic``)."""
    from motorid.fleet.synthetic import make_fleet, write_fleet

    check_out_folder(args.out)
    hold_out_folder(args, args.out)
    wearing = tuple(i for i in (1, 2) if i < args.drives)
    drives = make_fleet(args.drives, seed=args.seed, wearing=wearing, friction_growth=args.friction_growth,
                        dead_zone_drive=3 if args.drives > 3 else None, dead_zone_day=args.dead_zone_day)  # fmt: skip
    paths = write_fleet(args.out, drives, args.days, duration=args.duration, seed=args.seed)
    say(f"wrote {len(paths)} records of {args.drives} drives over {args.days} days in {args.out}/")
    for d in drives:
        what = []
        if d.friction_growth:
            what.append(f"friction +{d.friction_growth:.0%} per day")
        if d.dead_zone_day is not None:
            what.append(f"a {d.dead_zone:g} V dead zone from day {d.dead_zone_day}")
        say(f"  {d.name}: {', '.join(what) or 'healthy'}")
    if args.json:
        emit_json({"records": [str(p) for p in paths],
                   "drives": {d.name: {"friction_growth": d.friction_growth, "dead_zone_day": d.dead_zone_day}
                              for d in drives}})  # fmt: skip
    return 0


def _add_run_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("records", nargs="+", metavar="RECORDS",
                   help=f"record files, globs ('data/*.csv'), folders or @list files (one path a line); {RECORD_FILES}")  # fmt: skip
    p.add_argument("--out", type=Path, required=True,
                   help="run folder: results.parquet/, results.csv, figures under <drive>/<record>/")  # fmt: skip
    p.add_argument("--pattern", metavar="PATTERN",
                   help="drive and time from the file name, e.g. '{drive}_{date:%%Y%%m%%d}.csv' "
                        "(default: the record's attrs 'drive' and 'time', else the file name)")  # fmt: skip
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running Dask scheduler you trust, e.g. tcp://HOST:8786 (default: a local cluster "
                        "on 127.0.0.1 at a random port)")  # fmt: skip
    p.add_argument("--workers", type=number(int, low=1),
                   help="worker processes of the local cluster (default: the cores)")  # fmt: skip
    p.add_argument("--no-figures", dest="figures", action="store_false", help="write no figure per record")
    p.add_argument("--retry-failed", action="store_true", help="rerun the records whose row says failed")
    p.add_argument("--task-timeout", type=positive, default=TASK_TIMEOUT, metavar="SECONDS",
                   help="a record's (or drive's) task running longer is a failed row, its worker dropped, "
                        f"and the run goes on [s] (default: {TASK_TIMEOUT:g})")  # fmt: skip
    add_wait(p)
    add_record_columns(p)
    add_json(p)


def add_commands(sub: argparse._SubParsersAction) -> None:
    fleet = sub.add_parser("fleet", help="many records on a Dask cluster: identify, doctor, friction trends")
    commands = fleet.add_subparsers(dest="fleet_command", required=True, metavar="COMMAND",
                                    parser_class=type(fleet))  # fmt: skip

    p = commands.add_parser("identify", help="motorid identify on each record, one Dask task per record")
    _add_run_options(p)
    add_identify_options(p)
    p.set_defaults(func=cmd_fleet_identify)

    p = commands.add_parser(
        "doctor", help="motorid doctor on each record (one Dask task per record), or per drive"
    )
    _add_run_options(p)
    add_doctor_options(p)
    p.add_argument("--per-drive", action="store_true",
                   help="one doctor per drive on all its records as one model (motorid doctor A B C), one Dask "
                        "task per drive; a record without a drive id (pattern, attrs 'drive') is a drive of "
                        "its own")  # fmt: skip
    p.set_defaults(func=cmd_fleet_doctor)

    p = commands.add_parser(
        "trend", help="friction per drive against time; flag rising friction, new effects"
    )
    p.add_argument("results", type=Path, help="a run folder of motorid fleet identify or doctor")
    p.add_argument("--threshold", type=number(float, low=0.0, low_open=True), default=0.2,
                   help="flag a rise of Coulomb or viscous friction above this share (default: 0.2)")  # fmt: skip
    p.add_argument("--window", type=positive, default=30.0,
                   help="the rise is measured over each drive's last WINDOW days (default: 30)")  # fmt: skip
    p.add_argument("--out", type=Path, help="folder for the figures and flags.csv (default: RESULTS/trend)")
    add_wait(p)
    add_json(p)
    p.set_defaults(func=cmd_fleet_trend)

    p = commands.add_parser("generate", help="write a synthetic fleet's records (drive_YYYYMMDD.csv)")
    p.add_argument("--out", type=Path, required=True, help="folder for the records")
    p.add_argument("--drives", type=number(int, low=1), default=6, help="drives (default: 6)")
    p.add_argument("--days", type=number(int, low=1), default=10, help="one record a day (default: 10)")
    p.add_argument("--duration", type=positive, default=30.0, help="record length [s] (default: 30)")
    p.add_argument("--friction-growth", type=number(float, low=0.0), default=0.02,
                   help="friction growth of drives 1 and 2 per day (default: 0.02)")  # fmt: skip
    p.add_argument("--dead-zone-day", type=number(int, low=0), default=5,
                   help="day drive 3 grows a 0.8 V dead zone (default: 5)")  # fmt: skip
    p.add_argument("--seed", type=number(int, low=0), default=0, help="seed of the spread and the records")
    add_wait(p)
    add_json(p)
    p.set_defaults(func=cmd_fleet_generate)
