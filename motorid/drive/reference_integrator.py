"""Reference integrator of the two-mass drive: scipy ``solve_ivp`` with events.

The same model as the fast path (:mod:`.physics`), written directly as
ordinary differential equations in plain Python and integrated with an
adaptive Runge-Kutta method at tight tolerances. The friction laws and the
stick/slip rule are the fast path's own compiled functions (each written once);
what this integrator checks independently is the integration: exact event times
instead of events resolved to one internal step. Every switch of the hybrid
model ends an integration segment at an event located by root finding:

- a slipping mass with static friction reaching zero speed (``s ω = 0``,
  s its direction of motion): its speed is set to exactly 0 and the stick test
  decides whether it sticks or reverses;
- a stuck mass whose net torque reaches a breakaway torque
  (``T_net = T_break+`` or ``-T_net = T_break-``): it starts to slip;
- the shaft twist entering or leaving the backlash gap (``|δ| = b``);
- the sample boundaries, where the zero-order-hold input changes.

The motor's cogging ripple (a torque periodic in θ_m = θ_L + δ) is a smooth term of the motor's
equation, evaluated by the fast path's compiled law.

While a mass is stuck its speed equation is replaced by dω/dt = 0, so it stays
at exactly 0. ``max_step`` is bounded (default 1 ms) so that no sign change of
an event function is stepped over. It is slow (pure Python right-hand side):
use it to check the fast integrator, not for long records.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from motorid.drive.friction import pack_lugre, pack_rows
from motorid.drive.kernels import lugre_zdot, ripple_torque, static_friction, stick_or_slip

logger = logging.getLogger(__name__)

STUCK = "stuck"
#: Speed margin [rad/s] of the zero-speed event right after a breakaway.
_BREAKAWAY_MARGIN = 1e-9


class ReferenceIntegrator:
    """Event-driven ``solve_ivp`` integration of a :class:`~motorid.drive.two_mass.TwoMassRig`.

    Parameters
    ----------
    rig : TwoMassRig
        The rig to integrate (its amplifier, its masses' friction, shaft, backlash).
    rtol, atol : float
        Tolerances handed to ``solve_ivp``.
    max_step : float
        Largest step [s], > 0; bounds the time in which an event could be missed.
    method : str
        ``solve_ivp`` method; ``"RK45"`` by default, ``"Radau"`` or ``"LSODA"``
        for stiff LuGre parameters.
    """

    def __init__(
        self,
        rig: Any,
        rtol: float = 1e-10,
        atol: float = 1e-12,
        max_step: float = 1e-3,
        method: str = "RK45",
    ) -> None:
        for name, value in (("rtol", rtol), ("atol", atol), ("max_step", max_step)):
            if not math.isfinite(value) or value <= 0.0:
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        self.rig = rig
        self.rtol = rtol
        self.atol = atol
        self.max_step = max_step
        self.method = method
        self._static_rows = pack_rows(rig.friction)
        self._lugre = pack_lugre(rig.friction)
        self._viscous = (rig.viscous("motor"), rig.viscous("load"))
        self._J = (rig.J_m, rig.J_l)
        self._break = (rig.breakaway("motor"), rig.breakaway("load"))
        self._has_static = tuple(bp > 0.0 or bn > 0.0 for bp, bn in self._break)

    # ----------------------------------------------------------- model pieces
    def _static_torque(self, k: int, omega: float, direction: float) -> float:
        """The friction terms on mass k: the compiled law the fast path uses, on the same rows."""
        return static_friction(self._static_rows, k, omega, float(direction))

    def _lugre_parts(self, k: int, z: float, omega: float) -> tuple[float, float]:
        """(σ0 z + σ1 dz/dt, dz/dt) of the compiled row of mass k (the fast path's); the mass's
        viscous friction is counted with the viscous terms."""
        lug = self._lugre
        if not lug[k, 0]:
            return 0.0, 0.0
        zdot = lugre_zdot(lug, k, z, omega)
        return lug[k, 1] * z + lug[k, 2] * zdot, zdot

    def _cogging(self, x: np.ndarray) -> float:
        """The motor's cogging ripple at θ_m = θ_L + δ [N m] (the fast path's compiled law)."""
        rig = self.rig
        return ripple_torque(x[4] + x[3], rig.cogging_sin, rig.cogging_cos, rig.cogging_periods)

    def _shaft_torque(self, x: np.ndarray, regime: int) -> float:
        if regime == 0:
            return 0.0
        rig = self.rig
        return rig.k_s * (x[3] - rig.backlash * regime) + rig.B_s * (x[1] - x[2])

    def _net_torque(self, k: int, x: np.ndarray, regime: int, t_d: float) -> float:
        """Torque on mass k at zero speed, its friction terms excluded [N m]."""
        t_s = self._shaft_torque(x, regime)
        f_lug = self._lugre_parts(k, x[5 + k], x[1 + k])[0]
        if k == 0:
            return self.rig.K_m * x[0] - t_s - f_lug - self._cogging(x)
        return t_s - t_d - f_lug

    def _rhs_factory(
        self, modes: list[Any], regime: int, v: float, t_d: float
    ) -> Callable[[float, np.ndarray], list[float]]:
        rig = self.rig
        R, L, K = rig.R_a, rig.L_a, rig.K_m

        def rhs(t: float, x: np.ndarray) -> list[float]:
            t_s = self._shaft_torque(x, regime)
            acc = [0.0, 0.0]
            zdot = [0.0, 0.0]
            drive = (K * x[0] - t_s - self._cogging(x), t_s - t_d)
            for k in (0, 1):
                w = x[1 + k]
                f_lug, zdot[k] = self._lugre_parts(k, x[5 + k], w)
                if modes[k] == STUCK:
                    continue
                f_static = self._static_torque(k, w, modes[k]) if modes[k] else 0.0
                acc[k] = (drive[k] - self._viscous[k] * w - f_static - f_lug) / self._J[k]
            return [
                (v - R * x[0] - K * x[1]) / L,
                acc[0],
                acc[1],
                x[1] - x[2],
                x[2],
                zdot[0],
                zdot[1],
            ]

        return rhs

    def _events(
        self, modes: list[Any], regime: int, t_d: float, fresh: list[bool]
    ) -> tuple[list[Any], list[Any]]:
        events: list[Any] = []
        tags: list[Any] = []

        def add(fun: Callable[[float, np.ndarray], float], direction: float, tag: Any) -> None:
            fun.terminal = True  # type: ignore[attr-defined]
            fun.direction = direction  # type: ignore[attr-defined]
            events.append(fun)
            tags.append(tag)

        for k in (0, 1):
            if not self._has_static[k]:
                continue
            if modes[k] == STUCK:
                bp, bn = self._break[k]
                add(
                    lambda t, x, k=k, bp=bp: self._net_torque(k, x, regime, t_d) - bp,
                    1.0,
                    ("break", k, 1),
                )
                add(
                    lambda t, x, k=k, bn=bn: -self._net_torque(k, x, regime, t_d) - bn,
                    1.0,
                    ("break", k, -1),
                )
            else:
                s = modes[k]
                # just after breakaway T_net sits on the band edge to root-finding
                # accuracy; a tiny margin keeps that rounding from reading as a stop
                eps = _BREAKAWAY_MARGIN if fresh[k] else 0.0
                add(lambda t, x, k=k, s=s, e=eps: s * x[1 + k] + e, -1.0, ("stop", k))
        b = self.rig.backlash
        if b > 0.0:
            if regime == 0:
                add(lambda t, x: x[3] - b, 1.0, ("regime", 1))
                add(lambda t, x: -x[3] - b, 1.0, ("regime", -1))
            elif regime == 1:
                add(lambda t, x: x[3] - b, -1.0, ("regime", 0))
            else:
                add(lambda t, x: x[3] + b, 1.0, ("regime", 0))
        return events, tags

    def _settle_modes(self, modes: list[Any], x: np.ndarray, regime: int, t_d: float) -> None:
        """Stick test for every mass with static friction at exactly zero speed."""
        for k in (0, 1):
            if not self._has_static[k]:
                modes[k] = 0
                continue
            if modes[k] != STUCK and x[1 + k] != 0.0:
                modes[k] = 1 if x[1 + k] > 0.0 else -1
                continue
            if modes[k] == STUCK or x[1 + k] == 0.0:
                bp, bn = self._break[k]
                stuck, direction = stick_or_slip(0.0, self._net_torque(k, x, regime, t_d), bp, bn)
                if stuck:
                    modes[k] = STUCK
                    x[1 + k] = 0.0
                else:
                    modes[k] = 1 if direction > 0.0 else -1

    # -------------------------------------------------------------------- run
    def run(self, u: np.ndarray, t_d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Integrate from rest over the samples of ``u`` [V] and ``t_d`` [N m].

        Returns
        -------
        v_a : ndarray, shape (N,)
            Armature voltage per sample [V].
        states : ndarray, shape (N, 7)
            ``[i_a, ω_m, ω_L, δ, θ_L, z_m, z_L]`` at the end of each sample.
        """
        rig = self.rig
        dt = rig.dt
        v_a = rig.amplifier(np.asarray(u, dtype=float))
        n = v_a.size
        states = np.empty((n, 7))
        x = np.zeros(7)
        modes: list[Any] = [0, 0]
        b = rig.backlash
        regime = 0 if b > 0.0 else 1
        n_events = 0
        fresh = [False, False]
        for k in range(n):
            t = k * dt
            t_end = (k + 1) * dt
            v = float(v_a[k])
            td = float(t_d[k])
            self._settle_modes(modes, x, regime, td)
            stalls = 0
            while t < t_end:
                rhs = self._rhs_factory(modes, regime, v, td)
                events, tags = self._events(modes, regime, td, fresh)
                sol = solve_ivp(
                    rhs, (t, t_end), x, method=self.method, events=events or None,
                    rtol=self.rtol, atol=self.atol, max_step=self.max_step,
                )  # fmt: skip
                if sol.status == -1:
                    raise RuntimeError(f"solve_ivp failed at t = {t:.6g} s: {sol.message}")
                if sol.status == 1:
                    t_ev = float(sol.t[-1])
                    stalls = stalls + 1 if t_ev <= t else 0
                    if stalls > 20:
                        raise RuntimeError(f"stick/slip switching does not progress at t = {t:.6g} s")
                    x = np.array(sol.y[:, -1])
                    for j, tag in enumerate(tags):
                        if sol.t_events[j].size == 0:
                            continue
                        n_events += 1
                        if tag[0] == "stop":
                            x[1 + tag[1]] = 0.0
                            modes[tag[1]] = STUCK  # re-tested just below
                        elif tag[0] == "break":
                            modes[tag[1]] = tag[2]
                            x[1 + tag[1]] = 0.0
                        else:
                            regime = tag[1]
                    broke = [tag[1] for j, tag in enumerate(tags)
                             if tag[0] == "break" and sol.t_events[j].size]  # fmt: skip
                    self._settle_modes(modes, x, regime, td)
                    for kk in broke:  # at the breakaway root T_net sits on the band edge
                        if modes[kk] == STUCK:
                            modes[kk] = next(tag[2] for j, tag in enumerate(tags)
                                             if tag[:2] == ("break", kk) and sol.t_events[j].size)  # fmt: skip
                    fresh = [kk in broke for kk in (0, 1)]
                    t = t_ev
                else:
                    x = np.array(sol.y[:, -1])
                    fresh = [False, False]
                    t = t_end
            states[k] = x
        logger.debug("reference integrator: %d samples, %d events", n, n_events)
        return v_a, states
