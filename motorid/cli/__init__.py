"""The ``motorid`` command.

Each subcommand prints human text on stderr and, with ``--json``, one JSON object
on stdout. Figures are PNG files written where ``--out`` says.

With ``--quiet`` (before or after the subcommand) a command prints only its
errors and warnings on stderr: no progress bar, no report. Progress bars show
only when stderr is a terminal (:func:`motorid.cli.report.show_progress`).

Exit status: 0 done; 2 the user's input cannot be used (an option, a file, a
column, a value: one line names it); 1 a bug in motorid (one line, the
traceback with ``-v``); 130 interrupted.
"""

from __future__ import annotations

import argparse
import gc
import logging
import os
import sys
import traceback
import warnings
from collections.abc import Sequence
from typing import NoReturn, TextIO

# Set before numpy is first imported (by the subcommands below). The commands' linear algebra is on
# small matrices (the doctor solves ~600 least-squares problems of ~1,300 x 8 per record), where
# BLAS threads woken for each call cost more than they save: on a loaded 2-core machine the doctor's
# fit of an 80 s record took 2.3 s with two threads and 0.8 s with one, with equal results.
# A value the user sets is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from motorid.errors import DataError

from . import comparison, control, doctor, fleet, identification, rig, simulation
from .options import with_flags
from .report import configure, first_time, say_error, warning_line

__all__ = ["build_parser", "main", "run"]

logger = logging.getLogger("motorid")


def show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """A warning as one line on stderr, ``motorid: warning: <message>``, once per cause: no source
    line, no file name (what a user of the command can act on is the message; ``-v`` logs say where)."""
    said = warning_line(str(message))
    if said is not None:
        (file or sys.stderr).write(said + "\n")
    logger.debug("the warning above is a %s from %s:%s", category.__name__, filename, lineno)


class LogFormatter(logging.Formatter):
    """The library's log records on the command line: a warning or an error as the warnings are,
    ``motorid: warning: <message>`` on one line; the details of ``-v`` with their level and logger;
    the fields they name said as their flags (:func:`~motorid.cli.options.with_flags`)."""

    def __init__(self) -> None:
        super().__init__("%(levelname)s %(name)s: %(message)s")

    def format(self, record: logging.LogRecord) -> str:
        if record.levelno >= logging.WARNING:
            return f"motorid: {record.levelname.lower()}: {with_flags(' '.join(record.getMessage().split()))}"
        return with_flags(super().format(record))


class OncePerCause(logging.Filter):
    """Lets a warning through the first time the running command says it (:func:`first_time`)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return record.levelno < logging.WARNING or first_time(" ".join(record.getMessage().split()))


class _HelpFormatter(argparse.HelpFormatter):
    """argparse's help with each option's default shown where its help text does not say it."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        shown = "default" in text or "%(default)" in text
        meaningful = default is not None and default is not argparse.SUPPRESS and default != []
        flag = isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction))
        if shown or not meaningful or flag or not action.option_strings:
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error that names the option and where to find help, each option's
    default in ``--help``, and ``--quiet`` on every command, before or after the subcommand's name."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)
        # SUPPRESS: a subcommand's parser leaves the value the main parser set alone
        self.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                          help="print only errors and warnings on stderr: no progress bar, no report")  # fmt: skip

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="motorid",
        description="Nonlinear modelling and online identification of bidirectional DC motor drives.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output on stderr; the traceback of an internal error")  # fmt: skip
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_Parser)
    for module in (simulation, identification, doctor, comparison, rig, control, fleet):
        module.add_commands(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``motorid ARGV`` and return its exit status (also for a bad option or ``--help``).

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after ``motorid`` (``sys.argv[1:]`` when None).
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse has printed the help or the one-line error
        return int(exc.code or 0)
    configure(quiet=getattr(args, "quiet", False), json=getattr(args, "json", False))
    level = logging.WARNING - 10 * min(args.verbose, 2)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(LogFormatter())
    handler.addFilter(OncePerCause())
    logging.basicConfig(level=level, handlers=[handler])  # a handler the caller set up is kept
    # the cluster's own log (a worker lost and its tasks rerun) only with -v: the run reports what matters
    logging.getLogger("distributed").setLevel(logging.WARNING if args.verbose else logging.CRITICAL)
    subcommand = getattr(args, "rig_command", None) or getattr(args, "fleet_command", None)
    command = " ".join(filter(None, (args.command, subcommand)))
    try:
        with warnings.catch_warnings():  # the caller's own warning display is restored after the command
            warnings.showwarning = show_warning
            return args.func(args)
    except DataError as exc:
        say_error(f"motorid {command}: error: {with_flags(str(exc))}")
        return 2
    except KeyboardInterrupt:
        say_error(f"motorid {command}: interrupted")
        return 130
    except OSError as exc:  # the machine's answer about a file or a port the user named
        say_error(f"motorid {command}: error: {exc}")
        return 2
    except Exception as exc:
        if args.verbose:
            traceback.print_exc()
        say_error(
            f"motorid {command}: internal error: {type(exc).__name__}: {exc}. This is a bug in motorid; "
            + (
                "please report it with the traceback above."
                if args.verbose
                else "rerun with -v for the traceback."
            )
        )
        return 1
    finally:
        lock = getattr(args, "out_lock", None)  # the --out folder a command held (options.hold_out_folder)
        if lock is not None:
            lock.release()


def run() -> NoReturn:
    """The ``motorid`` console command: :func:`main` on ``sys.argv[1:]``, then the process ends with
    its exit status.

    A command's imports leave some 190,000 objects that live as long as the process (numpy,
    pandas, SciPy, numba and their modules). Python's collector passes over all of them in each
    full collection and once more at exit: 0.4-0.8 s of a 2.5 s ``motorid doctor``
    (``benchmarks/bench_doctor_startup.py``). So the objects of the modules loaded when this starts
    (the command line's, with everything its parser needs) are moved out of the collector's sight
    first (:func:`gc.freeze`), and everything once the command has returned, its files written and
    closed, so the exit frees the process without that pass. :func:`main`, which a caller may run
    many times in one process, leaves the collector as it is.
    """
    gc.freeze()  # the loaded modules live as long as the process: no full collection passes over them
    status = main()
    gc.freeze()  # the process ends here: no final pass over every object it made
    sys.exit(status)
