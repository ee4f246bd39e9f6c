"""Logging artefacts a record may carry, found and left out before the doctor fits it.

- **A held start**: a logger that records before the speed stream starts writes one output value
  (zero, or the first value it got) for the first samples while the input already moves. The
  samples before the output first changes are left out when they are at least
  :data:`MIN_HELD` and the input moves over them by more than :data:`INPUT_MOVES` of its range,
  and either the held value is not zero (a drive at speed does not hold a constant reading while
  its input moves) or the input reaches beyond :data:`REST_MARGIN` times the largest input under
  which the drive rests later in the record (the output reads zero for at least
  :data:`MIN_HELD` samples in a row; a drive at rest under an input below its breakaway level is
  physics and is kept).
- **A stale start**: a serial link that keeps the last value of the previous run reports it for
  the first samples of the next (the kit's logger: -205 rad/s at u = 0 for 8-84 ms). The first
  k0 >= :data:`MIN_STALE` samples hold one output value, not zero, while the input stays
  constant, and the output then leaves it by more than :data:`STALE_JUMP` of it within
  :data:`STALE_SAMPLES` samples, faster than the drive slows down: a drive turning at y_0 under a
  constant input does not read y_0 exactly k0 times and then lose half of it. Those samples
  are left out.
- **Drop-out spikes**: a serial link that loses a sample reports one value far from both its
  neighbours, which agree with each other. Sample k is one when

      |y_k - m_k| > max(SPIKE_FACTOR max(s, q), SPIKE_SHARE range(y))
      and   |y_k+1 - y_k-1| < NEIGHBOURS |y_k - m_k|,       m_k = (y_k-1 + y_k+1) / 2,

  with s = 1.4826 median |y_k - m_k| over the record (a robust standard deviation of the
  deviation from the neighbours' mean) and q the smallest step of the output (its quantisation:
  a quantised record's median deviation may be 0). A drop-out lands far from the speed (a
  tenth of the record's range at least): a one-sample blip of a speed estimate where the input
  steps (the wheel motors of ``realmotors/`` show 4 % of their range) is the sensor's, and
  kept. A spike is replaced by m_k, so the record keeps its uniform sample time.

Each artefact left out gets a one-line note (:func:`clean_output`).

One kind of record is refused rather than cleaned: **a pulsed drive** (:func:`driven_stops`). A
PWM slower than the motor (a few hertz to some tens) lets the drive stop in every off phase: the
speed falls to zero and starts again in the same direction while the input, the duty averaged
over the period, holds its sign well above the level that turns the drive. No drive model of the
averaged input describes that; the record is refused naming what to do (a PWM frequency well
above ``1 / (2 pi tau)``, or an input logged as the voltage the motor sees).
"""

from __future__ import annotations

import numpy as np

#: Fewest held samples at the start that count as a held start.
MIN_HELD = 10
#: Share of the input's range the input must move over a held start.
INPUT_MOVES = 0.05
#: A held zero start is an artefact when the input reaches beyond this many times the largest
#: input under which the drive rests later (a breakaway a little higher than elsewhere is kept).
REST_MARGIN = 1.2
#: Fewest samples of a stale start.
MIN_STALE = 3
#: A stale start's value is left by more than this share of it ...
STALE_JUMP = 0.5
#: ... within this many samples after it.
STALE_SAMPLES = 3
#: A spike deviates from its neighbours' mean by more than this many robust deviations: for
#: Gaussian noise a false alarm once in about 10^23 samples.
SPIKE_FACTOR = 10.0
#: A spike's neighbours differ by less than this share of its deviation.
NEIGHBOURS = 0.25
#: A spike deviates from its neighbours' mean by more than this share of the output's range.
SPIKE_SHARE = 0.1
#: A pulsed drive: the speed is "moving" above this share of its range (the 99th percentile of
#: |y|), "stopped" below :data:`STOPPED` of it, and "driven" where |u| exceeds :data:`DRIVEN` of
#: the input's (the 99th percentile of |u|).
MOVING = 0.1
STOPPED = 0.03
DRIVEN = 0.2
#: Fewest driven stops that make a record a pulsed drive. On the bank of benches
#: (:mod:`motorid.diagnose.bench`, seeds 0-12 of every effect, 65 benches per imperfection) the
#: benches that are not pulsed have at most 3, but one: 14 on a 163 Hz PWM at 20 % duty on an
#: 18 ms motor, which does stop at the bottom of its ripple; none of 110 planted rig records
#: (:func:`~motorid.diagnose.synthetic.planted_record`) has one, the real motors' records of
#: ``realmotors/`` at most 1. Of the 65 pulsed benches (5-20 Hz) 53 have 6 or more, up to 225;
#: the others stop too few times in 30 s to be told from a drive that stops now and then, and
#: are left to the fit.
MIN_DRIVEN_STOPS = 6
#: ... two of which lie at most this far apart [s] (a PWM's period, 50-200 ms at 5-20 Hz). A drive
#: whose friction holds it at the bottom of each period of a slow sine stops as often, seconds
#: apart, and is physics to fit. With both rules 51 of the 65 pulsed benches are refused.
MAX_STOP_SPACING = 1.0


