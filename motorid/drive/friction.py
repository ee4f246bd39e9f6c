"""Friction models for the two-mass drive, as composable objects.

Every friction object acts on one side of the drive: the motor mass
(``side="motor"``), the load mass (``side="load"``) or both (``side="both"``,
the same law applied to each mass). A rig takes any tuple of them and adds their
torques, so the friction torque on a mass in eqs. (12)-(13) of the paper is

    T_f(ω) = Σ_k T_f,k(ω)

Static (memoryless) laws, all special cases of the asymmetric law, eq. (11):

- :class:`ViscousLaw`       T_f = B ω                                [N m]
- :class:`CoulombLaw`       T_f = α sgn(ω)                            eq. (8)
- :class:`StribeckLaw`      T_f = (α0 + α1 exp(-α2 |ω|)) sgn(ω)      eq. (9)
- :class:`AsymmetricLaw`    T_f = (α0 + α1 e^{-α2|ω|}) sgn1(ω)
                                     + (α3 + α4 e^{-α5|ω|}) sgn2(ω)        eq. (11)

The Stribeck and asymmetric laws take ``stribeck_shape="gaussian"`` for the decay
exp(-(α2 ω)²) instead of the paper's exp(-α2 |ω|): both shapes are common on real
drives, and the doctor names either.

and one dynamic law, :class:`LuGreLaw` (Canudas de Wit et al., 1995), with
an internal bristle state z per mass.

Zero speed is not smoothed: the integrators use the breakaway torques of the
static laws for Karnopp-style stick/slip switching (a mass at exactly zero speed
stays there while the torque applied to it lies inside
``[-breakaway_negative, breakaway_positive]``). Each law is written once, as a
compiled function in :mod:`~motorid.drive.kernels` (eq. 11:
``friction_law``; LuGre: ``lugre_level`` and ``lugre_rate``; the stick/slip rule:
``stick_or_slip``): the ``torque`` methods here, the fast integrator (from
:func:`pack_static_friction` rows) and the reference integrator all call them.

Each law's ``kind`` (its name in ``to_dict`` and in model files) is its effect name,
the snake_case vocabulary the diagnose workflow names effects with:
``viscous_friction``, ``coulomb_friction``, ``stribeck_friction``,
``asymmetric_friction``, and ``lugre_friction``. A law is the per-side, α-form of an
effect on one mass of the rig (``*Law``); the effect itself, on a rigid drive, is the class
of that name in :mod:`motorid.drive.effects` (``CoulombFriction``, ...).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np
import numpy.typing as npt

from motorid.drive.kernels import (
    STRIBECK_EXPONENTIAL,
    STRIBECK_SHAPES,
    friction_torques,
    lugre_levels,
    lugre_rates,
)
from motorid.drive.ranges import check_parameter
from motorid.errors import ModelFileError
from motorid.json_input import key_path, scalars, text

Side = Literal["motor", "load", "both"]
SIDES: tuple[str, ...] = ("motor", "load", "both")

StribeckShape = Literal["exponential", "gaussian"]

#: Column layout of a packed static-friction row (see :func:`pack_static_friction`).
STATIC_ROW_WIDTH = 8


def _check_side(side: str) -> None:
    if side not in SIDES:
        raise ValueError(f"side must be one of {SIDES}, got {side!r}")


def _check_shape(shape: str) -> None:
    if shape not in STRIBECK_SHAPES:
        raise ValueError(f"stribeck_shape must be one of {', '.join(STRIBECK_SHAPES)}, got {shape!r}")


def _check_nonnegative(**values: float) -> None:
    for name, value in values.items():
        if not (isinstance(value, numbers.Real) and math.isfinite(value) and value >= 0.0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        check_parameter(name, value, "(SI units)")


@dataclass(frozen=True)
class Friction:
    """Base class: a friction law acting on ``side`` of the drive (keyword-only).

    Parameters
    ----------
    side : {"motor", "load", "both"}
        The mass the law acts on.
    """

    kind: ClassVar[str] = "friction"
    side: Side = field(default="both", kw_only=True)

    def __post_init__(self) -> None:
        _check_side(self.side)

    def sides(self) -> tuple[str, ...]:
        """The masses this law acts on: a subset of ``("motor", "load")``."""
        return ("motor", "load") if self.side == "both" else (self.side,)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able description, ``{"kind": ..., <parameters>}``."""
        return {"kind": self.kind, **asdict(self)}


@dataclass(frozen=True)
class ViscousLaw(Friction):
    """Viscous friction ``T_f = B ω`` [N m], added to B_m or B_L of eqs. (4)-(5).

    Parameters
    ----------
    B : float
        Viscous coefficient [N m s/rad], >= 0.
    side : {"motor", "load", "both"}
    """

    kind: ClassVar[str] = "viscous_friction"
    B: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_nonnegative(B=self.B)

    def torque(self, omega: npt.ArrayLike, direction: float = 0.0) -> np.ndarray:
        """Friction torque [N m] at speed ``omega`` [rad/s]."""
        return self.B * np.asarray(omega, dtype=float)


