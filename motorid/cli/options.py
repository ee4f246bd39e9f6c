"""The options several commands share, each declared once, and the checks at the edge.

Every value a user types is checked here, where it is parsed: a bad one stops the
command with one line naming the option (exit status 2) before any work is done.
"""

from __future__ import annotations

import argparse
import errno
import math
import os
import re
import shlex
import sys
from collections.abc import Callable, Iterator
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motorid.app.identify import PAPER_ORDER
from motorid.errors import DataError
from motorid.io.records import RecordOptions
from motorid.io.records.options import COMMAND_MAX_SAMPLES
from motorid.units import INPUT_UNITS, OUTPUT_UNIT_NAMES

#: The paper's low-speed band, |y| < 150 rpm (its Figs. 9-11).
LOW_SPEED_RPM = 150.0
#: Excitation signals by name (functions of motorid.signals).
SIGNALS = ("paper", "prbs", "multisine", "chirp", "steps")


# --------------------------------------------------------------------------- value types
def number(kind: type = float, *, low: float | None = None, high: float | None = None,
           low_open: bool = False, unit: str = "") -> Callable[[str], Any]:  # fmt: skip
    """An argparse type: a finite ``kind`` in ``[low, high]`` (``(low, high]`` when ``low_open``)."""
    lo = "(" if low_open else "["
    span = f"{lo}{'-inf' if low is None else f'{low:g}'}, {'inf' if high is None else f'{high:g}'}]"
    unit_text = f" [{unit}]" if unit else ""

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if kind is int else 'a number'}{unit_text}, "
                                             f"got {text!r}") from None  # fmt: skip
        ok = math.isfinite(value)
        ok = ok and (low is None or (value > low if low_open else value >= low))
        ok = ok and (high is None or value <= high)
        if not ok:
            raise argparse.ArgumentTypeError(f"must be in {span}{unit_text}, got {text}")
        return value

    parse.__name__ = kind.__name__  # argparse names the type in its messages
    return parse


positive = number(float, low=0.0, low_open=True)
non_negative = number(float, low=0.0)
forgetting_factor = number(float, low=0.0, high=1.0, low_open=True)


