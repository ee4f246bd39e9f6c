"""``motorid rig serve``, ``motorid rig map`` and ``motorid run``: a rig behind Modbus, online runs."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd

from motorid.errors import DataError

from .options import (
    EXCITATION_BLOCK,
    add_estimator_options,
    add_json,
    add_out_file,
    add_plant_seed,
    add_signal_options,
    add_u_max,
    check_out_file,
    excitation_from_args,
    non_negative,
    number,
    planned_samples,
    positive,
)
from .report import emit_json, say, say_error, say_params, show_progress

if TYPE_CHECKING:
    from motorid.io import DAQ, RegisterMap


def cmd_rig_serve(args: argparse.Namespace) -> int:
    """Serve the simulated rig (the default one or a model file's: a two-mass rig or a rigid
    drive) over Modbus until Ctrl-C."""
    from motorid.app.identify import drive_model_from_file
    from motorid.drive import RigidDrive, paper_rig
    from motorid.drive.files import read_model_file
    from motorid.io import RigServer
    from motorid.speed_control import SensedPlant

    rig = paper_rig() if args.model is None else drive_model_from_file(args.model)
    card = None if args.model is None else read_model_file(args.model).card
    if isinstance(rig, RigidDrive):
        served, rating, lacking = (
            "rigid drive",
            rig.params.get("saturation", math.inf),
            "the rigid drive has no input saturation",
        )
    else:
        served, rating, lacking = "rig", rig.amplifier.v_max, "its amplifier has no saturation"
    if not math.isfinite(rating) and card is not None and card.input_unit == "%":
        rating = 100.0  # a duty ends at 100 %
    u_max = rating if args.u_max is None else args.u_max
    if not math.isfinite(u_max):
        raise DataError(f"--model {args.model}: {lacking}; give the rating with --u-max")
    # a model file's card: the plant measured by its sensor (SensedPlant), the command register in its unit
    plant = rig.simulation() if card is None else SensedPlant(rig, card)
    if card is not None and card.input_unit not in (None, "V"):
        say(f"  note: {args.model.name} was fitted on {card.input_words()}: the command register is in "
            f"{card.input_unit}")  # fmt: skip
    server = RigServer(
        plant, host=args.host, port=args.port, serial_port=args.serial, baudrate=args.baudrate,
        register_map=register_map_option(args.map), word_order=args.word_order, lockstep=not args.realtime,
        seed=args.plant_seed, watchdog_periods=watchdog_periods(args, plant.dt) or None, u_max=u_max,
    )  # fmt: skip
    where = args.serial or f"{args.host}:{args.port}"
    if not args.serial:
        check_port_free(args.host, args.port)
    listening: list[bool] = []

    def banner() -> None:
        listening.append(True)
        what = "simulated rig" if args.model is None else f"{served} of {args.model}"
        say(f"motorid rig serve: {what} on Modbus {server.url} "
            f"({'real time' if args.realtime else 'lock-step'}); Ctrl-C stops it")  # fmt: skip

    try:
        server.serve_forever(on_listening=banner)
    except RuntimeError as exc:
        if listening:  # failed while serving: not the user's input
            raise
        option = "--serial" if args.serial else "--port"
        raise DataError(f"{option}: cannot serve Modbus on {where}: {exc.__cause__ or exc}") from None
    return 0


def watchdog_periods(args: argparse.Namespace, dt: float) -> float:
    """``--watchdog-periods``, or its default: 3 commands lock-step; with ``--realtime``, the periods of
    :data:`~motorid.io.rig_server.REALTIME_WATCHDOG` (2 s: 50 at 40 ms), since the served rig shares the
    computer's cores with its client.

    Parameters
    ----------
    args : argparse.Namespace
        ``rig serve``'s options (``watchdog_periods``, ``realtime``).
    dt : float
        The served plant's sample time [s].
    """
    from motorid.io.rig_server import REALTIME_WATCHDOG

    if args.watchdog_periods is not None:
        return args.watchdog_periods
    return max(3.0, REALTIME_WATCHDOG / dt) if args.realtime else 3.0


def check_port_free(host: str, port: int) -> None:
    """Refuse, with the operating system's reason, a TCP address the rig server could not listen on."""
    import socket

    with socket.socket() as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server binds
        try:
            probe.bind((host, port))
        except OSError as exc:
            raise DataError(f"--port {port}: cannot listen on {host}:{port}: {exc.strerror or exc}") from None


def cmd_rig_map(args: argparse.Namespace) -> int:
    """Print the register map in use as TOML."""
    from motorid.io import rig_map_toml

    sys.stdout.write(rig_map_toml(register_map_option(args.map), args.word_order))
    return 0