@dataclass(frozen=True)
class MemorylessLaw(Friction):
    """A memoryless friction law written in the asymmetric form of eq. (11).

    Subclasses provide :meth:`coefficients`: ``(α0, α1, α2, α3, α4, α5)`` with
    ``T_f = α0 + α1 exp(-α2 |ω|)`` for motion in the positive direction and
    ``T_f = -(α3 + α4 exp(-α5 |ω|))`` for motion in the negative direction.

    Parameters
    ----------
    side : {"motor", "load", "both"}
        The mass the law acts on.
    """

    kind: ClassVar[str] = "static"

    def coefficients(self) -> tuple[float, float, float, float, float, float]:
        raise NotImplementedError

    def shape_code(self) -> int:
        """The compiled code of the Stribeck decay's shape (exponential unless the law has one)."""
        return STRIBECK_EXPONENTIAL

    @property
    def breakaway_positive(self) -> float:
        """Torque [N m] needed to start a stuck mass moving forwards: α0 + α1."""
        a = self.coefficients()
        return a[0] + a[1]

    @property
    def breakaway_negative(self) -> float:
        """Magnitude of the torque [N m] needed to start it backwards: α3 + α4."""
        a = self.coefficients()
        return a[3] + a[4]

    def torque(self, omega: npt.ArrayLike, direction: float = 0.0) -> np.ndarray:
        """Friction torque [N m] opposing motion at speed ``omega`` [rad/s].

        Where ``omega == 0`` the value for motion in the direction
        ``sgn(direction)`` is returned (the kinetic level at 0±, what the
        integrators use at breakaway); ``direction=0`` gives 0 there, as sgn(0) = 0
        in eq. (10). Evaluated by the integrators' compiled law
        (:func:`~motorid.drive.kernels.friction_law`).
        """
        w = np.asarray(omega, dtype=float)
        flat = np.ascontiguousarray(w.reshape(-1))
        out = friction_torques(
            np.array(self.coefficients(), dtype=float), flat, float(direction), self.shape_code()
        )
        return out.reshape(w.shape)


@dataclass(frozen=True)
class CoulombLaw(MemorylessLaw):
    """Coulomb friction, eq. (8): ``T_f(ω) = α sgn(ω)`` [N m].

    Parameters
    ----------
    alpha : float
        Coulomb level α [N m], >= 0; also the breakaway torque.
    side : {"motor", "load", "both"}
    """

    kind: ClassVar[str] = "coulomb_friction"
    alpha: float = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_nonnegative(alpha=self.alpha)

    def coefficients(self) -> tuple[float, float, float, float, float, float]:
        return (self.alpha, 0.0, 0.0, self.alpha, 0.0, 0.0)


@dataclass(frozen=True)
class StribeckLaw(MemorylessLaw):
    """Coulomb plus Stribeck friction, eq. (9).

    ``T_f(ω) = α0 sgn(ω) + α1 exp(-α2 |ω|) sgn(ω)`` [N m].

    Parameters
    ----------
    alpha0 : float
        Coulomb level α0 [N m], >= 0.
    alpha1 : float
        Static excess α1 [N m], >= 0; breakaway torque is α0 + α1.
    alpha2 : float
        Stribeck decay rate α2 [s/rad], >= 0 (1/ω_s, ω_s the Stribeck speed).
    stribeck_shape : {"exponential", "gaussian"}
        The decay: exp(-α2 |ω|) (eq. 9) or exp(-(α2 ω)²).
    side : {"motor", "load", "both"}
    """

    kind: ClassVar[str] = "stribeck_friction"
    alpha0: float = 0.0
    alpha1: float = 0.0
    alpha2: float = 0.0
    stribeck_shape: StribeckShape = "exponential"

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_nonnegative(alpha0=self.alpha0, alpha1=self.alpha1, alpha2=self.alpha2)
        _check_shape(self.stribeck_shape)

    def coefficients(self) -> tuple[float, float, float, float, float, float]:
        return (self.alpha0, self.alpha1, self.alpha2, self.alpha0, self.alpha1, self.alpha2)

    def shape_code(self) -> int:
        return STRIBECK_SHAPES.index(self.stribeck_shape)


