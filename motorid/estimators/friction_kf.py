"""Joint estimation of the drive's state and its friction: an extended and an unscented
Kalman filter on the physical two-mass model, behind the one estimator interface.

The model, its state, the treatment of zero speed and of the armature current are
described in :mod:`motorid.estimators.friction_model`. Both filters use that one
model; per sample k, with the command u[k] held over the sample (the rig's timing)::

    predict:  v = amplifier(u)                          armature voltage [V] (a rigid
                                                        drive: its input path, with the
                                                        delay and lag's memory)
              x_prior = f_d(x, v)                       sub-stepped model, one sample
              P_prior = F P F^T + Q                     EKF: F = d f_d / d x (analytic)
                                                        UKF: unscented transform of f_d
              y_hat   = ω_L(x_prior)                    predicted tacho reading [rad/s]
    update:   S = H P_prior H^T + R,   K = P_prior H^T / S,   y = z - y_hat
              x = x_prior + K y,   then friction parameters projected onto >= 0
              P = (I - K H) P_prior (I - K H)^T + K R K^T      (EKF, Joseph form)
              P = P_prior - K S K^T                             (UKF, filterpy)
              P mirrored to exact symmetry; NIS = y^2 / S.

H picks ω_L: the rig's output ``y`` is the tachogenerator on the load read through
the A/D converter and scaled back to rad/s, so R is the tacho noise plus the
quantisation, ``(σ_t/G_t)^2 + (q/G_t)^2/12``. A measured armature current can be
given to ``update`` as well (EKF: a second, sequential scalar update; UKF: one
joint update), with ``i_a = (v - K_m ω_m)/R_a`` when the current is quasi-static.

Consistency. With a correct model the normalised innovation squared
``NIS = y^2/S`` is χ²(1): inside its two-sided 95 % band [0.00098, 5.02] on 95 % of
samples. ``nis`` holds the last value and ``nis_mean`` its mean over the last
``nis_window`` updates; a mean above ``divergence_nis`` marks the filter as
diverged (``diverged``) and, by ``on_divergence``, warns once naming the sample
(``"warn"``, the default), raises :class:`FilterDivergenceError` naming the sample
(``"raise"``: stop a run that no longer means anything) or only sets the flag
(``"ignore"``). The default warns rather than raises because a registered
estimator must run to the end on any record (the conformance suite feeds it data
from another system) and a user may want to see how far a wrong model goes. A
covariance that stops being positive definite or a non-finite estimate always
raises it.
"""

from __future__ import annotations

import copy
import inspect
import math
import warnings
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike

from motorid.drive import effects, kernels
from motorid.drive.input_path import InputPathState
from motorid.drive.kernels import armature_voltage, armature_voltages
from motorid.drive.ranges import LARGEST, MOST_SUBSTEPS, check_count, check_parameter
from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import TwoMassRig, paper_rig
from motorid.errors import FilterDivergenceError
from motorid.estimators import friction_model as fm
from motorid.estimators.base import BatchResult, Estimator, as_float_vector, check_covariance, first_bad_index
from motorid.estimators.rls import check_positive
from motorid.json_input import boolean, integer, key_path, number, object_keys, text
from motorid.outputs import jsonable

OnDivergence = Literal["raise", "warn", "ignore"]

#: Longest NIS window [updates]: a consistency test over seconds to minutes of samples, whose
#: ring (8 bytes an update) a model file sizes.
MOST_NIS_WINDOW = 100_000

#: Units of the entries of ``params``.
PARAM_UNITS: dict[str, str] = {
    "coulomb": "N m",
    "coulomb_std": "N m",
    "viscous": "N m s/rad",
    "viscous_std": "N m s/rad",
    "coulomb_neg": "N m",
    "coulomb_neg_std": "N m",
    "stribeck": "N m",
    "stribeck_std": "N m",
}


# --------------------------------------------------------------------------- filters
def tacho_variance(rig: TwoMassRig) -> float:
    """Variance [(rad/s)^2] of the rig's speed reading: tacho noise plus A/D quantisation.

    Parameters
    ----------
    rig : TwoMassRig
        The rig whose tacho and A/D converter read the speed.
    """
    g = rig.tacho.gain
    return (rig.tacho.noise_std / g) ** 2 + (rig.adc.lsb / g) ** 2 / 12.0


#: The parts of a rigid drive's input-path memory (its delay and lag) in a filter's state
#: (``input_ring``, ``input_lag``; the filters hold no backlash, so no dwell clock).
INPUT_STATE_KEYS = ("ring", "lag")


def check_rigid_drive(drive: RigidDrive) -> None:
    """ValueError naming an effect of ``drive`` the filters' model does not hold.

    Parameters
    ----------
    drive : RigidDrive
        The drive a filter is to model.
    """
    for name in drive.effects:
        if not effects.get(name).in_filter:
            raise ValueError(
                f"rig: the rigid drive's {name} is not in the friction filters' model "
                f"(it holds {', '.join(filter_effects())})"
            )
        for param in effects.get(name).filter_zero:
            if drive.params[param] != 0.0:
                raise ValueError(
                    f"rig: the rigid drive's {param} is not in the friction filters' model "
                    f"(it must be 0, got {drive.params[param]!r})"
                )


def filter_effects() -> tuple[str, ...]:
    """The effects of a rigid drive the filters' model holds, as estimated states or known parts
    (:attr:`Effect.in_filter <motorid.drive.effects.base.Effect.in_filter>`); the others are
    refused by name."""
    return tuple(name for name in effects.names() if effects.get(name).in_filter)


