"""Second-order sections run over a signal, compiled (numba): the loop of the doctor's zero-phase
filters (:func:`motorid.diagnose.kinematics.zero_phase`), in a module of its own so the doctor
can run it ahead-of-time compiled (:mod:`motorid.compiled`) without importing numba."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def run_sections(sos: np.ndarray, state: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """Run ``x`` through the cascade of second-order sections ``sos`` (transposed direct form
    II, state ``state`` updated in place) into ``out``, from ``x[0]`` to ``x[-1]``::

        y_s[k] = b0 x_s[k] + z0,  z0 = b1 x_s[k] - a1 y_s[k] + z1,  z1 = b2 x_s[k] - a2 y_s[k]
    """
    for k in range(x.size):
        value = x[k]
        for s in range(sos.shape[0]):
            new = sos[s, 0] * value + state[s, 0]
            state[s, 0] = sos[s, 1] * value - sos[s, 4] * new + state[s, 1]
            state[s, 1] = sos[s, 2] * value - sos[s, 5] * new
            value = new
        out[k] = value


@numba.njit(cache=True)
def zero_phase_run(sos: np.ndarray, zi: np.ndarray, x: np.ndarray, edge: int) -> np.ndarray:
    """``x`` extended by ``edge`` samples of its odd reflection at each end, run forwards through
    the sections from the steady state ``zi x_ext[0]``, backwards from ``zi y[-1]``, and cut back
    to ``x``'s samples (the recipe of :func:`motorid.diagnose.kinematics.zero_phase`)."""
    n = x.size
    ext = np.empty(n + 2 * edge)
    for i in range(edge):  # odd extension: 2 x[0] - x[edge - i], ..., 2 x[-1] - x[-2 - i]
        ext[i] = 2.0 * x[0] - x[edge - i]
        ext[n + edge + i] = 2.0 * x[n - 1] - x[n - 2 - i]
    ext[edge : n + edge] = x
    forward = np.empty_like(ext)
    run_sections(sos, zi * ext[0], ext, forward)
    backward = np.empty_like(ext)
    run_sections(sos, zi * forward[-1], forward[::-1], backward)
    return backward[::-1][edge : n + edge].copy()
