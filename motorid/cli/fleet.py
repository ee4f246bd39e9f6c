"""``motorid fleet identify|doctor|trend|generate``: many records on a Dask cluster.

``identify`` and ``doctor`` take the single-record commands' options and run the
same computation on each record (:func:`.identification.identify_record`,
:func:`.doctor.doctor_record`), one Dask task per record; their rows hold the
single command's ``--json`` output flattened.
"""

from __future__ import annotations

import argparse
import copy
import os
import socket
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motorid.errors import DataError

from .doctor import add_doctor_options, doctor_record, effect_list, read_record_segment
from .identification import (
    add_identify_options,
    identify_record,
    start_model_from_args,
    write_identify_figure,
)
from .options import (
    RECORD_FILES,
    add_json,
    add_record_columns,
    add_wait,
    check_out_folder,
    create_estimator,
    hold_out_folder,
    number,
    positive,
)
from .report import emit_json, frame_records, jsonable, say, say_error, show_progress


@dataclass(frozen=True)
class RecordTask:
    """One record's work in a worker: read it as the single command does, compute, return its row.

    Picklable (the parsed options travel with it). Every error of the record is caught and
    returned as a row with ``status = "failed"`` and ``error``, so one bad record does not stop
    the others; its warnings (a filter that diverged) are the row's ``warnings``.
    """

    command: str  # "identify" or "doctor"
    args: argparse.Namespace
    figures: Path | None  # the run folder, when figures are written

    def __call__(self, path: str, given: dict[str, Any]) -> dict[str, Any]:
        from motorid.fleet.results import flatten
        from motorid.fleet.sources import identity
        from motorid.outputs import safe_file_name

        from .options import read_record_from_args

        start = time.perf_counter()
        drive, when = identity(path, {}, given)
        row: dict[str, Any] = {"record": path, "drive": drive, "time": when, "command": self.command}
        with warnings.catch_warnings(record=True) as caught:  # a worker's warnings go in the row, not stderr
            warnings.simplefilter("always")
            try:
                args = copy.copy(self.args)
                args.data = Path(path)
                if self.command == "identify":
                    record, segment = read_record_from_args(args), False
                else:  # as motorid doctor reads it: a longer record's first --max-samples samples
                    record, segment = read_record_segment(args)
                drive, when = identity(path, record.attrs, given)
                row.update(drive=drive, time=when)
                # names from data are file names, never paths: everything stays under --out
                folder = (
                    self.figures / safe_file_name(drive) / safe_file_name(Path(path).stem)
                    if self.figures is not None
                    else None
                )
                if folder is not None:
                    folder.mkdir(parents=True, exist_ok=True)
                if self.command == "identify":
                    payload, tests, _ = identify_record(record, args)
                    figures = [write_identify_figure(tests, folder, args.estimator)] if folder else []
                    extra = {}
                else:
                    diagnosis = doctor_record(record, args, progress=False)
                    payload = diagnosis.to_dict()
                    figures = diagnosis.write_figures(folder) if folder else []
                    extra = {"named": ",".join(diagnosis.named), "segment": segment}
                row.update(status="ok", error=None)
                row.update(flatten(jsonable({**payload, **extra, "figures": [str(f) for f in figures]})))
            except Exception as exc:  # the record's failure, whatever it is, is its row
                message = str(exc) if isinstance(exc, DataError) else f"{type(exc).__name__}: {exc}"
                row.update(status="failed", error=message)
        # a ResourceWarning comes from the garbage collector, at any time: not this record's
        messages = [str(w.message) for w in caught if not issubclass(w.category, ResourceWarning)]
        row["warnings"] = "; ".join(dict.fromkeys(messages)) or None
        row["run_time_s"] = time.perf_counter() - start
        row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
        return row


def _run(args: argparse.Namespace, command: str) -> int:
    from motorid.fleet import FilenamePattern, FleetRun, find_records, fleet_client, run_fleet
    from motorid.fleet.runner import pending_records

    if command == "identify":
        create_estimator(args.estimator, args)  # a bad option stops before any work
        start_model_from_args(args)  # and a bad --model
    else:
        effect_list(args.base, "--base")
        if args.candidates:
            effect_list(args.candidates, "--candidates")
    paths = find_records(args.records)
    given: dict[str, dict[str, Any]] = {}
    if args.pattern:
        pattern = FilenamePattern(args.pattern)
        given = {os.path.abspath(p): pattern.parse(p) for p in paths}
    check_out_folder(args.out)
    task = RecordTask(command, argparse.Namespace(**vars(args)), args.out.resolve() if args.figures else None)
    hold_out_folder(args, args.out)  # after the task took its copy of the options: the lock stays here
    where = args.scheduler or f"a local cluster of {args.workers or os.cpu_count()} worker processes"
    say(f"motorid fleet {command}: {len(paths)} records on {where}; results in {args.out}/")
    if pending_records(paths, args.out, args.retry_failed):
        with fleet_client(args.scheduler, args.workers) as client:
            run = run_fleet(paths, task, args.out, client, given=given, retry_failed=args.retry_failed,
                            progress=show_progress())  # fmt: skip
    else:  # every record is in the results: no cluster to start
        run = FleetRun(records=len(paths), skipped=len(paths), done=0, failed=0, seconds=0.0)
    say(
        f"  {run.done} done, {run.failed} failed, {run.skipped} already in the results "
        f"({run.seconds:.1f} s); results: {args.out / 'results.parquet'}/ and {args.out / 'results.csv'}"
    )
    if run.failed:
        # also with --quiet: a run that lost records says so
        say_error(f"motorid fleet {command}: {run.failed} records failed: their errors are in the 'error' "
                  f"column of {args.out / 'results.csv'}")  # fmt: skip
    if args.json:
        emit_json({"records": run.records, "skipped": run.skipped, "done": run.done, "failed": run.failed,
                   "seconds": run.seconds, "results": args.out / "results.parquet"})  # fmt: skip
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
    from motorid.outputs import write_file

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
    write_file(out / "flags.csv", lambda fh: flags.to_csv(fh, index=False), overwrite=True)
    say(f"  wrote flags.csv and {len(figures)} figures in {out}/")
    if args.json:
        emit_json({"flagged": frame_records(flagged.set_index("drive")), "drives": len(flags),
                   "figures": figures, "flags": out / "flags.csv"})  # fmt: skip
    return 0


def cmd_fleet_generate(args: argparse.Namespace) -> int:
    """Write a synthetic fleet's records (``motorid.plants.fleet``)."""
    from motorid.plants.fleet import make_fleet, write_fleet

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
                   help="a running Dask scheduler, e.g. tcp://HOST:8786 (default: a local cluster)")  # fmt: skip
    p.add_argument("--workers", type=number(int, low=1),
                   help="worker processes of the local cluster (default: the cores)")  # fmt: skip
    p.add_argument("--no-figures", dest="figures", action="store_false", help="write no figure per record")
    p.add_argument("--retry-failed", action="store_true", help="rerun the records whose row says failed")
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

    p = commands.add_parser("doctor", help="motorid doctor on each record, one Dask task per record")
    _add_run_options(p)
    add_doctor_options(p)
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
