"""A bank of benches: records with the imperfections real benches have, each drawn at random
within stated ranges, for calibrating the doctor on drives it has never seen.

A bench is a rigid drive (:class:`~motorid.drive.rigid.RigidDrive`) drawn around a small DC
motor (inertia, input gain, viscous and Coulomb friction, a mechanical time constant
τ = J / B of 10-60 ms), with at most one planted effect, driven by one of the excitations
small-motor records use (:data:`SIGNALS`), simulated at a tenth of the record's sample time and
logged through one imperfection (:data:`IMPERFECTIONS`):

- ``none``: white noise of 0.2 % of the largest speed;
- ``encoder``: the speed an encoder gives (:func:`~motorid.diagnose.synthetic.encoder_speed`);
- ``constant_delay``: the logger writes each speed ``d`` late, ``d`` uniform in 2-200 ms
  (at least two samples);
- ``drifting_delay``: the logger's time base drifts, ``d(t) = d_0 + r t`` with ``d_0`` in
  0-20 ms and ``r`` in 1-3 ms per second;
- ``stale_start``: the first 8-84 ms read the last speed of a previous run (±100-250 rad/s at
  a zero input);
- ``pulsed_pwm``: the drive's PWM at 5-20 Hz, slower than the motor: the input column is the
  duty, the motor sees the supply in each on phase and nothing in the off phase;
- ``slow_sampling``: a sample time drawn in 20-40 ms (the others draw 1-10 ms);
- ``pwm_ripple``: the drive's PWM at 100-490 Hz (an Arduino's is 490 Hz), logged at 1 or 2 ms:
  the motor sees the supply in each on phase and nothing in the off phase, each simulation step
  the PWM's exact average over that step (:func:`pwm_average`), so the speed ripples at the PWM
  frequency and its harmonics, aliased by the logger; the input column is the mean voltage; a
  planted dead zone is the bridge's, on the mean voltage asked for (on the pulses themselves it
  would withhold nothing);
- ``torque_ripple``: a once-per-revolution torque ripple (a bent shaft, an eccentric load, the
  magnet's joint), ``A sin(θ + φ)`` with ``A`` 3-8 % of the full input's torque: the doctor
  may name it (``cogging``), which is no false name on this bench;
- ``closed_loop``: the drive in the speed loop of ``motorid control`` (the PI of
  :func:`~motorid.speed_control.design_speed_pi` on the true linear part, with the true friction
  fed forward on half of the benches, :class:`~motorid.compensation.FrictionCompensation`), the
  excitation as its reference speed, commands limited to ±12 V and the controller acting on the
  noisy speed it logs; the record is what ``motorid control --out`` writes
  (:func:`~motorid.speed_control.run_closed_loop`): columns ``t``, ``reference``, ``u``, ``y``
  (read at ``t``, then ``u`` computed from it and held over ``[t, t + dt)``), ``clamped``, and
  ``attrs`` ``dt``, ``units``, ``timing`` ``"sampled"`` and ``loop``
  (:func:`~motorid.speed_control.loop_attrs`: the PI's gains, its limit, the compensation);
- ``two_mass``: the paper's two-mass rig (:func:`~motorid.drive.paper_rig`) drawn around the same
  small motor, the motor 20-50 % of the inertia, a shaft between motor and load whose resonance
  lies at 30-80 Hz with a damping ratio of 0.05-0.2, Coulomb friction on both masses
  (the motor's share 30-70 %) and the planted friction on the motor (the dead zone in the
  amplifier), measured by the rig's tachogenerator and 12-bit A/D converter. The truth the
  doctor's rigid model is held to is the lumped drive: ``J_m + J_l``, ``K_m / R_a``,
  ``K_m^2 / R_a + B_m + B_l`` and the sum of the Coulomb levels.

The truth rides along (:class:`Bench`): the planted effect and its parameters, the drive's own
parameters and the logging delay at the start and the end. :func:`bench` draws one; the
calibration over the bank is :func:`motorid.diagnose.calibration.bank`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from motorid.diagnose.synthetic import encoder_speed
from motorid.drive.input_path import input_path
from motorid.drive.rigid import RigidDrive

#: The imperfections a bench is logged through (see the module notes).
IMPERFECTIONS = (
    "none", "encoder", "constant_delay", "drifting_delay", "stale_start", "pulsed_pwm", "slow_sampling",
    "pwm_ripple", "torque_ripple", "closed_loop", "two_mass",
)  # fmt: skip
#: The supply voltage of the PWM benches [V].
SUPPLY = 12.0
#: The excitations: the paper's two sines with quiet stretches, a full-scale chirp and held
#: random levels (a stair).
SIGNALS = ("two_sine", "chirp", "held_levels")
#: The effects a bench may hide (None: none).
BENCH_EFFECTS = (None, "stribeck_friction", "input_dead_zone", "static_friction", "quadratic_drag")
#: Simulation steps per logged sample.
OVERSAMPLE = 10


@dataclass
class Bench:
    """A simulated record of a bench and what it hides.

    Attributes
    ----------
    record : DataFrame
        Columns ``t`` [s], ``u`` [V] (the duty in [%] for ``pulsed_pwm``), ``y`` [rad/s];
        ``attrs["dt"]``. A ``closed_loop`` bench's is ``motorid control --out``'s record (the
        module notes).
    imperfection : str
        One of :data:`IMPERFECTIONS`.
    signal : str
        One of :data:`SIGNALS`.
    effect : str or None
        The planted effect.
    params : dict
        The drive's true parameters [SI] (``inertia``, ``input_gain``, ``viscous``, ``coulomb``
        and the planted effect's).
    logging_delay : tuple of float
        The logger's delay at the first and the last sample [s] (0, 0 without one).
    stale_samples : int
        Samples of a stale start (0 without one).
    notes : dict
        Other true values an imperfection draws: the PWM frequency ``pwm_frequency`` [Hz] of a
        pulsed or rippling drive, ``compensated`` (1.0 or 0.0) of a closed loop, the standard
        deviation ``noise_std`` [rad/s] of the white noise on the logged speed (not an encoder's).
    """

    record: pd.DataFrame
    imperfection: str
    signal: str
    effect: str | None
    params: dict[str, float]
    logging_delay: tuple[float, float] = (0.0, 0.0)
    stale_samples: int = 0
    notes: dict[str, float] = field(default_factory=dict)


def _excitation(
    signal: str, duration: float, dt: float, amplitude: float, rng: np.random.Generator
) -> np.ndarray:
    from motorid.signals import chirp, steps, two_sine_signal

    seed = int(rng.integers(2**31))
    if signal == "two_sine":
        return two_sine_signal(
            duration, dt, seed=seed, amplitudes=(amplitude, 0.625 * amplitude),
            active_seconds=(3.0, 6.0), low_seconds=(2.0, 4.0),
        )[1]  # fmt: skip
    if signal == "chirp":
        return chirp(duration, dt, f0=0.05, f1=float(rng.uniform(1.0, 4.0)), amplitude=amplitude,
                     method="linear", seed=seed)[1]  # fmt: skip
    return steps(duration, dt, amplitude=amplitude, hold_seconds=(0.3, 1.5), seed=seed)[1]


def _drive(
    effect: str | None, rng: np.random.Generator, dt_sim: float, ripple: bool = False
) -> tuple[RigidDrive, dict[str, float]]:
    """A small motor at 12 V turning up to 150-400 rad/s, with ``effect`` planted and, with
    ``ripple``, a once-per-revolution torque ripple (``cogging`` with ``cogging_periods`` = 1 per
    radian: one period per turn of the shaft)."""
    speed = float(rng.uniform(150.0, 400.0))  # at 12 V, without friction [rad/s]
    tau = float(rng.uniform(0.01, 0.06))  # J / B [s]
    gain = float(rng.uniform(2e-3, 6e-3))  # [N m/V]
    viscous = 12.0 * gain / speed
    params = {
        "inertia": tau * viscous,
        "input_gain": gain,
        "viscous": viscous,
        "coulomb": float(rng.uniform(0.04, 0.12)) * 12.0 * gain,  # 4-12 % of the full input's torque
        "offset": 0.0,
    }
    effects = ["viscous_friction", "coulomb_friction", "offset"]
    if effect == "stribeck_friction":
        params["stribeck"] = float(rng.uniform(0.5, 1.0)) * params["coulomb"]
        params["stribeck_velocity"] = float(rng.uniform(0.02, 0.06)) * speed
    elif effect == "input_dead_zone":
        params["dead_zone"] = float(rng.uniform(0.5, 1.5))
    elif effect == "static_friction":
        params["breakaway_excess"] = float(rng.uniform(0.4, 0.8)) * params["coulomb"]
    elif effect == "quadratic_drag":
        params["quadratic_drag"] = float(rng.uniform(0.3, 0.6)) * viscous / speed
    elif effect is not None:
        raise ValueError(f"effect must be one of {BENCH_EFFECTS}, got {effect!r}")
    if effect is not None:
        effects.append(effect)
    if ripple:
        amplitude = float(rng.uniform(0.03, 0.08)) * 12.0 * gain
        phase = float(rng.uniform(0.0, 2.0 * np.pi))
        params.update(cogging_sin=amplitude * np.cos(phase), cogging_cos=amplitude * np.sin(phase),
                      cogging_periods=1.0)  # fmt: skip
        effects.append("cogging")
    return RigidDrive(tuple(effects), params, dt_sim), params


def bench(
    imperfection: str,
    effect: str | None,
    seed: int,
    duration: float = 30.0,
    dt: float | None = None,
    logging_delay: tuple[float, float] | None = None,
) -> Bench:
    """Draw one bench (see the module notes).

    Parameters
    ----------
    imperfection : str
        One of :data:`IMPERFECTIONS`.
    effect : str or None
        One of :data:`BENCH_EFFECTS`.
    seed : int
        Draws the drive, the signal, the sample time, the imperfection's size and the noise.
    duration : float
        Length of the record [s].
    dt : float, optional
        The sample time [s], in place of the imperfection's draw.
    logging_delay : tuple of float, optional
        The logger's delay at the start and at the end [s], in place of the imperfection's draw
        (a ``constant_delay`` or ``drifting_delay`` bench).
    """
    if imperfection not in IMPERFECTIONS:
        raise ValueError(f"imperfection must be one of {', '.join(IMPERFECTIONS)}, got {imperfection!r}")
    rng = np.random.default_rng([seed, IMPERFECTIONS.index(imperfection)])
    if imperfection == "slow_sampling":
        drawn = rng.uniform(0.02, 0.04)
    elif imperfection == "pwm_ripple":
        drawn = rng.choice([1e-3, 2e-3])
    else:
        drawn = rng.choice([1e-3, 2e-3, 5e-3, 1e-2])
    dt = float(drawn if dt is None else dt)  # drawn either way: the other draws stay the same
    dt_sim = dt / OVERSAMPLE
    drive, params = _drive(effect, rng, dt_sim, ripple=imperfection == "torque_ripple")
    signal = SIGNALS[int(rng.integers(len(SIGNALS)))]
    amplitude = float(rng.uniform(6.0, 12.0))
    u = _excitation(signal, duration, dt, amplitude, rng)
    n = u.size
    t = np.arange(n) * dt
    truth = {p: float(v) for p, v in params.items()}
    if imperfection == "two_mass":
        record, truth = _two_mass(truth, effect, u, dt, rng)
        return Bench(record, imperfection, signal, effect, truth)
    if imperfection == "closed_loop":
        compensated = bool(rng.integers(2))
        reference = 0.6 * (12.0 * params["input_gain"] / params["viscous"]) * u / 12.0
        record = _closed_loop(drive, params, reference, dt, compensated, rng)
        return Bench(record, imperfection, signal, effect, truth, notes={"compensated": float(compensated)})
    stale = 0
    if imperfection == "stale_start":
        stale = max(3, round(float(rng.uniform(0.008, 0.084)) / dt))
        u[: stale + 1] = 0.0  # the drive at rest under a zero input while the link reads the stale value
    applied = np.repeat(u, OVERSAMPLE)  # the logged input, held over each sample
    notes: dict[str, float] = {}
    if imperfection == "pulsed_pwm":
        frequency = float(rng.uniform(5.0, 20.0))
        notes["pwm_frequency"] = frequency
        t_sim = np.arange(applied.size) * dt_sim
        duty = np.clip(np.abs(applied) / SUPPLY, 0.0, 1.0)
        applied = np.where((t_sim * frequency) % 1.0 < duty, np.sign(applied) * SUPPLY, 0.0)
        u = 100.0 * u / SUPPLY  # the record holds the duty [%]
    elif imperfection == "pwm_ripple":
        frequency = float(rng.uniform(100.0, 490.0))
        notes["pwm_frequency"] = frequency
        u = np.clip(u, -SUPPLY, SUPPLY)  # the bridge gives at most the supply: the record holds what it gave
        asked = u
        if effect == "input_dead_zone":
            # the bridge's dead zone withholds the small duties it is asked for; on the supply's
            # pulses themselves (0 or 12 V) a dead zone of 0.5-1.5 V would withhold nothing
            asked = input_path(u, dead_zone=params["dead_zone"])
            drive = drive.without("input_dead_zone")
        applied = pwm_average(np.repeat(asked, OVERSAMPLE), dt_sim, frequency)
    w = drive.free_run(applied)
    delay = (0.0, 0.0)
    if logging_delay is not None:
        delay = (float(logging_delay[0]), float(logging_delay[1]))
    elif imperfection == "constant_delay":
        d = float(rng.uniform(max(0.002, 2 * dt), 0.2))
        delay = (d, d)
    elif imperfection == "drifting_delay":
        d0, rate = float(rng.uniform(0.0, 0.02)), float(rng.uniform(1e-3, 3e-3))
        delay = (d0, d0 + rate * t[-1])
    # the speed at the end of sample k, read d(t_k) late, off the simulation's finer grid
    t_end = (np.arange(w.size) + 1) * dt_sim
    late = delay[0] + (delay[1] - delay[0]) * t / max(t[-1], dt)
    speed = np.interp(t + dt - late, t_end, w, left=0.0)
    if imperfection == "encoder":
        y = encoder_speed(speed, rng)
    else:
        notes["noise_std"] = 0.002 * float(np.max(np.abs(speed)))
        y = speed + notes["noise_std"] * rng.standard_normal(n)
    if stale:
        y[:stale] = float(rng.choice([-1.0, 1.0]) * rng.uniform(100.0, 250.0))
    record = pd.DataFrame({"t": t, "u": u, "y": y})
    record.attrs["dt"] = dt
    record.attrs["units"] = {"t": "s", "u": "%" if imperfection == "pulsed_pwm" else "V", "y": "rad/s"}
    return Bench(record, imperfection, signal, effect, truth, delay, stale, notes)


def pwm_average(volts: np.ndarray, step: float, frequency: float) -> np.ndarray:
    """What a PWM bridge applies over each simulation step: the supply's exact mean over the step.

    A PWM of period ``P = 1 / f`` and duty ``d = |v| / V_s`` (``v`` the mean voltage asked for,
    clipped to ``V_s`` = :data:`SUPPLY`) is on over ``[m P, m P + d P)`` of each period ``m``. The
    time it has been on since ``t = 0`` is ``H(t) = d P floor(t / P) + min(t mod P, d P)``, so the
    mean voltage over the step ``[t_i, t_i + h)`` is ``sgn(v) V_s (H(t_i + h) - H(t_i)) / h``:
    exact at any ratio of step to period (a step longer than the period sees the mean ``v``, a
    shorter one the ripple).

    Parameters
    ----------
    volts : ndarray, shape (N,)
        The mean voltage asked for over each step [V] (the controller's command, held).
    step : float
        The simulation step h [s].
    frequency : float
        The PWM frequency f [Hz].
    """
    period = 1.0 / frequency
    duty = np.clip(np.abs(volts) / SUPPLY, 0.0, 1.0)
    t = np.arange(volts.size + 1) * step

    def on_time(at: np.ndarray, d: np.ndarray) -> np.ndarray:
        return d * period * np.floor(at / period) + np.minimum(at % period, d * period)

    return np.sign(volts) * SUPPLY * (on_time(t[1:], duty) - on_time(t[:-1], duty)) / step


def _two_mass(
    params: dict[str, float], effect: str | None, u: np.ndarray, dt: float, rng: np.random.Generator
) -> tuple[pd.DataFrame, dict[str, float]]:
    """The record of a two-mass rig whose lumped drive is ``params`` (see the module notes), and
    the lumped truth."""
    from motorid.drive import Amplifier, Friction, paper_rig

    R_a = float(rng.uniform(1.5, 3.0))
    K_m = params["input_gain"] * R_a  # the torque per volt K_m / R_a of the drawn motor
    mechanical = params["viscous"] - K_m**2 / R_a  # what the back EMF leaves to the bearings
    if mechanical <= 0.0:  # a motor whose back EMF alone damps more: the bearings take 10 %
        K_m = float(np.sqrt(0.9 * params["viscous"] * R_a))
        mechanical = 0.1 * params["viscous"]
    share_m = float(rng.uniform(0.2, 0.5))  # the motor's share of the inertia
    J = params["inertia"]
    # the shaft: k_s = ω_r² J_m J_l / J and B_s = 2 ζ ω_r J_m J_l / J for the resonance ω_r
    reduced = share_m * (1.0 - share_m) * J
    resonance = 2.0 * np.pi * float(rng.uniform(30.0, 80.0))
    k_s, B_s = resonance**2 * reduced, 2.0 * float(rng.uniform(0.05, 0.2)) * resonance * reduced
    coulomb, share_c = params["coulomb"], float(rng.uniform(0.3, 0.7))
    friction = [
        Friction(("coulomb_friction",), {"coulomb": share_c * coulomb}, side="motor"),
        Friction(("coulomb_friction",), {"coulomb": (1.0 - share_c) * coulomb}, side="load"),
    ]
    planted = {
        k: v for k, v in params.items() if k not in ("inertia", "input_gain", "viscous", "coulomb", "offset")
    }
    if effect is not None and effect != "input_dead_zone":
        friction.append(Friction((effect,), planted, side="motor"))
    rig = paper_rig(
        J_m=share_m * J, J_l=(1.0 - share_m) * J, K_m=K_m, R_a=R_a, B_m=0.5 * mechanical,
        B_l=0.5 * mechanical, k_s=k_s, B_s=B_s, dt=dt, substeps=max(1, round(dt / 2.5e-4)),
        friction=tuple(friction),
        amplifier=Amplifier(gain=1.0, dead_zone=planted.get("dead_zone", 0.0), v_max=SUPPLY),
    )  # fmt: skip
    y = rig.simulate(np.clip(u, -SUPPLY, SUPPLY), seed=int(rng.integers(2**31)))["y"].to_numpy()
    record = pd.DataFrame({"t": np.arange(u.size) * dt, "u": np.clip(u, -SUPPLY, SUPPLY), "y": y})
    record.attrs["dt"] = dt
    record.attrs["units"] = {"t": "s", "u": "V", "y": "rad/s"}
    truth = {**params, "input_gain": K_m / R_a, "viscous": K_m**2 / R_a + mechanical}
    return record, truth


def _closed_loop(
    drive: RigidDrive,
    params: dict[str, float],
    reference: np.ndarray,
    dt: float,
    compensated: bool,
    rng: np.random.Generator,
) -> pd.DataFrame:
    """The drive in the speed loop of ``motorid control``: at each sample ``t_k`` the speed read
    (the truth plus white noise of 0.2 % of the largest reference), then the controller's command
    from the reference and that speed, held over ``[t_k, t_k + dt)`` (:data:`OVERSAMPLE` steps of
    the simulation). Returns the record as :func:`~motorid.speed_control.run_closed_loop` writes
    it: ``t`` [s], ``reference`` [rad/s], ``u`` [V], ``y`` [rad/s] read at ``t``, ``clamped``;
    ``attrs`` ``dt``, ``units``, ``timing`` ``"sampled"``, ``loop``."""
    from motorid.compensation import FrictionCompensation
    from motorid.drive.rigid import RigidSimulation
    from motorid.speed_control import SpeedController, design_speed_pi, loop_attrs

    linear = {k: params[k] for k in ("inertia", "input_gain", "viscous")}
    pi = design_speed_pi(RigidDrive(("viscous_friction",), linear, dt), dt, u_max=12.0)
    compensation = None
    if compensated:
        known = {
            "inertia": params["inertia"],
            "input_gain": params["input_gain"],
            "coulomb": params["coulomb"],
        }
        friction = RigidDrive(("coulomb_friction",), known, dt)
        compensation = FrictionCompensation(friction, speed_band=0.02 * float(np.max(np.abs(reference))))
    controller = SpeedController(pi, dt, compensation)
    plant = RigidSimulation(drive)
    n = reference.size
    noise = 0.002 * float(np.max(np.abs(reference))) * rng.standard_normal(n)
    u, y, clamped = np.empty(n), np.empty(n), np.zeros(n, dtype=int)
    speed = 0.0  # the drive at rest at t_0
    for k, r in enumerate(reference):
        y[k] = speed + noise[k]  # read at t_k ...
        u[k] = controller.step(float(r), y[k])  # ... then commanded, held over [t_k, t_k + dt)
        clamped[k] = controller.clamped
        speed = float(plant.run(np.full(OVERSAMPLE, u[k]))[-1])
    record = pd.DataFrame(
        {"t": np.arange(n) * dt, "reference": reference, "u": u, "y": y, "clamped": clamped}
    )
    record.attrs.update(
        dt=dt, units={"t": "s", "reference": "rad/s", "u": "V", "y": "rad/s"}, timing="sampled",
        loop=loop_attrs(controller),
    )  # fmt: skip
    return record


def delay_error_samples(found: float, bench: Bench) -> float:
    """How far a found input delay lies from the bench's mean logging delay, in samples.

    Parameters
    ----------
    found : float
        The input delay found [s].
    bench : Bench
        The bench it was found on.
    """
    return abs(found - 0.5 * sum(bench.logging_delay)) / bench.record.attrs["dt"]


__all__ = [
    "BENCH_EFFECTS", "IMPERFECTIONS", "OVERSAMPLE", "SIGNALS", "SUPPLY", "Bench", "bench",
    "delay_error_samples", "pwm_average",
]  # fmt: skip