def held_start(u: np.ndarray, y: np.ndarray) -> int:
    """Number of samples at the start of a record whose output is held by the logger (see the
    module notes); 0 for none.

    Parameters
    ----------
    u, y : ndarray
        The record's input and output.
    """
    changes = np.flatnonzero(y != y[0])
    if changes.size == 0 or changes[0] < MIN_HELD:
        return 0
    k0 = int(changes[0])
    span = float(np.ptp(u[:k0]))
    if span <= INPUT_MOVES * float(np.ptp(u)):
        return 0
    if y[0] != 0.0:
        return k0
    # samples inside runs of at least MIN_HELD zero readings after the start: the drive at rest
    zero = np.concatenate([[False], y[k0:] == 0.0, [False]])
    edges = np.flatnonzero(np.diff(zero.astype(np.int8)))
    runs = [(a, b) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= MIN_HELD]
    rest_input = max((float(np.max(np.abs(u[k0 + a : k0 + b]))) for a, b in runs), default=0.0)
    return k0 if float(np.max(np.abs(u[:k0]))) > REST_MARGIN * rest_input else 0


def stale_start(u: np.ndarray, y: np.ndarray) -> int:
    """Number of samples at the start of a record whose output is the previous run's last value
    (see the module notes); 0 for none.

    Parameters
    ----------
    u, y : ndarray
        The record's input and output.
    """
    if y.size <= MIN_STALE + STALE_SAMPLES or y[0] == 0.0:
        return 0
    changes = np.flatnonzero(y != y[0])
    if changes.size == 0 or changes[0] < MIN_STALE:
        return 0
    k0 = int(changes[0])
    if np.ptp(u[:k0]) > 0.0:
        return 0
    after = y[k0 : k0 + STALE_SAMPLES]
    return k0 if float(np.max(np.abs(after - y[0]))) > STALE_JUMP * abs(float(y[0])) else 0


