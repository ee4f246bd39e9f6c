"""A speed controller designed on the drive model, and the closed speed loop on a DAQ.

- :func:`design_speed_pi`: a PI tuned from a rigid drive model for a stated bandwidth.
- :class:`SpeedController`: the PI with anti-windup against the input limit, after the
  friction compensation of :mod:`motorid.compensation` (or without it: the baseline).
- :func:`reversing_reference`: triangle and sine references through zero speed.
- :func:`run_closed_loop`: the loop on a DAQ (the simulated rig, or Modbus: a PLC or
  ``motorid rig serve``), with ``motorid run``'s safety: 0 V on every way out, the
  watchdog fed by every command, Ctrl-C stopping between two samples.
- :func:`tracking_metrics`: RMS tracking error overall and at low speed, the
  largest interval the drive stays stuck after a reversal of the reference, and the
  samples whose command was clamped.
- :func:`default_u_max`: the command limit a model's input unit implies (±100 for % duty).
- :class:`SensedPlant`: a drive model's simulation measured by the sensor of its model file's
  card (quantisation, noise per speed band), fed in the controller's input unit: the plant of
  ``motorid control --daq sim --model`` and ``motorid rig serve --model``.

The loop's timing is ``"sampled"`` (:data:`motorid.io.records.TIMINGS`): at sample k the
controller reads y[k], measured at t[k], and holds u[k] over [t[k], t[k] + dt).
"""

from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motorid.compensation import FrictionCompensation
from motorid.drive.files import ModelCard
from motorid.drive.rigid import RigidDrive, check_sample_time
from motorid.io.base import DAQ
from motorid.io.online import KEEP_WITH_FILE, RunRecorder, sample_loop, samples_for
from motorid.io.records import attrs_line

logger = logging.getLogger(__name__)

__all__ = [
    "DEFAULT_VOLTS",
    "REFERENCES",
    "SensedPlant",
    "SpeedController",
    "SpeedPI",
    "TrackingMetrics",
    "default_bandwidth",
    "default_u_max",
    "design_speed_pi",
    "reversing_reference",
    "run_closed_loop",
    "tracking_metrics",
]

#: Built-in references (:func:`reversing_reference`).
REFERENCES = ("triangle", "sine")


@dataclass(frozen=True)
class SpeedPI:
    """PI gains of a speed loop and the limit of its command.

    ``v = K_p e + I``, ``dI/dt = K_i e + (u_sat - u) / T_t`` (back-calculation
    anti-windup, Åström & Hägglund: while the command ``u`` is clipped to ``u_sat`` the
    integral is pulled back with time constant T_t, so it does not wind up on the limit).

    Attributes
    ----------
    kp : float
        K_p [u/(v)], e.g. V per rad/s.
    ki : float
        K_i = K_p / T_i [u/(v s)].
    tracking_time : float
        T_t [s] of the anti-windup (T_i by the design rule).
    u_max : float
        The command's limit ±u_max [u] (the drive's rating or input saturation).
    bandwidth : float
        The crossover ω_c [rad/s] the gains were designed for.
    """

    kp: float
    ki: float
    tracking_time: float
    u_max: float
    bandwidth: float

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "tracking_time", "u_max", "bandwidth"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")

    def transfer_function(self) -> Any:
        """C(s) = K_p + K_i / s as a continuous ``control.TransferFunction`` (e [v] -> v [u])."""
        import control

        return control.tf([self.kp, self.ki], [1.0, 0.0], inputs="e", outputs="v")


def default_bandwidth(drive: RigidDrive, dt: float) -> float:
    """ω_c = 0.2 / (dt + τ_d + T_l) [rad/s]: the loop's sample time (half a sample of hold, half
    a sample of computation), the model's input delay τ_d and lag T_l cost a phase of
    ω_c (dt + τ_d + T_l) = 0.2 rad (11°) at the crossover.

    Parameters
    ----------
    drive : RigidDrive
        The model: its input delay τ_d [s] and lag T_l [s].
    dt : float
        The loop's sample time [s].
    """
    dead = (
        check_sample_time(dt)
        + drive.params.get("input_delay", 0.0)
        + drive.params.get("lag_time_constant", 0.0)
    )
    return 0.2 / dead


