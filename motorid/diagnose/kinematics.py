"""Zero-phase kinematics and parallel decimation for inverse-dynamics fits.

A record gives the input u [V] and either a velocity or a position. The torque
balance of the rigid drive needs velocity w and acceleration a at the same
instants as the force, with as little noise as the useful band allows. The
recipe (Gautier's inverse dynamic identification model, the one the EMPS
benchmark publishes its reference model with):

1. low-pass the measured signal with a 4th-order Butterworth filter run forwards
   and backwards (zero phase), cut-off ``f_c = 2.5 f_b``;
2. differentiate by central differences::

       w[k] = (q[k+1] - q[k-1]) / (2 dt)            (position records)
       a[k] = (q[k+1] - 2 q[k] + q[k-1]) / dt²
       a[k] = (w[k+1] - w[k-1]) / (2 dt)            (velocity records)

3. build every column of the regression (force, acceleration, friction
   signatures) at full rate and decimate each one the same way (parallel
   decimation: an 8th-order Chebyshev low-pass at ``0.8 f_s / (2 n_d)``, zero
   phase, then every ``n_d``-th sample), with ``n_d = floor(0.4 f_s / f_b)``
   so the band kept is ``f_b``;
4. drop the edge samples where the filters have not settled.

The default band is ``f_b = min(40 Hz, f_s / 10)``: for EMPS (1 kHz) this is
the published recipe (100 Hz cut-off, decimation by 10).

A velocity record's balance is not written on the filtered speed's central differences but on
each sample's own ends (:attr:`Kinematics.balance_w`, :attr:`Kinematics.balance_a`): the
input is held over a sample, and over it the balance of a drive with viscous friction is solved
exactly (:func:`motorid.diagnose.model.discrete_inertia`), so it holds at sample times near the
drive's time constant, where a derivative of the filtered speed does not (at dt = 0.8 J/B the
central differences' inertia is 10 % high, and the free run of that model four noise floors off).
Every column of the balance is then filtered and decimated alike (step 3), which keeps it.

A measured speed's noise is noise in the acceleration, a regressor of the balance, and least
squares pulls a noisy regressor's coefficient towards zero (errors in variables): a slow sine's
inertia comes out low. The noise of a speed record is measured above the band (the white part of
:attr:`Kinematics.hf`), and what the recipe makes of white noise is known
(:func:`acceleration_noise_gain`), so the noise variance of the decimated acceleration is known
(:func:`acceleration_noise`) and the fit can take it out (:mod:`motorid.diagnose.model`).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from motorid.iir import butterworth, chebyshev1, zero_phase

OutputKind = Literal["velocity", "position"]


#: The velocity's low-pass cuts off at this many times the useful band f_b.
CUTOFF_PER_BAND = 2.5


def default_band(dt: float) -> float:
    """Default useful band f_b [Hz] for a sample time ``dt`` [s]: min(40, f_s/10).

    Parameters
    ----------
    dt : float
        Sample time [s].
    """
    return min(40.0, 0.1 / dt)


def lowpass(x: np.ndarray, dt: float, cutoff: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` (:func:`motorid.iir.butterworth` run forwards and
    backwards, :func:`motorid.iir.zero_phase`).

    Parameters
    ----------
    x : ndarray, shape (N,)
        Signal sampled every ``dt`` [s].
    dt : float
        Sample time [s].
    cutoff : float
        -3 dB frequency of one pass [Hz]; clipped below the Nyquist frequency.
    order : int
        Filter order of one pass (the forward-backward pair doubles it).
    """
    nyquist = 0.5 / dt
    wn = min(cutoff / nyquist, 0.95)
    return zero_phase(butterworth(order, wn), x)


def decimation_factor(dt: float, band: float) -> int:
    """``n_d = max(1, floor(0.4 f_s / f_b))``: keeps the band ``f_b`` [Hz] below 0.8 of the new Nyquist.

    Parameters
    ----------
    dt : float
        Sample time [s] (f_s = 1/dt).
    band : float
        The useful band f_b [Hz].
    """
    return max(1, math.floor(0.4 / (dt * band) + 0.01))


def anti_alias(x: np.ndarray, factor: int) -> np.ndarray:
    """Zero-phase anti-alias filter of the decimation by ``factor`` at full rate (a copy of ``x``
    for ``factor`` 1): the filter of ``scipy.signal.decimate``'s "iir", an 8th-order Chebyshev
    type I low-pass with 0.05 dB ripple up to 0.8 / ``factor`` of the Nyquist frequency
    (:func:`motorid.iir.chebyshev1`), run forwards and backwards (:func:`motorid.iir.zero_phase`).

    Parameters
    ----------
    x : ndarray
        A signal at full rate.
    factor : int
        The decimation factor n_d >= 1.
    """
    if factor <= 1:
        return np.array(x, dtype=float)
    return zero_phase(chebyshev1(8, 0.05, 0.8 / factor), x)