def friction_prior(model: TwoMassRig | RigidDrive, stribeck: bool = True) -> dict[str, Any]:
    """The friction a drive model describes, as the filters' prior: constructor arguments
    ``coulomb0``, ``coulomb_neg0``, ``viscous0``, ``asymmetric``, ``stribeck``,
    ``stribeck0``, ``stribeck_decay`` and ``stribeck_shape``.

    A rigid drive's Coulomb level F_c and asymmetry ΔF_c give the forward and backward
    levels F_c ± ΔF_c, its Stribeck level, velocity v_s and shape the excess, the rate
    1/v_s and the shape; its viscous term is B. A two-mass rig's friction on both masses
    is summed the same way (the filter estimates the total, on one mass), with B_m + B_L and
    a LuGre law by its steady state (the Coulomb and Stribeck levels of its mass). With
    ``stribeck=False`` the Stribeck terms are left out (a filter without them).

    Parameters
    ----------
    model : TwoMassRig or RigidDrive
        The drive model.
    stribeck : bool
        Whether the filter estimates a Stribeck term.

    Raises
    ------
    ValueError
        When the friction does not fit the filters' one Stribeck term (excesses with
        different rates or shapes, or a different excess each way), or a rigid drive
        holds an effect the filters do not model.
    """
    if isinstance(model, RigidDrive):
        check_rigid_drive(model)
        viscous = 0.0
        sources = [(model.effects, model.params, model.stribeck_shape, 1)]
    else:  # each mass's friction, LuGre's by its steady state (its levels)
        viscous = model.B_m + model.B_l
        sources = [
            (tuple(e for e in f.effects if e != "lugre_friction"), f.params, f.stribeck_shape, len(f.sides()))
            for f in model.friction
        ]
        for names, params, _, _ in sources:
            for name in names:
                if not effects.get(name).filter_states or any(
                    params[p] for p in effects.get(name).filter_zero
                ):
                    raise ValueError(
                        f"rig: a mass's {name} is not in the friction filters' model "
                        "(on a two-mass rig it holds coulomb_friction, stribeck_friction, the Coulomb "
                        "asymmetry of asymmetric_friction, viscous_friction and lugre_friction's levels)"
                    )
    forward = backward = 0.0
    parts = []
    for names, params, shape, n in sources:  # each effect's share (Effect.filter_prior)
        for name in names:
            share = effects.get(name).filter_prior(params, shape)
            forward += n * share.get("coulomb0", 0.0)
            backward += n * share.get("coulomb_neg0", 0.0)
            viscous += n * share.get("viscous0", 0.0)
            if "stribeck0" in share:
                excess = n * share["stribeck0"]
                parts.append((excess, excess, share["stribeck_decay"], share["stribeck_shape"]))
    parts = [part for part in parts if stribeck and (part[0] > 0.0 or part[1] > 0.0)]
    prior: dict[str, Any] = {
        "coulomb0": forward,
        "coulomb_neg0": backward,
        "viscous0": viscous,
        "asymmetric": forward != backward,
        "stribeck": bool(parts),
    }
    if parts:
        if len({part[2:] for part in parts}) > 1:
            raise ValueError(
                "rig: its Stribeck terms have different rates or shapes "
                f"({', '.join(f'{rate:g} s/rad {shape}' for _, _, rate, shape in parts)}); "
                "the friction filters hold one"
            )
        up, down = sum(part[0] for part in parts), sum(part[1] for part in parts)
        if up != down:
            raise ValueError(
                f"rig: its Stribeck excess differs forwards ({up:g} N m) and backwards ({down:g} N m); "
                "the friction filters hold one excess both ways"
            )
        prior.update(stribeck0=up, stribeck_decay=parts[0][2], stribeck_shape=parts[0][3])
    return prior


