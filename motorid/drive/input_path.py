"""The input path of a rigid drive, and its memory.

The path from the input ``u`` [u] to the force reaching the drive [F]::

    F_in(u) = B(g · L(Δ(D(S(u)))))

S the input saturation, D the input dead zone, Δ the transport delay, L the first-order
lag, g the input gain and B the backlash dwell (the ``input_saturation``,
``input_dead_zone``, ``input_delay``, ``input_lag`` and ``backlash`` effects of
:mod:`motorid.drive.effects`). Every map is a compiled function of
:mod:`~motorid.drive.kernels`; the memory of the path (the delay's last inputs, the lag's
state, the dwell's clock) is an explicit :class:`InputPathState`, so a record can be run a
sample at a time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from motorid.drive import kernels


def _kernel_array(x: npt.ArrayLike) -> np.ndarray:
    """``x`` as the one array type the kernels here are called with, C-ordered writable float64:
    a read-only array (the values of a pandas column) is copied, so that each kernel is loaded from
    numba's cache for one type, not two (3-8 ms of a fresh process's CPU time each)."""
    return np.require(x, dtype=float, requirements=("C", "W"))


def time_since_reversal(x: np.ndarray, dt: float, before_first: float | None = None) -> np.ndarray:
    """Time [s] since the last change of sign of ``x`` (zeros keep the previous sign).

    Before the first reversal the time counts from the start of the record, or
    is ``before_first`` when given (:func:`~motorid.drive.kernels.reversal_clock`).

    Parameters
    ----------
    x : numpy.ndarray, shape (N,)
        The signal whose reversals are counted (any unit).
    dt : float
        Sample time [s].
    before_first : float, optional
        The time [s] given to the samples before the first reversal.
    """
    arr = _kernel_array(x)
    first = math.nan if before_first is None else float(before_first)
    return kernels.reversal_clock(arr, float(dt), first, InputPathState.fresh_clock())


def input_path(u: npt.ArrayLike, dead_zone: float = 0.0, saturation: float = math.inf) -> np.ndarray:
    """``D(S(u))`` [u]: saturation at ±``saturation``, then the dead zone of half-width ``dead_zone``.

    The amplifier's compiled map at unit gain::

        S(u) = clip(u, -u_s, u_s),    D(x) = 0 for |x| <= d, x - d sgn(x) beyond

    Parameters
    ----------
    u : array_like, shape (N,)
        The input [u].
    dead_zone : float
        Half-width d of the dead zone [u] (0: none).
    saturation : float
        Saturation level u_s [u] (inf: none).
    """
    x = _kernel_array(u)
    return kernels.armature_voltages(x, 1.0, float(dead_zone), float(saturation))


def input_dynamics(
    x: npt.ArrayLike,
    dt: float,
    delay: float = 0.0,
    time_constant: float = 0.0,
    state: InputPathState | None = None,
) -> np.ndarray:
    """``L(Δ(x))``: the held signal ``x`` delayed by ``delay`` [s] (whole and fractional samples),
    then lagged (``T_l dz/dt = x - z``), as the mean over each sample; one map, exact for the held
    input (:func:`~motorid.drive.kernels.rigid_input_dynamics`).

    Parameters
    ----------
    x : array_like, shape (N,)
        The signal held over each sample [u].
    dt : float
        Sample time [s].
    delay : float
        Transport delay τ_d [s] (0: none).
    time_constant : float
        Lag time constant T_l [s] (0: none).
    state : InputPathState, optional
        The running state of the map (updated in place); None starts at rest on the first input.
    """
    arr = _kernel_array(x)
    if state is None:
        state = InputPathState.fresh(dt, delay)
    return kernels.rigid_input_dynamics(
        arr, float(dt), float(delay), float(time_constant), state.ring, state.lag
    )


def backlash_dwell(
    force: np.ndarray, dt: float, backlash_time: float, state: InputPathState | None = None
) -> np.ndarray:
    """``B(F)``: the force ``F`` is not transmitted for ``backlash_time`` [s] after each reversal
    of its sign (lost motion crossed by the driving side; before the first reversal it is);
    :func:`~motorid.drive.kernels.backlash_dwell`.

    Parameters
    ----------
    force : numpy.ndarray, shape (N,)
        The drive force [F].
    dt : float
        Sample time [s].
    backlash_time : float
        The dwell τ_b [s] after each reversal.
    state : InputPathState, optional
        The running state (updated in place); None starts before any reversal.
    """
    arr = _kernel_array(force)
    clock = InputPathState.fresh_clock() if state is None else state.clock
    return kernels.backlash_dwell(arr, float(dt), float(backlash_time), clock)


@dataclass
class InputPathState:
    """The memory of a rigid drive's input path, updated in place as inputs pass.

    Attributes
    ----------
    ring : numpy.ndarray
        The latest m + 2 inputs of the delay (m whole samples of delay).
    lag : numpy.ndarray
        ``[z, samples seen]``: the lag's state and the samples the delay has seen.
    clock : numpy.ndarray
        The backlash dwell's clock (:func:`~motorid.drive.kernels.reversal_clock`).
    """

    ring: np.ndarray
    lag: np.ndarray
    clock: np.ndarray

    @staticmethod
    def fresh_clock() -> np.ndarray:
        """A reversal clock before any input: no sign yet, no reversal."""
        return np.array([0.0, -1.0, 0.0])

    @classmethod
    def fresh(cls, dt: float, delay: float = 0.0) -> InputPathState:
        """The state before the first input of a path with ``delay`` [s] at sample time ``dt`` [s]."""
        m, _ = kernels.rigid_delay_samples(float(dt), float(delay))
        return cls(ring=np.zeros(m + 2), lag=np.zeros(2), clock=cls.fresh_clock())


__all__ = ["InputPathState", "backlash_dwell", "input_dynamics", "input_path", "time_since_reversal"]