def register_map_option(path: str | None) -> RegisterMap | None:
    """The register map of ``--map PATH`` (None: the built-in one); a file that is no map is refused in one
    line naming the option."""
    from motorid.io import RegisterMap

    if path is None:
        return None
    try:
        return RegisterMap.from_toml(path)
    except DataError:  # a file that cannot be read: the message names it as a register map
        raise
    except ValueError as exc:  # a file that is no map: the message starts with the file's name
        raise DataError(f"--map {exc}") from None


def daq_from_options(
    url: str, *, dt: float | None, register_map: str | None, timeout: float | None, **kw: Any
) -> DAQ:
    """The DAQ of ``--daq URL`` with ``--dt``, ``--map`` and ``--timeout`` (:func:`motorid.io.daq_from_url`);
    what cannot be used is refused in one line naming the option."""
    from motorid.io import daq_from_url

    simulated = url.strip() in ("sim", "sim://", "simulated")
    if simulated and (register_map is not None or timeout is not None):
        given = "--map" if register_map is not None else "--timeout"
        raise DataError(f"{given} applies to a Modbus --daq only, not to --daq {url}")
    the_map = register_map_option(register_map)
    try:
        return daq_from_url(url, dt=dt, register_map=the_map, timeout=timeout, **kw)
    except ValueError as exc:  # the address said as url=... (main's with_flags: --daq), once
        text = str(exc).removeprefix(f"{url.strip()!r}: ").removeprefix(f"url={url!r}: ")
        if simulated:  # the simulated rig's refusal names its own field (dt=...)
            raise DataError(text) from None
        raise DataError(f"url={url.strip()!r}: {text}") from None


def rig_stopped(command: str, url: str, exc: Exception) -> DataError:
    """The one line that says why ``motorid COMMAND`` (run, control) stopped on the rig at ``url``.

    The library's errors advise Python calls; here the advice is a command and its options: a
    fault is acknowledged by starting the command again, a rig another client owns is freed by
    stopping that client. The notes on ``exc`` (what is on disk) follow.
    """
    from motorid.errors import RigBusyError, RigFaultError
    from motorid.io import STATUS_BITS
    from motorid.io.modbus import describe_status

    notes = " ".join(getattr(exc, "__notes__", []))
    if isinstance(exc, RigFaultError):
        why = ""
        if exc.status & STATUS_BITS["watchdog"]:
            why = " (its watchdog tripped: no heartbeat came for its watchdog periods)"
        text = (
            f"{command} stopped: the rig at {url} reports fault {describe_status(exc.status)}{why} and holds 0 V. "
            f"Once the cause is fixed, start motorid {command} again (with another --out, or --overwrite): "
            "it acknowledges the fault as it connects."
        )
    elif isinstance(exc, RigBusyError):
        text = (
            f"{command} stopped: the rig at {url} is owned by another client and refused this one's commands. "
            f"Stop the other client (or wait until the rig's watchdog frees it), then start motorid {command} again."
        )
    else:
        text = f"{command} stopped: {exc}."
    return DataError(f"{text} {notes}".strip())


def loop_timing(record: pd.DataFrame) -> str:
    """What a run's loop kept of its time: ``largest time between two samples 41.2 ms (dt 40 ms)``."""
    largest, dt = record.attrs["largest_interval"], record.attrs["dt"]
    if not math.isfinite(largest):
        return "fewer than two samples taken"
    return f"largest time between two samples {largest * 1e3:.3g} ms (dt {dt * 1e3:.3g} ms)"


