"""Digital low-pass IIR filters: Butterworth and Chebyshev type I design as second-order
sections, and their zero-phase (forward-backward) run.

The doctor filters every record some hundreds of times with a few fixed low-passes
(:mod:`motorid.diagnose.kinematics`). ``scipy.signal`` has these filters, but importing it
imports ``scipy.stats`` and ``scipy.interpolate`` with it (some 0.35 s of CPU time in a fresh
process), so the two designs and the run are written here, in the
form and with the edge handling of ``scipy.signal.butter(..., output="sos")`` and
``scipy.signal.sosfiltfilt``, which the tests hold them against.

Design (a low-pass of order N with cut-off ``wn``, a fraction of the Nyquist frequency, at
the sampling rate f_s = 2 of ``scipy.signal``):

1. the analog prototype's poles p_k (cut-off 1 rad/s), k = 1 .. N, with
   ``θ_k = π (2k - N - 1) / (2N)``::

       Butterworth:   p_k = -exp(j θ_k),                        gain 1
       Chebyshev I:   p_k = -sinh(μ + j θ_k),   ε = sqrt(10^(r/10) - 1),   μ = asinh(1/ε) / N,
                      gain Π(-p_k), divided by sqrt(1 + ε²) for an even N (r: pass-band ripple [dB])

2. the cut-off pre-warped, ``Ω = 4 tan(π wn / 2)``, and the prototype scaled to it:
   ``p_k <- Ω p_k``, ``k <- k Ω^N``;
3. the bilinear transform ``s = 4 (z - 1) / (z + 1)``: ``z_k = (4 + p_k) / (4 - p_k)``, the N
   zeros at infinity to ``z = -1``, the gain ``k / Π(4 - p_k)``;
4. one section per pair of conjugate poles, ``b = [1, 2, 1]``, ``a = [1, -2 Re z_k, |z_k|²]``, and
   for an odd N one first-order section ``b = [1, 1, 0]``, ``a = [1, -z_r, 0]``; the sections in
   the order of ``scipy.signal.zpk2sos``: the poles nearest the unit circle last, the gain in the
   first section's numerator. For an even N these are SciPy's sections, coefficient for
   coefficient; for an odd N SciPy pairs its zeros otherwise (the same transfer function).
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np


def butterworth(order: int, wn: float) -> np.ndarray:
    """Second-order sections of a digital Butterworth low-pass (module docstring).

    Parameters
    ----------
    order : int
        Filter order N >= 1.
    wn : float
        Cut-off (-3 dB) as a fraction of the Nyquist frequency, 0 < wn < 1.

    Returns
    -------
    ndarray, shape (ceil(N / 2), 6)
        ``[b0, b1, b2, 1, a1, a2]`` per section (read-only: the design is kept per argument).
    """
    return _design("butterworth", _checked_order(order), 0.0, _checked_cutoff(wn))


def chebyshev1(order: int, ripple: float, wn: float) -> np.ndarray:
    """Second-order sections of a digital Chebyshev type I low-pass (module docstring).

    Parameters
    ----------
    order : int
        Filter order N >= 1.
    ripple : float
        Peak-to-peak ripple r in the pass band [dB], > 0.
    wn : float
        Edge of the pass band (where the gain leaves the ripple band) as a fraction of the
        Nyquist frequency, 0 < wn < 1.

    Returns
    -------
    ndarray, shape (ceil(N / 2), 6)
        ``[b0, b1, b2, 1, a1, a2]`` per section (read-only).
    """
    if not (math.isfinite(ripple) and ripple > 0):
        raise ValueError(f"ripple must be a positive number of dB, got {ripple!r}")
    return _design("chebyshev1", _checked_order(order), float(ripple), _checked_cutoff(wn))


def _checked_order(order: int) -> int:
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 1:
        raise ValueError(f"order must be an integer >= 1, got {order!r}")
    return int(order)


def _checked_cutoff(wn: float) -> float:
    if not (math.isfinite(wn) and 0.0 < wn < 1.0):
        raise ValueError(
            f"wn must lie strictly between 0 and 1 (a fraction of the Nyquist frequency), got {wn!r}"
        )
    return float(wn)


@functools.cache
def _design(kind: str, order: int, ripple: float, wn: float) -> np.ndarray:
    """The sections of :func:`butterworth` (``ripple`` unused) or :func:`chebyshev1`."""
    m = np.arange(-order + 1, order, 2, dtype=float)  # θ_k = π m / (2N)
    if kind == "butterworth":
        # the complex product and quotient as SciPy writes them (numpy divides a complex number by
        # multiplying with the reciprocal: the real π m / (2N) can differ in the last bit)
        poles = -np.exp(1j * np.pi * m / (2 * order))
        gain = 1.0
    else:
        theta = np.pi * m / (2 * order)
        eps = np.sqrt(10.0 ** (0.1 * ripple) - 1.0)
        mu = 1.0 / order * np.arcsinh(1.0 / eps)
        poles = -np.sinh(mu + 1j * theta)
        gain = float(np.prod(-poles).real)
        if order % 2 == 0:
            gain /= float(np.sqrt(1.0 + eps * eps))
    # Ω, pre-warped for f_s = 2; numpy's tan, as SciPy's, not the C library's (they can differ in
    # the last bit, and so would the sections)
    warped = float(4.0 * np.tan(np.pi * np.asarray(wn) / 2.0))
    poles = warped * poles
    gain *= warped**order
    digital = (4.0 + poles) / (4.0 - poles)  # bilinear transform of each pole
    gain *= float((1.0 / np.prod(4.0 - poles)).real)  # and of the gain; the zeros go to z = -1
    # one section per conjugate pair (the pole above the real axis), one for the real pole of an
    # odd order (the prototype's middle pole, θ = 0: real to the last bit)
    sections = [(p, [1.0, 2.0, 1.0, 1.0, -2.0 * p.real, p.real * p.real + p.imag * p.imag])
                for p in digital[digital.imag > 0]]  # fmt: skip
    if order % 2:
        p = digital[order // 2]
        sections.append((p, [1.0, 1.0, 0.0, 1.0, -p.real, 0.0]))
    # the poles nearest the unit circle last, as scipy.signal.zpk2sos orders them
    sections.sort(key=lambda section: -abs(1.0 - abs(section[0])))
    sos = np.array([coefficients for _, coefficients in sections])
    sos[0, :3] *= gain
    sos.flags.writeable = False
    return sos


def zero_phase(sos: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Zero-phase filter: the second-order sections ``sos`` run forwards, then backwards over ``x``.

    As ``scipy.signal.sosfiltfilt`` runs them: ``x`` extended at each end by ``n_e = 3 (2 n_sections + 1)``
    samples of its odd reflection (``2 x_0 - x_{n_e..1}`` before, ``2 x_{N-1} - x_{N-2..N-1-n_e}``
    after), each pass started from the sections' steady state for a constant input equal to its
    first sample (``z_0 = z_ss x_0``, :func:`steady_state`), the extension cut off. Each section
    runs in transposed direct form II::

        y[n]  = b0 x[n] + z0[n-1]
        z0[n] = b1 x[n] - a1 y[n] + z1[n-1]
        z1[n] = b2 x[n] - a2 y[n]

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        Second-order sections ``[b0, b1, b2, 1, a1, a2]`` (:func:`butterworth`, :func:`chebyshev1`).
    x : ndarray, shape (N,)
        The signal.

    Returns
    -------
    ndarray, shape (N,)
        The filtered signal.

    Raises
    ------
    ValueError
        When ``sos`` is not of that shape or a section's ``a0`` is not 1, when ``x`` is not
        one-dimensional, or when ``x`` has no more samples than the extension.
    """
    sos = np.array(sos, dtype=float)  # a writable C-ordered copy: one compiled signature
    if sos.ndim != 2 or sos.shape[1] != 6 or sos.shape[0] == 0:
        raise ValueError(f"sos must have shape (n_sections, 6), got {sos.shape}")
    if not np.all(sos[:, 3] == 1.0):
        raise ValueError(f"every section's a0 (sos[:, 3]) must be 1, got {sos[:, 3].tolist()}")
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"x must be one-dimensional, got shape {x.shape}")
    edge = 3 * (2 * sos.shape[0] + 1)
    if x.size <= edge:
        raise ValueError(f"the signal has {x.size} samples; the zero-phase filter needs more than {edge}")
    extended = np.concatenate((2 * x[:1] - x[edge:0:-1], x, 2 * x[-1:] - x[-2 : -(edge + 2) : -1]))
    steady = _steady_state(sos.tobytes(), sos.shape[0])
    _sections_pass(sos, steady * extended[0], extended, False)  # from z_0 = z_ss x_0
    _sections_pass(sos, steady * extended[-1], extended, True)  # from the forward pass's last output
    return extended[edge:-edge]