def design_speed_pi(
    drive: RigidDrive,
    dt: float,
    bandwidth: float | None = None,
    u_max: float = 12.0,
    damping: float | None = None,
) -> SpeedPI:
    """A PI for the speed loop of ``drive``, tuned for the crossover ``bandwidth``.

    The rule, on the drive's linear part ``G(s) = g / (J s + B)`` (input gain g [F/u],
    inertia J [F s/v], viscous friction B [F s/v]; its other friction is the compensation's)::

        K_p = ω_c J / g,        T_i = min(J / B, 4 / ω_c),        K_i = K_p / T_i,   T_t = T_i

    When the mechanical pole B/J is faster than ω_c/4 the integral zero cancels it and the
    loop is ``L(s) = ω_c / s``: a first-order closed loop of bandwidth ω_c, no overshoot.
    A slower pole (or B = 0) would leave a slow closed-loop pole at the zero, so T_i is
    held at 4/ω_c, where ``L(s) ≈ ω_c (s + ω_c/4) / s²`` crosses near ω_c with about 76°
    of phase margin. The anti-windup's tracking time is T_i.

    Parameters
    ----------
    drive : RigidDrive
        The drive model (the doctor's).
    dt : float
        The loop's sample time [s] (for the default bandwidth).
    bandwidth : float, optional
        ω_c [rad/s]; default :func:`default_bandwidth`.
    u_max : float
        The command's limit [u]; the model's input saturation when lower.
    damping : float, optional
        B [F s/v] to design on; default the model's viscous friction. Pass 0 when a
        compensation from the measured speed cancels it inside the loop.
    """
    if not isinstance(drive, RigidDrive):
        raise ValueError(f"drive must be a RigidDrive (the doctor's model), got {type(drive).__name__}")
    drive.check_physical()
    w_c = default_bandwidth(drive, dt) if bandwidth is None else float(bandwidth)
    if not (math.isfinite(w_c) and w_c > 0):
        raise ValueError(f"bandwidth must be a finite number > 0 [rad/s], got {bandwidth!r}")
    J, g = drive.inertia, drive.input_gain
    B = drive.params.get("viscous", 0.0) if damping is None else float(damping)
    if not (math.isfinite(B) and B >= 0):
        raise ValueError(f"damping must be a finite number >= 0, got {damping!r}")
    kp = w_c * J / g
    ti = min(J / B, 4.0 / w_c) if B > 0 else 4.0 / w_c
    limit = min(float(u_max), drive.params.get("saturation", math.inf))
    return SpeedPI(kp=kp, ki=kp / ti, tracking_time=ti, u_max=limit, bandwidth=w_c)


class SpeedController:
    """A speed controller stepped once a sample: the PI, then the friction compensation.

    Each :meth:`step` computes, with e = r - y [v]::

        v = K_p e + I                                            (PI)               [u]
        u = D̃⁻¹(v + (F̃(ω_c) + T̃_p(θ_m))/g)   (FrictionCompensation.command, with the position
                                 torque at the measured position θ_m; u = v without)  [u]
        u_sat = clip(u, -u_max, u_max)
        I ← I + dt (K_i e + (u_sat - u) / T_t)                  (anti-windup)

    and returns u_sat; ``clamped`` says whether this step's command was clipped (u_sat != u).
    The state is the integral I [u] alone (:meth:`reset` zeroes it).
    A step is a few microseconds with compensation, half a microsecond without
    (``benchmarks/bench_control.py``).

    Parameters
    ----------
    pi : SpeedPI
    dt : float
        The loop's sample time [s].
    compensation : FrictionCompensation, optional
        None: the PI alone (the baseline).
    """

    def __init__(self, pi: SpeedPI, dt: float, compensation: FrictionCompensation | None = None) -> None:
        if not isinstance(pi, SpeedPI):
            raise ValueError(f"pi must be a SpeedPI, got {type(pi).__name__}")
        if compensation is not None and not isinstance(compensation, FrictionCompensation):
            raise ValueError(f"compensation must be a FrictionCompensation or None, got {compensation!r}")
        self.pi = pi
        self.dt = check_sample_time(dt)
        self.compensation = compensation
        self._kp, self._ki, self._tt, self._limit = pi.kp, pi.ki, pi.tracking_time, pi.u_max
        self.integral = 0.0
        self.clamped = False

    def reset(self) -> None:
        """Zero the integral (a new run)."""
        self.integral = 0.0
        self.clamped = False

    def step(self, reference: float, measured: float, position: float | None = None) -> float:
        """The command u [u] for this sample from the reference and measured speeds [v] and, for a
        compensation of a position torque (cogging), the measured position [v s].

        Parameters
        ----------
        reference, measured : float
            The reference and measured speeds [v].
        position : float, optional
            The measured position [v s] (rad or m); None: no position torque fed forward.
        """
        e = reference - measured
        v = self._kp * e + self.integral
        comp = self.compensation
        u = v if comp is None else comp.command(v, reference, measured, position)
        limit = self._limit
        u_sat = limit if u > limit else (-limit if u < -limit else u)
        self.clamped = u_sat != u
        self.integral += self.dt * (self._ki * e + (u_sat - u) / self._tt)
        return u_sat