def cmd_run(args: argparse.Namespace) -> int:
    """Online identification on a DAQ (simulated rig or Modbus)."""
    from motorid.app.identify import create_estimator
    from motorid.errors import DAQError
    from motorid.io import run_online

    check_out_file(args.out, args.overwrite)
    estimators = {name: create_estimator(name, args) for name in args.estimator}
    simulated = args.daq.strip() in ("sim", "sim://", "simulated")
    if not simulated and args.plant_seed is not None:
        raise DataError(f"--plant-seed applies to --daq sim only; the rig behind {args.daq} has its own "
                        "(motorid rig serve --plant-seed)")  # fmt: skip
    daq = daq_from_options(
        args.daq, seed=(args.plant_seed or 0) if simulated else None, dt=args.dt, register_map=args.map,
        u_max=args.u_max, timeout=args.timeout,
    )  # fmt: skip
    dt = daq.dt
    n = planned_samples(args.duration, dt, 0, "the run")  # the rows go to --out as they come
    block = excitation_from_args(args, dt, longest=EXCITATION_BLOCK * dt)

    def repeated(t: float) -> float:  # a run longer than the block repeats it
        return float(block[round(t / dt) % block.size])

    excitation = block if block.size >= n else repeated
    try:
        record = run_online(daq, estimators, excitation, args.duration, out=args.out, progress=show_progress(),
                            overwrite=args.overwrite)  # fmt: skip
    except DAQError as exc:
        raise rig_stopped("run", args.daq, exc) from None
    except KeyboardInterrupt as exc:  # exit 130 (main), after saying what is on disk
        say_error(f"motorid run: {exc or 'interrupted'}; " + " ".join(getattr(exc, "__notes__", [])))
        raise
    say(f"wrote {args.out}: {record.attrs['samples']} samples; {loop_timing(record)}")
    for name, est in estimators.items():
        say_params(f"{name}.", est.params)
    if args.json:
        emit_json({"out": args.out, "samples": record.attrs["samples"],
                   "largest_interval": record.attrs["largest_interval"],
                   "params": {n: e.params for n, e in estimators.items()}})  # fmt: skip
    return 0


def add_register_map(parser: argparse.ArgumentParser, printed: bool = False) -> None:
    text = (
        "register map TOML file to print, e.g. one edited from this command's output (default: the built-in map)"
        if printed
        else "register map TOML file (default: the built-in map; motorid rig map prints it)"
    )
    parser.add_argument("--map", help=text)


def add_commands(sub: argparse._SubParsersAction) -> None:
    rig = sub.add_parser("rig", help="the simulated rig behind Modbus").add_subparsers(
        dest="rig_command", required=True, metavar="RIG_COMMAND"
    )
    for name, helptext, func in (
        ("serve", "serve the simulated rig over Modbus TCP or RTU", cmd_rig_serve),
        ("map", "print the register map in use as TOML", cmd_rig_map),
    ):
        p = rig.add_parser(name, help=helptext)
        add_register_map(p, printed=name == "map")
        p.add_argument("--word-order", choices=("ABCD", "CDAB"), default="ABCD", help="float32 word order")
        p.set_defaults(func=func)
    serve = rig.choices["serve"]
    serve.add_argument("--model", type=Path, metavar="FILE",
                       help="serve the model file's rig or rigid drive (default: the default rig)")  # fmt: skip
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (default: 127.0.0.1)")
    serve.add_argument("--port", type=number(int, low=1, high=65535), default=5020,
                       help="TCP port (default: 5020)")  # fmt: skip
    serve.add_argument("--serial", metavar="DEVICE", help="serve Modbus RTU on this serial device instead")
    serve.add_argument("--baudrate", type=number(int, low=1), default=115200,
                       help="the serial line's speed with --serial [bit/s]")  # fmt: skip
    serve.add_argument("--realtime", action="store_true", help="advance with the clock, not lock-step")
    add_plant_seed(serve, default=None)
    serve.add_argument("--watchdog-periods", type=non_negative,
                       help="the watchdog: with --realtime, the time without a heartbeat [sample periods]; "
                            "lock-step, the commands in a row without a heartbeat (the plant waits for the "
                            "client); more zero the voltage and latch a fault; 0: off (default: 3 lock-step; "
                            "with --realtime, 2 s of periods: 50 at 40 ms)")  # fmt: skip
    serve.add_argument("--u-max", type=positive,
                       help="voltage rating [V]: commands are clamped to it (default: the rig's amplifier "
                            "saturation, or the rigid drive's input saturation)")  # fmt: skip

    p = sub.add_parser("run", help="online identification on a DAQ")
    p.add_argument(
        "--daq", default="sim", help="sim, modbus://HOST:PORT or modbus-rtu:///dev/X (default: sim)"
    )
    add_estimator_options(p, repeatable=True)
    add_signal_options(p, duration=None)
    add_out_file(
        p,
        "CSV written row by row as the run goes, after a first line of the record's attributes (dt, "
        "units V and rad/s, timing hold), so motorid doctor, identify and compare read it as it is",
    )
    add_plant_seed(p, default=None)
    p.add_argument("--dt", type=positive, help="sample time [s] (default: the rig's)")
    add_register_map(p)
    p.add_argument(
        "--timeout", type=positive, help="wait for each Modbus answer [s] (default: 2 s, or 2.5 dt if longer)"
    )
    add_u_max(p, "voltage clamp")
    add_json(p)
    p.set_defaults(func=cmd_run)