def steady_state(sos: np.ndarray) -> np.ndarray:
    """The state of each section of ``sos`` for a unit constant input (``scipy.signal.sosfilt_zi``).

    Section s, ``a0 = 1``, alone in its steady state solves ``(I - A^T) z = b[1:] - a[1:] b0``
    (A the companion matrix of ``a``)::

        [1 + a1  -1] [z0]   [b1 - a1 b0]
        [  a2     1] [z1] = [b2 - a2 b0]       (closed form: z0 = H - b0, z1 = b2 - a2 H)

    with ``H = Σb / Σa`` the section's DC gain, and is scaled by the DC gain of the sections
    before it, ``g_s = Π_{j<s} H_j``. Solved as SciPy solves it (``numpy.linalg.solve``), so the
    zero-phase run starts from SciPy's state to the last bit.

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6)
        Second-order sections ``[b0, b1, b2, 1, a1, a2]``.

    Returns
    -------
    ndarray, shape (n_sections, 2)
        ``[z0, z1]`` of each section (read-only: kept per filter).
    """
    sos = np.array(sos, dtype=float)
    return _steady_state(sos.tobytes(), sos.shape[0])


@functools.cache
def _steady_state(sections: bytes, count: int) -> np.ndarray:
    """:func:`steady_state` of the ``count`` sections whose float64 bytes are ``sections``."""
    sos = np.frombuffer(sections, dtype=float).reshape(count, 6)
    state = np.empty((count, 2))
    scale = 1.0
    for s, (b0, b1, b2, _, a1, a2) in enumerate(sos):
        system = np.eye(2) - np.array([[-a1, -a2], [1.0, 0.0]]).T  # I - A^T
        state[s] = scale * np.linalg.solve(system, np.array([b1 - a1 * b0, b2 - a2 * b0]))
        scale *= np.sum(sos[s, :3]) / np.sum(sos[s, 3:])  # g_{s+1} = g_s H_s
    state.flags.writeable = False
    return state


@numba.njit(cache=True)
def _sections_pass(sos: np.ndarray, z: np.ndarray, x: np.ndarray, backward: bool) -> None:
    """One pass of :func:`zero_phase` over ``x``, in place, from the sections' state ``z`` (updated
    in place): every sample through every section in transposed direct form II, from the first
    sample to the last, or from the last to the first when ``backward``."""
    first, stop, step = (x.size - 1, -1, -1) if backward else (0, x.size, 1)
    for n in range(first, stop, step):
        value = x[n]
        for s in range(sos.shape[0]):
            out = sos[s, 0] * value + z[s, 0]  # y = b0 x + z0
            z[s, 0] = sos[s, 1] * value - sos[s, 4] * out + z[s, 1]  # z0 = b1 x - a1 y + z1
            z[s, 1] = sos[s, 2] * value - sos[s, 5] * out  # z1 = b2 x - a2 y
            value = out
        x[n] = value


__all__ = ["butterworth", "chebyshev1", "steady_state", "zero_phase"]