#: The command limit of a model in volts when none is given [V] (a 12 V drive).
DEFAULT_VOLTS = 12.0


def default_u_max(card: ModelCard | None) -> float:
    """The command limit [the model's input unit] when none is given: ±100 for a model fitted on
    % duty, the supply voltage for one in volts that knows it, else :data:`DEFAULT_VOLTS`.

    Parameters
    ----------
    card : ModelCard or None
        The design model's card (None: unknown, volts assumed).
    """
    if card is not None and card.input_unit == "%":
        return 100.0
    if card is not None and card.input_unit == "V" and card.supply_voltage is not None:
        return float(card.supply_voltage)
    return DEFAULT_VOLTS


class SensedPlant:
    """A drive model's simulation, fed in the controller's input unit and measured by the sensor
    its model card describes (the simulated plant of ``motorid control --daq sim --model``).

    Each :meth:`step` holds the command ``u`` [the controller's unit] for one sample and returns
    the measured speed::

        ω = plant.step(k u)                          (k: the controller's unit -> the plant's)
        ỹ = ω + n,   n ~ N(0, σ_n(|ω|)²)              (σ_n: the noise added in the speed band |ω| is in)
        y = q round(ỹ / q)                            (q: the quantisation step)
        σ_n² = max(σ² - q²/12, 0)                     (σ: the card's noise in that band)

    with σ and q from the card (:attr:`~motorid.drive.files.ModelCard.noise_bands`,
    :attr:`~motorid.drive.files.ModelCard.quantisation_step`; a speed beyond the last band takes
    its σ); none of them without a card, with ``noise_free``, or for a two-mass rig, which
    measures with its own sensors. The card's σ is the RMS error the doctor measured on the
    sensor's readings, rounding included; rounding a speed that moves through the steps errs by
    q²/12 in variance on its own, so the noise added before it is what is left of σ², and the
    measured speed errs by σ RMS, as the sensor did. Where σ² < q²/12 the rounding alone errs
    more than the card says: no noise is added in that band (logged at info level), and the
    error there is q/√12.

    Parameters
    ----------
    model : drive model
        The plant (a rigid drive or a two-mass rig), run in a simulation of its own.
    card : ModelCard, optional
        Its card: the sensor it was measured with.
    input_scale : float
        k, the factor from the controller's input unit to the plant's (``V_s / 100`` from % duty
        to volts), > 0.
    noise_free : bool
        Leave the sensor out.
    """

    def __init__(self, model: Any, card: ModelCard | None = None, input_scale: float = 1.0,
                 noise_free: bool = False) -> None:  # fmt: skip
        from motorid.io.simulated import plant_to_step

        if not (math.isfinite(input_scale) and input_scale > 0):
            raise ValueError(f"input_scale must be a finite number > 0, got {input_scale!r}")
        self._plant = plant_to_step(model)
        self.dt = float(self._plant.dt)
        self.input_scale = float(input_scale)
        # a two-mass rig measures with its own tachogenerator, A/D converter and encoder
        sensed = card is not None and not noise_free and isinstance(model, RigidDrive)
        self.quantisation_step = card.quantisation_step if sensed else None  # type: ignore[union-attr]
        bands = card.noise_bands if sensed else ()  # type: ignore[union-attr]
        self._edges = np.array([band["speed_to"] for band in bands[:-1]], dtype=float)
        card_std = np.array([band["std"] for band in bands], dtype=float)
        rounding_variance = self.quantisation_step**2 / 12.0 if self.quantisation_step else 0.0
        # σ_n² = max(σ² - q²/12, 0): the rounding's own error makes up the rest of the card's σ
        self._std = np.sqrt(np.maximum(card_std**2 - rounding_variance, 0.0))
        for band, std in zip(bands, card_std, strict=True):
            if std**2 < rounding_variance:
                logger.info(
                    "the card's noise %.4g at %g-%g is below its step's rounding error q/sqrt(12) = %.4g: "
                    "no noise is added there, the rounding alone errs by %.4g",
                    std, band["speed_from"], band["speed_to"], math.sqrt(rounding_variance), math.sqrt(rounding_variance),
                )  # fmt: skip
        self._rng = np.random.default_rng(0)

    def reset(self, seed: int | None = None) -> None:
        """Back to rest; the sensor's noise drawn from ``seed``."""
        self._plant.reset(seed=seed)
        self._rng = np.random.default_rng(seed)

    def step(self, u: float) -> float:
        """The measured speed at the end of a sample with ``u`` [the controller's unit] held over it."""
        omega = float(self._plant.step(self.input_scale * u))
        y = omega
        if self._std.size:
            y += (
                self._std[int(np.searchsorted(self._edges, abs(omega), side="right"))]
                * self._rng.standard_normal()
            )
        q = self.quantisation_step
        return q * round(y / q) if q else y


