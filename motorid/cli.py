"""The ``motorid`` command.

Each subcommand prints human text on stderr and, with ``--json``, one JSON object
on stdout. Figures are PNG files written where ``--out`` says.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

logger = logging.getLogger("motorid")

SIGNALS = ("paper", "prbs", "multisine", "chirp", "steps")


class CommandError(Exception):
    """A problem with the command line or its inputs, reported as one line."""


# --------------------------------------------------------------------------- output
def _jsonable(value: Any) -> Any:
    """numpy and pandas values as plain JSON (NaN and inf as null)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, Path):
        return str(value)
    return value


def _emit_json(payload: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(_jsonable(payload), indent=2) + "\n")


def _say(text: str = "") -> None:
    sys.stderr.write(text + "\n")


def _frame_records(df: pd.DataFrame) -> list[dict[str, Any]]:
    return [
        {df.index.name or "index": idx, **row}
        for idx, row in zip(df.index, df.to_dict("records"), strict=True)
    ]


# --------------------------------------------------------------------------- shared arguments
def _add_record_columns(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("data", type=Path, help="record CSV (columns t [s], u [V], y [rad/s] by default)")
    parser.add_argument("--time", default="t", metavar="COL", help="time column [s] (default: t)")
    parser.add_argument("--input", default="u", metavar="COL", help="input column [V] (default: u)")
    parser.add_argument("--output", default="y", metavar="COL", help="output column [rad/s] (default: y)")
    parser.add_argument("--dt", type=float, help="sample time [s] (default: from the file)")


def _add_estimator_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("estimator options (passed only when given)")
    group.add_argument("--na", type=int, help="order of A(q^-1)")
    group.add_argument("--nb", type=int, help="order of B(q^-1)")
    group.add_argument("--degree", type=int, help="polynomial degree of the static block")
    group.add_argument("--basis", help="static block basis, e.g. 'u,sign' or 'dead_zone:0.8'")
    group.add_argument("--lam", type=float, help="forgetting factor, 0 < lam <= 1")
    group.add_argument("--delta", type=float, help="initial covariance P0 = delta I")
    group.add_argument("--gamma-method", choices=("paper", "svd"), help="Hammerstein step 2")
    group.add_argument(
        "-p", "--param", action="append", default=[], metavar="KEY=VALUE", help="any other estimator argument"
    )


def _parse_value(text: str) -> Any:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    return text


def _estimator_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    kwargs: dict[str, Any] = {}
    for key in ("na", "nb", "degree", "basis", "lam", "delta", "gamma_method"):
        value = getattr(args, key, None)
        if value is not None:
            kwargs[key] = value
    for item in args.param:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise CommandError(f"--param expects KEY=VALUE, got {item!r}")
        kwargs[key.replace("-", "_")] = _parse_value(value)
    return kwargs


def _create_estimator(name: str, kwargs: dict[str, Any]):
    from motorid.estimators import create

    try:
        return create(name, **kwargs)
    except TypeError as exc:  # an argument this estimator does not take
        raise CommandError(f"estimator {name!r}: {exc}") from None


def _read(args: argparse.Namespace, min_samples: int = 20) -> pd.DataFrame:
    from motorid.records import read_record

    if not args.data.exists():
        raise CommandError(f"no such file: {args.data}")
    columns = {"t": args.time, "u": args.input, "y": args.output}
    return read_record(args.data, dt=args.dt, columns=columns, min_samples=min_samples)


# --------------------------------------------------------------------------- subcommands
def cmd_demo(args: argparse.Namespace) -> int:
    """The paper's experiment on the simulated rig: tables, figures, record."""
    from motorid.experiment import run_paper_experiment
    from motorid.records import write_record

    _say(f"motorid demo: simulating the default rig for {args.duration:g} s and identifying online ...")
    experiment = run_paper_experiment(
        duration=args.duration, seed=args.seed, low_speed_rpm=args.low_speed_rpm
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    record_path = out / "demo_record.csv"
    write_record(experiment.record, record_path)
    table = experiment.table()
    table.to_csv(out / "demo_table.csv")
    figures = experiment.write_figures(out)
    with pd.option_context("display.width", 140, "display.max_columns", 10):
        _say(f"\nMSE [rpm^2] over the whole record and at low speed (|y| < {args.low_speed_rpm:g} rpm):")
        _say(table.round(2).to_string())
    _say(f"\nwrote {record_path}, {out / 'demo_table.csv'} and {len(figures)} figures in {out}/")
    if args.json:
        _emit_json(
            {
                "table": [
                    {"model": m, "prediction": p, **row}
                    for (m, p), row in zip(table.index, table.to_dict("records"), strict=True)
                ],
                "params": {label: run.estimator.params for label, run in experiment.runs.items()},
                "record": record_path,
                "figures": figures,
            }
        )
    return 0


def _signal(name: str, duration: float, dt: float, seed: int, amplitude: float | None) -> np.ndarray:
    from motorid.plants import signals

    kwargs: dict[str, Any] = {"duration": duration, "dt": dt, "seed": seed}
    if name == "paper":
        if amplitude is not None:
            kwargs["amplitudes"] = (amplitude, 0.625 * amplitude)
        return signals.two_sine_signal(**kwargs)[1]
    if amplitude is not None:
        kwargs["amplitude"] = amplitude
    return getattr(signals, name)(**kwargs)[1]


def _rig_from_args(args: argparse.Namespace):
    from motorid.plants import Amplifier, CoulombFriction, StribeckFriction, ViscousFriction, paper_rig

    friction = []
    if args.coulomb_motor > 0:
        friction.append(CoulombFriction(alpha=args.coulomb_motor, side="motor"))
    if args.coulomb_load > 0:
        friction.append(CoulombFriction(alpha=args.coulomb_load, side="load"))
    if args.stribeck is not None:
        a1, a2 = args.stribeck
        friction.append(StribeckFriction(alpha0=0.0, alpha1=a1, alpha2=a2, side="motor"))
    if args.viscous > 0:
        friction.append(ViscousFriction(B=args.viscous, side="motor"))
    return paper_rig(
        friction=tuple(friction),
        amplifier=Amplifier(gain=1.0, dead_zone=args.dead_zone, v_max=args.u_max),
        backlash=args.backlash,
    )


def cmd_simulate(args: argparse.Namespace) -> int:
    """Simulate the rig on an excitation signal and write the record."""
    from motorid.records import write_record

    rig = _rig_from_args(args)
    u = _signal(args.signal, args.duration, rig.dt, args.seed, args.amplitude)
    record = rig.simulate(u, seed=args.seed, integrator=args.integrator)
    write_record(record, args.out)
    y = record["y"].to_numpy()
    _say(f"wrote {args.out}: {len(record)} samples at dt = {rig.dt:g} s, |y| max {np.abs(y).max():.1f} rad/s")
    if args.json:
        _emit_json({"out": args.out, "samples": len(record), "dt": rig.dt, "rig": record.attrs.get("rig")})
    return 0


def cmd_identify(args: argparse.Namespace) -> int:
    """Identify one estimator on a record; report params, MSE, FIT and residual tests."""
    from motorid.validation import (
        RPM_PER_RAD_S,
        plot_residual_tests,
        residual_tests,
        rpm_to_rad_s,
        score_predictions,
    )

    record = _read(args)
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    est = _create_estimator(args.estimator, _estimator_kwargs(args))
    result = est.batch_filter(u, y)
    free_run = est.simulate(u)
    threshold = float(rpm_to_rad_s(args.low_speed_rpm))
    scores = score_predictions(y, {"one_step": result.y_hat, "free_run": free_run}, threshold, args.skip)
    tests = residual_tests(u[args.skip :], (y - result.y_hat)[args.skip :], max_lag=args.max_lag)
    _say(f"{args.estimator} on {args.data} ({len(record)} samples)")
    for name, value in est.params.items():
        _say(f"  {name} = {np.array2string(np.asarray(value), precision=5)}")
    for kind, row in scores.iterrows():
        _say(
            f"  {kind:<9} MSE {row['mse']:.4g} (rad/s)^2 = {row['mse'] * RPM_PER_RAD_S**2:.4g} rpm^2, "
            f"low-speed MSE {row['low_speed_mse'] * RPM_PER_RAD_S**2:.4g} rpm^2, FIT {row['fit_percent']:.2f} %"
        )
    for test in tests:
        _say(f"  residual test {test.formula:<22} {'pass' if test.passed else 'FAIL'}")
    figure = None
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        figure = Path(args.out) / "residual_tests.png"
        plot_residual_tests(tests, str(figure), f"Residuals of {args.estimator} (one-step)")
        _say(f"  wrote {figure}")
    if args.json:
        _emit_json(
            {
                "estimator": args.estimator,
                "samples": len(record),
                "params": est.params,
                "scores": {
                    kind: {**row, "mse_rpm2": row["mse"] * RPM_PER_RAD_S**2}
                    for kind, row in scores.to_dict("index").items()
                },
                "low_speed_threshold_rad_s": threshold,
                "residual_tests": {
                    t.name: {"passed": t.passed, "fraction_outside": t.fraction_outside} for t in tests
                },
                "figure": figure,
            }
        )
    return 0


def _int_range(text: str) -> list[int]:
    """'1-6' or '2,3,5' as a list of ints."""
    try:
        if "-" in text:
            lo, hi = text.split("-", 1)
            return list(range(int(lo), int(hi) + 1))
        return [int(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a range like 1-6 or a list like 2,3,5, got {text!r}"
        ) from None


def cmd_sweep(args: argparse.Namespace) -> int:
    """The paper's Tables 1 and 2 on a record."""
    from motorid.validation import order_sweep, rpm_to_rad_s

    record = _read(args)
    tables = order_sweep(
        record["u"].to_numpy(), record["y"].to_numpy(), args.orders, args.degrees,
        degree=args.degree, order=args.order, lam=args.lam, prediction=args.prediction,
        low_speed_threshold=float(rpm_to_rad_s(args.low_speed_rpm)), skip=args.skip, progress=True,
    )  # fmt: skip
    with pd.option_context("display.width", 140, "display.max_columns", 12):
        _say(f"Table 1: MSE [rpm^2] per model order (degree {args.degree}), {args.prediction} prediction")
        _say(tables.orders.round(3).to_string())
        _say(f"\nTable 2: MSE [rpm^2] and gamma per polynomial degree (order {args.order})")
        _say(tables.degrees.to_string(float_format=lambda v: f"{v:.5g}"))
    if args.json:
        _emit_json(
            {
                "table1": _frame_records(tables.orders),
                "table2": _frame_records(tables.degrees),
                "low_speed_threshold_rad_s": tables.low_speed_threshold,
                "prediction": tables.prediction,
            }
        )
    return 0


def cmd_rig_serve(args: argparse.Namespace) -> int:
    """Serve the simulated rig over Modbus until Ctrl-C."""
    from motorid.io import RigServer

    server = RigServer(
        None, host=args.host, port=args.port, serial_port=args.serial, baudrate=args.baudrate,
        register_map=args.map, word_order=args.word_order, lockstep=not args.realtime, seed=args.seed,
        watchdog_periods=args.watchdog_periods or None, u_max=args.u_max,
    )  # fmt: skip
    where = args.serial or f"{args.host}:{args.port}"
    _say(
        f"motorid rig serve: simulated rig on Modbus {where} ({'real time' if args.realtime else 'lock-step'})"
    )
    server.serve_forever()
    return 0


def cmd_rig_map(args: argparse.Namespace) -> int:
    """Print the register map in use as TOML."""
    from motorid.io import rig_map_toml

    sys.stdout.write(rig_map_toml(args.map, args.word_order))
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """Online identification on a DAQ (simulated rig or Modbus)."""
    from motorid.io import DAQError, daq_from_url, run_online

    kwargs = _estimator_kwargs(args)
    estimators = {name: _create_estimator(name, kwargs) for name in args.estimator}
    daq = daq_from_url(
        args.daq, seed=args.seed, dt=args.dt, register_map=args.map, u_max=args.u_max, timeout=args.timeout
    )
    excitation = _signal(args.signal, args.duration, daq.dt, args.seed, args.amplitude)
    try:
        record = run_online(daq, estimators, excitation, args.duration, out=args.out, progress=True)
    except (DAQError, KeyboardInterrupt) as exc:
        notes = " ".join(getattr(exc, "__notes__", []))
        raise CommandError(f"run stopped: {exc or type(exc).__name__}. {notes}".strip()) from None
    _say(f"wrote {args.out}: {len(record)} samples")
    for name, est in estimators.items():
        for key, value in est.params.items():
            _say(f"  {name}.{key} = {np.array2string(np.asarray(value), precision=5)}")
    if args.json:
        _emit_json(
            {"out": args.out, "samples": len(record), "params": {n: e.params for n, e in estimators.items()}}
        )
    return 0


def cmd_doctor(args: argparse.Namespace) -> int:
    """Find the missing effect: where model and measurement disagree, which effect, how much better."""
    from motorid.diagnose import diagnose
    from motorid.records import read_record

    base = _effect_list(args.base, "--base")
    candidates = _effect_list(args.candidates, "--candidates") if args.candidates else None
    if not args.data.exists():
        raise CommandError(f"no such file: {args.data}")
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise CommandError(f"--dt must be finite and > 0 [s], got {args.dt!r}")
    if not (math.isfinite(args.input_gain) and args.input_gain > 0):
        raise CommandError(f"--input-gain must be finite and > 0, got {args.input_gain!r}")
    # checks every column (NaN or text names the column and row) and dt against the time column
    record = read_record(args.data, dt=args.dt, columns=[args.input, args.output], min_samples=20)
    try:
        diagnosis = diagnose(
            record, dt=args.dt, input=args.input, output=args.output, output_kind=args.output_kind,
            input_gain=args.input_gain, base=base, candidates=candidates,
            holdout=args.holdout, max_steps=args.max_steps, progress=not args.json, timing=args.timing,
        )  # fmt: skip
    except ValueError as exc:
        raise CommandError(str(exc)) from None
    units = diagnosis.units
    _say(f"motorid doctor on {args.data} ({len(record)} samples), base model: inertia, input gain"
         + "".join(f", {b}" for b in diagnosis.settings["base"]))  # fmt: skip
    _say(f"  located: {diagnosis.region.description}")
    table = diagnosis.table()
    if len(table):
        with pd.option_context("display.width", 160, "display.max_columns", 12, "display.max_colwidth", 48):
            _say(f"  gaps [{units['v']}] and force error [%] per step:")
            _say(table.round(4).to_string())
    for step in diagnosis.steps:
        params = ", ".join(f"{k} = {v:.5g}" for k, v in step.params.items())
        _say(f"  + {step.effect}: {params} (ΔBIC {step.evidence['delta_bic']:.1f})")
    _say(
        f"  gap {diagnosis.initial_gap['overall']:.4g} -> {diagnosis.final_gap['overall']:.4g} {units['v']}, "
        f"force error {diagnosis.initial_gap['force_error_percent']:.2f} % -> "
        f"{diagnosis.final_gap['force_error_percent']:.2f} %"
    )
    _say(f"  stopped: {diagnosis.stop_reason}")
    figures = []
    if args.out:
        figures = diagnosis.write_figures(args.out)
        table.to_csv(Path(args.out) / "doctor_table.csv")
        _say(f"  wrote {len(figures)} figures and doctor_table.csv in {args.out}/")
    if args.json:
        _emit_json({**diagnosis.to_dict(), "figures": figures})
    return 0


def _effect_list(text: str, option: str) -> list[str]:
    from motorid.diagnose import EFFECTS

    names = [n.strip() for n in text.split(",") if n.strip()]
    for name in names:
        if name not in EFFECTS:
            raise CommandError(f"{option}: unknown effect {name!r}; known effects: {', '.join(EFFECTS)}")
    return names


# --------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="motorid",
        description="Nonlinear modelling and online identification of bidirectional DC motor drives.",
    )
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output on stderr")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("demo", help="the paper's experiment on the simulated rig: tables and figures")
    p.add_argument("--out", default="out", help="folder for figures, tables and the record (default: out)")
    p.add_argument("--duration", type=float, default=120.0, help="record length [s] (default: 120)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--low-speed-rpm", type=float, default=150.0, help="low-speed band |y| < this [rpm]")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("simulate", help="simulate the rig and write a record CSV")
    p.add_argument("--out", required=True, help="record CSV to write")
    p.add_argument("--signal", choices=SIGNALS, default="paper", help="excitation (default: paper)")
    p.add_argument("--amplitude", type=float, help="signal amplitude [V]")
    p.add_argument("--duration", type=float, default=120.0, help="[s] (default: 120)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--coulomb-motor", type=float, default=4e-3, help="Coulomb torque, motor side [N m]")
    p.add_argument("--coulomb-load", type=float, default=2e-3, help="Coulomb torque, load side [N m]")
    p.add_argument(
        "--stribeck", type=float, nargs=2, metavar=("ALPHA1", "ALPHA2"), help="Stribeck [N m] [s/rad]"
    )
    p.add_argument(
        "--viscous", type=float, default=0.0, help="extra viscous friction, motor side [N m s/rad]"
    )
    p.add_argument("--dead-zone", type=float, default=0.6, help="amplifier dead zone half-width [V]")
    p.add_argument("--backlash", type=float, default=0.0, help="shaft backlash, total play [rad]")
    p.add_argument("--u-max", type=float, default=12.0, help="amplifier saturation [V]")
    p.add_argument("--integrator", choices=("fast", "reference"), default="fast")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("identify", help="identify an estimator on a record")
    _add_record_columns(p)
    p.add_argument(
        "--estimator", default="hammerstein-rls", help="registered name (default: hammerstein-rls)"
    )
    _add_estimator_options(p)
    p.add_argument("--low-speed-rpm", type=float, default=150.0, help="low-speed band |y| < this [rpm]")
    p.add_argument("--skip", type=int, default=50, help="leading samples left out of the scores")
    p.add_argument("--max-lag", type=int, default=25, help="largest lag of the residual tests [samples]")
    p.add_argument("--out", help="folder for the residual-test figure")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_identify)

    p = sub.add_parser("sweep", help="the paper's Tables 1 and 2 on a record")
    _add_record_columns(p)
    p.add_argument("--orders", type=_int_range, default=list(range(1, 7)), help="model orders (default: 1-6)")
    p.add_argument("--degrees", type=_int_range, default=list(range(2, 6)), help="degrees (default: 2-5)")
    p.add_argument("--order", type=int, default=4, help="model order of Table 2 (default: 4)")
    p.add_argument("--degree", type=int, default=3, help="polynomial degree of Table 1 (default: 3)")
    p.add_argument("--lam", type=float, default=1.0)
    p.add_argument("--prediction", choices=("one_step", "free_run"), default="one_step")
    p.add_argument("--low-speed-rpm", type=float, default=150.0)
    p.add_argument("--skip", type=int, default=50)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("doctor", help="find the effect missing from a drive model and show the gap shrink")
    p.add_argument("data", type=Path, help="record CSV")
    p.add_argument("--input", default="u", metavar="COL", help="input column [V] (default: u)")
    p.add_argument("--output", default="y", metavar="COL", help="output column (default: y)")
    p.add_argument("--dt", type=float, help="sample time [s] (default: from the file)")
    p.add_argument(
        "--output-kind", choices=("velocity", "position"), default="velocity", help="what the output is"
    )
    p.add_argument(
        "--input-gain", type=float, default=1.0, help="force or torque per input unit [N/V, N m/V]"
    )
    p.add_argument(
        "--base", default="viscous_friction,offset", metavar="EFFECT,...",
        help="effects already in the model (default: viscous_friction,offset)",
    )  # fmt: skip
    p.add_argument("--candidates", metavar="EFFECT,...", help="effects to try (default: all others)")
    p.add_argument("--holdout", type=float, default=0.3, help="share of the record held out (default: 0.3)")
    p.add_argument("--max-steps", type=int, default=3, help="most effects added (default: 3)")
    p.add_argument(
        "--timing",
        choices=("hold", "sampled", "auto"),
        default=None,
        help="input/output timing: hold (y[k] at the end of the interval u[k] is held over; the "
        "default, or the record's own), sampled (a controller reads y[k], then holds u[k]), auto",
    )
    p.add_argument("--out", help="folder for the figures and the table")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_doctor)

    rig = sub.add_parser("rig", help="the simulated rig behind Modbus").add_subparsers(
        dest="rig_command", required=True, metavar="RIG_COMMAND"
    )
    for name, helptext, func in (
        ("serve", "serve the simulated rig over Modbus TCP or RTU", cmd_rig_serve),
        ("map", "print the register map in use as TOML", cmd_rig_map),
    ):
        p = rig.add_parser(name, help=helptext)
        p.add_argument("--map", help="register map TOML file (default: the built-in map)")
        p.add_argument("--word-order", choices=("ABCD", "CDAB"), default="ABCD", help="float32 word order")
        p.set_defaults(func=func)
        if name == "serve":
            p.add_argument("--host", default="127.0.0.1")
            p.add_argument("--port", type=int, default=5020)
            p.add_argument(
                "--serial", metavar="DEVICE", help="serve Modbus RTU on this serial device instead"
            )
            p.add_argument("--baudrate", type=int, default=115200)
            p.add_argument("--realtime", action="store_true", help="advance with the clock, not lock-step")
            p.add_argument("--seed", type=int)
            p.add_argument(
                "--watchdog-periods", type=float, default=3.0, help="heartbeat timeout [samples]; 0: off"
            )
            p.add_argument("--u-max", type=float, default=12.0, help="voltage rating [V]")

    p = sub.add_parser("run", help="online identification on a DAQ")
    p.add_argument(
        "--daq", default="sim", help="sim, modbus://HOST:PORT or modbus-rtu:///dev/X (default: sim)"
    )
    p.add_argument("--estimator", action="append", required=True, help="registered name (repeatable)")
    _add_estimator_options(p)
    p.add_argument("--duration", type=float, required=True, help="[s]")
    p.add_argument("--out", required=True, help="CSV appended to as the run goes")
    p.add_argument("--signal", choices=SIGNALS, default="paper")
    p.add_argument("--amplitude", type=float, help="signal amplitude [V]")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--dt", type=float, help="sample time [s]")
    p.add_argument("--map", help="register map TOML file")
    p.add_argument("--timeout", type=float, help="Modbus timeout [s]")
    p.add_argument("--u-max", type=float, default=12.0, help="voltage clamp [V]")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr)
    try:
        return args.func(args)
    except (CommandError, ValueError, OSError) as exc:
        _say(f"motorid {args.command}: error: {exc}")
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