def int_range(text: str) -> list[int]:
    """'1-6' or '2,3,5' as a non-empty list of ints >= 1."""
    try:
        if "-" in text:
            lo, hi = (int(v) for v in text.split("-", 1))
            values = list(range(lo, hi + 1))
        else:
            values = [int(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a range like 1-6 or a list like 2,3,5, got {text!r}"
        ) from None
    if not values:
        raise argparse.ArgumentTypeError(
            f"the range {text!r} is empty (write the smaller number first, e.g. 1-6)"
        )
    if min(values) < 1:
        raise argparse.ArgumentTypeError(f"every value must be >= 1, got {text!r}")
    return values


# --------------------------------------------------------------------------- option groups
def add_json(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", action="store_true", help="one JSON object on stdout (text stays on stderr)"
    )


#: What a record file may be, in --help.
RECORD_FILES = (
    "CSV (also .gz, .bz2, .xz, a .zip of one), Parquet, MATLAB .mat, NI .tdms, HDF5 .h5 or Excel .xlsx by "
    "extension; columns t [s], u [V], y [rad/s] by default"
)


#: What --max-samples does in a command that holds its record whole.
MAX_SAMPLES_HELP = "refuse a longer record (default: %(default)s); decimate a longer one first"


def add_record_input(parser: argparse.ArgumentParser, max_samples_help: str = MAX_SAMPLES_HELP) -> None:
    """The record a command reads: file, columns, sample time, size limit (what the limit does in
    this command: ``max_samples_help``)."""
    parser.add_argument("data", type=Path, help=f"record file ({RECORD_FILES})")
    add_record_columns(parser, max_samples_help)


def add_record_columns(parser: argparse.ArgumentParser, max_samples_help: str = MAX_SAMPLES_HELP) -> None:
    """How a record is read: columns, time, separator, units, size limit (:class:`motorid.io.records.RecordOptions`;
    what the limit does in this command: ``max_samples_help``), and the span used (--start, --stop:
    :func:`add_trim_options`)."""
    from motorid.io.records import COMMENT, DUPLICATES, THOUSANDS
    from motorid.units import TIME_UNITS

    group = parser.add_argument_group("record")
    group.add_argument("--time", metavar="COL",
                       help="time column, any name (default: t; optional when the sample time is known)")  # fmt: skip
    group.add_argument("--input", default="u", metavar="COL", help="input column (default: u)")
    group.add_argument("--output", default="y", metavar="COL", help="output column (default: y)")
    group.add_argument("--time-unit", choices=TIME_UNITS,
                       help="unit of the time column (default: the file's, else s); its origin is free: "
                            "the time is shifted to start at 0")  # fmt: skip
    group.add_argument("--dt", type=positive, help="sample time [s] (default: from the file); a time "
                       "column that says otherwise is refused")  # fmt: skip
    group.add_argument("--resample", action="store_true",
                       help="put a record with gaps (missing samples) on a uniform grid too, instead of "
                            "refusing it (jittered time stamps are always resampled)")  # fmt: skip
    group.add_argument("--sep", type=separator, metavar="CHAR",
                       help="CSV separator: one character, or 'tab' (default: detected; -v says which)")  # fmt: skip
    group.add_argument("--decimal", choices=(".", ","),
                       help="CSV decimal mark (default: detected, ',' with a ';' or tab separator)")  # fmt: skip
    as_read = "(default: the unit the file names; none: the numbers are used as they are)"
    group.add_argument("--input-unit", metavar="UNIT", choices=INPUT_UNITS,
                       help=f"unit of the input column, converted to V as it is read: "
                       f"{', '.join(INPUT_UNITS).replace('%', '%%')} {as_read}; %% is PWM duty (|u| <= 100), "
                       "converted with --supply-voltage; counts is a PWM count, --input-full-scale of it "
                       "is 100 %%")  # fmt: skip
    group.add_argument("--input-full-scale", type=positive, metavar="N",
                       help="the count of full duty for --input-unit counts (255 for an 8-bit PWM)")  # fmt: skip
    group.add_argument("--output-unit", metavar="UNIT", choices=OUTPUT_UNIT_NAMES,
                       help=f"unit of the output column, converted to rad/s, rad, m/s or m as it is read: "
                       f"{', '.join(OUTPUT_UNIT_NAMES)} {as_read}; counts is an encoder's position, "
                       "with --counts-per-rev: the commands differentiate it to a speed")  # fmt: skip
    group.add_argument("--counts-per-rev", type=positive, metavar="N",
                       help="counts per revolution of the encoder for --output-unit counts (four times the "
                            "lines of a quadrature encoder)")  # fmt: skip
    group.add_argument("--direction", metavar="COL",
                       help="direction column of a sign-and-magnitude drive: gives the unsigned input its sign")  # fmt: skip
    group.add_argument("--direction-forward", type=number(float), default=1.0, metavar="VALUE",
                       help="the --direction column's value for forward (default: 1); it may hold one other")  # fmt: skip
    group.add_argument("--duplicates", choices=DUPLICATES, default="refuse",
                       help="rows that repeat a time stamp with other values: refuse (default), or merge into "
                            "the first, the last or the mean (repeated equal rows are always dropped)")  # fmt: skip
    group.add_argument("--thousands", choices=THOUSANDS, metavar="CHAR",
                       help="CSV thousands separator: , . ' or a space (default: detected with the decimal mark)")  # fmt: skip
    group.add_argument("--comment", default=COMMENT, metavar="PREFIX",
                       help="prefix of the comment lines before a CSV's header, kept as the record's notes "
                            "(default: #; '' for none)")  # fmt: skip
    group.add_argument("--sheet", metavar="NAME", help="the sheet of an Excel record (default: its first)")
    group.add_argument("--supply-voltage", type=positive, metavar="V",
                       help="supply voltage of a PWM drive [V]: --input-unit %% or counts becomes volts")  # fmt: skip
    group.add_argument(
        "--max-samples", type=number(int, low=1), default=COMMAND_MAX_SAMPLES, help=max_samples_help,
    )  # fmt: skip
    add_trim_options(parser)


#: The fields the library's messages name (``field=...`` or ``field=VALUE``) and the flags the command
#: line says instead, the one table of them: the record options' (:class:`motorid.io.records.RecordOptions`,
#: which :func:`record_options_from_args` reads from their flags), the commands' options that the
#: application layer's messages name (``model``, ``estimator``, ``param``, ``save_model``, ``skip``,
#: ``degree``), the fleet's (``out``, ``pattern``, ``per_drive`` of :func:`motorid.fleet.run`) and the
#: DAQ address (``url`` of :func:`motorid.io.daq_from_url`, the command line's ``--daq``).
FLAGS: dict[str, str] = {
    **{
        field: "--" + field.replace("_", "-")
        for field in ("time", "input", "output", "time_unit", "dt", "resample", "sep", "decimal", "thousands",
                      "comment", "sheet", "input_unit", "input_full_scale", "output_unit", "counts_per_rev",
                      "supply_voltage", "direction", "direction_forward", "duplicates", "max_samples", "start",
                      "stop", "model", "estimator", "param", "save_model", "skip", "na", "nb", "degree", "basis",
                      "low_speed_rpm", "reference_column", "out", "pattern", "per_drive")
    },
    "url": "--daq",
}  # fmt: skip
_ASIDE = re.compile(r" \(([a-z_]+=[^()]*)\)")
_FIELD = re.compile(r"\b(" + "|".join(sorted(FLAGS, key=len, reverse=True)) + r")=(\.\.\.|'[^']*'|[^\s);]+)?")


def with_flags(message: str) -> str:
    """A library message as the command line says it: each field of :data:`FLAGS` named as ``field=...``
    (``time_unit=...``, ``direction='dir'``, ``pattern='{drive}.csv'``) becomes its flag with the value
    as a shell takes it (``--time-unit``, ``--direction dir``, ``--pattern '{drive}.csv'``).

    Parameters
    ----------
    message : str
        The message of a :class:`motorid.errors.DataError`.
    """

    def flag(found: re.Match[str]) -> str:
        value = found.group(2)
        if value in (None, "...", "True"):  # True: a flag that takes no value
            return FLAGS[found.group(1)]
        if value.startswith("'") and value.endswith("'") and len(value) > 1:
            value = shlex.quote(value[1:-1])
        return f"{FLAGS[found.group(1)]} {value}"

    def aside(found: re.Match[str]) -> str:  # "--time-unit (time_unit=...)": the flag is said already
        fields = [field for field, _ in _FIELD.findall(found.group(1))]
        said = all(FLAGS[f] in message or message.count(f"{f}=") > 1 for f in fields)
        return "" if fields and said else found.group(0)

    return _FIELD.sub(flag, _ASIDE.sub(aside, message))


def separator(text: str) -> str:
    """An argparse type: a CSV separator, one character (``tab`` or ``\\t`` for a tab)."""
    value = {"tab": "\t", "\\t": "\t"}.get(text, text)
    if len(value) != 1 or value in '\r\n".':
        raise argparse.ArgumentTypeError(f"expected one character such as ',' ';' or tab, got {text!r}")
    return value


def record_options_from_args(args: argparse.Namespace) -> RecordOptions:
    """The record options (:func:`add_record_columns`) as one :class:`motorid.io.records.RecordOptions`,
    each field from its flag (:data:`FLAGS`)."""
    names = {f.name for f in fields(RecordOptions)}
    return RecordOptions(**{field: getattr(args, field) for field in FLAGS if field in names})


def read_record_from_args(args: argparse.Namespace, min_samples: int = 20) -> pd.DataFrame:
    """Read the record named by :func:`add_record_input`'s options, with columns ``t`` [s], ``u``, ``y``.

    :func:`motorid.io.records.read_record` with the options of :func:`record_options_from_args`:
    the time column is optional when the sample time is known (``--dt``, the file's attrs),
    the input and output are converted to motorid's units as they are read, an encoder's
    position is differentiated to a speed; then the span of ``--start``/``--stop`` is kept.
    """
    from motorid.io.records import read_record

    options = record_options_from_args(args)
    return read_record(args.data, options, min_samples=min_samples, other_columns=False, speed=True)


def iter_record_from_args(
    args: argparse.Namespace, chunk_rows: int | None = None, min_samples: int = 20
) -> Iterator[pd.DataFrame]:
    """The record of :func:`read_record_from_args` in consecutive blocks of ``chunk_rows`` rows
    (default :data:`motorid.io.records.CHUNK_ROWS`), each read, checked and converted as the
    whole record is, with the same options (:func:`motorid.io.records.iter_record`);
    ``--max-samples`` does not apply, since memory does not grow with the record. A record whose
    time stamps jitter raises :class:`motorid.errors.UniformGridError` (it is resampled
    whole: :func:`read_record_from_args`)."""
    from motorid.io.records import CHUNK_ROWS, iter_record

    options = record_options_from_args(args)
    return iter_record(
        args.data, options, min_samples=min_samples, chunk_rows=chunk_rows or CHUNK_ROWS, speed=True
    )


def add_trim_options(parser: argparse.ArgumentParser) -> None:
    """--start and --stop: the span of each record a command uses (:class:`motorid.io.records.RecordOptions`)."""
    group = parser.add_argument_group("span")
    group.add_argument("--start", type=number(float, low=0.0, unit="s"), metavar="SECONDS",
                       help="leave out the samples before this time [s] of the record's time column "
                            "(without one: k dt from its first sample)")  # fmt: skip
    group.add_argument("--stop", type=number(float, low=0.0, low_open=True, unit="s"), metavar="SECONDS",
                       help="leave out the samples after this time [s]")  # fmt: skip


def add_estimator_options(parser: argparse.ArgumentParser, repeatable: bool = False) -> None:
    """--estimator and its arguments; an argument is passed only to estimators that take it."""
    group = parser.add_argument_group("estimator")
    from motorid.estimators import available

    names = ", ".join(available())
    if repeatable:
        group.add_argument("--estimator", action="append", required=True, metavar="NAME",
                           help=f"registered estimator name, one of {names} (repeatable)")  # fmt: skip
    else:
        group.add_argument("--estimator", default="hammerstein-rls", metavar="NAME",
                           help=f"registered estimator name, one of {names} (default: hammerstein-rls)")  # fmt: skip
    group.add_argument("--help-params", action=EstimatorParamsHelp,
                       help="print the arguments (-p KEY=VALUE) the estimator named by --estimator takes, "
                            "with their defaults, and exit; give it after --estimator")  # fmt: skip
    group.add_argument("--na", type=number(int, low=0),
                       help=f"order of A(q^-1), arx-rls and hammerstein-rls (default: {PAPER_ORDER})")  # fmt: skip
    group.add_argument("--nb", type=number(int, low=0),
                       help=f"order of B(q^-1), arx-rls and hammerstein-rls (default: {PAPER_ORDER})")  # fmt: skip
    group.add_argument("--degree", type=number(int, low=1),
                       help="polynomial degree of hammerstein-rls's static block, e.g. 3 for the paper's cubic "
                            "(default: none; the static block is then --basis's)")  # fmt: skip
    group.add_argument("--basis",
                       help="hammerstein-rls's static block basis, e.g. 'u,sign' or 'dead_zone:0.8' "
                            "(default: u,sign where no --degree is given)")  # fmt: skip
    add_lam(group, default=None)
    group.add_argument("--delta", type=positive,
                       help="initial covariance P0 = delta I of the RLS estimators (default: 1000)")  # fmt: skip
    group.add_argument("--gamma-method", choices=("paper", "svd"),
                       help="Hammerstein step 2: gamma by the paper's formula or the rank-1 SVD (default: paper)")  # fmt: skip
    group.add_argument("-p", "--param", action="append", default=[], metavar="KEY=VALUE",
                       help="any other argument of the estimator, repeatable, e.g. -p R=0.18 for friction-ekf "
                            "(the speed sensor's variance [(rad/s)^2]); --help-params lists them")  # fmt: skip


def add_lam(group: argparse._ActionsContainer, default: float | None) -> None:
    shown = "1, the estimators' own: no forgetting" if default is None else f"{default:g}"
    group.add_argument("--lam", type=forgetting_factor, default=default,
                       help=f"forgetting factor of the RLS estimators, 0 < lam <= 1 (default: {shown})")  # fmt: skip


class EstimatorParamsHelp(argparse.Action):
    """``--help-params``: print the keyword arguments of the estimator ``--estimator`` names (its
    constructor's, through the classes it passes ``**kwargs`` on to), each with its default and the
    first line of its description in the docstrings, and exit."""

    def __init__(self, option_strings: list[str], dest: str, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        import inspect
        import re

        from motorid.estimators import available, factory

        name = getattr(namespace, "estimator", None) or "hammerstein-rls"
        name = name[-1] if isinstance(name, list) else name
        if name not in available():
            parser.error(f"--estimator: unknown estimator {name!r}; known: {', '.join(available())}")
        make = factory(name)
        classes = make.__mro__ if isinstance(make, type) else (make,)
        docs = "\n".join(inspect.getdoc(c) or "" for c in classes)
        lines = [f"{name}: -p KEY=VALUE sets any of these arguments [default]:"]
        for owner in classes:
            try:
                parameters = inspect.signature(owner).parameters.values()
            except (TypeError, ValueError):
                break
            for parameter in parameters:
                if parameter.name == "rig" or parameter.kind in (
                    parameter.VAR_KEYWORD,
                    parameter.VAR_POSITIONAL,
                ):
                    continue
                default = "required" if parameter.default is parameter.empty else repr(parameter.default)
                found = re.search(rf"^{re.escape(parameter.name)} : [^\n]*\n\s+([^\n]+)", docs, flags=re.M)
                meaning = f": {found.group(1).strip()}" if found else ""
                lines.append(f"  {parameter.name} [{default}]{meaning}")
            if not any(p.kind is p.VAR_KEYWORD for p in parameters):
                break
        if hasattr(make, "from_rig"):
            lines.append("With --model FILE the filter starts from that drive model (its constants and friction);"
                         " the doctor's rigid drive needs R, the speed sensor's variance [(rad/s)^2].")  # fmt: skip
        parser._print_message("\n".join(lines) + "\n", sys.stdout)  # on stdout, as --help is
        parser.exit(0)


def add_signal_options(parser: argparse.ArgumentParser, duration: float | None) -> None:
    """The excitation: --signal, --amplitude, --duration, --seed (the signal's seed only)."""
    group = parser.add_argument_group("excitation signal")
    group.add_argument("--signal", choices=SIGNALS, default="paper", help="excitation (default: paper)")
    group.add_argument("--amplitude", type=positive, help="signal amplitude [V] (default: the signal's)")
    group.add_argument(
        "--duration", type=positive, default=duration, required=duration is None,
        help="[s]" + ("" if duration is None else f" (default: {duration:g})"),
    )  # fmt: skip
    group.add_argument("--seed", type=number(int, low=0), default=0,
                       help="seed of the excitation signal (default: 0)")  # fmt: skip


#: The longest run or simulation a command plans [s]: a year.
MAX_PLANNED_SECONDS = 366 * 86400.0
#: Samples of excitation a run holds; a longer run repeats them (``motorid run``).
EXCITATION_BLOCK = 2**20


def planned_samples(duration: float, dt: float, bytes_per_sample: float, held: str) -> int:
    """The samples of ``--duration`` [s] at ``dt`` [s], refused in one line when impossible.

    A duration over :data:`MAX_PLANNED_SECONDS` is refused, and so is one whose samples, at
    ``bytes_per_sample`` in memory each (0: the command allocates as it goes), would need more
    than this machine's physical memory.

    Parameters
    ----------
    duration : float
        The ``--duration`` given [s].
    dt : float
        Sample time [s].
    bytes_per_sample : float
        Memory the command holds per planned sample [B].
    held : str
        What it holds in memory, for the message (``the record``).

    Raises
    ------
    DataError
        Naming ``--duration``, the samples and the bound.
    """
    if duration > MAX_PLANNED_SECONDS:
        raise DataError(
            f"--duration {duration:g} s is longer than a year ({MAX_PLANNED_SECONDS:g} s), the longest a "
            "command plans; run it in parts"
        )
    n = round(duration / dt)
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # no such figure on this system
        memory = 0
    need = n * bytes_per_sample
    if memory > 0 and need > memory:
        longest = memory / bytes_per_sample * dt
        raise DataError(
            f"--duration {duration:g} s is {n:,} samples at dt = {dt:g} s: {held} would need about "
            f"{need / 1e9:.3g} GB in memory, more than this machine's {memory / 1e9:.3g} GB; "
            f"give at most --duration {longest:.3g}"
        )
    return n


def excitation_from_args(args: argparse.Namespace, dt: float, longest: float | None = None) -> np.ndarray:
    """The excitation [V] per sample of :func:`add_signal_options`'s options at sample time ``dt``:
    the first ``longest`` seconds of it when given (a run repeats them)."""
    from motorid import signals

    duration = args.duration if longest is None else min(args.duration, longest)
    kwargs: dict[str, Any] = {"duration": duration, "dt": dt, "seed": args.seed}
    if args.signal == "paper":
        if args.amplitude is not None:
            kwargs["amplitudes"] = (args.amplitude, 0.625 * args.amplitude)
        return signals.two_sine_signal(**kwargs)[1]
    if args.amplitude is not None:
        kwargs["amplitude"] = args.amplitude
    return getattr(signals, args.signal)(**kwargs)[1]


def add_plant_seed(parser: argparse.ArgumentParser, default: int | None) -> None:
    parser.add_argument(
        "--plant-seed", type=number(int, low=0), default=default,
        help="seed of the simulated rig's sensor noise" + ("" if default is None else f" (default: {default})"),
    )  # fmt: skip


def add_u_max(parser: argparse.ArgumentParser, meaning: str) -> None:
    parser.add_argument("--u-max", type=positive, default=12.0, help=f"{meaning} [V] (default: 12)")


def add_low_speed_band(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--low-speed-rpm", type=positive, default=LOW_SPEED_RPM,
                        help=f"low-speed band |y| < this [rpm] (default: {LOW_SPEED_RPM:g})")  # fmt: skip


def add_skip(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--skip", type=number(int, low=0), default=50,
                        help="leading samples left out of the scores (default: 50)")  # fmt: skip


# --------------------------------------------------------------------------- files written
def add_out_file(parser: argparse.ArgumentParser, what: str, required: bool = True) -> None:
    parser.add_argument("--out", type=Path, required=required, help=f"{what}; an existing file is refused "
                        "unless --overwrite is given")  # fmt: skip
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out file")


def check_out_file(path: Path, overwrite: bool, option: str = "--out") -> None:
    """Refuse, before any work, a file that exists (without ``overwrite``) or cannot be written."""
    if path.is_dir():
        raise DataError(f"{option} {path}: is a folder, expected a file name")
    if path.exists() and not overwrite:
        raise DataError(
            f"{option} {path}: the file exists; pass --overwrite to replace it, or choose another name"
        )
    folder = path.parent if str(path.parent) else Path(".")
    _check_folder_writable(folder, option, path)


def check_out_folder(path: Path, option: str = "--out") -> None:
    """Create the folder ``path`` (and parents) or refuse with the reason, before any work."""
    if path.exists() and not path.is_dir():
        raise DataError(f"{option} {path}: is a file, expected a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DataError(f"{option} {path}: cannot create the folder: {exc.strerror}") from None
    _check_folder_writable(path, option, path)


def add_wait(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--wait", action="store_true",
                        help="when another run writes the --out folder, wait for it to finish instead of "
                             "refusing")  # fmt: skip


def hold_out_folder(args: argparse.Namespace, path: Path, option: str = "--out") -> None:
    """Lock the folder ``path`` for the rest of the command (:class:`motorid.outputs.FolderLock`).

    A second run into the folder is refused with one line naming the lock file and
    the first run's process, or waits for it with ``--wait``. The lock is kept in
    ``args.out_lock``; :func:`motorid.cli.main` releases it when the command returns
    (and the kernel, if the process dies first).
    """
    from motorid.errors import OutputError
    from motorid.outputs import FolderLock

    lock = FolderLock(path, wait=getattr(args, "wait", False))
    try:
        lock.acquire()
    except OutputError as exc:
        if getattr(exc, "errno", None) == errno.EWOULDBLOCK:
            raise DataError(f"{option} {exc}; pass --wait to wait for it, or choose another folder") from None
        raise DataError(f"{option} {exc}; remove it, or choose another folder") from None
    args.out_lock = lock


def _check_folder_writable(folder: Path, option: str, path: Path) -> None:
    if not folder.is_dir():
        raise DataError(f"{option} {path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DataError(f"{option} {path}: the folder {folder} is not writable")
