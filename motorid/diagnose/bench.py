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
- ``slow_sampling``: a sample time drawn in 20-40 ms (the others draw 1-10 ms).

The truth rides along (:class:`Bench`): the planted effect and its parameters, the drive's own
parameters and the logging delay at the start and the end. :func:`bench` draws one; the
calibration over the bank is :func:`motorid.diagnose.calibration.bank`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from motorid.diagnose.synthetic import encoder_speed
from motorid.drive.rigid import RigidDrive

#: The imperfections a bench is logged through (see the module notes).
IMPERFECTIONS = (
    "none", "encoder", "constant_delay", "drifting_delay", "stale_start", "pulsed_pwm", "slow_sampling",
)  # fmt: skip
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
        ``attrs["dt"]``.
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
        Other true values an imperfection draws (the PWM frequency [Hz] of a pulsed drive).
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
    effect: str | None, rng: np.random.Generator, dt_sim: float
) -> tuple[RigidDrive, dict[str, float]]:
    """A small motor at 12 V turning up to 150-400 rad/s, with ``effect`` planted."""
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
    drawn = (
        rng.uniform(0.02, 0.04) if imperfection == "slow_sampling" else rng.choice([1e-3, 2e-3, 5e-3, 1e-2])
    )
    dt = float(drawn if dt is None else dt)  # drawn either way: the other draws stay the same
    dt_sim = dt / OVERSAMPLE
    drive, params = _drive(effect, rng, dt_sim)
    signal = SIGNALS[int(rng.integers(len(SIGNALS)))]
    amplitude = float(rng.uniform(6.0, 12.0))
    u = _excitation(signal, duration, dt, amplitude, rng)
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
        duty = np.clip(np.abs(applied) / 12.0, 0.0, 1.0)
        applied = np.where((t_sim * frequency) % 1.0 < duty, np.sign(applied) * 12.0, 0.0)
        u = 100.0 * u / 12.0  # the record holds the duty [%]
    w = drive.free_run(applied)
    n = u.size
    t = np.arange(n) * dt
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
        y = speed + 0.002 * float(np.max(np.abs(speed))) * rng.standard_normal(n)
    if stale:
        y[:stale] = float(rng.choice([-1.0, 1.0]) * rng.uniform(100.0, 250.0))
    record = pd.DataFrame({"t": t, "u": u, "y": y})
    record.attrs["dt"] = dt
    record.attrs["units"] = {"t": "s", "u": "%" if imperfection == "pulsed_pwm" else "V", "y": "rad/s"}
    truth = {p: float(v) for p, v in params.items()}
    return Bench(record, imperfection, signal, effect, truth, delay, stale, notes)


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


__all__ = ["BENCH_EFFECTS", "IMPERFECTIONS", "OVERSAMPLE", "SIGNALS", "Bench", "bench", "delay_error_samples"]