@dataclass(frozen=True)
class Kinematics:
    """Filtered velocity and acceleration of a record, at full rate.

    Attributes
    ----------
    dt : float
        Sample time [s].
    u : ndarray
        Raw input [input units, e.g. V].
    w : ndarray
        Zero-phase low-passed velocity [rad/s or m/s].
    a : ndarray
        Acceleration [rad/s² or m/s²] by central differences.
    valid : ndarray of bool
        Samples away from the edges where the filters have settled.
    band : float
        Useful band f_b [Hz]; the Butterworth cut-off is 2.5 f_b.
    factor : int
        Decimation factor n_d.
    noise : float
        Estimated standard deviation of the noise on ``w`` [rad/s or m/s]
        (:func:`filtered_noise` over the settled samples).
    output_kind : {"velocity", "position"}
    hf : ndarray
        The high-frequency part of the measured velocity the noise is estimated from
        (:func:`noise_bands`).
    q : ndarray
        Position [rad or m] at the instants of ``w``: the low-passed measured position of a
        position record, else the trapezoidal integral of ``w`` from 0 at the first sample (the
        position an effect whose torque depends on it, cogging, is a function of; its origin is
        then arbitrary).
    balance_w, balance_a : ndarray
        The speed [v] and acceleration [v/s] the torque balance is written on (see
        :mod:`motorid.diagnose.model`). A velocity record's measured speed ``y[k]`` ends sample
        ``k``, over which the input ``u[k]`` is held, so sample k's balance is written on that
        sample's own ends: ``balance_w[k] = (y[k-1] + y[k]) / 2`` and ``balance_a[k] = (y[k] -
        y[k-1]) / dt`` (unfiltered: the balance's columns are all filtered alike when they are
        decimated); for the first sample, the second's acceleration and its own speed. A
        position record's: :attr:`w` and :attr:`a`.
    """

    dt: float
    u: np.ndarray
    w: np.ndarray
    a: np.ndarray
    valid: np.ndarray
    band: float
    factor: int
    noise: float
    output_kind: str
    hf: np.ndarray
    q: np.ndarray
    balance_w: np.ndarray
    balance_a: np.ndarray

    @property
    def n(self) -> int:
        return int(self.u.size)

    @property
    def filter_period(self) -> int:
        """One period of the zero-phase filter's cut-off ``CUTOFF_PER_BAND * band`` [samples], at least
        1: about how far the filter spreads a change of the speed, and how long its noise stays."""
        return max(1, math.ceil(1.0 / (CUTOFF_PER_BAND * self.band * self.dt)))

    @functools.cached_property
    def decimated_index(self) -> np.ndarray:
        """Full-rate indices of the decimated samples that lie in the settled span."""
        idx = np.arange(0, self.n, self.factor)
        # the anti-alias filter of the decimation needs a few output samples to settle too
        margin = 4
        keep = self.valid[idx]
        first = np.flatnonzero(keep)
        if first.size == 0:
            return idx[:0]
        lo, hi = first[0] + margin, first[-1] - margin
        keep[: max(lo, 0)] = False
        keep[hi + 1 :] = False
        return idx[keep]

    def decimate(self, x: np.ndarray) -> np.ndarray:
        """Parallel decimation of a full-rate column, at :attr:`decimated_index`."""
        return anti_alias(x, self.factor)[self.decimated_index]


