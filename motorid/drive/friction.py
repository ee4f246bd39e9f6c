"""The friction on the masses of the two-mass rig, in the effects' vocabulary.

A :class:`Friction` is a set of effects (:mod:`motorid.drive.effects`) with their parameters on
one mass of the rig (``side="motor"``, ``"load"``, or ``"both"``: the same friction on each), the
same effect objects, parameter names and compiled terms as a rigid drive's
(:class:`~motorid.drive.rigid.RigidDrive`). The friction torque on a mass in eqs. (12)-(13) of the
paper is the sum over the entries on it::

    T_f(ω) = Σ_k Σ_t θ_t T_t(ω)                                                          [N m]

with ``T_t`` the rigid drive's terms (:func:`~motorid.drive.kernels.rigid_term`): Coulomb
``F_c sgn ω`` (eq. 8), Stribeck ``F_s decay(ω) sgn ω`` (eq. 9, ``decay = exp(-|ω|/v_s)`` or the
Gaussian ``exp(-(ω/v_s)²)``), the asymmetry ``ΔF_c + ΔF_v |ω|`` (eq. 11's different levels each
way), viscous ``B ω`` (added to B_m or B_L of eqs. 4-5), quadratic drag ``c ω |ω|``. Zero speed is
not smoothed: the integrators stop a mass at exactly zero speed and hold it there while the torque
on it lies inside ``[-breakaway_backward, breakaway_forward]``, the kinetic levels at 0± raised by
a ``static_friction`` excess ΔF_s (:func:`~motorid.drive.kernels.stick_or_slip`). With
``lugre_friction`` the mass's Coulomb and Stribeck levels act through LuGre's bristle state
instead (:class:`~motorid.drive.effects.lugre.LuGreFriction`), with no stick rule.

Files written before the rig took the effects (eq. 11's laws ``coulomb_friction {"alpha"}``,
``stribeck_friction {"alpha0", "alpha1", "alpha2"}``, ``asymmetric_friction {"alpha0".."alpha5"}``,
``viscous_friction {"B"}``, ``lugre_friction {"sigma0", ...}``) are read as their effects
(:func:`friction_from_dict`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from motorid.drive import effects as registry
from motorid.drive import kernels
from motorid.drive.ranges import check_parameter
from motorid.errors import ModelFileError
from motorid.json_input import build, key_path, number, object_keys, text

SIDES: tuple[str, ...] = ("motor", "load", "both")
#: The SI units of a rotary rig, for the parameters' units in messages.
RIG_UNITS = {"F": "N m", "v": "rad/s", "u": "V", "q": "rad"}
#: The compiled terms a LuGre law takes over from the static rows of its mass.
_LUGRE_TERMS = (kernels.TERM_COULOMB, kernels.TERM_STRIBECK)


def side_index(side: str) -> int:
    """0 for the motor mass, 1 for the load mass.

    Parameters
    ----------
    side : {"motor", "load"}
        The mass.
    """
    return {"motor": 0, "load": 1}[side]


@dataclass(frozen=True)
class Friction:
    """Friction effects with their parameters on one mass of the rig, or on both.

    Parameters
    ----------
    effects : tuple of str
        Effect names (:func:`motorid.drive.effects.names`) a mass can hold (those without
        :attr:`~motorid.drive.effects.Effect.not_on_a_mass`): ``coulomb_friction``,
        ``stribeck_friction``, ``asymmetric_friction``, ``viscous_friction``, ``quadratic_drag``,
        ``static_friction``, ``lugre_friction`` and friction-type plugins; kept in the library's
        order.
    params : dict
        Every parameter of the effects, in SI units (the rigid drive's names: ``coulomb`` [N m],
        ``stribeck_velocity`` [rad/s], ``viscous`` [N m s/rad], ...), physical (non-negative
        levels) and with kinetic levels that are not negative either way.
    side : {"motor", "load", "both"}
        The mass it acts on (``both``: the same friction on each).
    stribeck_shape : {"exponential", "gaussian"}
        Shape of the Stribeck decay, exp(-|ω|/v_s) or exp(-(ω/v_s)²).

    Examples
    --------
    >>> from motorid.drive import Friction
    >>> brushes = Friction(("coulomb_friction",), {"coulomb": 4e-3}, side="motor")
    >>> brushes.breakaway
    (0.004, 0.004)
    """

    effects: tuple[str, ...]
    params: dict[str, float]
    side: str = "both"
    stribeck_shape: str = "exponential"

    def __post_init__(self) -> None:
        if isinstance(self.effects, str):
            raise ValueError(f"effects must be a sequence of effect names, got {self.effects!r}")
        effects = registry.effect_order(tuple(self.effects))
        for name in effects:
            reason = registry.get(name).not_on_a_mass
            if reason:
                raise ValueError(f"{name}: a mass of the two-mass rig cannot hold it ({reason})")
        object.__setattr__(self, "effects", effects)
        if self.side not in SIDES:
            raise ValueError(f"side must be one of {', '.join(SIDES)}, got {self.side!r}")
        if self.stribeck_shape not in kernels.STRIBECK_SHAPES:
            raise ValueError(
                f"stribeck_shape must be one of {', '.join(kernels.STRIBECK_SHAPES)}, got {self.stribeck_shape!r}"
            )
        if not isinstance(self.params, dict):
            raise ValueError(f"params must be a dict of parameter values, got {type(self.params).__name__}")
        expected = [p.name for e in effects for p in registry.get(e).parameters]
        for name in self.params:
            if name not in expected:
                raise ValueError(
                    f"params: {name!r} belongs to no effect of this friction (it holds {', '.join(expected)})"
                )
        params = {}
        for name in expected:
            if name not in self.params:
                raise ValueError(f"params: {name!r} is missing (this friction holds {', '.join(expected)})")
            value = self.params[name]
            if isinstance(value, bool):
                raise ValueError(f"{name} must be a number, got {value!r}")
            unit = registry.param_unit(name, RIG_UNITS)
            params[name] = check_parameter(name, value, unit, sign=registry.parameter(name).sign)
        object.__setattr__(self, "params", params)
        if self.lugre:
            if params.get("coulomb", 0.0) <= 0.0:
                raise ValueError("lugre_friction needs coulomb_friction with coulomb > 0 on its mass")
            for name in ("asymmetric_friction", "static_friction"):
                if name in effects:
                    raise ValueError(
                        f"{name}: a mass with lugre_friction cannot hold it (LuGre's levels are the same "
                        "both ways, and it has its own stiction)"
                    )
        for level, direction in zip(self.kinetic, ("forwards", "backwards"), strict=True):
            if level < 0.0:
                raise ValueError(
                    f"coulomb_asymmetry: the kinetic friction {direction} would be {level:.4g} N m < 0"
                )

    def __hash__(self) -> int:  # a rig holding it is hashable (a cache key), as before its params were a dict
        return hash((self.effects, tuple(self.params.items()), self.side, self.stribeck_shape))

    # ------------------------------------------------------------------ parts
    def sides(self) -> tuple[str, ...]:
        """The masses this friction acts on: a subset of ``("motor", "load")``."""
        return ("motor", "load") if self.side == "both" else (self.side,)

    @property
    def lugre(self) -> bool:
        """Whether the mass's Coulomb and Stribeck levels act through LuGre's bristle state."""
        return "lugre_friction" in self.effects

    @property
    def rate(self) -> float:
        """1/v_s [s/rad], the Stribeck decay's rate (1 without Stribeck friction)."""
        return 1.0 / self.params.get("stribeck_velocity", 1.0)

    @property
    def shape_code(self) -> int:
        """The compiled code of :attr:`stribeck_shape`."""
        return kernels.STRIBECK_SHAPES.index(self.stribeck_shape)

    def terms(self) -> list[tuple[int, float]]:
        """``(term code, coefficient)`` of every linear parameter (``kernels.TERM_*``)."""
        return [
            (term, self.params[name]) for e in self.effects for name, term in registry.get(e).terms.items()
        ]

    @property
    def viscous(self) -> float:
        """The viscous coefficient B [N m s/rad] it adds to its mass (each mass for ``both``)."""
        return sum(c for t, c in self.terms() if t == kernels.TERM_VISCOUS)

    def rows(self) -> list[list[float]]:
        """Rows ``[mass, term, coefficient, rate, shape]`` of the terms the integrators evaluate
        explicitly (:func:`~motorid.drive.kernels.static_friction`): all but the viscous term, which
        is in the rig's linear part, and, with LuGre, the levels its bristle law holds."""
        skip = (kernels.TERM_VISCOUS, *(_LUGRE_TERMS if self.lugre else ()))
        return [row for s in self.sides() for row in self._rows(side_index(s), skip)]

    def _rows(self, mass: int, skip: tuple[int, ...] = ()) -> list[list[float]]:
        """The rows of its terms but those in ``skip``, on mass ``mass`` (0 or 1)."""
        return [
            [float(mass), float(t), c, self.rate, float(self.shape_code)]
            for t, c in self.terms()
            if t not in skip
        ]

    def lugre_row(self) -> list[float]:
        """LuGre's compiled row ``[1, σ0, σ1, F_c, F_s, rate, shape]`` (:func:`~motorid.drive.kernels.lugre_zdot`)."""
        p = self.params
        return [1.0, p["bristle_stiffness"], p["bristle_damping"], p["coulomb"], p.get("stribeck", 0.0),
                self.rate, float(self.shape_code)]  # fmt: skip

    @property
    def kinetic(self) -> tuple[float, float]:
        """The kinetic friction at 0+ and the magnitude at 0- [N m] (LuGre's steady state for it)."""
        levels = []
        for direction in (1.0, -1.0):
            total = sum(
                c * kernels.rigid_term(t, 0.0, direction, self.rate, self.shape_code)
                for t, c in self.terms()
                if t >= kernels.N_SPEED_TERMS
            )
            levels.append(direction * total)
        return levels[0], levels[1]

    @property
    def breakaway(self) -> tuple[float, float]:
        """The torques [N m] that start a mass at rest forwards and backwards (magnitude): the
        kinetic levels at 0± plus a static friction's excess; (0, 0) with LuGre, whose stiction is
        its bristles'."""
        if self.lugre:
            return 0.0, 0.0
        excess = self.params.get("breakaway_excess", 0.0)
        forward, backward = self.kinetic
        return forward + excess, backward + excess

    def torque(self, omega: npt.ArrayLike, direction: float = 0.0) -> np.ndarray:
        """The friction torque [N m] on a mass turning at ``omega`` [rad/s], viscous term included
        (with LuGre, its steady state). Where ``omega == 0`` the torque for motion in the direction
        ``sgn(direction)`` (the kinetic level at 0±); ``direction=0`` gives 0 there.

        Parameters
        ----------
        omega : array_like
            Speeds [rad/s].
        direction : float
            The direction of impending motion at ``omega == 0``.
        """
        w = np.asarray(omega, dtype=float)
        flat = np.ascontiguousarray(w.reshape(-1))
        rows = np.array(self._rows(0) or [[0.0] * 5])
        return kernels.friction_torques(rows, flat, float(direction)).reshape(w.shape)

    def slope(self, omega: float, direction: float) -> float:
        """d/dω of the torque of :meth:`rows` (the viscous term excluded) at ``omega`` [N m s/rad],
        moving in ``direction`` where ``omega == 0``.

        Parameters
        ----------
        omega : float
            Speed [rad/s].
        direction : float
            The direction of motion (its sign) at ``omega == 0``.
        """
        s = math.copysign(1.0, omega) if omega != 0.0 else math.copysign(1.0, direction)
        slope = 0.0
        for t, c in self.terms():
            if t == kernels.TERM_STRIBECK:
                slope += c * s * kernels.stribeck_decay_slope(omega, self.rate, self.shape_code, s)
            elif t == kernels.TERM_VISCOUS_ASYMMETRY:
                slope += c * s
            elif t == kernels.TERM_QUADRATIC_DRAG:
                slope += 2.0 * c * abs(omega)
        return slope

    def replace(self, **changes: Any) -> Friction:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    # ------------------------------------------------------------- description
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description (inverse: :func:`friction_from_dict`)."""
        return {
            "effects": list(self.effects),
            "params": dict(self.params),
            "side": self.side,
            "stribeck_shape": self.stribeck_shape,
        }


def friction_from_dict(data: dict[str, Any], where: str = "") -> Friction:
    """Rebuild a rig's :class:`Friction` from :meth:`Friction.to_dict` output, or from a law of a
    file written before the rig took the effects (see the module notes), every key checked.

    Parameters
    ----------
    data : dict
        ``{"effects", "params", "side", "stribeck_shape"}`` (or ``{"kind", <law parameters>}``).
    where : str
        Where ``data`` sits in its file (``"model.friction[1]"``), put in front of the key an
        error names.

    Raises
    ------
    motorid.errors.ModelFileError
        A DataError naming the unknown effect or law, or the missing, mistyped or bad parameter.
    """
    if not isinstance(data, dict):
        raise ModelFileError(where, f"must be a JSON object, got {type(data).__name__}")
    if "kind" in data:
        return build(Friction, _law_fields(data, where), where)
    object_keys(data, ("effects", "params", "side", "stribeck_shape"), where)
    e_where = key_path(where, "effects")
    p_where = key_path(where, "params")
    effects = registry.effect_order(registry.effect_names_read(data["effects"], e_where))
    for name in effects:
        if registry.get(name).not_on_a_mass:
            raise ModelFileError(e_where, f"{name}: a mass of the two-mass rig cannot hold it")
    names = [p.name for e in effects for p in registry.get(e).parameters]
    params = object_keys(data["params"], names, p_where)
    values = {n: number(params[n], key_path(p_where, n)) for n in names}
    fields = {
        "effects": effects,
        "params": values,
        "side": text(data["side"], key_path(where, "side")),
        "stribeck_shape": text(data["stribeck_shape"], key_path(where, "stribeck_shape")),
    }
    try:
        return Friction(**fields)
    except ValueError as exc:
        name = str(exc).split(" ", 1)[0].rstrip(":")
        raise ModelFileError(key_path(p_where, name) if name in values else where, str(exc)) from None


#: The parameters of the laws of older files, by kind.
_LAW_KEYS = {
    "viscous_friction": ("B",),
    "coulomb_friction": ("alpha",),
    "stribeck_friction": ("alpha0", "alpha1", "alpha2", "stribeck_shape"),
    "asymmetric_friction": ("alpha0", "alpha1", "alpha2", "alpha3", "alpha4", "alpha5", "stribeck_shape"),
    "lugre_friction": ("sigma0", "sigma1", "sigma2", "Fc", "Fs", "omega_s"),
}


def _law_fields(data: dict[str, Any], where: str) -> dict[str, Any]:
    """The :class:`Friction` fields of a law of an older file (eq. 11's α-form, SI units)."""
    kind = text(data["kind"], key_path(where, "kind"))
    if kind not in _LAW_KEYS:
        raise ModelFileError(
            key_path(where, "kind"), f"unknown friction law {kind!r} (known: {', '.join(_LAW_KEYS)})"
        )
    keys = _LAW_KEYS[kind]
    object_keys(data, ("kind", *keys, "side"), where)
    a = {k: number(data[k], key_path(where, k)) for k in keys if k != "stribeck_shape"}
    shape = (
        text(data["stribeck_shape"], key_path(where, "stribeck_shape")) if "stribeck_shape" in keys else None
    )
    params: dict[str, float] = {}
    if kind == "viscous_friction":
        params["viscous"] = a["B"]
    elif kind == "coulomb_friction":
        params["coulomb"] = a["alpha"]
    elif kind == "lugre_friction":
        shape = "gaussian"
        params.update(coulomb=a["Fc"], bristle_stiffness=a["sigma0"], bristle_damping=a["sigma1"])
        if a["Fs"] > a["Fc"]:
            params.update(stribeck=a["Fs"] - a["Fc"], stribeck_velocity=a["omega_s"])
        if a["sigma2"]:
            params["viscous"] = a["sigma2"]
    else:
        if kind == "stribeck_friction":
            a.update(alpha3=a["alpha0"], alpha4=a["alpha1"], alpha5=a["alpha2"])
        if (a["alpha1"], a["alpha2"]) != (a["alpha4"], a["alpha5"]) and (a["alpha1"] or a["alpha4"]):
            raise ModelFileError(
                where,
                "an asymmetric_friction law whose Stribeck excess or rate differs forwards and backwards "
                "(alpha1, alpha2 vs alpha4, alpha5); a mass of the rig has one Stribeck term "
                "(stribeck_friction) and its asymmetry in the Coulomb and viscous levels (asymmetric_friction)",
            )
        forward, backward = a["alpha0"], a["alpha3"]
        if a["alpha1"] and not a["alpha2"]:  # an excess that never decays is Coulomb friction
            forward, backward = forward + a["alpha1"], backward + a["alpha1"]
        elif a["alpha1"]:
            params.update(stribeck=a["alpha1"], stribeck_velocity=1.0 / a["alpha2"])
        params["coulomb"] = 0.5 * (forward + backward)
        if forward != backward:
            params.update(coulomb_asymmetry=0.5 * (forward - backward), viscous_asymmetry=0.0)
    effects = tuple(e for e in registry.names() if _holds(e, params))
    fields: dict[str, Any] = {"effects": effects, "params": params, "side": data["side"]}
    if shape is not None:
        fields["stribeck_shape"] = shape
    return fields


def _holds(effect: str, params: dict[str, float]) -> bool:
    """Whether ``params`` hold every parameter of ``effect`` (and it has some)."""
    names = [p.name for p in registry.get(effect).parameters]
    return bool(names) and all(n in params for n in names)


def pack_rows(frictions: tuple[Friction, ...]) -> np.ndarray:
    """The rows of every entry's terms (:meth:`Friction.rows`), shape (n, 5), for the compiled
    integrators; one inert all-zero row when there are none (the array is never empty).

    Parameters
    ----------
    frictions : tuple of Friction
        The rig's friction.
    """
    rows = [row for f in frictions for row in f.rows()]
    return np.ascontiguousarray(rows or [[0.0] * 5], dtype=np.float64)


def pack_lugre(frictions: tuple[Friction, ...]) -> np.ndarray:
    """Per-mass LuGre rows (:meth:`Friction.lugre_row`), shape (2, 7), inactive rows ``[0, 1, 0, 1,
    0, 1, 0]``; ValueError for two LuGre laws on one mass.

    Parameters
    ----------
    frictions : tuple of Friction
        The rig's friction.
    """
    out = np.array([[0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0]] * 2)
    for f in frictions:
        if f.lugre:
            for s in f.sides():
                k = side_index(s)
                if out[k, 0]:
                    raise ValueError(f"friction: more than one lugre_friction on the {s} side")
                out[k] = f.lugre_row()
    return out


__all__ = ["SIDES", "Friction", "friction_from_dict", "pack_lugre", "pack_rows", "side_index"]