def driven_stops(u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Where the drive stops while driven: the indices of the first sample of each stop.

    A driven stop is a stretch of samples between two moving samples ``m_1 < m_2``
    (``|y| > MOVING y_s``) that holds at least one stopped sample (``|y| < STOPPED y_s``), over
    which the input keeps one sign, the sign of ``y[m_1]`` and of ``y[m_2]``, with
    ``|u| > DRIVEN u_s`` throughout (``y_s``, ``u_s``: the 99th percentiles of ``|y|`` and
    ``|u|``). A reversal (the speed's sign changes) and a rest under a small input (a dead zone,
    a breakaway) are no driven stops; a drive pulsed by a slow PWM makes one each period.

    Parameters
    ----------
    u, y : ndarray
        The record's input and speed.
    """
    if not y.size:
        return np.zeros(0, dtype=int)
    speed = np.abs(y)  # the one full-rate copy: a long record's doctor keeps few columns at once
    y_s = float(np.quantile(speed, 0.99))
    u_s = float(np.quantile(np.abs(u[:: max(1, u.size // 100_000)]), 0.99))  # a sample of u suffices
    if not (y_s > 0.0 and u_s > 0.0):
        return np.zeros(0, dtype=int)
    moving = np.flatnonzero(speed > MOVING * y_s)
    gaps = np.flatnonzero(np.diff(moving) > 1)
    found = []
    for first, second in zip(moving[gaps], moving[gaps + 1], strict=True):
        direction = np.sign(y[first])
        if direction != np.sign(y[second]) or not np.any(speed[first + 1 : second] < STOPPED * y_s):
            continue
        if np.all(direction * u[first : second + 1] > DRIVEN * u_s):
            found.append(first + 1)
    return np.array(found, dtype=int)


def refuse_pulsed(u: np.ndarray, y: np.ndarray, dt: float) -> None:
    """Refuse a pulsed drive (:func:`driven_stops`: at least :data:`MIN_DRIVEN_STOPS` stops, two of
    them :data:`MAX_STOP_SPACING` or less apart) with a :class:`~motorid.errors.DataError` that says
    what the record shows and what to do.

    Parameters
    ----------
    u, y : ndarray
        The record's input and speed.
    dt : float
        Sample time [s].
    """
    from motorid.errors import DataError

    stops = driven_stops(u, y)
    if stops.size < MIN_DRIVEN_STOPS:
        return
    apart = float(np.min(np.diff(stops))) * dt
    if apart > MAX_STOP_SPACING:
        return
    raise DataError(
        f"no drive model describes this record: the speed falls to zero {stops.size} times while the "
        f"input keeps its sign above {DRIVEN:.0%} of its range (the first at sample {int(stops[0])}, "
        f"the closest two {1e3 * apart:.3g} ms apart): a pulsed drive, whose PWM is slower than the motor "
        "(about one stop per PWM period). Record with a PWM frequency well above the motor's bandwidth "
        "(hundreds of hertz or more), or average the speed over whole PWM periods"
    )


def dropout_spikes(y: np.ndarray) -> np.ndarray:
    """Indices of single-sample drop-out spikes in ``y`` (see the module notes).

    Parameters
    ----------
    y : ndarray
        The record's output.
    """
    if y.size < 3:
        return np.zeros(0, dtype=int)
    mid = 0.5 * (y[:-2] + y[2:])
    dev = np.abs(y[1:-1] - mid)
    steps = np.abs(np.diff(y))
    steps = steps[steps > 0.0]
    quantum = float(np.min(steps)) if steps.size else 0.0
    scale = max(1.4826 * float(np.median(dev)), quantum)
    limit = max(SPIKE_FACTOR * scale, SPIKE_SHARE * float(np.ptp(y)))
    spike = (dev > limit) & (np.abs(y[2:] - y[:-2]) < NEIGHBOURS * dev)
    return np.flatnonzero(spike) + 1


def clean_output(
    u: np.ndarray, y: np.ndarray, dt: float, units: tuple[str, str] = ("", ""), start: bool = True
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """``u`` and ``y`` without a held start (looked for when ``start``: a velocity output; a
    resting drive holds its position) and with drop-out spikes replaced, and a note for each
    artefact left out (``units``: the input's and the output's, for the notes; ``dt`` [s]).

    Parameters
    ----------
    u, y : ndarray
        The record's input and output.
    dt : float
        Sample time [s].
    units : tuple of str
        The input's and the output's units, for the notes.
    start : bool
        Look for a held start (a velocity output).
    """
    u_unit, y_unit = (f" {x}" if x else "" for x in units)
    notes = []
    k0 = held_start(u, y) if start else 0
    if k0:
        notes.append(
            f"the output holds {y[0]:.4g}{y_unit} over the first {k0} samples ({k0 * dt:.3g} s) while the "
            f"input moves (to {np.max(np.abs(u[:k0])):.3g}{u_unit}): a logging artefact, left out"
        )
        u, y = u[k0:], y[k0:]
    stale = stale_start(u, y) if start else 0
    if stale:
        notes.append(
            f"the output reads {y[0]:.4g}{y_unit} over the first {stale} samples ({stale * dt:.3g} s) under a "
            f"constant input ({u[0]:.3g}{u_unit}) and then leaves it at once: a stale value of an earlier run, "
            "left out"
        )
        u, y, k0 = u[stale:], y[stale:], k0 + stale
    spikes = dropout_spikes(y)
    if spikes.size:
        y = y.copy()
        first = int(spikes[0])
        y[spikes] = 0.5 * (y[spikes - 1] + y[spikes + 1])
        notes.append(
            f"{spikes.size} drop-out spike{'s' if spikes.size > 1 else ''} in the output (single samples far "
            f"from both neighbours, the first at sample {first + k0}, t = {(first + k0) * dt:.4g} s from "
            "the start): replaced by the mean of the neighbours"
        )
    return u, y, notes


__all__ = [
    "clean_output", "driven_stops", "dropout_spikes", "held_start", "refuse_pulsed", "stale_start",
]  # fmt: skip
