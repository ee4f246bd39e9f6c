"""``motorid control``: close the speed loop on a DAQ with a controller designed on the doctor's model."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from motorid.errors import DataError

from .options import (
    LOW_SPEED_RPM,
    add_json,
    add_out_file,
    add_plant_seed,
    check_out_file,
    planned_samples,
    positive,
)
from .report import emit_json, say, say_warning, show_progress
from .rig import add_register_map
from .simulation import add_rig_options

#: Share of the samples whose command may be clamped before ``motorid control`` warns [-].
CLAMP_WARNING_SHARE = 0.05
#: Memory the planned reference takes [B per sample]: its time and speed arrays, and the loop's copy.
REFERENCE_BYTES_PER_SAMPLE = 24
#: The largest --reference file read [bytes]: a day at 1 ms in two columns of text.
MAX_REFERENCE_BYTES = 256 << 20


def reference_from_file(path: Path, dt: float, duration: float | None) -> np.ndarray:
    """The reference speed [rad/s] of the CSV ``path`` (columns ``t`` [s] and ``r`` [rad/s]) at the
    loop's samples k dt, linearly interpolated; DataError naming the file and what is wrong."""
    import io

    import pandas as pd

    from motorid.inputs import read_small_file

    raw = read_small_file(path, "--reference", MAX_REFERENCE_BYTES)
    try:
        table = pd.read_csv(io.BytesIO(raw))
    except (OSError, ValueError) as exc:
        raise DataError(f"--reference {path}: cannot read it as CSV: {exc}") from None
    for column in ("t", "r"):
        if column not in table.columns:
            raise DataError(f"--reference {path}: no column {column!r} (columns t [s] and r [rad/s] are needed, "
                            f"found {', '.join(map(str, table.columns))})")  # fmt: skip
    values = {}
    for column in ("t", "r"):
        numbers = pd.to_numeric(table[column], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(numbers))
        if bad.size:
            raise DataError(f"--reference {path}: column {column!r} row {bad[0]} is not a finite number "
                            f"({table[column].iloc[bad[0]]!r})")  # fmt: skip
        values[column] = numbers
    t, r = values["t"], values["r"]
    if t.size < 2:
        raise DataError(f"--reference {path}: needs at least 2 rows, has {t.size}")
    step = np.flatnonzero(np.diff(t) <= 0)
    if step.size:
        raise DataError(f"--reference {path}: column 't' must increase, row {step[0] + 1} ({t[step[0] + 1]!r}) "
                        f"does not follow {t[step[0]]!r}")  # fmt: skip
    span = t[-1] - t[0]
    if duration is None:
        duration = span
    elif duration > span + 1e-9:
        raise DataError(f"--duration {duration:g} s is longer than the reference in {path} ({span:g} s)")
    n = round(duration / dt)
    if n < 1:
        raise DataError(f"--reference {path}: spans {span:g} s, shorter than one sample ({dt:g} s)")
    return np.interp(t[0] + np.arange(n) * dt, t, r)


