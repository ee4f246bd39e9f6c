"""Excitation signals for the rig: the paper's test signal, PRBS, multisine, chirp, steps.

Every generator takes a ``duration`` [s] and a sample time ``dt`` [s] and returns
``(t, u)``: the time base ``t[k] = k dt`` [s] and the command ``u[k]`` [V], both
float arrays of ``round(duration/dt)`` samples. Random choices (phases, levels,
where the quiet stretches go) come from ``numpy.random.default_rng(seed)``, so
a seed makes a signal reproducible.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal

Signal = tuple[np.ndarray, np.ndarray]


def _time_base(duration: float, dt: float) -> np.ndarray:
    if not math.isfinite(dt) or dt <= 0.0:
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    if not math.isfinite(duration) or duration <= 0.0:
        raise ValueError(f"duration must be finite and > 0, got {duration!r}")
    n = round(duration / dt)
    if n < 1:
        raise ValueError(f"duration must be at least one sample (dt = {dt!r}), got {duration!r}")
    return np.arange(n) * dt


def _positive(name: str, value: float) -> None:
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")


def two_sine_signal(
    duration: float = 120.0,
    dt: float = 0.04,
    seed: int | None = None,
    amplitudes: tuple[float, float] = (4.0, 2.5),
    frequencies: tuple[float, float] = (0.13, 0.71),
    low_level: float = 0.2,
    active_seconds: tuple[float, float] = (5.0, 12.0),
    low_seconds: tuple[float, float] = (3.0, 8.0),
    ramp: float = 0.5,
) -> Signal:
    """The paper's test signal (section 4, Fig. 8): two sinusoids around 0 V
    with deliberate low-amplitude stretches.

    ``u(t) = e(t) (A1 sin(2π f1 t + φ1) + A2 sin(2π f2 t + φ2))`` [V], where the
    envelope e(t) alternates between 1 (active stretches, lengths drawn from
    ``active_seconds``) and ``low_level`` (quiet stretches, lengths from
    ``low_seconds``), with raised-cosine ramps of ``ramp`` seconds. The quiet
    stretches keep the drive near zero speed, where Coulomb friction and dead
    zone act; the phases φ and the stretch layout are drawn from ``seed``.

    Parameters
    ----------
    duration, dt : float
        Length [s] and sample time [s].
    seed : int or None
        Seed of the phases and the stretch layout.
    amplitudes : (float, float)
        A1, A2 [V] (the two signal generators of the paper's setup).
    frequencies : (float, float)
        f1, f2 [Hz]; default 0.13 and 0.71 Hz, inside the ~1.6 Hz bandwidth of a
        drive that settles in 400 ms, and not commensurate.
    low_level : float
        Envelope in the quiet stretches, in [0, 1].
    active_seconds, low_seconds : (float, float)
        Ranges [s] of the stretch lengths.
    ramp : float
        Length [s] of the transitions between stretches, >= 0.
    """
    t = _time_base(duration, dt)
    if not 0.0 <= low_level <= 1.0:
        raise ValueError(f"low_level must be in [0, 1], got {low_level!r}")
    for name, (lo, hi) in (("active_seconds", active_seconds), ("low_seconds", low_seconds)):
        if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi):
            raise ValueError(f"{name} must be (low, high) with 0 < low <= high, got {(lo, hi)!r}")
    if not math.isfinite(ramp) or ramp < 0.0:
        raise ValueError(f"ramp must be finite and >= 0, got {ramp!r}")
    for f in frequencies:
        _positive("frequencies", f)
    rng = np.random.default_rng(seed)
    phases = rng.uniform(0.0, 2.0 * math.pi, 2)
    # stretch layout: active, quiet, active, quiet, ...
    edges = [0.0]
    levels = []
    active = True
    while edges[-1] < t[-1] + dt:
        span = active_seconds if active else low_seconds
        edges.append(edges[-1] + rng.uniform(*span))
        levels.append(1.0 if active else low_level)
        active = not active
    # the stretch k holding t: edges[k] <= t < edges[k + 1]
    env = np.asarray(levels)[np.searchsorted(edges, t, side="right") - 1]
    if ramp > 0.0:
        n_ramp = max(1, round(ramp / dt))
        kernel = np.hanning(n_ramp + 2)[1:-1]
        kernel /= kernel.sum()
        env = np.convolve(np.pad(env, (n_ramp, n_ramp), mode="edge"), kernel, mode="same")
        env = env[n_ramp:-n_ramp]
    carrier = sum(
        a * np.sin(2.0 * math.pi * f * t + p) for a, f, p in zip(amplitudes, frequencies, phases, strict=True)
    )
    return t, env * carrier


def prbs(
    duration: float,
    dt: float,
    amplitude: float = 3.0,
    offset: float = 0.0,
    hold: int = 1,
    nbits: int = 10,
    seed: int | None = None,
) -> Signal:
    """Pseudo-random binary sequence: ``offset ± amplitude`` [V].

    A maximum-length sequence of a ``nbits`` shift register (period 2^nbits - 1
    bits) starting from a seeded non-zero state, each bit held for ``hold``
    samples (clock period ``hold dt``).

    Parameters
    ----------
    duration : float
        Length [s].
    dt : float
        Sample time [s].
    amplitude : float
        Amplitude [V].
    offset : float
        Mean [V].
    hold : int
        Samples each bit is held.
    nbits : int
        Length of the shift register.
    seed : int, optional
        Seed of the start state.
    """
    t = _time_base(duration, dt)
    _positive("amplitude", amplitude)
    if not isinstance(hold, int) or hold < 1:
        raise ValueError(f"hold must be an integer >= 1, got {hold!r}")
    if not isinstance(nbits, int) or not 2 <= nbits <= 32:
        raise ValueError(f"nbits must be an integer in [2, 32], got {nbits!r}")
    rng = np.random.default_rng(seed)
    state = rng.integers(0, 2, nbits)
    if not state.any():
        state[0] = 1
    n_bits = -(-t.size // hold)
    period = 2**nbits - 1
    seq, _ = scipy.signal.max_len_seq(nbits, state=state, length=min(n_bits, period))
    seq = np.resize(seq, n_bits)
    bits = np.repeat(seq, hold)[: t.size]
    return t, offset + amplitude * (2.0 * bits - 1.0)


def multisine(
    duration: float,
    dt: float,
    amplitude: float = 3.0,
    f_min: float = 0.05,
    f_max: float = 2.0,
    n_freqs: int = 20,
    offset: float = 0.0,
    seed: int | None = None,
) -> Signal:
    """Random-phase multisine scaled to peak ``amplitude`` [V] about ``offset``.

    ``n_freqs`` lines spread logarithmically in ``[f_min, f_max]`` [Hz], each
    rounded to a multiple of 1/duration (so the record holds whole periods),
    phases uniform from ``seed``.

    Parameters
    ----------
    duration : float
        Length [s].
    dt : float
        Sample time [s].
    amplitude : float
        Peak amplitude [V].
    f_min, f_max : float
        The band [Hz].
    n_freqs : int
        Number of lines.
    offset : float
        Mean [V].
    seed : int, optional
        Seed of the phases.
    """
    t = _time_base(duration, dt)
    _positive("amplitude", amplitude)
    _positive("f_min", f_min)
    if not math.isfinite(f_max) or f_max <= f_min or f_max >= 0.5 / dt:
        raise ValueError(f"f_max must lie in (f_min, 1/(2 dt)) = ({f_min}, {0.5 / dt}), got {f_max!r}")
    if not isinstance(n_freqs, int) or n_freqs < 1:
        raise ValueError(f"n_freqs must be an integer >= 1, got {n_freqs!r}")
    df = 1.0 / (t.size * dt)
    lines = np.unique(np.maximum(1, np.round(np.geomspace(f_min, f_max, n_freqs) / df)))
    freqs = lines * df
    phases = np.random.default_rng(seed).uniform(0.0, 2.0 * math.pi, freqs.size)
    u = np.sin(2.0 * math.pi * np.outer(t, freqs) + phases).sum(axis=1)
    peak = np.max(np.abs(u))
    return t, offset + amplitude * u / peak


def chirp(
    duration: float,
    dt: float,
    f0: float = 0.05,
    f1: float = 2.0,
    amplitude: float = 3.0,
    offset: float = 0.0,
    method: str = "logarithmic",
    seed: int | None = None,
) -> Signal:
    """Swept sine from ``f0`` to ``f1`` [Hz] over the duration (``scipy.signal.chirp``).

    ``u = offset + amplitude cos(φ(t) + φ0)`` [V]; the start phase φ0 is drawn
    from ``seed`` (``seed=None`` and a fixed seed both give a valid sweep).

    Parameters
    ----------
    duration : float
        Length [s].
    dt : float
        Sample time [s].
    f0, f1 : float
        Start and end frequency [Hz].
    amplitude : float
        Amplitude [V].
    offset : float
        Mean [V].
    method : str
        The sweep's law (``scipy.signal.chirp``: ``"logarithmic"``, ``"linear"``, ...).
    seed : int, optional
        Seed of the start phase.
    """
    t = _time_base(duration, dt)
    _positive("amplitude", amplitude)
    _positive("f0", f0)
    _positive("f1", f1)
    phase = np.random.default_rng(seed).uniform(0.0, 360.0)
    t_end = max(t[-1], dt)
    u = scipy.signal.chirp(t, f0=f0, t1=t_end, f1=f1, method=method, phi=phase)
    return t, offset + amplitude * u


def steps(
    duration: float,
    dt: float,
    amplitude: float = 6.0,
    hold_seconds: tuple[float, float] = (0.5, 2.0),
    seed: int | None = None,
) -> Signal:
    """Random steps: levels uniform in ``[-amplitude, amplitude]`` [V], each held
    for a time drawn from ``hold_seconds`` [s].

    Parameters
    ----------
    duration : float
        Length [s].
    dt : float
        Sample time [s].
    amplitude : float
        Largest level [V].
    hold_seconds : tuple of float
        Shortest and longest hold [s].
    seed : int, optional
        Seed of the levels and holds.
    """
    t = _time_base(duration, dt)
    _positive("amplitude", amplitude)
    lo, hi = hold_seconds
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 < lo <= hi):
        raise ValueError(f"hold_seconds must be (low, high) with 0 < low <= high, got {hold_seconds!r}")
    rng = np.random.default_rng(seed)
    u = np.empty_like(t)
    k = 0
    while k < t.size:
        n = max(1, round(rng.uniform(lo, hi) / dt))
        u[k : k + n] = rng.uniform(-amplitude, amplitude)
        k += n
    return t, u


__all__ = ["chirp", "multisine", "prbs", "steps", "two_sine_signal"]