def kinematics(
    u: np.ndarray,
    y: np.ndarray,
    dt: float,
    output_kind: OutputKind = "velocity",
    band: float | None = None,
) -> Kinematics:
    """Zero-phase velocity and acceleration of a record (see the module recipe).

    Parameters
    ----------
    u : ndarray, shape (N,)
        Input [V].
    y : ndarray, shape (N,)
        Measured velocity [rad/s or m/s] or position [rad or m].
    dt : float
        Sample time [s], > 0.
    output_kind : {"velocity", "position"}
    band : float, optional
        Useful band f_b [Hz]; default :func:`default_band`.

    Returns
    -------
    Kinematics
    """
    band = default_band(dt) if band is None else float(band)
    cutoff = CUTOFF_PER_BAND * band
    y = np.asarray(y, dtype=float)
    n = y.size
    if output_kind == "position":
        q = lowpass(y, dt, cutoff)
        w = np.gradient(q, dt)
        a = np.empty_like(q)
        a[1:-1] = (q[2:] - 2.0 * q[1:-1] + q[:-2]) / dt**2
        a[0], a[-1] = a[1], a[-2]
        w_meas = np.gradient(lowpass(y, dt, min(0.45 / dt, 5.0 * cutoff)), dt)
        balance_w, balance_a = w, a
    elif output_kind == "velocity":
        w = lowpass(y, dt, cutoff)
        a = np.gradient(w, dt)
        w_meas = y
        q = np.concatenate([[0.0], np.cumsum(0.5 * dt * (w[1:] + w[:-1]))])
        balance_w, balance_a = y.copy(), np.zeros(n)
        if n > 1:
            balance_w[1:] = 0.5 * (y[1:] + y[:-1])
            balance_a[1:] = np.diff(y) / dt
            balance_a[0] = balance_a[1]
    else:
        raise ValueError(f"output_kind must be 'velocity' or 'position', got {output_kind!r}")
    edge = math.ceil(5.0 / (cutoff * dt)) + 2
    valid = np.zeros(n, dtype=bool)
    valid[edge : n - edge] = True
    # noise on the filtered velocity: what the filter leaves of the white part of w_meas
    hf = w_meas - lowpass(w_meas, dt, min(0.45 / dt, 4.0 * cutoff))
    keep = slice(edge, n - edge) if n > 2 * edge else slice(None)
    return Kinematics(
        dt=float(dt), u=np.asarray(u, dtype=float), w=w, a=a, valid=valid,
        band=band, factor=decimation_factor(dt, band), noise=filtered_noise(hf[keep], cutoff, dt),
        output_kind=output_kind, hf=hf, q=q, balance_w=balance_w, balance_a=balance_a,
    )  # fmt: skip


def filtered_noise(hf: np.ndarray, cutoff: float, dt: float) -> float:
    """Standard deviation [v] of the noise left on the velocity low-passed at ``cutoff`` [Hz]
    (sample time ``dt`` [s]), from ``hf``, the part of the measured velocity above ``4 cutoff``:
    σ = std(hf) / sqrt(max(1 - min(8 f_c dt, 0.9), 0.1)) (hf misses the noise below 4 f_c), and
    what the low-pass leaves of white noise of that σ: σ sqrt(min(1, 2 f_c dt)).

    Parameters
    ----------
    hf : numpy.ndarray
        The measured velocity's part above ``4 cutoff`` [v].
    cutoff : float
        The low-pass's cut-off f_c [Hz].
    dt : float
        Sample time [s].
    """
    sigma = float(np.std(hf)) * math.sqrt(max(1.0 - min(8.0 * cutoff * dt, 0.9), 0.1)) ** -1
    return sigma * noise_left(cutoff, dt)


def noise_left(cutoff: float, dt: float) -> float:
    """Share of white noise's standard deviation the velocity's low-pass at ``cutoff`` [Hz] leaves
    (sample time ``dt`` [s]): ``sqrt(min(1, 2 f_c dt))``, its share of the band up to Nyquist."""
    return math.sqrt(min(1.0, 2.0 * cutoff * dt))


def white_noise_variance(kin: Kinematics, samples: np.ndarray) -> float:
    """Per-sample variance σ² [v²] of the white noise on the measured velocity of a velocity record
    ``kin`` at the full-rate ``samples`` (bool), from its high-frequency part (:attr:`Kinematics.hf`,
    the velocity less its low-pass at ``f_h = min(0.45 / dt, 10 f_b)``)::

        σ² = mean(hf²) / Σ_k g[k]²

    ``g`` the impulse response of that high-pass (1 minus the zero-phase Butterworth low-pass at
    ``f_h``): the share of white noise's variance it keeps. 0 with no sample.

    Parameters
    ----------
    kin : Kinematics
        A record's kinematics.
    samples : ndarray of bool, shape (N,)
        The samples the noise is measured on (an encoder's grows with speed).
    """
    hf = kin.hf[samples]
    if hf.size == 0:
        return 0.0
    return float(np.mean(hf**2)) / _high_pass_gain(kin.dt, kin.band)