@dataclass(frozen=True)
class AsymmetricLaw(MemorylessLaw):
    """Asymmetric Coulomb-Stribeck friction, eq. (11).

    ``T_f(ω) = (α0 + α1 e^{-α2|ω|}) sgn1(ω) + (α3 + α4 e^{-α5|ω|}) sgn2(ω)`` [N m],
    with sgn1 = 1 for ω >= 0 (else 0) and sgn2 = -1 for ω < 0 (else 0).

    Parameters
    ----------
    alpha0, alpha1, alpha2 : float
        Coulomb level [N m], static excess [N m] and decay rate [s/rad] for ω > 0.
    alpha3, alpha4, alpha5 : float
        The same for ω < 0 (magnitudes).
    stribeck_shape : {"exponential", "gaussian"}
        The decays: e^{-α|ω|} (eq. 11) or e^{-(α ω)²}.
    side : {"motor", "load", "both"}
    """

    kind: ClassVar[str] = "asymmetric_friction"
    alpha0: float = 0.0
    alpha1: float = 0.0
    alpha2: float = 0.0
    alpha3: float = 0.0
    alpha4: float = 0.0
    alpha5: float = 0.0
    stribeck_shape: StribeckShape = "exponential"

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_nonnegative(
            alpha0=self.alpha0, alpha1=self.alpha1, alpha2=self.alpha2,
            alpha3=self.alpha3, alpha4=self.alpha4, alpha5=self.alpha5,
        )  # fmt: skip
        _check_shape(self.stribeck_shape)

    def coefficients(self) -> tuple[float, float, float, float, float, float]:
        return (self.alpha0, self.alpha1, self.alpha2, self.alpha3, self.alpha4, self.alpha5)

    def shape_code(self) -> int:
        return STRIBECK_SHAPES.index(self.stribeck_shape)

    def torque(self, omega: npt.ArrayLike, direction: float = 1.0) -> np.ndarray:
        """Eq. (11) literally; at ω == 0 sgn1 = 1, so the default direction is +1."""
        return super().torque(omega, direction)


@dataclass(frozen=True)
class LuGreLaw(Friction):
    """LuGre dynamic friction (Canudas de Wit, Olsson, Åström, Lischinsky 1995).

    With bristle deflection z [rad] on a mass turning at ω [rad/s]::

        g(ω)  = Fc + (Fs - Fc) exp(-(ω/ωs)^2)                       [N m]
        dz/dt = ω - σ0 |ω| z / g(ω)                                 [rad/s]
        T_f   = σ0 z + σ1 dz/dt + σ2 ω                              [N m]

    At constant speed T_f tends to ``g(ω) sgn(ω) + σ2 ω``. Sticking is part of
    the law (pre-sliding displacement of about Fc/σ0), so no Karnopp switching
    is added for it. The fast integrator treats the bristle spring explicitly
    within a sub-step: keep ``h sqrt(σ0/J) < 0.5`` (h the internal step).

    Parameters
    ----------
    sigma0 : float
        Bristle stiffness σ0 [N m/rad], > 0.
    sigma1 : float
        Bristle damping σ1 [N m s/rad], >= 0.
    sigma2 : float
        Viscous coefficient σ2 [N m s/rad], >= 0.
    Fc, Fs : float
        Coulomb and static levels [N m], Fs >= Fc > 0.
    omega_s : float
        Stribeck speed ωs [rad/s], > 0.
    side : {"motor", "load", "both"}
    """

    kind: ClassVar[str] = "lugre_friction"
    sigma0: float = 1.0
    sigma1: float = 0.0
    sigma2: float = 0.0
    Fc: float = 0.0
    Fs: float = 0.0
    omega_s: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_nonnegative(
            sigma0=self.sigma0, sigma1=self.sigma1, sigma2=self.sigma2,
            Fc=self.Fc, Fs=self.Fs, omega_s=self.omega_s,
        )  # fmt: skip
        for name in ("sigma0", "Fc", "omega_s"):
            check_parameter(name, getattr(self, name), "(SI units)", sign="> 0")
        if self.Fs < self.Fc:
            raise ValueError(f"Fs must be >= Fc, got Fs={self.Fs!r} < Fc={self.Fc!r}")

    def g(self, omega: npt.ArrayLike) -> np.ndarray:
        """Stribeck curve g(ω) [N m] (:func:`~motorid.drive.kernels.lugre_level`)."""
        w = np.asarray(omega, dtype=float)
        flat = np.ascontiguousarray(w.reshape(-1))
        return lugre_levels(self.Fc, self.Fs, self.omega_s, flat).reshape(w.shape)

    def z_dot(self, z: npt.ArrayLike, omega: npt.ArrayLike) -> np.ndarray:
        """Bristle rate dz/dt [rad/s] (:func:`~motorid.drive.kernels.lugre_rate`)."""
        zb, wb = np.broadcast_arrays(np.asarray(z, dtype=float), np.asarray(omega, dtype=float))
        flat_z = np.ascontiguousarray(zb.reshape(-1))
        flat_w = np.ascontiguousarray(wb.reshape(-1))
        return lugre_rates(self.sigma0, self.Fc, self.Fs, self.omega_s, flat_z, flat_w).reshape(wb.shape)

    def torque(self, z: npt.ArrayLike, omega: npt.ArrayLike) -> np.ndarray:
        """Friction torque [N m] for bristle state ``z`` [rad] at speed ``omega``."""
        w = np.asarray(omega, dtype=float)
        return self.sigma0 * np.asarray(z) + self.sigma1 * self.z_dot(z, w) + self.sigma2 * w

    def steady_state_torque(self, omega: npt.ArrayLike) -> np.ndarray:
        """Friction torque [N m] after a long run at constant ``omega``."""
        w = np.asarray(omega, dtype=float)
        return self.g(w) * np.sign(w) + self.sigma2 * w


