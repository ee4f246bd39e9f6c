"""The rigid drive: one mass, an input gain and the effects the doctor names.

Model (SI units; ``F`` is the force unit of ``g u``, N m for a rotary drive, N for a
linear one, or the input's unit when the gain is not known; ``v`` the velocity unit)::

    J dω/dt = F_in(u) - Σ_t θ_t T_t(ω)                                      [F]
    F_in(u) = B(g · L(Δ(D(S(u)))))                                           (input path)

========================= ============================================= ==============================
effect                    term T (or input map)                         parameters [unit]
========================= ============================================= ==============================
``viscous_friction``      B ω                                           viscous [F s/v]
``coulomb_friction``      F_c sgn(ω)                                    coulomb [F]
``stribeck_friction``     F_s decay(ω) sgn(ω), decay = exp(-|ω|/v_s)    stribeck [F], stribeck_velocity [v]
                          or exp(-(ω/v_s)²) (``stribeck_shape``)
``asymmetric_friction``   ΔF_c |sgn ω| + ΔF_v |ω|                       coulomb_asymmetry [F],
                                                                        viscous_asymmetry [F s/v]
``quadratic_drag``        c ω |ω|                                       quadratic_drag [F s²/v²]
``offset``                T_0 (also at rest)                            offset [F]
``input_dead_zone``       D(u) = 0 for |u| <= d, u - d sgn(u) beyond    dead_zone [u]
``input_saturation``      S(u) = clip(u, -u_s, u_s)                     saturation [u]
``backlash``              B(F) = 0 for τ_b after each reversal of F     backlash_time [s]
``input_delay``           Δ(x)(t) = x(t - τ_d), whole and fractional    input_delay [s]
                          samples (transport delay, driver latency)
``input_lag``             L: T_l dz/dt = x - z, first-order lag          lag_time_constant [s]
                          (driver bandwidth, current loop)
``static_friction``       breakaway at rest ΔF_s above the kinetic       breakaway_excess [F]
                          level at 0± (Karnopp rule only: a moving
                          drive slows against the kinetic level, so it
                          breaks away high and keeps moving down low)
``cogging``               A_s sin(p θ) + A_c cos(p θ), periodic in the   cogging_sin [F], cogging_cos [F],
                          position θ = ∫ω dt (also at rest): amplitude   cogging_periods [1/(v s)]
                          sqrt(A_s² + A_c²), phase atan2(A_c, A_s)
========================= ============================================= ==============================

An effect whose torque depends on the position (:attr:`Effect.position
<motorid.drive.effects.base.Effect.position>`, cogging) gives it as the compiled position
ripple (:meth:`Effect.ripple <motorid.drive.effects.base.Effect.ripple>`,
:func:`~motorid.drive.kernels.ripple_torque`), so a drive with one integrates the position
(:meth:`RigidDrive.motion`; :meth:`RigidDrive.free_run` from ``q0``); a drive holds at most one.
The cogging ripple's ``cogging_periods`` p is per radian of a rotary drive, so the count of
ripple periods per revolution, or per metre of a linear one (2π over the ripple's pitch).

Each effect is one class of :mod:`motorid.drive.effects` (its parameters with their units,
physical signs and compiled terms); the drive knows them through that package's registry, so
an effect registered there (or by a plugin) is an effect of the drive and of its model files.

The delay and the lag act on the held input as one map (``rigid_input_dynamics``): each
sample holds the mean over it of the delayed, then lagged signal, exact for a held input. The memory of the input path (the delay's last inputs, the lag's state,
the dwell's clock) is an explicit :class:`~motorid.drive.input_path.InputPathState`, so :meth:`RigidDrive.simulation`
steps the same record a sample at a time. A first-order lag of the measured speed (a speed filter) acts like the input
lag on a drive's linear part; the model carries the input lag only.

Every term is evaluated by the compiled functions of
:mod:`~motorid.drive.kernels` (``rigid_term``, ``stribeck_decay``,
``stick_or_slip``, ``rigid_motion``: speed and position; the input path by ``armature_voltages``, the
amplifier's own dead zone and saturation at unit gain), the same ones the doctor's fit
(:mod:`motorid.diagnose`) builds its regressor columns from.

When a rigid drive fits a measurement, and when a two-mass rig is needed: a rigid drive
describes what one measured speed sees when the coupling between motor and load is
stiff, i.e. its resonance (for the paper's rig sqrt(k_s (1/J_m + 1/J_L)) / 2π) lies
well above the band the record excites and the electrical time constant L_a/R_a is
short beside a sample; then the back-EMF and the bearings act as one viscous term and
the motor and load frictions add up. It needs no motor current or constants, so it is
what a velocity (or position) record and an input identify. Use
:class:`~motorid.drive.two_mass.TwoMassRig` when the shaft mode or the backlash gap shows in
the record (oscillation or impacts after reversals), when motor and load speeds are
both measured, or when the armature current or voltage matters.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from motorid.drive import kernels
from motorid.drive.effects import registry
from motorid.drive.effects.registry import effect_order, parameter_names
from motorid.drive.files import KIND_RIGID, register_kind, save_model
from motorid.drive.input_path import InputPathState, backlash_dwell, input_dynamics, input_path
from motorid.drive.ranges import MOST_DELAY_SAMPLES, SAMPLE_TIME, check_parameter
from motorid.errors import ModelFileError
from motorid.json_input import build, key_path, number, object_keys, text


def check_sample_time(dt: object) -> float:
    """``dt`` [s] as a float; ValueError unless it is a real number (not a bool) in
    :data:`~motorid.drive.ranges.SAMPLE_TIME`, [1e-9, 3600] s."""
    if (
        isinstance(dt, bool)
        or not isinstance(dt, int | float | np.number)
        or not math.isfinite(dt)
        or dt <= 0
    ):
        raise ValueError(f"dt must be a finite number > 0 [s], got {dt!r}")
    low, high = SAMPLE_TIME
    if not low <= dt <= high:
        raise ValueError(f"dt must be within [{low:g}, {high:g}] s (the sample time of a drive), got {dt!r}")
    return float(dt)


def check_input(name: str, values: npt.ArrayLike) -> np.ndarray:
    """1-D float array; ValueError naming the first non-finite sample."""
    arr = np.asarray(values, dtype=float)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {arr.shape}")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{name} must be finite: {name}[{k}] = {arr[k]!r} at sample {k}")
    return np.ascontiguousarray(arr)


def linear_term(name: str) -> int:
    """The compiled term code of the linear parameter ``name``; ValueError for a shape parameter.

    Parameters
    ----------
    name : str
        A parameter of some effect.
    """
    term = registry.parameter(name).term
    if term is None:
        raise ValueError(f"{name} does not enter the balance linearly (it has no compiled term)")
    return term


def term_columns(
    params: tuple[str, ...], omega: np.ndarray, stribeck_velocity: float = 1.0, shape: str = "exponential"
) -> np.ndarray:
    """Torque per unit parameter of the linear ``params`` at each speed, shape (N, len(params)),
    for a drive moving in the direction sgn(ω) (:func:`~motorid.drive.kernels.rigid_columns`).

    Parameters
    ----------
    params : tuple of str
        Linear parameters of any effects (each with a compiled term,
        :attr:`Parameter.term <motorid.drive.effects.base.Parameter.term>`).
    omega : numpy.ndarray, shape (N,)
        Speeds ω [v].
    stribeck_velocity : float
        v_s [v] of a Stribeck term.
    shape : {"exponential", "gaussian"}
        Shape of the Stribeck decay.
    """
    terms = np.array([linear_term(p) for p in params], dtype=np.int64)
    w = np.ascontiguousarray(np.asarray(omega, dtype=float))
    return kernels.rigid_columns(terms, w, 1.0 / stribeck_velocity, kernels.STRIBECK_SHAPES.index(shape))


@dataclass(frozen=True)
class RigidDrive:
    """A rigid drive: inertia, input gain and a set of effects with their parameters.

    Same family as :class:`~motorid.drive.two_mass.TwoMassRig`: an immutable description,
    :meth:`simulate` runs a record, :meth:`simulation` a running simulation stepped a sample at
    a time (the same record to the last bit; both noise free, a rigid drive has no sensor),
    :meth:`to_dict`/:meth:`from_dict` and :meth:`save`
    (a model file of kind ``rigid-drive``, read by :func:`motorid.load_model`). See the
    module notes for the model and for when it fits a measurement.

    Parameters
    ----------
    effects : tuple of str
        Effect names (:func:`motorid.drive.effects.names`); kept in the library's order.
    params : dict
        ``inertia`` [F s/v = kg m² or kg], ``input_gain`` [F/u] and every parameter of
        each effect (the module table), all finite. A fitted model may hold
        non-physical values (a negative level); :meth:`check_physical` refuses them, as
        the model files do, and a free run with ``inertia <= 0`` is NaN.
    dt : float
        Sample time [s], > 0: the input is held over each sample.
    stribeck_shape : {"exponential", "gaussian"}
        Shape of the Stribeck decay, exp(-|ω|/v_s) or exp(-(ω/v_s)²).
    """

    effects: tuple[str, ...]
    params: dict[str, float]
    dt: float
    stribeck_shape: str = "exponential"

    def __post_init__(self) -> None:
        if isinstance(self.effects, str):
            raise ValueError(f"effects must be a sequence of effect names, got {self.effects!r}")
        effects = effect_order(tuple(self.effects))
        for name in effects:
            reason = registry.get(name).not_on_a_rigid_drive
            if reason:
                raise ValueError(f"{name}: a rigid drive cannot hold it ({reason})")
        object.__setattr__(self, "effects", effects)
        if not isinstance(self.params, dict):
            raise ValueError(f"params must be a dict of parameter values, got {type(self.params).__name__}")
        expected = list(parameter_names(effects))
        missing = [p for p in expected if p not in self.params]
        if missing:
            raise ValueError(f"params: {missing[0]!r} is missing (the model holds {', '.join(expected)})")
        unknown = [p for p in self.params if p not in expected]
        if unknown:
            raise ValueError(
                f"params: {unknown[0]!r} belongs to no effect of the model (it holds {', '.join(expected)})"
            )
        params = {}
        for name in expected:
            value = self.params[name]
            if isinstance(value, bool) or not isinstance(value, int | float | np.number):
                raise ValueError(f"{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
            params[name] = float(value)
        object.__setattr__(self, "params", params)
        object.__setattr__(self, "dt", check_sample_time(self.dt))
        delay = params.get("input_delay", 0.0)
        if delay > MOST_DELAY_SAMPLES * self.dt:  # the delay line holds delay/dt inputs
            raise ValueError(
                f"input_delay must be at most {MOST_DELAY_SAMPLES} samples ({MOST_DELAY_SAMPLES * self.dt:g} s "
                f"at dt = {self.dt:g} s), got {delay!r} s"
            )
        if len(self.position_effects) > 1:
            raise ValueError(
                f"effects: at most one effect whose torque depends on the position, got "
                f"{', '.join(self.position_effects)}"
            )
        if self.stribeck_shape not in kernels.STRIBECK_SHAPES:
            raise ValueError(
                f"stribeck_shape must be one of {', '.join(kernels.STRIBECK_SHAPES)}, got {self.stribeck_shape!r}"
            )

    # ------------------------------------------------------------------ parts
    @property
    def inertia(self) -> float:
        """J [F s/v]."""
        return self.params["inertia"]

    @property
    def input_gain(self) -> float:
        """g [F/u]."""
        return self.params["input_gain"]

    def check_physical(self) -> RigidDrive:
        """This drive if it is physical (positive inertia, gain, Stribeck velocity, saturation;
        non-negative levels, dead zone, dwell; every parameter in the physical range of
        :mod:`~motorid.drive.ranges`); ValueError naming the parameter otherwise."""
        for name, value in self.params.items():
            check_parameter(name, value, "(SI units)", sign=registry.parameter(name).sign)
        return self

    def replace(self, **changes: Any) -> RigidDrive:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def with_params(self, **changes: float) -> RigidDrive:
        """A copy with some parameter values changed."""
        return dataclasses.replace(self, params={**self.params, **changes})

    def with_effects(self, effects: tuple[str, ...], params: dict[str, float]) -> RigidDrive:
        """A copy holding ``effects`` with ``params`` (same dt and Stribeck shape)."""
        return dataclasses.replace(self, effects=tuple(effects), params=dict(params))

    def without(self, *effects: str) -> RigidDrive:
        """A copy without ``effects`` and their parameters; this drive itself when it has none.

        Parameters
        ----------
        *effects : str
            Effect names (:func:`motorid.drive.effects.names`).
        """
        gone = [e for e in effects if e in self.effects]
        if not gone:
            return self
        dropped = {p.name for e in gone for p in registry.get(e).parameters}
        params = {k: v for k, v in self.params.items() if k not in dropped}
        return self.with_effects(tuple(e for e in self.effects if e not in gone), params)

    @property
    def position_effects(self) -> tuple[str, ...]:
        """The drive's effects whose torque depends on the position (cogging)."""
        return tuple(e for e in self.effects if registry.get(e).position)

    def _ripple(self) -> tuple:
        """The compiled position torque's arguments (:meth:`Effect.ripple
        <motorid.drive.effects.base.Effect.ripple>`): its position effect's, else none."""
        for e in self.position_effects:
            return registry.get(e).ripple(self.params)
        return 0.0, 0.0, 0.0, False, kernels.NO_HARMONICS, kernels.NO_HARMONICS

    def input_signal(self, u: npt.ArrayLike, state: InputPathState | None = None) -> np.ndarray:
        """``L(Δ(D(S(u))))`` [u]: the input after saturation, dead zone, delay and lag, before
        the gain; ``state`` as in :meth:`input_force` (the friction filters' input)."""
        p = self.params
        x = input_path(u, p.get("dead_zone", 0.0), p.get("saturation", math.inf))
        if "input_delay" in self.effects or "input_lag" in self.effects:
            if state is None:
                state = self.input_state()
            x = input_dynamics(x, self.dt, p.get("input_delay", 0.0), p.get("lag_time_constant", 0.0), state)
        return x

    def input_force(self, u: npt.ArrayLike, state: InputPathState | None = None) -> np.ndarray:
        """Force reaching the drive, F_in(u) = B(g :meth:`input_signal`) [F], for the input [u]
        held over each sample.

        ``state`` is the memory of the input path (delay, lag, backlash dwell), updated in
        place, so consecutive calls continue one record (what :meth:`simulation` does a sample
        at a time); None starts a record at rest on its first input.
        """
        if state is None:
            state = self.input_state()
        force = self.params["input_gain"] * self.input_signal(u, state)
        if "backlash" in self.effects:
            force = backlash_dwell(force, self.dt, self.params["backlash_time"], state)
        return force

    def input_state(self) -> InputPathState:
        """The input path's memory before the first input (see :meth:`input_force`)."""
        return InputPathState.fresh(self.dt, self.params.get("input_delay", 0.0))

    def linear_terms(self) -> list[tuple[str, int]]:
        """Each parameter of the drive that enters the balance linearly, with the code of its
        compiled term (:attr:`Parameter.term <motorid.drive.effects.base.Parameter.term>`), in
        the order of the drive's effects."""
        return [(name, term) for e in self.effects for name, term in registry.get(e).terms.items()]

    def friction(self, omega: npt.ArrayLike, position: npt.ArrayLike | None = None) -> np.ndarray:
        """Σ_t θ_t T_t(ω) [F] at speeds ``omega`` [v] for a drive moving in the direction sgn(ω),
        with the position ripple at ``position`` [v s] of a drive that has one (cogging).

        Parameters
        ----------
        omega : array_like
            Speeds [v].
        position : array_like, optional
            Positions [v s: rad or m], of the shape of ``omega``; needed by a drive with a
            position effect (ValueError without), ignored by one without.
        """
        names = tuple(name for name, _ in self.linear_terms())
        w = np.asarray(omega, dtype=float)
        if names:
            cols = term_columns(names, w, self.params.get("stribeck_velocity", 1.0), self.stribeck_shape)
            total = cols @ np.array([self.params[n] for n in names])
            del cols  # a record's columns go before the ripple is computed
        else:
            total = np.zeros_like(w)
        if self.position_effects:
            if position is None:
                raise ValueError(
                    f"position is needed for the {self.position_effects[0]} ripple of this drive"
                )
            q = np.asarray(position, dtype=float)
            if q.shape != w.shape:
                raise ValueError(f"position must have the shape of omega {w.shape}, got {q.shape}")
            torque = self.position_torque(q)
            total = total + (np.sign(w) * torque if self._ripple()[3] else torque)
        return total

    def position_torque(self, position: npt.ArrayLike) -> np.ndarray | float:
        """The position torque Σ_k A_s,k sin(k p θ) + A_c,k cos(k p θ) [F] at ``position`` θ [v s]
        (:func:`~motorid.drive.kernels.position_torque`) of the drive's position effect, for a
        position friction its level F(θ) (the torque against the motion); 0.0 for a drive without
        one.

        Parameters
        ----------
        position : array_like
            Positions [v s: rad or m].
        """
        if not self.position_effects:
            return 0.0
        q = np.asarray(position, dtype=float)
        flat = np.ascontiguousarray(q.ravel())
        a_s, a_c, p, _, h_s, h_c = self._ripple()
        return kernels.position_torques(flat, a_s, a_c, p, h_s, h_c).reshape(q.shape)

    def free_run(
        self,
        u: npt.ArrayLike,
        w0: float = 0.0,
        substeps: int | None = None,
        start: int = 0,
        q0: float = 0.0,
        position: npt.ArrayLike | None = None,
    ) -> np.ndarray:
        """Free-run velocity [v] at the end of each sample for the input ``u`` [u] held over it.

        Parameters
        ----------
        u : array_like, shape (N,)
            Input [u], zero-order hold.
        w0 : float
            Velocity at the start [v].
        substeps : int, optional
            Steps per sample; default enough for 20 steps per mechanical time
            constant J/B (1 to 50).
        start : int
            Start the free run at sample ``start`` (with ``w0``); the input path
            (the backlash dwell) still sees the whole input. The result has
            ``N - start`` samples.
        q0 : float
            Position at the start [v s: rad or m]; only a position ripple (cogging) depends on it.
        position : array_like, shape (N,), optional
            A record's position [v s] at the end of each sample: a position ripple that is no
            level against the motion (cogging, not a position friction) is taken there, its torque
            at the mean of each sample's two ends held over the sample like the input, rather than
            at the free run's own position. That position integrates every error of the speed, and
            over many periods of the ripple drifts out of its phase: a ripple out of phase adds
            twice its amplitude to the gap where it should take it away.
        """
        force = np.ascontiguousarray(self.input_force(u)[start:], dtype=float)
        if position is not None and self.position_effects and not self._ripple()[3]:
            q = np.asarray(position, dtype=float)
            if q.shape != np.shape(u):
                raise ValueError(f"position has shape {q.shape}, the input {np.shape(u)}")
            ends = q[start - 1 :] if start > 0 else np.concatenate(([q0], q))
            mid = 0.5 * (ends[:-1] + ends[1:])
            bare = self.without(*self.position_effects)
            force = np.ascontiguousarray(force - self.position_torque(mid), dtype=float)
            return bare._free_run_force(bare._free_run_setup(substeps), force, float(w0))
        return self._free_run_force(self._free_run_setup(substeps), force, float(w0), float(q0))

    def motion(
        self,
        u: npt.ArrayLike,
        w0: float = 0.0,
        q0: float = 0.0,
        substeps: int | None = None,
        start: int = 0,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Free-run velocity [v] and position [v s: rad or m] at the end of each sample for the
        input ``u`` [u] held over it, from velocity ``w0`` and position ``q0``.

        The position is integrated inside the compiled free run, over its internal steps
        (:func:`~motorid.drive.kernels.rigid_motion`); the velocity is :meth:`free_run`'s to the
        last bit. Parameters as in :meth:`free_run`.

        Returns
        -------
        velocity, position : numpy.ndarray
            Each of shape (N - start,); NaN without a positive inertia.
        """
        force = np.ascontiguousarray(self.input_force(u)[start:], dtype=float)
        return self._motion_force(self._free_run_setup(substeps), force, float(w0), float(q0))

    def _free_run_setup(self, substeps: int | None) -> tuple:
        """The arguments of :func:`~motorid.drive.kernels.rigid_motion` other than the force and
        the start speed and position: ``(dt, substeps, J, coef, rate, shape, breakaway_excess,
        ripple)``, ``ripple`` = the compiled position torque's arguments (:meth:`_ripple`) of a drive with a
        position ripple, ``()`` without (the kernels' defaults: nothing passed, nothing evaluated)."""
        J = self.inertia
        coef = np.zeros(kernels.N_TERMS)
        for name, term in self.linear_terms():
            coef[term] += self.params[name]  # effects from outside the package may share a term
        if substeps is None:
            substeps = int(min(50, max(1, math.ceil(20.0 * self.dt * abs(coef[kernels.TERM_VISCOUS]) / J))))
        vs = self.params.get("stribeck_velocity", 1.0)
        rate = 1.0 / vs if vs > 0.0 else 1.0
        shape = kernels.STRIBECK_SHAPES.index(self.stribeck_shape)
        excess = self.params.get("breakaway_excess", 0.0)
        ripple = self._ripple() if self.position_effects else ()
        return self.dt, int(substeps), J, coef, rate, shape, excess, ripple

    @staticmethod
    def _free_run_force(setup: tuple, force: np.ndarray, w0: float, q0: float = 0.0) -> np.ndarray:
        """The free run from ``w0`` [v] and ``q0`` [v s] for the input force ``force`` [F] (NaN
        without a positive inertia)."""
        dt, substeps, J, coef, rate, shape, excess, ripple = setup
        if not J > 0.0:
            return np.full(force.size, np.nan)  # no free run without a positive inertia
        if ripple:  # the speed depends on the position only through a ripple
            return kernels.rigid_motion(force, dt, substeps, J, coef, rate, shape, w0, q0, excess, *ripple)[0]
        return kernels.rigid_free_run(force, dt, substeps, J, coef, rate, shape, w0, excess)

    @staticmethod
    def _motion_force(setup: tuple, force: np.ndarray, w0: float, q0: float) -> tuple[np.ndarray, np.ndarray]:
        """Speed and position from ``w0`` [v] and ``q0`` [v s] for the input force ``force`` [F]
        (NaN without a positive inertia)."""
        dt, substeps, J, coef, rate, shape, excess, ripple = setup
        if not J > 0.0:
            nan = np.full(force.size, np.nan)
            return nan, nan.copy()
        return kernels.rigid_motion(force, dt, substeps, J, coef, rate, shape, w0, q0, excess, *ripple)

    def simulation(self, seed: int | None = None) -> RigidSimulation:
        """A running simulation of this drive at rest (``reset``, ``step``), the
        :class:`~motorid.io.base.Plant` a simulated DAQ or the rig server steps."""
        return RigidSimulation(self, seed)

    # -------------------------------------------------------------- records
    def simulate(self, u: npt.ArrayLike, w0: float = 0.0, q0: float = 0.0) -> pd.DataFrame:
        """A record of the drive from speed ``w0`` [v] and position ``q0`` for the input ``u`` [u]
        held over each sample.

        Returns
        -------
        pandas.DataFrame
            Columns ``t`` [s] (start of each sample), ``u``, ``y`` (the velocity at the end of
            the sample, noise free) and ``position`` (at the end of the sample, :meth:`motion`);
            ``attrs``: ``dt``, ``units``, ``timing`` (``"hold"``) and ``model`` (:meth:`to_dict`).
        """
        arr = check_input("u", u)
        y, position = self.motion(arr, w0=w0, q0=q0)
        df = pd.DataFrame({"t": np.arange(arr.size) * self.dt, "u": arr, "y": y, "position": position})
        df.attrs["dt"] = self.dt
        df.attrs["units"] = {"t": "s", "u": "V", "y": "rad/s", "position": "rad"}
        df.attrs["timing"] = "hold"
        df.attrs["model"] = self.to_dict()
        return df

    # ---------------------------------------------------------- description
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (inverse: :meth:`from_dict`)."""
        return {
            "effects": list(self.effects),
            "params": dict(self.params),
            "dt": self.dt,
            "stribeck_shape": self.stribeck_shape,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "") -> RigidDrive:
        """Rebuild a physical drive from :meth:`to_dict` output, every key checked.

        Parameters
        ----------
        data : dict
            :meth:`to_dict` output: ``effects``, ``params`` (SI units), ``dt`` [s] and
            ``stribeck_shape``.
        where : str
            Where ``data`` sits in its file (``"model"``), put in front of the key an
            error names.

        Raises
        ------
        motorid.errors.ModelFileError
            A DataError naming the key, e.g. ``params.inertia: inertia must be > 0``.
        """
        object_keys(data, ("effects", "params", "dt", "stribeck_shape"), where)
        effects = registry.effect_names_read(data["effects"], key_path(where, "effects"))
        p_where = key_path(where, "params")
        names = list(parameter_names(tuple(dict.fromkeys(effects))))
        params = object_keys(data["params"], names, p_where)
        values = {n: number(params[n], key_path(p_where, n)) for n in names}
        dt = number(data["dt"], key_path(where, "dt"))
        shape = text(data["stribeck_shape"], key_path(where, "stribeck_shape"))
        drive = build(cls, {"effects": tuple(effects), "params": values, "dt": dt,
                            "stribeck_shape": shape}, where)  # fmt: skip
        try:
            return drive.check_physical()
        except ValueError as exc:
            name = str(exc).split(" ", 1)[0]
            raise ModelFileError(key_path(p_where, name), str(exc)) from None

    def save(self, path: str | Path, *, overwrite: bool = True) -> None:
        """Write the drive as a model file; :func:`motorid.load_model` reads it.

        Written whole; ``overwrite=False`` refuses an existing file
        (:func:`motorid.drive.files.write_model_file`).

        Parameters
        ----------
        path : str or Path
            The file to write.
        overwrite : bool
            False refuses an existing file.

        Raises
        ------
        ValueError
            For a drive that is not physical (:meth:`check_physical`).
        """
        save_model(self, path, overwrite=overwrite)


def physical_description(drive: RigidDrive) -> dict[str, Any]:
    """The model file's description of ``drive`` (:meth:`RigidDrive.to_dict`), for a physical drive only.

    Parameters
    ----------
    drive : RigidDrive
        The drive to save.

    Raises
    ------
    ValueError
        For a drive that is not physical (:meth:`RigidDrive.check_physical`).
    """
    return drive.check_physical().to_dict()


register_kind(KIND_RIGID, RigidDrive, RigidDrive.from_dict, physical_description)


class RigidSimulation:
    """A running simulation of a :class:`RigidDrive`: the input path's memory and the speed.

    The drive is the description; this object is what changes as samples are applied.
    Its steps are :meth:`RigidDrive.simulate` a sample at a time, to the last bit: each
    step passes one input through :meth:`RigidDrive.input_force` with the running
    :class:`InputPathState` and continues the compiled free run from the last speed, the
    same functions a whole record runs. A rigid drive has no sensor, so the speed is
    noise free and the seed changes nothing (it is taken for the ``Plant`` protocol).

    Parameters
    ----------
    drive : RigidDrive
        The drive simulated (read only).
    seed : int or None
        Ignored: the record is noise free.

    Attributes
    ----------
    drive : RigidDrive
    sample_index : int
        Samples applied since the last :meth:`reset`.
    """

    def __init__(self, drive: RigidDrive, seed: int | None = None) -> None:
        self.drive = drive
        self._setup = drive._free_run_setup(None)
        self._position = bool(drive.position_effects)  # the position is carried where the speed needs it
        self.reset(seed)

    @property
    def dt(self) -> float:
        """Sample time [s] (the drive's)."""
        return self.drive.dt

    def reset(self, seed: int | None = None) -> None:
        """Return to rest (speed 0, the input path before its first input); ``seed`` is ignored."""
        self._input = self.drive.input_state()
        self._w = 0.0
        self._q = 0.0
        self.sample_index = 0

    def step(self, u: float) -> float:
        """Apply ``u`` [u] for one sample (zero-order hold); return the speed [v] at its end."""
        u = float(u)
        if not math.isfinite(u):
            raise ValueError(f"u must be finite, got {u!r} at sample {self.sample_index}")
        force = self.drive.input_force(np.array([u]), self._input)
        if self._position:
            speed, position = self.drive._motion_force(self._setup, force, self._w, self._q)
            self._w, self._q = float(speed[0]), float(position[0])
        else:
            self._w = float(self.drive._free_run_force(self._setup, force, self._w)[0])
        self.sample_index += 1
        return self._w

    def run(self, u: npt.ArrayLike) -> np.ndarray:
        """Apply the inputs ``u`` [u] one sample each (zero-order hold); the speed [v] at the end of
        each sample. :meth:`step` over a block, in one compiled call: consecutive blocks continue
        one record, and give :meth:`RigidDrive.free_run` of the whole input to the last bit.

        Parameters
        ----------
        u : array_like, shape (N,)
            The next inputs [u] (finite).
        """
        arr = check_input("u", u)
        force = np.ascontiguousarray(self.drive.input_force(arr, self._input), dtype=float)
        if self._position:
            speed, position = self.drive._motion_force(self._setup, force, self._w, self._q)
            if speed.size:
                self._q = float(position[-1])
        else:
            speed = self.drive._free_run_force(self._setup, force, self._w)
        if speed.size:
            self._w = float(speed[-1])
        self.sample_index += speed.size
        return speed

    @property
    def state(self) -> dict[str, float]:
        """``t`` [s] and the speed ``omega`` [v] after the last :meth:`step`, and for a drive with a
        position ripple (cogging), whose speed depends on it, the ``position`` [v s]."""
        state = {"t": self.sample_index * self.drive.dt, "omega": self._w}
        if self._position:
            state["position"] = self._q
        return state


__all__ = ["RigidDrive", "RigidSimulation", "linear_term", "term_columns"]
