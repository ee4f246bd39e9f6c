"""The effect library: the physical effects the workflow can name and add to a model.

The model is the rigid drive of :mod:`motorid.drive.rigid`
(:class:`~motorid.drive.rigid.RigidDrive`: inertia J, input gain g and the effects'
parameters; its module holds the table of terms and units)::

    J dw/dt = F_in(u) - Σ_e T_e(w),    F_in(u) = B(g · L(Δ(D(S(u)))))        [F]

"F" stands for the force unit of the model (N m or N, that of ``g u``; without a
known g the fit takes g = 1 and F is the input's unit), "v" for the velocity unit
and "u" for the input unit (e.g. V); :func:`param_unit` makes them concrete.

Each effect here is what the workflow needs to name and fit one effect of the
drive: its name (the snake_case names of DESIGN.md), the parameters it adds
(``linear``: enter the balance linearly, fitted by least squares; ``nonlinear``: a
few shape parameters fitted by a bounded search), its signature (where it shows in
the residual), the search interval of its shape parameters, and how it adds itself
to the model: friction-type effects give regressor columns ``T_e(w) = Σ θ_i c_i(w)``,
input-path effects transform the input. Both are evaluated by the drive's compiled
functions in :mod:`motorid.drive` (:func:`~motorid.drive.rigid.term_columns`,
:func:`~motorid.drive.rigid.input_path`, :func:`~motorid.drive.rigid.backlash_dwell`),
the ones its free run uses, so no term is written twice.

What ``backlash`` models: lost motion in a rigid drive seen from the measured
side. After the drive force reverses, the driving side crosses the play
before it pushes again; for a velocity record this is a dwell of τ_b during
which the measured side coasts under friction alone (the driving side's
momentum, small beside the load's, is not carried over). τ_b ≈ sqrt(4 b J_m
/ |F|) for a play 2b and a driving inertia J_m; the effect reports τ_b, not b.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from motorid.drive.rigid import (
    RIGID_EFFECTS,
    backlash_dwell,
    input_dynamics,
    input_path,
    term_columns,
)

#: The effects that give a model a kinetic friction level (a force that holds back a moving drive
#: at any speed): the Stribeck decay is one only in a model without them.
KINETIC = ("coulomb_friction", "input_dead_zone")
#: The physics effects are forms of (:meth:`Effect.physics`).
KINETIC_FRICTION = "kinetic friction"
BREAKAWAY_FRICTION = "breakaway friction above the kinetic level"


class Effect:
    """One physical effect of the library (a stateless description).

    Class attributes
    ----------------
    name : str
        snake_case name (DESIGN.md); never renamed.
    kind : {"friction", "input"}
        ``friction``: adds torque columns to the balance; ``input``: transforms
        the input path.
    linear : tuple of str
        Parameters that enter the balance linearly (least squares).
    nonlinear : tuple of str
        Shape parameters found by a bounded one-dimensional search.
    units : dict
        Parameter -> unit, with ``F`` the force unit, ``v`` the velocity unit
        and ``u`` the input unit.
    signature : str
        Where the effect shows in the residual of a model that lacks it.
    order : int
        Position in the input path (input effects): saturation, dead zone,
        delay, lag, then backlash.
    structure : bool
        Part of the base structure (delay, lag), chosen from the data before any
        other effect is judged (:func:`motorid.diagnose.workflow.choose_structure`),
        not a candidate of the steps.
    rest_only : bool
        Acts on a drive at rest only (static friction): invisible to the balance of the
        moving samples, so a fit of the balance keeps its value as given; the steps fit and
        judge it on the free run.
    nonnegative : tuple of str
        Parameters that are >= 0 for the effect to be physical (a fit with a
        negative value is not this effect).
    requires : tuple of str
        Effects that must be in the model before this one is a candidate.
    acts : {"", "rests", "rest", "speed"}
        Where the effect acts, so where it is judged against the noise: ``rests`` at the rests
        and breakaways the record shows (static friction), ``rest`` at the lowest speeds (a
        Stribeck decay), ``speed`` at the highest speeds
        (quadratic drag), empty for everywhere (:meth:`motorid.diagnose.workflow.Pool.band_floor`).
    """

    name: ClassVar[str] = ""
    kind: ClassVar[str] = "friction"
    linear: ClassVar[tuple[str, ...]] = ()
    nonlinear: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}
    signature: ClassVar[str] = ""
    order: ClassVar[int] = 0
    nonnegative: ClassVar[tuple[str, ...]] = ()
    requires: ClassVar[tuple[str, ...]] = ()
    structure: ClassVar[bool] = False
    rest_only: ClassVar[bool] = False
    acts: ClassVar[str] = ""

    def physics(self, model: tuple[str, ...]) -> str:
        """The physics this effect is one form of when added to a model with the effects
        ``model``: effects of one physics are what a record may not tell apart (``kinetic
        friction``: Coulomb friction and an input dead zone on a drive that never reverses while
        moving). Empty for none. :meth:`level` gives its size."""
        return ""

    def level(self, params: dict[str, float]) -> float:
        """The size of its :meth:`physics` in a model's ``params`` [F] (NaN for an effect without one)."""
        return math.nan

    def columns(
        self, w: np.ndarray, shape: dict[str, float], stribeck_shape: str = "exponential"
    ) -> np.ndarray:
        """Regressor columns ``c_i(w)``, shape (N, len(linear)): the torque per unit parameter
        (the rigid drive's compiled terms, :func:`motorid.drive.rigid.term_columns`)."""
        if not self.linear:
            return np.zeros((w.size, 0))
        return term_columns(self.linear, w, shape.get("stribeck_velocity", 1.0), stribeck_shape)

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        """Input path: ``u`` (or the drive force, for backlash) after this effect."""
        return x

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        """Search interval of each nonlinear parameter, from the record's scales.

        ``scale`` holds ``w_max`` [v], ``w_noise`` [v], ``u_max`` [u], ``dt`` [s] and
        ``dt_band`` [s], the decimated sample time.
        """
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class ViscousFriction(Effect):
    """Viscous friction ``T = B w`` [F]: residual proportional to w, sign of w, largest at high |w|."""

    name = "viscous_friction"
    linear = ("viscous",)
    units: ClassVar[dict[str, str]] = {"viscous": "F s/v"}
    nonnegative = ("viscous",)
    signature = "grows in proportion to w, sign follows sgn(w), largest at high |w|"