FRICTION_KINDS: dict[str, type[Friction]] = {
    cls.kind: cls
    for cls in (
        ViscousLaw,
        CoulombLaw,
        StribeckLaw,
        AsymmetricLaw,
        LuGreLaw,
    )
}


def friction_from_dict(data: dict[str, Any], where: str = "") -> Friction:
    """Rebuild a friction law from :meth:`Friction.to_dict` output, every key checked
    (the reader the rig and the model files use).

    Parameters
    ----------
    data : dict
        ``{"kind": ..., <parameters>}``, parameters in SI units.
    where : str
        Where ``data`` sits in its file (``"model.friction[1]"``), put in front of the
        key an error names.

    Raises
    ------
    motorid.errors.ModelFileError
        A DataError naming an unknown ``kind`` or a missing, mistyped or bad parameter.
    """
    if not isinstance(data, dict):
        raise ModelFileError(where, f"must be a JSON object, got {type(data).__name__}")
    kind = text(data.get("kind"), key_path(where, "kind"))
    if kind not in FRICTION_KINDS:
        raise ModelFileError(
            key_path(where, "kind"), f"unknown friction law {kind!r} (known: {', '.join(FRICTION_KINDS)})"
        )
    return scalars(FRICTION_KINDS[kind], {k: v for k, v in data.items() if k != "kind"}, where)


def side_index(side: str) -> int:
    """0 for the motor mass, 1 for the load mass."""
    return {"motor": 0, "load": 1}[side]


def pack_static_friction(frictions: Iterable[Friction]) -> np.ndarray:
    """Rows ``[side, α0, α1, α2, α3, α4, α5, shape]`` for the compiled integrator.

    ``side`` is 0 (motor) or 1 (load), ``shape`` the Stribeck shape's code; a
    ``side="both"`` law gives two rows.
    Viscous and LuGre laws are not packed here. Shape ``(n, 7)``, at least one
    (all-zero, inert) row so the array is never empty.
    """
    rows: list[list[float]] = []
    for f in frictions:
        if isinstance(f, MemorylessLaw):
            for s in f.sides():
                rows.append([float(side_index(s)), *map(float, f.coefficients()), float(f.shape_code())])
    if not rows:
        rows.append([0.0] * STATIC_ROW_WIDTH)
    return np.ascontiguousarray(rows, dtype=np.float64)


def pack_lugre(frictions: Sequence[Friction]) -> np.ndarray:
    """Per-mass LuGre rows ``[active, σ0, σ1, Fc, Fs, ωs]``, shape (2, 6).

    σ2 is viscous and goes into the linear part. Raises ValueError if a mass
    has more than one LuGre law.
    """
    out = np.zeros((2, 6))
    out[:, 1] = 1.0
    out[:, 3] = 1.0
    out[:, 4] = 1.0
    out[:, 5] = 1.0
    for f in frictions:
        if isinstance(f, LuGreLaw):
            for s in f.sides():
                k = side_index(s)
                if out[k, 0]:
                    raise ValueError(f"friction: more than one LuGreLaw on the {s} side")
                out[k] = [1.0, f.sigma0, f.sigma1, f.Fc, f.Fs, f.omega_s]
    return out


def viscous_total(frictions: Iterable[Friction], side: str) -> float:
    """Extra viscous coefficient [N m s/rad] on ``side`` (ViscousLaw B + LuGre σ2)."""
    total = 0.0
    for f in frictions:
        if side in f.sides():
            if isinstance(f, ViscousLaw):
                total += f.B
            elif isinstance(f, LuGreLaw):
                total += f.sigma2
    return total


def breakaway(frictions: Iterable[Friction], side: str) -> tuple[float, float]:
    """Breakaway torques ``(positive, negative magnitude)`` [N m] of the static laws on ``side``."""
    pos = neg = 0.0
    for f in frictions:
        if isinstance(f, MemorylessLaw) and side in f.sides():
            pos += f.breakaway_positive
            neg += f.breakaway_negative
    return pos, neg