def cmd_control(args: argparse.Namespace) -> int:
    """Close the speed loop: PI designed on the model, friction compensation from it (or not)."""
    from motorid.app.identify import drive_model_from_file
    from motorid.app.model_cards import input_scale
    from motorid.compensation import FrictionCompensation
    from motorid.drive import RigidDrive
    from motorid.drive.files import read_model_file
    from motorid.errors import DAQError
    from motorid.io import daq_from_url
    from motorid.speed_control import (
        SensedPlant,
        SpeedController,
        TrackingMetrics,
        default_u_max,
        design_speed_pi,
        reversing_reference,
        run_closed_loop,
    )
    from motorid.validation import rpm_to_rad_s

    from .rig import loop_timing, rig_stopped
    from .simulation import RIG_OPTIONS, rig_from_args

    if args.out is not None:
        check_out_file(args.out, args.overwrite)
    simulated = args.daq.strip() in ("sim", "sim://", "simulated")
    # the rig options of motorid simulate (its --u-max here is the command's limit, the rig's rating too)
    rig_given = [
        "--" + name.replace("_", "-")
        for name in RIG_OPTIONS
        if name != "u_max" and getattr(args, name) is not None
    ]
    if not simulated:
        given = [o for o, v in (("--model", args.model), ("--plant-seed", args.plant_seed)) if v is not None]
        if given or rig_given:
            raise DataError(f"{(given + rig_given)[0]} applies to --daq sim only; the rig behind {args.daq} is its "
                            "own (motorid rig serve --model, --plant-seed)")  # fmt: skip
    if args.model is not None and rig_given:
        raise DataError(f"{rig_given[0]} cannot be combined with --model: the model file describes the rig")
    if args.no_compensation and (args.source is not None or args.speed_band is not None):
        raise DataError("--source and --speed-band set the compensation, which --no-compensation leaves out")
    if args.noise_free and args.model is None:
        raise DataError("--noise-free leaves out the sensor of a --model plant's card: give --model FILE")
    design_file = read_model_file(args.design)
    design, card = design_file.model, design_file.card
    if not isinstance(design, RigidDrive):
        raise DataError(f"--design {args.design}: holds a {type(design).__name__}; the controller is designed "
                        "on a rigid-drive model (a file motorid doctor --save-model wrote)")  # fmt: skip
    unit = card.input_unit if card is not None and card.input_unit is not None else "V"
    u_max = args.u_max if args.u_max is not None else default_u_max(card)
    if args.model is not None:
        plant_file = read_model_file(args.model)
        drive_model_from_file(args.model)  # a drive model, or one line saying what it holds
        scale, note = input_scale(plant_file.card, {"u": unit}, args.model.name, args.supply_voltage,
                                  given_as=f"the controller designed on {args.design.name} commands")  # fmt: skip
        if note:
            say(f"  note: {note}")
        plant = SensedPlant(plant_file.model, plant_file.card, scale, noise_free=args.noise_free)
    else:  # the default rig, changed by the rig options given (u_max: the rating)
        plant = rig_from_args(args) if rig_given else None
    try:
        daq = daq_from_url(
            args.daq, plant=plant, seed=(args.plant_seed or 0) if simulated else None, dt=args.dt,
            register_map=args.map, u_max=u_max, timeout=args.timeout,
        )  # fmt: skip
    except ValueError as exc:
        raise DataError(str(exc)) from None
    dt = daq.dt
    if args.duration is not None:
        planned_samples(args.duration, dt, REFERENCE_BYTES_PER_SAMPLE, "the reference")
    if args.reference is not None:
        reference = reference_from_file(args.reference, dt, args.duration)
    else:
        _, reference = reversing_reference(args.shape, args.amplitude, args.period, args.duration or 12.0, dt)
    source = args.source or "reference"
    try:
        pi = design_speed_pi(design, dt, bandwidth=args.bandwidth, u_max=u_max,
                             damping=0.0 if source == "measured" else None)  # fmt: skip
        compensation = None if args.no_compensation else FrictionCompensation(
            design, speed_band=args.speed_band or 1.0, source=source
        )  # fmt: skip
    except ValueError as exc:
        raise DataError(f"--design {args.design}: {exc}") from None
    controller = SpeedController(pi, dt, compensation)
    speed_unit = card.output_unit if card is not None and card.output_unit else "rad/s"
    exported: list[Path] = []
    if args.export_c is not None:
        from motorid.controller_c import export_controller_c

        exported = list(export_controller_c(controller, args.export_c, input_unit=unit, model=args.design.name,
                                            speed_unit=speed_unit))  # fmt: skip
        say(
            f"wrote {exported[0]} and {exported[1]}: the controller in C99 (motorid_speed_step once every {dt:g} s)"
        )
    say(f"motorid control: PI K_p = {pi.kp:.4g}, K_i = {pi.ki:.4g} for a bandwidth of {pi.bandwidth:.3g} rad/s, "
        + ("no friction compensation" if compensation is None else f"friction compensation from the {source} "
           f"speed") + f"; {reference.size} samples at dt = {dt:g} s on {args.daq}")  # fmt: skip
    band = float(rpm_to_rad_s(args.low_speed_rpm))
    tracking = TrackingMetrics(low_speed=band)
    try:
        record = run_closed_loop(daq, controller, reference, out=args.out, progress=show_progress(), overwrite=args.overwrite,
                                 metrics=tracking, input_unit=unit, output_unit=speed_unit)  # fmt: skip
    except DAQError as exc:
        raise rig_stopped("control", args.daq, exc) from None
    except KeyboardInterrupt as exc:  # exit 130 (main), after saying what is on disk
        say(f"motorid control: {exc or 'interrupted'}; " + " ".join(getattr(exc, "__notes__", [])))
        raise
    metrics = tracking.result()
    if args.out is not None:
        say(f"wrote {args.out}: {record.attrs['samples']} samples (t, reference [{speed_unit}], u [{unit}], "
            f"y [{speed_unit}], clamped) at dt = {dt:g} s, timing sampled: motorid doctor, identify and "
            "compare read it as it is")  # fmt: skip
    say(f"motorid control: {loop_timing(record)}")
    say(f"RMS tracking error {metrics['rms_error']:.3g} rad/s; at low speed (|r| < {args.low_speed_rpm:g} rpm) "
        f"{metrics['low_speed_rms_error']:.3g} rad/s; largest stuck interval after a reversal "
        f"{metrics['largest_stuck_after_reversal']:.3g} s")  # fmt: skip
    if metrics["clamped_share"] > CLAMP_WARNING_SHARE:
        say_warning(f"the command was clamped at ±{pi.u_max:g} {unit} on {metrics['clamped_share']:.0%} of the "
            f"samples ({metrics['clamped_samples']} of {record.attrs['samples']}): raise --u-max if the drive "
            "takes more, or lower the reference")  # fmt: skip
    if args.json:
        emit_json({
            "out": args.out, "samples": record.attrs["samples"], "dt": dt,
            "compensation": None if compensation is None else source,
            "pi": {"kp": pi.kp, "ki": pi.ki, "tracking_time": pi.tracking_time, "u_max": pi.u_max,
                   "bandwidth": pi.bandwidth}, "input_unit": unit, "export_c": exported,
            "low_speed_band": band, "largest_interval": record.attrs["largest_interval"], **metrics,
        })  # fmt: skip
    return 0


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "control", help="close the speed loop on a DAQ, with friction compensation from a model"
    )
    p.add_argument("--daq", default="sim",
                   help="sim, modbus://HOST:PORT or modbus-rtu:///dev/X (default: sim)")  # fmt: skip
    p.add_argument("--design", type=Path, required=True, metavar="FILE",
                   help="the rigid-drive model the controller is designed on (motorid doctor --save-model)")  # fmt: skip
    group = p.add_argument_group("the simulated plant of --daq sim (default: the default rig)")
    add_rig_options(
        group, "the plant's model file, a two-mass rig or a rigid drive, instead of the options below"
    )
    add_plant_seed(group, default=None)
    group.add_argument("--noise-free", action="store_true",
                       help="the --model plant without the sensor its card describes (quantisation, noise)")  # fmt: skip
    group.add_argument("--supply-voltage", type=positive, metavar="V",
                       help="the drive's supply [V], to convert commands between %% duty and volts where the "
                            "design and the plant models were fitted in different units")  # fmt: skip
    group = p.add_argument_group("controller")
    group.add_argument("--no-compensation", action="store_true", help="the PI alone (the baseline)")
    group.add_argument("--source", choices=("reference", "measured"),
                       help="the speed the friction compensation follows (default: reference)")  # fmt: skip
    group.add_argument("--speed-band", type=positive,
                       help="half-width of the compensation's ramp through zero speed [rad/s] (default: 1)")  # fmt: skip
    group.add_argument("--bandwidth", type=positive,
                       help="the PI's crossover [rad/s] (default: 0.2 / (dt + the model's delay and lag))")  # fmt: skip
    group.add_argument("--export-c", type=Path, metavar="DIR",
                       help="write the controller (PI with anti-windup and friction compensation) as C99 "
                            "motorid_speed.h and motorid_speed.c in DIR, for a microcontroller")  # fmt: skip
    group = p.add_argument_group("reference (default: a reversing triangle)")
    group.add_argument("--reference", type=Path, metavar="FILE", help="CSV with columns t [s] and r [rad/s]")
    group.add_argument("--shape", choices=("triangle", "sine"), default="triangle",
                       help="the built-in reference through zero speed (default: triangle)")  # fmt: skip
    group.add_argument("--amplitude", type=positive, default=40.0,
                       help="its peak speed [rad/s] (default: 40)")  # fmt: skip
    group.add_argument("--period", type=positive, default=4.0, help="its period [s] (default: 4)")
    group.add_argument("--duration", type=positive,
                       help="[s] (default: 12, or the whole --reference file)")  # fmt: skip
    add_out_file(p, "CSV of t [s], reference [rad/s], u (the command held over the sample, in the model's "
                 "input unit), y [rad/s] (measured at t) and clamped (1 where the rig clamped the command "
                 "to its rating), written row by row after a first line of the record's attributes (dt, "
                 "units, timing), so motorid doctor, identify and compare read it as it is", required=False)  # fmt: skip
    p.add_argument(
        "--dt", type=positive, help="sample time [s] (default: the simulated plant's; Modbus: 0.04)"
    )
    add_register_map(p)
    p.add_argument(
        "--timeout", type=positive, help="wait for each Modbus answer [s] (default: 2 s, or 2.5 dt if longer)"
    )
    p.add_argument("--u-max", type=positive,
                   help="limit of the command, in the design model's input unit (default: 100 for a model "
                        "fitted on %% duty; for one in volts its supply voltage where known, else 12)")  # fmt: skip
    p.add_argument("--low-speed-rpm", type=positive, default=LOW_SPEED_RPM,
                   help=f"low-speed band of the metrics, |r| < this [rpm] (default: {LOW_SPEED_RPM:g})")  # fmt: skip
    add_json(p)
    p.set_defaults(func=cmd_control)