class CoulombFriction(Effect):
    """Coulomb friction ``T = F_c sgn(w)`` [F] (paper eq. 8)."""

    name = "coulomb_friction"
    linear = ("coulomb",)
    units: ClassVar[dict[str, str]] = {"coulomb": "F"}
    nonnegative = ("coulomb",)
    signature = "constant level whose sign follows sgn(w); dominates at low |w| and holds a resting drive"

    def physics(self, model: tuple[str, ...]) -> str:
        return KINETIC_FRICTION

    def level(self, params: dict[str, float]) -> float:
        """The Coulomb level F_c [F]."""
        return float(params["coulomb"])


class StribeckFriction(Effect):
    """Stribeck excess ``T = F_s exp(-|w|/v_s) sgn(w)`` [F] (paper eq. 9, α1 and α2 = 1/v_s)."""

    name = "stribeck_friction"
    linear = ("stribeck",)
    nonlinear = ("stribeck_velocity",)
    units: ClassVar[dict[str, str]] = {"stribeck": "F", "stribeck_velocity": "v"}
    nonnegative = ("stribeck",)
    signature = "sign follows sgn(w), confined to |w| below a few v_s and decaying with |w|"
    acts = "rest"

    def physics(self, model: tuple[str, ...]) -> str:
        """Breakaway friction beside a kinetic level; without one, its decay slow enough to hold
        back a moving drive at every speed (a Stribeck velocity far above the low speeds) makes
        it the model's kinetic friction."""
        return BREAKAWAY_FRICTION if any(n in model for n in KINETIC) else KINETIC_FRICTION

    def level(self, params: dict[str, float]) -> float:
        """The excess F_s at rest over the kinetic level [F]."""
        return float(params["stribeck"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        lo = max(2.0 * scale["w_noise"], 1e-3 * scale["w_max"])
        return {"stribeck_velocity": (lo, 0.3 * scale["w_max"])}


class AsymmetricFriction(Effect):
    """Direction-dependent friction: ``T = ΔF_c |sgn w| + ΔF_v |w|`` [F] on top of B w + F_c sgn w.

    Forwards the friction is ``(F_c + ΔF_c) + (B + ΔF_v) w``, backwards
    ``-(F_c - ΔF_c) + (B - ΔF_v) w``. While the drive moves, ΔF_c is the same
    column as a constant offset; the fit drops it when an offset is in the model.
    It refines a model's Coulomb and viscous friction, so it is a candidate only
    once both are in the model.
    """

    name = "asymmetric_friction"
    linear = ("coulomb_asymmetry", "viscous_asymmetry")
    units: ClassVar[dict[str, str]] = {"coulomb_asymmetry": "F", "viscous_asymmetry": "F s/v"}
    requires = ("coulomb_friction", "viscous_friction")
    signature = "same sign in both directions of motion (even in w), growing with |w|"


class QuadraticDrag(Effect):
    """Quadratic drag ``T = c w |w|`` [F] (windage, fluid drag)."""

    name = "quadratic_drag"
    linear = ("quadratic_drag",)
    units: ClassVar[dict[str, str]] = {"quadratic_drag": "F s²/v²"}
    nonnegative = ("quadratic_drag",)
    signature = "grows as w², sign follows sgn(w), concentrated at the highest |w|"
    acts = "speed"


class Offset(Effect):
    """Constant torque ``T = T_0`` [F] (gravity on a tilted axis, a biased amplifier), also at rest."""

    name = "offset"
    linear = ("offset",)
    units: ClassVar[dict[str, str]] = {"offset": "F"}
    signature = "constant, the same sign in both directions of motion and at rest"


class InputDeadZone(Effect):
    """Input dead zone ``D(u) = 0`` for ``|u| <= d``, else ``u - d sgn(u)`` (paper Fig. 4)."""

    name = "input_dead_zone"
    kind = "input"
    nonlinear = ("dead_zone",)
    units: ClassVar[dict[str, str]] = {"dead_zone": "u"}
    signature = "at small |u| and wherever u drives: a force deficit whose sign follows sgn(u)"
    order = 1

    def physics(self, model: tuple[str, ...]) -> str:
        return KINETIC_FRICTION

    def level(self, params: dict[str, float]) -> float:
        """The force g d the dead zone withholds [F]."""
        return float(params["input_gain"] * params["dead_zone"])

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        return input_path(x, dead_zone=shape["dead_zone"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        return {"dead_zone": (1e-3 * scale["u_max"], 0.5 * scale["u_max"])}


class InputSaturation(Effect):
    """Input saturation ``S(u) = clip(u, -u_s, u_s)``."""

    name = "input_saturation"
    kind = "input"
    nonlinear = ("saturation",)
    units: ClassVar[dict[str, str]] = {"saturation": "u"}
    signature = "at the largest |u| only, sign follows sgn(u): the drive gets less than commanded"
    order = 0

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        return input_path(x, saturation=shape["saturation"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        return {"saturation": (0.2 * scale["u_max"], scale["u_max"])}


class Backlash(Effect):
    """Lost motion: the drive force is not transmitted for ``τ_b`` after each reversal of its sign.

    See the module notes for what this models and how τ_b relates to the play.
    """

    name = "backlash"
    kind = "input"
    nonlinear = ("backlash_time",)
    units: ClassVar[dict[str, str]] = {"backlash_time": "s"}
    signature = "right after each reversal of the drive force: the measured side lags, sign follows the force"
    order = 4

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        return backlash_dwell(x, dt, shape["backlash_time"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        # a dwell shorter than the decimated sample time is below the band the balance resolves
        lo = scale.get("dt_band", scale["dt"])
        return {"backlash_time": (lo, max(2.0 * lo, min(50.0 * scale["dt"], 0.3)))}


class InputDelay(Effect):
    """Transport delay of the input path ``Δ(x)(t) = x(t - τ_d)``, whole and fractional samples
    (driver latency, a controller's computation time)."""

    name = "input_delay"
    kind = "input"
    nonlinear = ("input_delay",)
    units: ClassVar[dict[str, str]] = {"input_delay": "s"}
    signature = "after every change of u: the measured drive answers τ_d late, in both directions"
    order = 2
    structure = True

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        # with a lag in the model the two are one map (the drive's), applied here
        return input_dynamics(x, dt, shape["input_delay"], shape.get("lag_time_constant", 0.0))

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        # from a twentieth of a sample (below it the balance cannot tell) to 20 samples
        return {"input_delay": (0.05 * scale["dt"], 20.0 * scale["dt"])}


class InputLag(Effect):
    """First-order lag of the input path ``T_l dz/dt = x - z`` (driver bandwidth, current loop;
    on the linear part the same as a first-order speed filter in the measurement)."""

    name = "input_lag"
    kind = "input"
    nonlinear = ("lag_time_constant",)
    units: ClassVar[dict[str, str]] = {"lag_time_constant": "s"}
    signature = "after every change of u: the force builds up over T_l, the acceleration is rounded"
    order = 3
    structure = True

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        if "input_delay" in shape:
            return x  # the delay's transform applied the lag with it (one map)
        return input_dynamics(x, dt, 0.0, shape["lag_time_constant"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        return {"lag_time_constant": (0.1 * scale["dt"], 100.0 * scale["dt"])}


class StaticFriction(Effect):
    """Static friction above the kinetic level: a drive at rest breaks away only when the net
    force exceeds the kinetic level at 0± by ``ΔF_s`` [F]; moving, it slows against the kinetic
    level alone, so it breaks away high and keeps moving down to a lower force (hysteresis).

    It acts through the stick/slip rule of the free run only; the balance of the moving
    samples does not see it, so a fit of the balance keeps the value it is given, and the
    workflow fits and judges it on the free run
    (:func:`~motorid.diagnose.workflow.fit_static_friction`).
    """

    name = "static_friction"
    nonlinear = ("breakaway_excess",)
    units: ClassVar[dict[str, str]] = {"breakaway_excess": "F"}
    nonnegative = ("breakaway_excess",)
    signature = "at rest only: the drive stays stuck under forces beyond its kinetic friction level"
    rest_only = True
    acts = "rests"

    def physics(self, model: tuple[str, ...]) -> str:
        """Breakaway friction, in a model with a kinetic level to break away above."""
        return BREAKAWAY_FRICTION if any(n in model for n in (*KINETIC, "stribeck_friction")) else ""

    def level(self, params: dict[str, float]) -> float:
        """The breakaway excess ΔF_s [F]."""
        return float(params["breakaway_excess"])


_CLASSES: tuple[type[Effect], ...] = (
    CoulombFriction,
    StribeckFriction,
    AsymmetricFriction,
    ViscousFriction,
    QuadraticDrag,
    InputDeadZone,
    InputSaturation,
    Backlash,
    Offset,
    InputDelay,
    InputLag,
    StaticFriction,
)

#: The library: effect name -> effect class, in the order of the drive's effects
#: (:data:`motorid.drive.rigid.RIGID_EFFECTS`).
EFFECTS: dict[str, type[Effect]] = {
    name: cls for name in RIGID_EFFECTS for cls in _CLASSES if cls.name == name
}


def get_effect(name: str) -> Effect:
    """The effect called ``name``; ValueError naming the known ones otherwise.

    Parameters
    ----------
    name : str
        An effect's snake_case name (``coulomb_friction``, ...).
    """
    try:
        return EFFECTS[name]()
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None


#: Units of the parameters every model has (``F`` force, ``v`` velocity, ``u`` input).
MODEL_UNITS: dict[str, str] = {"inertia": "F s/v", "input_gain": "F/u"}


def param_unit(name: str, units: dict[str, str]) -> str:
    """Concrete unit of parameter ``name`` (of any effect, or ``inertia``/``input_gain``).

    Parameters
    ----------
    name : str
        Parameter name, e.g. ``"viscous"``.
    units : dict
        Concrete ``F``, ``v`` and ``u`` (:attr:`motorid.diagnose.Diagnosis.units`).

    Returns
    -------
    str
        E.g. ``"N m s/(rad/s)"`` for ``viscous`` of a rotary drive with a known
        input gain, ``"V"`` for ``coulomb`` without one (forces per volt).
    """
    templates = dict(MODEL_UNITS)
    for cls in EFFECTS.values():
        templates.update(cls.units)
    out = []
    after_slash = False
    for token in templates[name].replace("/", " / ").split():
        base = token.rstrip("²")
        power = token[len(base) :]
        unit = units.get(base, base)
        compound = " " in unit or "/" in unit
        out.append(f"({unit}){power}" if compound and (power or after_slash) else unit + power)
        after_slash = token == "/"
    return " ".join(out).replace(" / ", "/")


def is_finite_number(value: float) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


__all__ = [
    "EFFECTS",
    "MODEL_UNITS",
    "AsymmetricFriction",
    "Backlash",
    "CoulombFriction",
    "Effect",
    "InputDeadZone",
    "InputDelay",
    "InputLag",
    "InputSaturation",
    "Offset",
    "QuadraticDrag",
    "StaticFriction",
    "StribeckFriction",
    "ViscousFriction",
    "get_effect",
    "param_unit",
]