# --------------------------------------------------------------------------- references
def reversing_reference(
    kind: str = "triangle",
    amplitude: float = 40.0,
    period: float = 4.0,
    duration: float = 12.0,
    dt: float = 0.01,
) -> tuple[np.ndarray, np.ndarray]:
    """A reference speed that reverses through zero: ``(t, r)`` [s], [rad/s] at each sample.

    ``triangle``: ramps between ±amplitude, crossing zero at a constant rate
    4 amplitude / period (the drive spends time at every low speed); ``sine``:
    amplitude sin(2π t / period), slowest at the peaks and fastest through zero. Both start
    at zero speed rising.

    Parameters
    ----------
    kind : {"triangle", "sine"}
    amplitude : float
        Peak speed [rad/s], > 0.
    period : float
        [s], > 0: two reversals a period.
    duration : float
        [s]: ``round(duration / dt)`` samples.
    dt : float
        The loop's sample time [s].
    """
    if kind not in REFERENCES:
        raise ValueError(f"kind must be one of {', '.join(REFERENCES)}, got {kind!r}")
    for name, value in (("amplitude", amplitude), ("period", period), ("duration", duration)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    dt = check_sample_time(dt)
    n = round(duration / dt)
    if n < 1:
        raise ValueError(f"duration {duration!r} s is shorter than one sample ({dt!r} s)")
    t = np.arange(n) * dt
    phase = (t / period) % 1.0
    if kind == "sine":
        r = amplitude * np.sin(2.0 * np.pi * phase)
    else:
        r = amplitude * (1.0 - np.abs(((4.0 * phase + 1.0) % 4.0) - 2.0))
    return t, r


# --------------------------------------------------------------------------- metrics
class TrackingMetrics:
    """How well the speed follows the reference, accumulated a sample at a time (in constant
    memory, so a loop of days gets its figures without keeping its record).

    Parameters
    ----------
    low_speed : float
        The low-speed band [rad/s]: samples with |reference| below it (the paper's is
        150 rpm, 15.7 rad/s, ``motorid control``'s default).
    moving : float
        Speed [rad/s] beyond which the drive counts as moving in a direction.
    """

    def __init__(self, low_speed: float, moving: float = 1.0) -> None:
        for name, value in (("low_speed", low_speed), ("moving", moving)):
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite speed > 0 [rad/s], got {value!r}")
        self.low_speed = float(low_speed)
        self.moving = float(moving)
        self._n = self._n_low = self._reversals = self._clamped = 0
        self._sum = self._sum_low = 0.0
        self._sign = 0.0  # the reference's last non-zero sign
        self._since: float | None = None  # time of a reversal the drive has not followed yet
        self._largest = math.nan
        self._t = 0.0

    def _close_reversal(self, t: float) -> None:
        stuck = t - self._since
        self._largest = stuck if not self._largest >= stuck else self._largest
        self._since = None

    def add(self, t: float, reference: float, measured: float, clamped: bool = False) -> None:
        """One sample: the reference and the measured speed [rad/s] at the time ``t`` [s], and
        whether its command was clamped at the limit."""
        e = reference - measured
        self._n += 1
        self._clamped += bool(clamped)
        self._sum += e * e
        if abs(reference) < self.low_speed:
            self._n_low += 1
            self._sum_low += e * e
        s = 1.0 if reference > 0.0 else (-1.0 if reference < 0.0 else 0.0)
        if s != 0.0 and self._sign != 0.0 and s != self._sign:
            if self._since is not None:  # reversed again before the drive followed
                self._close_reversal(t)
            self._since = t
            self._reversals += 1
        if s != 0.0:
            self._sign = s
        if self._since is not None and self._sign * measured > self.moving:
            self._close_reversal(t)
        self._t = t

    def result(self) -> dict[str, float]:
        """``rms_error`` [rad/s] (RMS of r - y over the samples), ``low_speed_rms_error`` [rad/s]
        (over |r| < low_speed; NaN if none), ``low_speed_samples``,
        ``largest_stuck_after_reversal`` [s]: after each change of sign of the reference, the
        time until the measured speed moves beyond ``moving`` in the new direction (or until
        the next reversal, or the last sample, when it does not), the largest (NaN without a
        reversal), ``reversals``, and ``clamped_samples`` (commands clamped at the limit) with
        their ``clamped_share`` of the samples [-]."""
        largest = self._largest
        if self._since is not None:
            largest = max(self._t - self._since, 0.0 if math.isnan(largest) else largest)
        return {
            "rms_error": math.sqrt(self._sum / self._n) if self._n else math.nan,
            "low_speed_rms_error": math.sqrt(self._sum_low / self._n_low) if self._n_low else math.nan,
            "low_speed_samples": self._n_low,
            "largest_stuck_after_reversal": largest,
            "reversals": self._reversals,
            "clamped_samples": self._clamped,
            "clamped_share": self._clamped / self._n if self._n else math.nan,
        }


def tracking_metrics(record: pd.DataFrame, low_speed: float, moving: float = 1.0) -> dict[str, float]:
    """:class:`TrackingMetrics` of a closed-loop record: columns ``t`` [s], ``reference`` and ``y``
    [rad/s] at the same instants (:func:`run_closed_loop`'s record).

    Parameters
    ----------
    record : DataFrame
        The closed-loop record.
    low_speed : float
        The low-speed band [rad/s]: samples with |reference| below it.
    moving : float
        Speed [rad/s] beyond which the drive counts as moving in a direction.
    """
    metrics = TrackingMetrics(low_speed, moving)
    columns = (record[c].to_numpy(dtype=float).tolist() for c in ("t", "reference", "y"))
    for t, r, y in zip(*columns, strict=True):
        metrics.add(t, r, y)
    return metrics.result()


# --------------------------------------------------------------------------- the loop
def warm_up(controller: SpeedController) -> None:
    """One step of a copy of the controller before the DAQ is opened: the compiled friction law
    compiles at its first call (longer than a rig's watchdog allows between two samples)."""
    copy.deepcopy(controller).step(1.0, 0.0)


def run_closed_loop(
    daq: DAQ,
    controller: SpeedController,
    reference: np.ndarray | Callable[[float], float],
    duration: float | None = None,
    out: str | Path | None = None,
    progress: bool = False,
    *,
    overwrite: bool = False,
    metrics: TrackingMetrics | None = None,
    keep: int | None = None,
    input_unit: str = "V",
    output_unit: str = "rad/s",
) -> pd.DataFrame:
    """Close the speed loop on a DAQ: read the speed, step the controller, command, record.

    The loop first commands 0 V for one sample and reads the speed (the drive's state
    before the run), then each sample k: the controller's command from the reference
    r[k] and the speed y[k] read last, written to the DAQ (each write also feeds the
    rig's heartbeat watchdog), and the next speed read.

    Parameters
    ----------
    daq : DAQ
        The rig (opened here; always closed on return, which commands 0 V).
    controller : SpeedController
        Stepped once a sample (reset first); warmed up on a copy before the DAQ is opened.
    reference : array or callable
        The reference speed [rad/s] per sample, or a function of time t [s].
    duration : float, optional
        Length [s]; default the whole array.
    out : path, optional
        CSV written row by row as the loop runs (:class:`~motorid.io.online.RunRecorder`);
        an existing file is refused before the DAQ is opened unless ``overwrite``. Its first
        line is the record's attributes (:data:`motorid.io.records.ATTRS_MARKER`: ``dt``,
        ``units``, ``timing`` ``"sampled"``, ``loop``), so ``motorid doctor``, ``identify`` and
        ``compare`` read it as it is, in its units, and the doctor knows the ``reference``
        column for a closed loop's.
    progress : bool
        A progress bar on stderr (:func:`motorid.progress.progress_bar`).
    overwrite : bool
        Replace an existing ``out``.
    metrics : TrackingMetrics, optional
        Fed every sample (the figures of the whole run, whatever ``keep`` holds).
    keep : int, optional
        Rows kept in memory and returned. None: every row without ``out``, the last
        :data:`~motorid.io.online.KEEP_WITH_FILE` with it (the file holds them all).
    input_unit : str
        The unit of the commands, the design model's input (``V``, ``%``), in the record's units.
    output_unit : str
        The unit of the measured speed and the reference (the design model's output: ``rad/s``,
        or ``m/s`` for a linear drive), in the record's units.

    Returns
    -------
    DataFrame
        Columns ``t`` [s], ``reference`` [``output_unit``], ``u`` [``input_unit``: V or %] (the
        command held over [t, t + dt), after the DAQ's clamp), ``y`` [``output_unit``] (measured at t),
        ``clamped`` (1 where the command was clipped, by the controller's limit or the DAQ's);
        ``attrs``: ``dt``, ``units``, ``timing`` (``"sampled"``), ``loop`` (:func:`loop_attrs`),
        ``samples``.

    Raises
    ------
    DAQError
        The rig failed; 0 V where it can, the DAQ closed, the CSV holds every sample taken
        (a note on the exception says how many).
    KeyboardInterrupt
        Ctrl-C or SIGTERM: the loop stops before the next sample, with the same clean-up.
    """
    dt = float(daq.dt)
    n = samples_for(duration, dt, reference, "run_closed_loop", "reference")
    if callable(reference):
        r = np.array([float(reference(k * dt)) for k in range(n)])
    else:
        r = np.asarray(reference, dtype=float)
        if r.ndim != 1 or r.size < n:
            raise ValueError(
                f"run_closed_loop: reference must be 1-D with at least {n} samples, got shape {r.shape}"
            )
        r = r[:n]
    bad = np.flatnonzero(~np.isfinite(r))
    if bad.size:
        raise ValueError(f"run_closed_loop: reference[{bad[0]}] = {r[bad[0]]!r} is not finite")
    if keep is None and out is not None:
        keep = KEEP_WITH_FILE
    units = {"t": "s", "reference": output_unit, "u": input_unit, "y": output_unit}
    attrs = {"dt": dt, "units": units, "timing": "sampled", "loop": loop_attrs(controller)}
    recorder = RunRecorder(out, overwrite=overwrite, keep=keep, preamble=[attrs_line(attrs)])
    comp = controller.compensation
    if comp is not None and comp.position_effect:
        logger.warning(
            "the model's %s is not compensated: a DAQ reads the speed, not the position it depends on",
            comp.position_effect,
        )
    controller.reset()
    warm_up(controller)
    y = 0.0  # the speed the controller acts on: read at the start of each sample

    def sample(k: int) -> dict[str, float | int]:
        nonlocal y
        if k == 0:
            daq.write(0.0)
            y = daq.read().y
        u = controller.step(r[k], y)
        daq.write(u)
        taken = daq.read()
        clamped = controller.clamped or taken.clamped  # at the controller's limit, or the rig's
        if metrics is not None:
            metrics.add(k * dt, float(r[k]), y, clamped)
        row = {"t": k * dt, "reference": float(r[k]), "u": taken.u, "y": y, "clamped": int(clamped)}
        y = taken.y
        return row

    sample_loop(daq, n, sample, recorder, "run_closed_loop", progress)
    record = recorder.frame(
        dt, columns=("t", "reference", "u", "y", "clamped"), units=units, timing="sampled"
    )
    record.attrs["loop"] = attrs["loop"]
    return record


def loop_attrs(controller: SpeedController) -> dict[str, Any]:
    """What a closed-loop record says of its loop (``attrs["loop"]``, descriptive): the column of
    the reference, the PI's ``kp`` [u/(v)], ``ki`` [u/(v s)] and ``u_max`` [u], and the speed the
    friction compensation follows (``reference``, ``measured``; None: no compensation).

    Parameters
    ----------
    controller : SpeedController
        The loop's controller.
    """
    comp = controller.compensation
    return {
        "reference": "reference", "kp": controller.pi.kp, "ki": controller.pi.ki, "u_max": controller.pi.u_max,
        "compensation": None if comp is None else comp.source,
    }  # fmt: skip