class _FrictionFilter(Estimator):
    """Shared part of :class:`FrictionEKF` and :class:`FrictionUKF`: parameters, model
    set-up, ``params``, ``simulate``, consistency bookkeeping."""

    skips_nan_measurements: ClassVar[bool] = True

    def __init__(
        self,
        rig: TwoMassRig | RigidDrive | None = None,
        *,
        friction_side: Literal["motor", "load"] = "motor",
        asymmetric: bool = False,
        stribeck: bool = False,
        stribeck_decay: float = 0.1,
        stribeck_shape: Literal["exponential", "gaussian"] = "exponential",
        current_state: bool | None = None,
        substeps: int | None = None,
        coulomb0: float = 5e-3,
        coulomb_neg0: float | None = None,
        viscous0: float = 5e-5,
        stribeck0: float = 0.0,
        coulomb_std0: float = 5e-3,
        viscous_std0: float = 5e-5,
        stribeck_std0: float = 5e-3,
        speed_std0: float = 1.0,
        speed_noise: float = 0.05,
        twist_noise: float = 1e-5,
        current_noise: float = 1e-2,
        coulomb_drift: float = 2e-5,
        viscous_drift: float = 2e-7,
        stribeck_drift: float = 2e-5,
        R: float | None = None,
        R_current: float = 1e-4,
        nis_window: int = 50,
        divergence_nis: float = 25.0,
        on_divergence: OnDivergence = "warn",
    ):
        self.rig = rig
        self.friction_side = friction_side
        self.asymmetric = asymmetric
        self.stribeck = stribeck
        self.stribeck_decay = stribeck_decay
        self.stribeck_shape = stribeck_shape
        self.current_state = current_state
        self.substeps = substeps
        self.coulomb0 = coulomb0
        self.coulomb_neg0 = coulomb_neg0
        self.viscous0 = viscous0
        self.stribeck0 = stribeck0
        self.coulomb_std0 = coulomb_std0
        self.viscous_std0 = viscous_std0
        self.stribeck_std0 = stribeck_std0
        self.speed_std0 = speed_std0
        self.speed_noise = speed_noise
        self.twist_noise = twist_noise
        self.current_noise = current_noise
        self.coulomb_drift = coulomb_drift
        self.viscous_drift = viscous_drift
        self.stribeck_drift = stribeck_drift
        self.R = R
        self.R_current = R_current
        self.nis_window = nis_window
        self.divergence_nis = divergence_nis
        self.on_divergence = on_divergence
        self.reset()

    @classmethod
    def from_rig(cls, rig: TwoMassRig | RigidDrive, **kwargs: Any) -> _FrictionFilter:
        """A filter for the drive described by ``rig``, starting from its friction.

        The known constants are taken from ``rig``. A two-mass rig gives R_a, L_a,
        K_m, J_m, J_L, k_s, B_s, the constant load torque T_d, the sample time dt, the
        amplifier (gain, dead zone, saturation) and, unless ``R`` is given, the
        measurement variance of its tacho + A/D chain. A rigid drive (the doctor's
        model, e.g. ``load_model("improved.json")``) gives its inertia, input gain,
        offset torque, dead zone, saturation, its position torque (cogging, position
        friction: then every record needs its measured position) and dt; it has no sensor
        model, so ``R`` must be given. The friction it describes (:func:`friction_prior`: Coulomb
        levels each way, viscous coefficient, Stribeck excess, rate and shape) is the
        prior the filter starts from and goes on estimating.

        Parameters
        ----------
        rig : TwoMassRig or RigidDrive
        **kwargs
            Any other constructor argument; given ones override the prior (e.g.
            ``coulomb0=3e-3`` to start from another guess).
        """
        if not isinstance(rig, TwoMassRig | RigidDrive):
            raise ValueError(f"rig must be a TwoMassRig or a RigidDrive, got {type(rig).__name__}")
        return cls(rig=rig, **{**friction_prior(rig, kwargs.get("stribeck", True) is not False), **kwargs})

    # ------------------------------------------------------------------ set-up
    def _configure(self) -> None:
        """Validate the stored parameters (errors name the argument) and build the
        compiled model's constants, Q, R and the initial estimate."""
        rig = paper_rig() if self.rig is None else self.rig
        if not isinstance(rig, TwoMassRig | RigidDrive):
            raise ValueError(f"rig must be a TwoMassRig, a RigidDrive or None, got {type(rig).__name__}")
        rigid = isinstance(rig, RigidDrive)
        if self.friction_side not in ("motor", "load"):
            raise ValueError(f"friction_side must be 'motor' or 'load', got {self.friction_side!r}")
        if self.stribeck_shape not in kernels.STRIBECK_SHAPES:
            raise ValueError(
                f"stribeck_shape must be one of {', '.join(kernels.STRIBECK_SHAPES)}, got {self.stribeck_shape!r}"
            )
        if not rigid and (rig.cogging_sin != 0.0 or rig.cogging_cos != 0.0):
            raise ValueError(
                "rig: the two-mass rig's motor cogging is not in the friction filters' two-mass model "
                "(the motor position is no state of it); filter its rigid_equivalent(), which holds it"
            )
        if rigid:
            check_rigid_drive(rig)
            if self.friction_side != "motor":
                raise ValueError("friction_side: a RigidDrive has one mass; leave friction_side at 'motor'")
            if self.current_state:
                raise ValueError("current_state: a RigidDrive has no armature current")
            if self.R is None:
                raise ValueError(
                    "R: give the variance of the speed measurement [(rad/s)^2]; a RigidDrive has no sensor model"
                )
        if self.on_divergence not in ("raise", "warn", "ignore"):
            raise ValueError(f"on_divergence must be 'raise', 'warn' or 'ignore', got {self.on_divergence!r}")
        for name in ("asymmetric", "stribeck"):
            if not isinstance(getattr(self, name), bool | np.bool_):
                raise ValueError(f"{name} must be True or False, got {getattr(self, name)!r}")
        if self.current_state is not None and not isinstance(self.current_state, bool | np.bool_):
            raise ValueError(f"current_state must be True, False or None, got {self.current_state!r}")
        for name in (
            "stribeck_decay", "coulomb_std0", "viscous_std0", "stribeck_std0", "speed_std0",
            "speed_noise", "twist_noise", "current_noise", "coulomb_drift", "viscous_drift",
            "stribeck_drift", "R_current", "divergence_nis",
        ):  # fmt: skip
            check_positive(name, getattr(self, name))
            check_parameter(name, getattr(self, name), "(SI units)", sign="> 0")
        for name in ("coulomb0", "coulomb_neg0", "viscous0", "stribeck0"):
            value = getattr(self, name)
            if value is None and name == "coulomb_neg0":
                continue
            if isinstance(value, bool) or not isinstance(value, int | float | np.number) or not value >= 0:
                raise ValueError(f"{name} must be a number >= 0, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
            check_parameter(name, value, "(SI units)")
        if self.R is None:
            r = tacho_variance(rig)
        else:
            r = check_parameter("R", check_positive("R", self.R), "(rad/s)²", sign="> 0")
        window = check_count("nis_window", self.nis_window, 1, MOST_NIS_WINDOW)

        dt = rig.dt
        shape = str(self.stribeck_shape)
        ripple: tuple = ()
        if rigid:
            current = False
            position = rig.position_effects
            if position:  # its position torque, held at the drive's values (RigidDrive.position_torque)
                ripple = effects.get(position[0]).ripple(rig.params)
            names, index = fm.state_layout(
                False, bool(self.asymmetric), bool(self.stribeck), rigid=True, position=bool(position)
            )
            p = rig.params
            constants = {
                "J_m": rig.inertia, "J_l": 0.0, "K_m": 0.0, "R_a": 1.0, "L_a": 0.0, "k_s": 0.0, "B_s": 0.0,
                "T_d": p.get("offset", 0.0), "input_gain": rig.input_gain,
                "breakaway_excess": p.get("breakaway_excess", 0.0),
            }  # fmt: skip
            amp = (1.0, p.get("dead_zone", 0.0), p.get("saturation", math.inf))
        else:
            current = (
                dt < 10.0 * rig.L_a / rig.R_a if self.current_state is None else bool(self.current_state)
            )
            names, index = fm.state_layout(current, bool(self.asymmetric), bool(self.stribeck))
            constants = {
                "J_m": rig.J_m, "J_l": rig.J_l, "K_m": rig.K_m, "R_a": rig.R_a, "L_a": rig.L_a,
                "k_s": rig.k_s, "B_s": rig.B_s, "T_d": rig.T_d,
            }  # fmt: skip
            amp = (float(rig.amplifier.gain), float(rig.amplifier.dead_zone), float(rig.amplifier.v_max))
        constants.update(
            stribeck_decay=float(self.stribeck_decay), stribeck_shape=shape, dt=dt,
            friction_side=self.friction_side, index=index, ripple=ripple,
        )  # fmt: skip
        n = len(names)
        speeds = [index[k] for k in ("omega_m", "omega_l") if index[k] >= 0]
        x0 = np.zeros(n)
        x0[index["coulomb"]] = self.coulomb0
        x0[index["viscous"]] = self.viscous0
        if self.asymmetric:
            x0[index["coulomb_neg"]] = self.coulomb0 if self.coulomb_neg0 is None else self.coulomb_neg0
        if self.stribeck:
            x0[index["stribeck"]] = self.stribeck0
        if self.substeps is None:
            # Heun: keep h |lambda_max| <= 0.25, lambda from the model moving at 1 rad/s
            probe = x0.copy()
            probe[speeds] = 1.0
            c_probe = fm.pack_constants(**constants, substeps=1)
            substeps = max(1, math.ceil(dt * fm.stiffest_rate(c_probe, probe) / 0.25))
        else:
            substeps = check_count("substeps", self.substeps, 1, MOST_SUBSTEPS)
        self._c = fm.pack_constants(**constants, substeps=substeps)
        self._names = names
        self._index = index
        self._rig = rig
        self._r = float(r)
        self._window = window
        self.n_substeps = substeps
        self.has_current_state = current

        # initial covariance and process noise (per sample), both diagonal
        p0 = np.zeros(n)
        q = np.zeros(n)
        p0[speeds] = self.speed_std0**2
        q[speeds] = self.speed_noise**2
        if index["twist"] >= 0:
            # the twist that a speed difference builds over a sample
            p0[index["twist"]] = (self.speed_std0 * dt) ** 2
            q[index["twist"]] = self.twist_noise**2
        if index["position"] >= 0:
            # the position a speed's random change moves the drive over a sample; a measured
            # position is then held with this variance (kernels.hold_position)
            p0[index["position"]] = q[index["position"]] = (self.speed_noise * dt) ** 2
        if current:
            p0[index["i_a"]] = (self.speed_std0 * rig.K_m / rig.R_a) ** 2 + self.current_noise**2
            q[index["i_a"]] = self.current_noise**2
        for key, std0, drift in (
            ("coulomb", self.coulomb_std0, self.coulomb_drift),
            ("viscous", self.viscous_std0, self.viscous_drift),
            ("coulomb_neg", self.coulomb_std0, self.coulomb_drift),
            ("stribeck", self.stribeck_std0, self.stribeck_drift),
        ):
            if index[key] >= 0:
                p0[index[key]] = std0**2
                q[index[key]] = drift**2 * dt
        self.x0 = x0
        self.P0 = np.diag(p0)
        self.Q = np.diag(q)
        self._lower = np.full(n, -np.inf)
        for key in ("coulomb", "viscous", "coulomb_neg", "stribeck"):
            if index[key] >= 0:
                self._lower[index[key]] = 0.0
        self._speed = index["speed"]
        self._h_speed = np.zeros(n)
        self._h_speed[self._speed] = 1.0
        self._h_current = np.zeros(n)
        self._current_gain = 0.0
        if current:
            self._h_current[index["i_a"]] = 1.0
        elif not rigid:
            self._h_current[fm.I_OMEGA_M] = -rig.K_m / rig.R_a
            self._current_gain = 1.0 / rig.R_a
        self._amp = amp
        self._position_var = float(q[index["position"]]) if index["position"] >= 0 else 0.0

    def reset(self) -> None:
        """Validate the parameters and return to the prior: drive at rest, friction at
        ``coulomb0``, ``viscous0`` (...) with covariance ``P0``. Change a parameter
        attribute, then call ``reset()`` for it to take effect."""
        self._configure()
        n = len(self._names)
        self.x = self.x0.copy()
        self.P = self.P0.copy()
        self.x_prior, self.P_prior = self.x.copy(), self.P.copy()
        self.x_post, self.P_post = self.x.copy(), self.P.copy()
        self.F = np.eye(n)
        self.K = np.zeros(n)
        self.y = 0.0
        self.S = 0.0
        self.z = None
        self.v = 0.0
        self.nis = math.nan
        self.nis_mean = math.nan
        self.diverged = False
        self.y_current = 0.0
        self.S_current = 0.0
        self.sample_index = 0
        self._nis_ring = np.zeros(self._window)
        self._nis_count = 0
        self._input_state = self._rig.input_state() if isinstance(self._rig, RigidDrive) else None
        self._pending = False

    # ------------------------------------------------------------------ saving
    @classmethod
    def parameter_annotations(cls) -> dict[str, str]:
        """The constructor arguments by name (``rig`` included), each with the text of
        its type annotation, e.g. ``{"rig": "TwoMassRig | None", ..., "R": "float | None"}``."""
        out: dict[str, str] = {}
        for owner in (cls, _FrictionFilter):
            for name, p in inspect.signature(owner.__init__).parameters.items():
                if name != "self" and p.kind is not inspect.Parameter.VAR_KEYWORD:
                    out.setdefault(name, str(p.annotation))
        return out

    def params_to_json(self) -> dict[str, Any]:
        """:meth:`get_params` as JSON values, the rig as its description (``to_dict()``), the
        ``settings`` of a model file."""
        params = self.get_params()
        params["rig"] = None if params["rig"] is None else params["rig"].to_dict()
        return jsonable(params)

    @classmethod
    def params_from_json(cls, settings: Any, where: str) -> dict[str, Any]:
        """The constructor arguments from a model file's ``settings``, each read for the type
        its annotation names (:meth:`parameter_annotations`); the rig is a two-mass rig or a
        rigid drive (whose description has ``effects``), or null.

        Parameters
        ----------
        settings : Any
            The JSON value of ``settings``.
        where : str
            Its path in the file, named in a :class:`~motorid.errors.ModelFileError`.
        """
        annotations = cls.parameter_annotations()
        object_keys(settings, list(annotations), where)
        kw: dict[str, Any] = {}
        for name, annotation in annotations.items():
            key, value = key_path(where, name), settings[name]
            if name == "rig":
                if value is None:
                    kw[name] = None
                elif isinstance(value, dict) and "effects" in value:
                    kw[name] = RigidDrive.from_dict(value, key)
                else:
                    kw[name] = TwoMassRig.from_dict(value, key)
            elif value is None and "None" in annotation:
                kw[name] = None
            elif annotation.startswith("bool"):
                kw[name] = boolean(value, key)
            elif annotation.startswith("int"):
                kw[name] = integer(value, key)
            elif annotation.startswith("float"):
                kw[name] = number(value, key)
            else:  # a Literal of names
                kw[name] = text(value, key)
        return kw

    def get_params(self) -> dict[str, Any]:
        """The constructor arguments, by name (``rig`` included): ``type(self)(**get_params())``
        builds the same filter at its prior."""
        return {name: getattr(self, name) for name in self.parameter_annotations()}

    @property
    def _has_input_memory(self) -> bool:
        """True on a rigid drive with an input delay or lag (an input path with memory)."""
        rig = self._rig
        return isinstance(rig, RigidDrive) and bool({"input_delay", "input_lag"} & set(rig.effects))

    def get_state(self) -> dict[str, Any]:
        """What :meth:`update` has learnt: ``x``, ``P``, ``sample_index``, the NIS window
        (``nis_ring``, ``nis_count``, ``nis_mean``) and ``diverged``, and on a rigid drive with
        an input delay or lag the memory of its input path (``input_ring``, ``input_lag``:
        :class:`~motorid.drive.input_path.InputPathState`); :meth:`set_state` puts it back.
        Refused between a :meth:`predict` and its :meth:`update`."""
        if self._pending:
            raise ValueError("the filter is between predict() and update(): call update() first")
        memory = {}
        if self._has_input_memory:
            memory = {f"input_{k}": getattr(self._input_state, k).copy() for k in INPUT_STATE_KEYS}
        return {
            **memory,
            "x": self.x.copy(),
            "P": self.P.copy(),
            "sample_index": self.sample_index,
            "nis_ring": self._nis_ring.copy(),
            "nis_count": self._nis_count,
            "nis_mean": self.nis_mean,
            "diverged": self.diverged,
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a :meth:`get_state` of a filter built with the same parameters.

        Raises
        ------
        ValueError
            Naming the entry whose shape does not fit this filter, a covariance that
            is not symmetric positive definite (:func:`~motorid.estimators.base.check_covariance`),
            a negative count or NIS.
        """
        n = self.dim_x
        x = np.array(state["x"], dtype=float)
        P = np.array(state["P"], dtype=float)
        ring = np.array(state["nis_ring"], dtype=float)
        checks = [("x", x, (n,)), ("P", P, (n, n)), ("nis_ring", ring, (self._window,))]
        memory = None
        if self._has_input_memory:
            parts = {k: np.array(state[f"input_{k}"], dtype=float) for k in INPUT_STATE_KEYS}
            memory = InputPathState(**parts, clock=InputPathState.fresh_clock())
            checks += [
                (f"input_{k}", parts[k], getattr(self._input_state, k).shape) for k in INPUT_STATE_KEYS
            ]
        for key, value, shape in checks:
            if value.shape != shape:
                raise ValueError(f"{key} must have shape {shape} for this filter, got {value.shape}")
        P = check_covariance("P", P)
        if np.any(np.abs(x) > LARGEST):
            raise ValueError(f"x must be within ±{LARGEST:g} (the physical range of a drive's states)")
        if not kernels.is_healthy(x, P):
            raise ValueError("P must be symmetric positive definite and x finite")
        for key in ("sample_index", "nis_count"):
            if isinstance(state[key], bool) or not isinstance(state[key], int | np.integer) or state[key] < 0:
                raise ValueError(f"{key} must be an integer >= 0, got {state[key]!r}")
        if not np.all(ring >= 0.0) or float(state["nis_mean"]) < 0.0:  # NaN nis_mean: the window is not full
            raise ValueError(
                "nis_ring and nis_mean must be >= 0 (a NIS is a squared innovation over its variance)"
            )
        if memory is not None:
            self._input_state = memory
        self.x = self.x_prior = self.x_post = x
        self.P = self.P_prior = self.P_post = P
        self.sample_index = int(state["sample_index"])
        self._nis_ring, self._nis_count = ring, int(state["nis_count"])
        self.nis_mean = float(state["nis_mean"])
        self.diverged = bool(state["diverged"])
        self._pending = False

    # ------------------------------------------------------------------ description
    @property
    def state_names(self) -> tuple[str, ...]:
        return self._names

    @property
    def dt(self) -> float:
        """Sample time [s] (the rig's)."""
        return float(self._rig.dt)

    @property
    def R_speed(self) -> float:
        """Variance of the speed measurement in use [(rad/s)^2]."""
        return self._r

    @property
    def params(self) -> dict[str, Any]:
        """Friction estimates and their standard deviations.

        ``coulomb`` [N m] (the forward level when ``asymmetric``), ``viscous``
        [N m s/rad], with ``asymmetric`` ``coulomb_neg`` [N m], with ``stribeck``
        ``stribeck`` [N m] (the excess α1 at zero speed); ``<name>_std`` is the square
        root of the diagonal of P. Units in :data:`PARAM_UNITS`.
        """
        out: dict[str, Any] = {}
        for key in ("coulomb", "viscous", "coulomb_neg", "stribeck"):
            i = self._index[key]
            if i >= 0:
                out[key] = float(self.x[i])
                out[f"{key}_std"] = float(math.sqrt(max(self.P[i, i], 0.0)))
        return out

    param_units: ClassVar[dict[str, str]] = PARAM_UNITS

    def voltage(self, u: float) -> float:
        """Armature voltage [V] for command ``u`` [V]: the rig's amplifier (known); a rigid
        drive's dead zone and saturation at unit gain (its delay and lag have memory: see
        :meth:`model_inputs`)."""
        return float(armature_voltage(u, *self._amp))

    def model_inputs(self, u: np.ndarray, state: InputPathState | None) -> np.ndarray:
        """The model's input per sample for the commands ``u`` [V] held over each: a two-mass
        rig's armature voltage [V] (its amplifier), a rigid drive's input after saturation,
        dead zone, delay and lag (:meth:`RigidDrive.input_signal
        <motorid.drive.rigid.RigidDrive.input_signal>`) on the input path's memory ``state``,
        updated in place (None: a record from rest). The one input map of :meth:`predict`,
        ``batch_filter`` and :meth:`simulate`."""
        u = np.ascontiguousarray(u, dtype=float)
        if isinstance(self._rig, RigidDrive):
            return self._rig.input_signal(u, state)
        return armature_voltages(u, *self._amp)

    def simulate(self, u: ArrayLike) -> np.ndarray:
        """Free-run load speed [rad/s] of the model with the current friction estimates,
        from rest, for the command record ``u`` [V] (sample timing as the rig's); a rigid drive
        with a position torque from position 0, as :meth:`RigidDrive.simulate
        <motorid.drive.rigid.RigidDrive.simulate>` starts."""
        u_arr = as_float_vector(u, "u")
        bad = first_bad_index(u_arr)
        if bad is not None:
            raise ValueError(f"u[{bad}] = {u_arr[bad]} is not finite: the input must be finite")
        x0 = np.zeros(len(self._names))
        for key in ("coulomb", "viscous", "coulomb_neg", "stribeck"):
            i = self._index[key]
            if i >= 0:
                x0[i] = self.x[i]
        v = self.model_inputs(u_arr, None)
        return kernels.filter_free_run(v, x0, self._c)[:, self._speed].copy()

    def _sample_input(self, u: float) -> float:
        """:meth:`model_inputs` of one command on the filter's running input memory (a two-mass
        rig's amplifier has none: its element map :func:`armature_voltage` directly)."""
        if self._input_state is None:
            return float(armature_voltage(u, *self._amp))
        return float(self.model_inputs(np.array([u]), self._input_state)[0])

    # ------------------------------------------------------------------ checks
    def _check_current(self, current: float | None) -> float | None:
        if current is not None and isinstance(self._rig, RigidDrive):
            raise ValueError("current: a RigidDrive has no armature current to measure")
        return None if current is None else self.check_measured_value("current", current)

    def _warn_nan_record(self, z: Any) -> None:
        """One RuntimeWarning naming the NaN measurements of a record."""
        try:
            values = np.asarray([np.nan if item is None else item for item in z], dtype=float)
        except (TypeError, ValueError):
            return  # check_record names the problem
        nan = np.flatnonzero(np.isnan(values) & np.array([item is not None for item in z]))
        if nan.size:
            shown = ", ".join(str(int(k)) for k in nan[:5]) + (", ..." if nan.size > 5 else "")
            warnings.warn(
                f"z is NaN at {nan.size} sample(s) ({shown}): those measurement updates are skipped",
                RuntimeWarning,
                stacklevel=3,
            )

    def _current_record(self, current: ArrayLike | None, n: int) -> tuple[np.ndarray, np.ndarray]:
        if current is None:
            return np.zeros(n), np.zeros(n, dtype=bool)
        self._check_current(0.0)
        values = as_float_vector(current, "current")
        if values.shape != (n,):
            raise ValueError(f"current must have the length of u ({n}), got shape {values.shape}")
        if np.isinf(values).any():
            k = int(np.flatnonzero(np.isinf(values))[0])
            raise ValueError(f"current[{k}] = {values[k]} is not finite")
        nan = np.isnan(values)
        if nan.any():
            warnings.warn(
                f"current is NaN at {int(nan.sum())} sample(s): those current updates are skipped",
                RuntimeWarning,
                stacklevel=3,
            )
        return np.where(nan, 0.0, values), ~nan

    # ------------------------------------------------------------------ position
    @property
    def position_effect(self) -> str:
        """The rigid drive's effect whose torque depends on the position (``cogging``,
        ``position_friction``), whose position the filter needs; empty for none."""
        rig = self._rig
        return rig.position_effects[0] if isinstance(rig, RigidDrive) and rig.position_effects else ""

    def hold_position(self, position: float | None) -> None:
        """Take the measured ``position`` [rad or m] at the end of this sample as the model's
        position state θ (:func:`~motorid.drive.kernels.hold_position`): the position torque of
        the next sample starts from it, and between two measurements θ follows the speed
        estimate. The position is a known input of the torque, not a measurement of the speed:
        a speed from an encoder is the same position's difference already, and counting it
        twice would make the speed estimate overconfident. None (or NaN, with a warning)
        leaves θ to the model.

        Parameters
        ----------
        position : float or None
            The measured position [rad or m].

        Raises
        ------
        ValueError
            A position given to a filter whose drive has no position torque.
        """
        if position is None:
            return
        if not self.position_effect:
            raise ValueError("position: this filter's drive has no torque that depends on the position")
        value = self.check_measured_value("position", position)
        if value is None:
            return
        x, P = self.x.copy(), self.P.copy()
        kernels.hold_position(x, P, self._index["position"], value, self._position_var)
        self.x, self.P = x, P

    def _position_record(self, position: ArrayLike | None, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The measured positions of a record of ``n`` samples and where they are present (not
        NaN); ValueError naming the position effect when the drive needs them and they are
        missing, or naming the argument when it does not fit."""
        effect = self.position_effect
        if position is None:
            if effect:
                raise ValueError(
                    f"position: the rigid drive's {effect} torque depends on the position, so the filter "
                    "needs the record's measured position [rad or m] (an encoder's) at every sample; "
                    "this record has none"
                )
            return kernels.NO_POSITIONS, kernels.NO_MEASUREMENTS
        if not effect:
            raise ValueError("position: this filter's drive has no torque that depends on the position")
        values = as_float_vector(position, "position")
        if values.shape != (n,):
            raise ValueError(f"position must have the length of u ({n}), got shape {values.shape}")
        if np.isinf(values).any():
            k = int(np.flatnonzero(np.isinf(values))[0])
            raise ValueError(f"position[{k}] = {values[k]} is not finite")
        nan = np.isnan(values)
        if nan.any():
            warnings.warn(
                f"position is NaN at {int(nan.sum())} sample(s): the model's position follows its speed there",
                RuntimeWarning,
                stacklevel=3,
            )
        return np.where(nan, 0.0, values), ~nan

    def _sample_loop(
        self, u: ArrayLike, z: ArrayLike | Sequence[float | None], position: ArrayLike | None, saver: Any
    ) -> BatchResult:
        """:meth:`Estimator.batch_filter`'s loop of :meth:`predict` and :meth:`update`, with the
        measured ``position`` of a drive with a position torque (checked whole first)."""
        u_arr, z_arr, present = self.check_record(u, z)
        held, held_present = self._position_record(position, len(u_arr))
        if not held.size:
            return super().batch_filter(u_arr, z, saver)
        n_samples, n = len(u_arr), self.dim_x
        x_hist, p_diag = np.empty((n_samples, n)), np.empty((n_samples, n))
        y_hat, innovation, s_hist = np.empty(n_samples), np.full(n_samples, np.nan), np.empty(n_samples)
        for t in range(n_samples):
            y_hat[t] = self.predict(u_arr[t])
            self.update(z_arr[t] if present[t] else None, position=held[t] if held_present[t] else None)
            if present[t]:
                innovation[t] = self.y
            x_hist[t], p_diag[t], s_hist[t] = self.x, np.diag(self.P), self.S
            if saver is not None:
                saver.save()
        return BatchResult(x_hist, p_diag, y_hat, innovation, s_hist, self.state_names)

    # ------------------------------------------------------------------ consistency
    def _record_nis(self, e: float, s: float) -> None:
        self.nis = e * e / s
        self._nis_count, self.nis_mean = kernels.push_nis(self._nis_ring, self._nis_count, self.nis)

    def _breakdown(self, sample: int) -> None:
        self.diverged = True
        raise FilterDivergenceError(
            f"{self.name} diverged at sample {sample}: the covariance P is no longer positive "
            "definite or the estimate is not finite",
            sample,
        )

    def _check_health(self, sample: int) -> None:
        """Raise on a numerical breakdown; flag (and raise or warn) on a NIS excursion."""
        if not kernels.is_healthy(self.x, self.P):
            self._breakdown(sample)
        if self.nis_mean > self.divergence_nis:
            self._flag_divergence(sample, self.nis_mean)

    def _flag_divergence(self, sample: int, nis_mean: float) -> None:
        first = not self.diverged
        self.diverged = True
        message = (
            f"{self.name} diverged at sample {sample}: the mean normalised innovation squared over "
            f"the last {self._window} updates is {nis_mean:.3g} (> divergence_nis = {self.divergence_nis:g}; "
            "a consistent filter gives about 1). The model does not describe the data: check the rig "
            "constants, the measurement variance R and the process noise"
        )
        if self.on_divergence == "raise":
            raise FilterDivergenceError(message, sample, nis_mean)
        if self.on_divergence == "warn" and first:
            warnings.warn(message, RuntimeWarning, stacklevel=4)

    def __repr__(self) -> str:
        head = (
            f"{type(self).__name__}(friction_side={self.friction_side!r}, asymmetric={self.asymmetric}, "
            f"stribeck={self.stribeck}, current_state={self.has_current_state}, substeps={self.n_substeps}, "
            f"dt={self.dt}, R={self._r:.4g})"
        )
        lines = [head, super().__repr__(), f"nis = {self.nis}", f"nis_mean = {self.nis_mean}"]
        return "\n".join(lines)


class FrictionEKF(_FrictionFilter):
    """Extended Kalman filter on the two-mass drive, learning its friction online.

    filterpy's ``ExtendedKalmanFilter`` with the model of
    :mod:`~motorid.estimators.friction_model` filled in: :meth:`predict` integrates
    the nonlinear model over one sample (sub-stepped, compiled) and sets the
    Jacobian ``F`` itself; :meth:`update` is filterpy's Joseph-form update with
    ``H = [0, 1, 0, ...]`` (the load speed), followed by the projection of the
    friction parameters onto >= 0. The equations are in :mod:`.friction_kf`; the
    model, zero speed and the armature current in :mod:`.friction_model`.

    Parameters
    ----------
    rig : TwoMassRig or RigidDrive, optional
        The known constants of the drive: R_a [Ω], L_a [H], K_m [N m/A], J_m, J_L
        [kg m²], k_s [N m/rad], B_s [N m s/rad], T_d [N m], dt [s], the amplifier
        and the tacho + A/D chain (for R). Default :func:`~motorid.drive.paper_rig`.
        Its friction laws and B_m, B_L are not used here: they are estimated
        (:meth:`from_rig` starts from them). A rigid drive (one mass, the doctor's
        model) gives its inertia, input gain, offset torque, dead zone, saturation
        and dt; ``R`` is then required and no current can be measured. Its torque that
        depends on the position (cogging, position friction) is a known part of the model, at
        the position given to :meth:`update` and ``batch_filter`` (required there).
    friction_side : {"motor", "load"}
        The mass the estimated friction acts on. With one speed sensor and a stiff
        shaft only the total friction of the drive is observable; the estimate is
        that total, placed on this mass.
    asymmetric : bool
        Estimate a separate backward Coulomb level ``coulomb_neg`` (eq. 11).
    stribeck : bool
        Estimate the Stribeck excess ``stribeck`` = α1 of eq. (9).
    stribeck_decay : float
        α2 [s/rad] of eq. (9), known, > 0 (the rate 1/v_s of either shape).
    stribeck_shape : {"exponential", "gaussian"}
        The Stribeck decay exp(-α2 |ω|) of eq. (9) or exp(-(α2 ω)²).
    current_state : bool, optional
        Keep i_a in the state (True) or use its quasi-static value (False); None
        (default) keeps it when dt < 10 L_a/R_a (see :mod:`.friction_model`).
    substeps : int, optional
        Heun sub-steps per sample; None chooses h |λ_max| <= 0.25 from the model's
        stiffest eigenvalue (26 for the paper's rig: 1.5 ms steps).
    coulomb0, viscous0, stribeck0 : float
        Prior estimates [N m], [N m s/rad], [N m].
    coulomb_neg0 : float, optional
        Prior of the backward level ``coulomb_neg`` [N m]; None starts it at ``coulomb0``.
    coulomb_std0, viscous_std0, stribeck_std0 : float
        Prior standard deviations, same units.
    speed_std0 : float
        Prior standard deviation of both speeds [rad/s] (the drive starts at rest).
    speed_noise : float
        Standard deviation [rad/s] of the random change of each speed per sample
        (unmodelled torques, integration error).
    twist_noise : float
        The same for the shaft twist [rad].
    current_noise : float
        The same for i_a [A] when it is in the state.
    coulomb_drift, viscous_drift, stribeck_drift : float
        Random-walk intensities of the friction parameters [unit/√s]: per sample
        their variance grows by ``drift² dt``.
    R : float, optional
        Variance of the speed measurement [(rad/s)²]; default from the rig's tacho
        noise and A/D step, ``(σ_t/G_t)² + (q/G_t)²/12``.
    R_current : float
        Variance of a measured armature current [A²].
    nis_window : int
        Number of updates over which the NIS is averaged for the divergence test,
        1 to :data:`MOST_NIS_WINDOW`.
    divergence_nis : float
        Threshold of that mean; a consistent filter averages 1, so 25 means
        innovations five times their predicted standard deviation.
    on_divergence : {"warn", "raise", "ignore"}
        What a NIS excursion does besides setting ``diverged``: warn once (default),
        raise :class:`FilterDivergenceError`, or nothing.

    Attributes
    ----------
    x, P, x_prior, P_prior, x_post, P_post, F, K, y, S, z
        As filterpy's ExtendedKalmanFilter (1-D x, scalar y and S).
    v : float
        Armature voltage [V] of the last sample.
    nis : float
        Normalised innovation squared y²/S of the last update (NaN when skipped).
    nis_mean : float
        Its mean over the last ``nis_window`` updates (NaN until that many).
    diverged : bool
        Set once the windowed NIS passed ``divergence_nis``.
    n_substeps : int
        Heun sub-steps per sample in use.
    has_current_state : bool
        Whether i_a is in the state.

    Examples
    --------
    >>> from motorid.drive import paper_rig
    >>> ekf = FrictionEKF.from_rig(paper_rig(), coulomb0=3e-3)
    >>> result = ekf.batch_filter(df["u"], df["y"])          # doctest: +SKIP
    >>> ekf.params["coulomb"], ekf.params["coulomb_std"]    # doctest: +SKIP
    """

    name = "friction-ekf"

    def predict(self, u: float) -> float:
        """Time update with the command ``u`` [V] held over the sample; returns the
        predicted load speed [rad/s]. A sample still waiting for its update is
        closed as skipped."""
        u = self.check_input(u)
        if self._pending:
            self.update(None)
        v = self._sample_input(u)
        x_prior, P_prior, F = kernels.ekf_predict(self.x, self.P, v, self._c, self.Q)
        self.v = v
        self.F = F
        self.x = self.x_prior = x_prior
        self.P = self.P_prior = P_prior
        i = self._speed
        self.S = float(P_prior[i, i] + self._r)
        self.sample_index += 1
        self._pending = True
        return float(x_prior[i])

    def update(self, z: float | None, current: float | None = None, position: float | None = None) -> None:
        """Measurement update with the measured load speed ``z`` [rad/s] and, where
        measured, the armature current ``current`` [A] and, on a rigid drive with a position
        torque, the position ``position`` [rad or m] (held as the model's position: see
        :meth:`hold_position`).

        ``None`` skips; NaN skips with a RuntimeWarning naming the sample.

        Raises
        ------
        FilterDivergenceError
            When P breaks down, or the windowed NIS passes ``divergence_nis`` with
            ``on_divergence="raise"`` (the update has been applied).
        """
        if not self._pending:
            raise RuntimeError("update() needs a predict(u) for this sample first")
        value = None if z is None else self.check_measurement(z)
        i_meas = self._check_current(current)
        self._pending = False
        healthy = True
        if value is None:
            self.z = None
            self.y = 0.0
            self.K = np.zeros(self.dim_x)
            self.nis = math.nan
        else:
            self.z = value
            x, P, K, e, s, count, nis_mean, healthy = kernels.ekf_update_step(
                self.x, self.P, self._h_speed, value, self._r, self._lower, self._nis_ring, self._nis_count
            )
            self.x, self.P, self.K = x, P, K
            self.y, self.S = float(e), float(s)
            self.nis = self.y * self.y / self.S
            self._nis_count, self.nis_mean = count, nis_mean
        if i_meas is not None:
            self.x, self.P, _, e, s = kernels.joseph_update(
                self.x,
                self.P,
                self._h_current,
                self._current_gain * self.v,
                i_meas,
                self.R_current,
                self._lower,
            )
            self.y_current, self.S_current = float(e), float(s)
            healthy = kernels.is_healthy(self.x, self.P)
        elif value is None:
            healthy = kernels.is_healthy(self.x, self.P)
        self.hold_position(position)
        self.x_post, self.P_post = self.x, self.P
        if not healthy:
            self._breakdown(self.sample_index - 1)
        if self.nis_mean > self.divergence_nis:
            self._flag_divergence(self.sample_index - 1, self.nis_mean)

    def batch_filter(
        self,
        u: ArrayLike,
        z: ArrayLike | Sequence[float | None],
        saver: Any = None,
        current: ArrayLike | None = None,
        position: ArrayLike | None = None,
    ) -> BatchResult:
        """Run over a whole record (see :meth:`Estimator.batch_filter`); ``current``
        [A] optionally adds the measured armature current (NaN: not measured); ``position``
        [rad or m], the measured position at the end of each sample, is needed by a rigid drive
        with a position torque (NaN: not measured; see :meth:`hold_position`).

        Without a ``saver`` this is one compiled loop over the same kernels as
        :meth:`predict` and :meth:`update` and gives the same numbers. The whole
        record is validated first: a non-finite ``u`` raises ValueError naming its
        index before anything changes; NaN in ``z`` is skipped with one warning.
        """
        if saver is not None:
            if current is not None:
                raise ValueError("current cannot be combined with saver; run the sample loop instead")
            if not isinstance(z, np.ndarray):
                z = list(z)
            self._warn_nan_record(z)
            return self._sample_loop(u, z, position, saver)
        if not isinstance(z, np.ndarray):
            z = list(z)
        u_arr, z_arr, present = self.check_record(u, z)
        cur, cur_present = self._current_record(current, len(u_arr))
        held, held_present = self._position_record(position, len(u_arr))
        self._warn_nan_record(z)
        if self._pending:
            self.update(None)
        state = copy.deepcopy(self._input_state)
        v = self.model_inputs(u_arr, state)
        ring = self._nis_ring.copy()
        already = self.diverged
        (
            X, P_diag, y_hat, innovation, S, NIS, x, P, x_prior, P_prior, F, K, e, s,
            count, nis_mean, flag, flag_at, flag_mean, done,
        ) = kernels.ekf_batch(
            v, np.where(present, z_arr, 0.0), present, cur, cur_present, self.x.copy(), self.P.copy(),
            self._c, self.Q, self._r, float(self.R_current), self._h_speed, self._h_current,
            self._current_gain, self._lower, ring, self._nis_count, float(self.divergence_nis),
            self.on_divergence == "raise", held, held_present, self._position_var,
        )  # fmt: skip
        if done:
            last = done - 1
            self.x, self.P = x, P
            self.x_prior, self.P_prior = x_prior, P_prior
            self.x_post, self.P_post = x, P
            self.F, self.K = F, K
            self.y, self.S = float(e), float(s)
            self.z = float(z_arr[last]) if present[last] else None
            self.v = float(v[last])
            self.nis = float(NIS[last])
            self.nis_mean = float(nis_mean)
            self._nis_ring, self._nis_count = ring, int(count)
            self.sample_index += done
            if state is not None:  # the input path's memory after the last sample filtered
                if done < len(u_arr):
                    state = copy.deepcopy(self._input_state)
                    self.model_inputs(u_arr[:done], state)
                self._input_state = state
        if flag == kernels.FLAG_BREAKDOWN:
            self._check_health(self.sample_index - 1)
        elif flag == kernels.FLAG_NIS:
            self.diverged = already
            self._flag_divergence(self.sample_index - (done - flag_at), float(flag_mean))
        return BatchResult(
            X[:done], P_diag[:done], y_hat[:done], innovation[:done], S[:done], self.state_names
        )


class FrictionUKF(_FrictionFilter):
    """Unscented Kalman filter on the same model as :class:`FrictionEKF`; needs no
    Jacobian.

    Built on filterpy's ``UnscentedKalmanFilter`` with Van der Merwe's scaled sigma
    points: the 2n + 1 sigma points go through the same compiled sub-stepped model
    (:func:`~motorid.estimators.friction_model.propagate`), so sigma points on either
    side of zero speed each follow their own stick/slip path. After each update the
    friction parameters are projected onto >= 0 and P is mirrored to exact
    symmetry. Slower than the EKF (2n + 1 model runs per sample through Python).

    Parameters
    ----------
    rig : TwoMassRig or RigidDrive, optional
        As for :class:`FrictionEKF`.
    **kwargs : Any
        ``friction_side``, ``asymmetric``, ``stribeck``, ..., ``on_divergence``: as for
        :class:`FrictionEKF` (keyword-only).
    alpha, beta, kappa : float
        Sigma-point spread and weights (filterpy's ``MerweScaledSigmaPoints``);
        alpha = 1, kappa = 0 put the points at ±√n σ with no negative weight.

    Attributes
    ----------
    ukf : filterpy.kalman.UnscentedKalmanFilter
        The underlying filter (its x and P are this estimator's).
    nis, nis_mean, diverged
        As for :class:`FrictionEKF`.
    """

    name = "friction-ukf"

    def __init__(
        self,
        rig: TwoMassRig | None = None,
        *,
        alpha: float = 1.0,
        beta: float = 2.0,
        kappa: float = 0.0,
        **kwargs: Any,
    ):
        self.alpha = alpha
        self.beta = beta
        self.kappa = kappa
        super().__init__(rig, **kwargs)

    def reset(self) -> None:
        check_positive("alpha", self.alpha)
        for name in ("beta", "kappa"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
        super().reset()
        # imported here: filterpy.kalman pulls in scipy.stats, half a second that
        # every user of motorid.estimators would otherwise pay at import
        from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

        n = self.dim_x
        points = MerweScaledSigmaPoints(
            n, alpha=float(self.alpha), beta=float(self.beta), kappa=float(self.kappa)
        )
        c = self._c
        empty = np.empty((0, 0))
        i = self._speed

        def fx(x: np.ndarray, dt: float, v: float = 0.0) -> np.ndarray:
            return kernels.filter_propagate(x, v, c, empty, False)

        def hx(x: np.ndarray) -> np.ndarray:
            return x[i : i + 1]

        ukf = UnscentedKalmanFilter(dim_x=n, dim_z=1, dt=self.dt, hx=hx, fx=fx, points=points)
        ukf.x = self.x.copy()
        ukf.P = self.P.copy()
        ukf.Q = self.Q.copy()
        ukf.R = np.array([[self._r]])
        self.ukf = ukf

    def predict(self, u: float) -> float:
        """Time update with the command ``u`` [V]; returns the predicted load speed [rad/s]."""
        u = self.check_input(u)
        if self._pending:
            self.update(None)
        v = self._sample_input(u)
        ukf = self.ukf
        ukf.x, ukf.P = self.x.copy(), self.P.copy()
        try:
            ukf.predict(v=v)
        except np.linalg.LinAlgError as exc:
            self.diverged = True
            raise FilterDivergenceError(
                f"{self.name} diverged at sample {self.sample_index}: no sigma points ({exc})",
                self.sample_index,
            ) from None
        P = ukf.P
        P = 0.5 * (P + P.T)
        self.v = v
        self.x = self.x_prior = ukf.x.copy()
        self.P = self.P_prior = P
        i = self._speed
        self.S = float(P[i, i] + self._r)
        self.sample_index += 1
        self._pending = True
        return float(self.x[i])

    def update(self, z: float | None, current: float | None = None, position: float | None = None) -> None:
        """Measurement update with the load speed ``z`` [rad/s] and optionally the
        armature current [A] (a joint two-dimensional update) and, on a rigid drive with a
        position torque, the position [rad or m] (held: :meth:`hold_position`); None skips, NaN
        skips with a RuntimeWarning."""
        if not self._pending:
            raise RuntimeError("update() needs a predict(u) for this sample first")
        value = None if z is None else self.check_measurement(z)
        i_meas = self._check_current(current)
        self._pending = False
        ukf = self.ukf
        ukf.x, ukf.P = self.x.copy(), self.P.copy()
        if value is None and i_meas is None:
            self.z = None
            self.y = 0.0
            self.K = np.zeros(self.dim_x)
            self.nis = math.nan
            self.hold_position(position)
            self.x_post, self.P_post = self.x, self.P
            return
        if value is not None and i_meas is None:
            ukf.update(np.array([value]))
        else:
            h_cur, gain, v = self._h_current, self._current_gain, self.v

            def current_of(x: np.ndarray) -> float:
                return float(h_cur @ x + gain * v)

            if value is None:
                ukf.update(
                    np.array([i_meas]), R=np.array([[self.R_current]]), hx=lambda x: np.array([current_of(x)])
                )
            else:
                ukf.update(
                    np.array([value, i_meas]),
                    R=np.diag([self._r, self.R_current]),
                    hx=lambda x: np.array([x[self._speed], current_of(x)]),
                )
        x = np.maximum(ukf.x, self._lower)
        P = 0.5 * (ukf.P + ukf.P.T)
        self.x, self.P = x.copy(), P.copy()
        self.hold_position(position)
        ukf.x, ukf.P = self.x.copy(), self.P.copy()
        self.x_post, self.P_post = self.x, self.P
        if value is not None:
            self.z = value
            self.y = float(ukf.y[0])
            self.S = float(ukf.S[0, 0])
            self.K = np.array(ukf.K[:, 0], dtype=float)
            self._record_nis(self.y, self.S)
        else:
            self.z = None
            self.y = 0.0
            self.K = np.zeros(self.dim_x)
            self.nis = math.nan
        if i_meas is not None:
            self.y_current = float(ukf.y[-1])
            self.S_current = float(ukf.S[-1, -1])
        self._check_health(self.sample_index - 1)

    def batch_filter(
        self,
        u: ArrayLike,
        z: ArrayLike | Sequence[float | None],
        saver: Any = None,
        position: ArrayLike | None = None,
    ) -> BatchResult:
        """Run over a whole record, one :meth:`predict` and :meth:`update` per sample;
        NaN measurements are skipped with one warning. ``position`` [rad or m]: as for
        :meth:`FrictionEKF.batch_filter`."""
        if not isinstance(z, np.ndarray):
            z = list(z)
        self._warn_nan_record(z)
        return self._sample_loop(u, z, position, saver)


__all__ = [
    "PARAM_UNITS",
    "FrictionEKF",
    "FrictionUKF",
    "check_rigid_drive",
    "filter_effects",
    "friction_prior",
    "tacho_variance",
]