@functools.cache
def _high_pass_gain(dt: float, band: float) -> float:
    """``Σ_k g[k]²`` of :func:`white_noise_variance`'s high-pass (sample time ``dt`` [s], band [Hz])."""
    cutoff = min(0.45 / dt, 4.0 * CUTOFF_PER_BAND * band)
    n = 2 * (math.ceil(40.0 / (cutoff * dt)) + 40) + 1
    impulse = np.zeros(n)
    impulse[n // 2] = 1.0
    return float(np.sum((impulse - lowpass(impulse, dt, cutoff)) ** 2))


@functools.cache
def acceleration_noise_gain(dt: float, band: float) -> float:
    """Variance of the decimated acceleration per unit variance of white noise on a measured
    velocity [1/s²]: ``G = Σ_k h[k]²``, ``h`` the impulse response of the balance's acceleration
    (:attr:`Kinematics.balance_a`: the difference over each sample, then the decimation's
    anti-alias filter).

    Parameters
    ----------
    dt : float
        Sample time [s].
    band : float
        Useful band f_b [Hz].
    """
    factor = decimation_factor(dt, band)
    n = 2 * 40 * factor + 1
    impulse = np.zeros(n)
    impulse[n // 2] = 1.0
    h = anti_alias(np.diff(impulse, prepend=0.0) / dt, factor)
    return float(np.sum(h**2))


def acceleration_noise(kin: Kinematics, samples: np.ndarray) -> float:
    """Variance [v²/s²] of the noise on the decimated acceleration of a velocity record, the
    measured velocity's noise white of variance σ² at the full-rate ``samples``::

        var(a_noise) = σ² G(dt, f_b)

    (:func:`white_noise_variance`, :func:`acceleration_noise_gain`). 0 for a position record: its
    noise is on the position, which this does not describe.

    Parameters
    ----------
    kin : Kinematics
        A record's kinematics.
    samples : ndarray of bool, shape (N,)
        The samples the noise is measured on.
    """
    if kin.output_kind != "velocity":
        return 0.0
    return white_noise_variance(kin, samples) * acceleration_noise_gain(kin.dt, kin.band)


@dataclass(frozen=True)
class NoiseBand:
    """The noise floor of one speed band.

    Attributes
    ----------
    speed_from, speed_to : float
        The band's edges of |velocity| [v].
    samples : int
        Settled samples in it.
    noise_floor : float
        Its noise floor [v] (NaN for a band of fewer than 10 samples).
    """

    speed_from: float
    speed_to: float
    samples: int
    noise_floor: float

    def to_dict(self) -> dict[str, float]:
        return {"speed_from": self.speed_from, "speed_to": self.speed_to, "samples": self.samples,
                "noise_floor": self.noise_floor}  # fmt: skip


def noise_bands(
    speed: np.ndarray, hf: np.ndarray, edges: np.ndarray, band: float, dt: float
) -> list[NoiseBand]:
    """The noise floor per speed band ``edges[i] <= speed < edges[i+1]`` [v] (the top band holds
    its upper edge), :func:`filtered_noise` of the ``hf`` of the samples in it (velocity filtered
    for the useful ``band`` [Hz]): an encoder's speed noise grows with speed, so one record-wide
    figure is too high near rest and too low at speed (a :class:`NoiseBand` each).

    Parameters
    ----------
    speed : numpy.ndarray
        |velocity| at each sample [v].
    hf : numpy.ndarray
        The velocity's high-frequency part at each sample [v] (:attr:`Kinematics.hf`).
    edges : numpy.ndarray
        The band edges [v], increasing.
    band : float
        The record's useful band [Hz]: the noise is taken as left by a low-pass at 2.5 times it.
    dt : float
        Sample time [s].
    """
    out = []
    for k, (lo, hi) in enumerate(itertools.pairwise(edges)):
        last = k == len(edges) - 2
        inside = (speed >= lo) & ((speed <= hi) if last else (speed < hi))
        count = int(inside.sum())
        floor = filtered_noise(hf[inside], CUTOFF_PER_BAND * band, dt) if count >= 10 else math.nan
        out.append(NoiseBand(float(lo), float(hi), count, floor))
    return out


def quantisation_step(y: np.ndarray) -> float | None:
    """The step of a quantised output (an encoder's count per sample) [its unit], or None when
    it does not show. A first guess is the median of the smallest nonzero changes between samples
    (those below 1.5 times the smallest, which rounding in a file spreads); it is refined by least
    squares ``q = Σ y n / Σ n²`` over the counts ``n = round(y / q)``, first of the samples within
    50 steps of zero, then of all. It shows when at least 99 % of the samples lie within 5 % of
    a step of a multiple of it.

    Parameters
    ----------
    y : ndarray
        The record's output.
    """
    steps = np.abs(np.diff(y))
    steps = steps[steps > 0.0]
    if steps.size == 0:
        return None
    q = float(np.median(steps[steps < 1.5 * np.min(steps)]))
    for near in (np.abs(y) <= 50.0 * q, np.ones(y.size, dtype=bool)):
        counts = np.round(y[near] / q)
        if not np.any(counts):
            return None
        q = float(np.dot(y[near], counts) / np.dot(counts, counts))
    offset = np.abs(y / q - np.round(y / q))
    return q if float(np.mean(offset < 0.05)) >= 0.99 else None


__all__ = [
    "Kinematics",
    "NoiseBand",
    "acceleration_noise",
    "acceleration_noise_gain",
    "anti_alias",
    "decimation_factor",
    "default_band",
    "filtered_noise",
    "kinematics",
    "lowpass",
    "noise_bands",
    "quantisation_step",
    "white_noise_variance",
]
