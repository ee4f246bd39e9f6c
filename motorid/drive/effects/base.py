"""What an effect of a drive is: its parameters, and everything the library does with it.

The model is the rigid drive of :mod:`motorid.drive.rigid` (inertia J, input gain g and the
effects' parameters)::

    J dω/dt = F_in(u) - Σ_e T_e(ω),    F_in(u) = B(g · L(Δ(D(S(u)))))        [F]

``F`` stands for the force unit of the model (N m or N, that of ``g u``; without a known g
the fit takes g = 1 and F is the input's unit), ``v`` for the velocity unit, ``q`` for the
position unit (v s: rad or m) and ``u`` for the input unit (e.g. V);
:func:`motorid.drive.effects.param_unit` makes them concrete.

An effect (one class, one file of this package) is what every part of the library needs
of it:

- the drive: its parameters (:class:`Parameter`: one spelling each, with the unit, the
  physical sign and, for a parameter entering the balance linearly, the code of its
  compiled term ``T_t`` in :mod:`~motorid.drive.kernels`);
- the doctor: its signature (where it shows in the residual of a model that lacks it), the
  search interval of its shape parameters (:meth:`Effect.bounds`), the physics it is a form
  of, where it acts, what it requires; friction-type effects give regressor columns
  ``T_e(ω) = Σ θ_i c_i(ω)`` (``c_i(ω, θ)`` for an effect whose torque depends on the position
  θ, :attr:`Effect.position`), input-path effects transform the input; both are the drive's
  compiled functions, so no term is written twice;
- the friction filters (:mod:`motorid.estimators.friction_kf`): the states it maps to, or
  whether their model holds it as a known part (input path, offset, stick rule).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from motorid.drive import kernels

#: The signs a parameter may be bound to (:func:`motorid.drive.ranges.check_parameter`).
SIGNS = (">= 0", "> 0", "any")
#: The effects that give a model a kinetic friction level (a force that holds back a moving drive
#: at any speed): the Stribeck decay is one only in a model without them.
KINETIC = ("coulomb_friction", "input_dead_zone")
#: The physics effects are forms of (:meth:`Effect.physics`).
KINETIC_FRICTION = "kinetic friction"
BREAKAWAY_FRICTION = "breakaway friction above the kinetic level"


@dataclass(frozen=True)
class Parameter:
    """One parameter of a drive model, spelled once.

    Parameters
    ----------
    name : str
        Its name in the drive's ``params``, model files and the doctor's JSON.
    unit : str
        Its unit in the model's ``F`` (force), ``v`` (velocity) and ``u`` (input) units,
        e.g. ``"F s/v"``.
    sign : {">= 0", "> 0", "any"}
        Its sign in a physical drive (what a model file and :meth:`RigidDrive.check_physical
        <motorid.drive.rigid.RigidDrive.check_physical>` require, and what a fit of the doctor
        must give for the effect to be physical).
    term : int or None
        For a parameter that enters the balance linearly (fitted by least squares), the code of
        its compiled term ``T_t`` (``kernels.TERM_*``): its torque is ``θ T_t(ω)``. None for a
        shape parameter (fitted by a bounded search) and for a linear parameter of a torque that
        depends on the position (``in_position``).
    in_position : bool
        It enters the balance linearly as the amplitude of a torque that depends on the position
        (the effect's :meth:`Effect.columns` from the position; the drive's compiled position
        ripple, :func:`~motorid.drive.kernels.ripple_torque`), not through a speed term.
    """

    name: str
    unit: str
    sign: str = ">= 0"
    term: int | None = None
    in_position: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise ValueError(f"name must be a snake_case identifier, got {self.name!r}")
        if self.sign not in SIGNS:
            raise ValueError(f"{self.name}: sign must be one of {', '.join(SIGNS)}, got {self.sign!r}")
        if self.term is not None and (
            isinstance(self.term, bool)
            or not isinstance(self.term, int)
            or not 0 <= self.term < kernels.N_TERMS
        ):
            raise ValueError(
                f"{self.name}: term must be a compiled term code in [0, {kernels.N_TERMS}), got {self.term!r}"
            )
        if self.in_position and self.term is not None:
            raise ValueError(f"{self.name}: a parameter of a position torque has no speed term")

    @property
    def linear(self) -> bool:
        """Whether it enters the balance linearly (it has a compiled term, or is the amplitude of
        a torque that depends on the position)."""
        return self.term is not None or self.in_position


#: The parameters every rigid drive has: inertia J [F s/v = kg m² or kg] and input gain g [F/u].
DRIVE_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("inertia", "F s/v", "> 0"),
    Parameter("input_gain", "F/u", "> 0"),
)


class Effect:
    """One physical effect of a drive (a stateless description; one class per effect).

    A subclass declares its class attributes; the ones derived from ``parameters``
    (``linear``, ``nonlinear``, ``units``, ``signs``, ``terms``, ``nonnegative``) are set
    when the class is made.

    Class attributes
    ----------------
    name : str
        snake_case name (DESIGN.md); never renamed: model files and the doctor's JSON use it.
    kind : {"friction", "input"}
        ``friction``: adds torque terms to the balance; ``input``: transforms the input path.
    parameters : tuple of Parameter
        Its parameters, linear ones first (the order of the drive's ``params``).
    linear, nonlinear : tuple of str
        The parameters that enter the balance linearly (least squares) and the shape
        parameters found by a bounded one-dimensional search.
    units, signs, terms : dict
        Parameter -> unit, -> sign, and (linear ones) -> compiled term code.
    nonnegative : tuple of str
        Parameters that are >= 0 (or > 0) for the effect to be physical (a fit with a
        negative value is not this effect).
    signature : str
        Where the effect shows in the residual of a model that lacks it.
    order : int
        Position in the input path (input effects): saturation, dead zone, delay, lag, then
        backlash.
    structure : bool
        Part of the base structure (delay, lag), chosen from the data before any other effect
        is judged (:func:`motorid.diagnose.workflow.choose_structure`), not a candidate of the
        steps.
    rest_only : bool
        Acts on a drive at rest only (static friction): invisible to the balance of the moving
        samples, so a fit of the balance keeps its value as given; the doctor fits and judges
        it on the free run.
    requires : tuple of str
        Effects that must be in the model before this one is a candidate.
    acts : {"", "rests", "rest", "speed"}
        Where the effect acts, so where it is judged against the noise: ``rests`` at the rests
        and breakaways the record shows (static friction), ``rest`` at the lowest speeds (a
        Stribeck decay), ``speed`` at the highest speeds (quadratic drag), empty for everywhere
        (:meth:`motorid.diagnose.workflow.Pool.band_floor`).
    filter_states : tuple of str
        The friction filters' estimated states it maps to (``coulomb``, ``coulomb_neg``,
        ``viscous``, ``stribeck``); :meth:`filter_prior` gives their starting values.
    filter_known : bool
        The friction filters' model holds it as a known part (input path, offset, stick rule).
        An effect with neither is refused by the filters.
    filter_zero : tuple of str
        Parameters the filters' model does not hold: they must be 0 for it to hold the effect.
    position : bool
        Its torque depends on the position θ [v s] (a ripple periodic in it, cogging): its
        :meth:`columns` need the position, the drive runs its :meth:`ripple` in the compiled free
        run, and the doctor finds its shape where the residual shows it in position
        (:meth:`locate`).
    measured_position : bool
        The doctor tries it by default only on a record of the position (asked for, on any): the
        position the effect depends on is then where the drive is, not the integral of a measured
        speed, which drifts.
    derived_units : dict
        Unit of each figure :meth:`derived` reports beside the parameters.
    not_on_a_mass : str
        Why a mass of the two-mass rig (:class:`~motorid.drive.friction.Friction`) cannot hold it;
        empty for an effect it can (every torque of the speed, static friction, LuGre).
    not_on_a_rigid_drive : str
        Why a rigid drive (and so the doctor) cannot hold it; empty for one it can.
    """

    name: ClassVar[str] = ""
    kind: ClassVar[str] = "friction"
    parameters: ClassVar[tuple[Parameter, ...]] = ()
    signature: ClassVar[str] = ""
    order: ClassVar[int] = 0
    requires: ClassVar[tuple[str, ...]] = ()
    structure: ClassVar[bool] = False
    rest_only: ClassVar[bool] = False
    acts: ClassVar[str] = ""
    filter_states: ClassVar[tuple[str, ...]] = ()
    filter_known: ClassVar[bool] = False
    filter_zero: ClassVar[tuple[str, ...]] = ()
    position: ClassVar[bool] = False
    measured_position: ClassVar[bool] = False
    derived_units: ClassVar[dict[str, str]] = {}
    not_on_a_mass: ClassVar[str] = ""
    not_on_a_rigid_drive: ClassVar[str] = ""

    # derived from ``parameters`` when the class is made
    linear: ClassVar[tuple[str, ...]] = ()
    nonlinear: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}
    signs: ClassVar[dict[str, str]] = {}
    terms: ClassVar[dict[str, int]] = {}
    nonnegative: ClassVar[tuple[str, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        params = tuple(cls.parameters)
        cls.linear = tuple(p.name for p in params if p.linear)
        cls.nonlinear = tuple(p.name for p in params if not p.linear)
        if tuple(p.name for p in params) != (*cls.linear, *cls.nonlinear):
            raise TypeError(f"{cls.__name__}: its linear parameters must come before its shape parameters")
        cls.units = {p.name: p.unit for p in params}
        cls.signs = {p.name: p.sign for p in params}
        cls.terms = {p.name: p.term for p in params if p.term is not None}
        cls.nonnegative = tuple(p.name for p in params if p.sign != "any")

    @property
    def in_filter(self) -> bool:
        """Whether the friction filters' model holds this effect (as states or as a known part)."""
        return bool(self.filter_states) or self.filter_known

    def physics(self, model: tuple[str, ...]) -> str:
        """The physics this effect is one form of when added to a model with the effects
        ``model``: effects of one physics are what a record may not tell apart (``kinetic
        friction``: Coulomb friction and an input dead zone on a drive that never reverses while
        moving). Empty for none. :meth:`level` gives its size.

        Parameters
        ----------
        model : tuple of str
            The effects of the model it is added to.
        """
        return ""

    def level(self, params: dict[str, float]) -> float:
        """The size of its :meth:`physics` in a model's ``params`` [F] (NaN for an effect without one).

        Parameters
        ----------
        params : dict
            The model's parameters.
        """
        return math.nan

    def columns(
        self,
        w: np.ndarray,
        shape: dict[str, float],
        stribeck_shape: str = "exponential",
        position: np.ndarray | None = None,
    ) -> np.ndarray:
        """Regressor columns ``c_i(ω)``, shape (N, len(linear)): the torque per unit parameter of
        the linear parameters, for a drive moving in the direction sgn(ω)
        (:func:`~motorid.drive.kernels.rigid_columns`).

        Parameters
        ----------
        w : numpy.ndarray, shape (N,)
            Speeds ω [v].
        shape : dict
            Shape parameters by name (``stribeck_velocity`` [v]; 1 when absent).
        stribeck_shape : {"exponential", "gaussian"}
            Shape of the Stribeck decay.
        position : numpy.ndarray, shape (N,), optional
            Positions θ [v s] at the samples of ``w``, for an effect whose torque depends on it
            (:attr:`position`); the others ignore it.
        """
        if not self.linear:
            return np.zeros((w.size, 0))
        terms = np.array([self.terms[p] for p in self.linear], dtype=np.int64)
        speeds = np.ascontiguousarray(np.asarray(w, dtype=float))
        rate = 1.0 / shape.get("stribeck_velocity", 1.0)
        return kernels.rigid_columns(terms, speeds, rate, kernels.STRIBECK_SHAPES.index(stribeck_shape))

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        """Input path: ``u`` (or the drive force, for backlash) after this effect.

        Parameters
        ----------
        x : numpy.ndarray, shape (N,)
            The input [u] (the force [F] for backlash), held over each sample.
        dt : float
            Sample time [s].
        shape : dict
            Shape parameters by name.
        """
        return x

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        """Search interval of each nonlinear parameter, from the record's scales.

        Parameters
        ----------
        scale : dict
            ``w_max`` [v], ``w_noise`` [v], ``u_max`` [u], ``dt`` [s], ``dt_band`` [s], the
            decimated sample time, ``band`` [Hz], the useful band, and ``q_span`` [v s], the span
            of positions the record covers.
        """
        return {}

    def unreached(self, params: dict[str, float], scale: dict[str, float]) -> dict[str, float]:
        """The shape parameters of this effect, valued as in ``params``, that records of these
        ``scale`` never reach and so cannot tell (:meth:`bounds`' scales): a fit holds them at
        those values. None by default.

        Parameters
        ----------
        params : dict
            A model's parameters (a given model's, or a fit's start).
        scale : dict
            The records' scales, as in :meth:`bounds`.
        """
        return {}

    def locate(
        self, bounds: dict[str, tuple[float, float]], residual: np.ndarray, position: np.ndarray
    ) -> dict[str, tuple[float, float]]:
        """The search intervals narrowed where the ``residual`` [F] of a model without this effect
        shows it against the ``position`` [v s] of its samples (an effect periodic in position:
        its period); the :meth:`bounds` as they are for the others.

        Parameters
        ----------
        bounds : dict
            Search interval of each nonlinear parameter (:meth:`bounds`).
        residual : numpy.ndarray
            The balance residual of the model without this effect on the fitted rows [F].
        position : numpy.ndarray
            The position at those rows [v s].
        """
        return bounds

    def ripple(self, params: dict[str, float]) -> tuple:
        """An effect whose torque depends on the position (:attr:`position`): its torque as the
        compiled position torque ``Σ_k A_s,k sin(k p θ) + A_c,k cos(k p θ)``
        (:func:`~motorid.drive.kernels.position_torque`), ``(A_s,1 [F], A_c,1 [F], p [1/(v s)],
        directed, A_s,2.. [F], A_c,2.. [F])`` from a drive's ``params`` (``directed``: a level
        against the motion, times sgn ω; the overtones as arrays); no torque,
        ``(0, 0, 0, False, [], [])``, for the others.

        Parameters
        ----------
        params : dict
            The drive's parameters.
        """
        return 0.0, 0.0, 0.0, False, kernels.NO_HARMONICS, kernels.NO_HARMONICS

    def derived(self, params: dict[str, float]) -> dict[str, float]:
        """Figures reported beside the fitted parameters (their units in :attr:`derived_units`);
        none here.

        Parameters
        ----------
        params : dict
            The effect's fitted parameters.
        """
        return {}

    def filter_prior(self, params: dict[str, float], stribeck_shape: str) -> dict[str, Any]:
        """Its share of a friction filter's prior (constructor arguments; additive for
        ``coulomb0``, ``coulomb_neg0`` and ``viscous0``), from a rigid drive's ``params``.

        Parameters
        ----------
        params : dict
            The drive's parameters.
        stribeck_shape : {"exponential", "gaussian"}
            The drive's Stribeck shape.
        """
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


__all__ = [
    "BREAKAWAY_FRICTION",
    "DRIVE_PARAMETERS",
    "KINETIC",
    "KINETIC_FRICTION",
    "Effect",
    "Parameter",
]
