"""The doctor's fit of a rigid drive to the torque balance of a record.

The model is :class:`motorid.drive.rigid.RigidDrive` (see :mod:`motorid.drive.effects`
for the terms)::

    J dw/dt = F_in(u) - Σ_e T_e(w)                                        [F]

Fit (inverse dynamics, :class:`BalanceData`): with the force and the
regressor columns decimated in parallel, least squares on the moving samples
(|w| above the noise band: a resting drive's static friction is not a function
of w) of::

    F_in,d = J_b a_d + Σ_i θ_i c_i,d                                      (linear part)

On a velocity record each sample's balance is written on its own ends, ``a = Δw / dt`` and the
columns on ``w̄ = (w_{k-1} + w_k) / 2``, against the force held over the sample: with the force
and friction held over it this holds exactly for ``J_b`` (:func:`discrete_inertia`), and J comes
back from J_b and B (:func:`inertia_from_discrete`). Samples it does not hold on (the speed
reverses or comes to rest inside them) are set to zero in every column before the decimation's
filter (:meth:`BalanceData.decimated`), so each decimated row is a sum of balances that hold.
A position record's balance is the filtered position's central differences, J_b = J.

bias-compensated for the noise in the acceleration: ``a_d`` is the derivative of the measured
speed, and its noise (variance ``σ_a²`` per row, :func:`~motorid.diagnose.kinematics.acceleration_noise`)
would pull J towards zero by ``σ_a² / var(a_d)`` (errors in variables: a slow sine's inertia
comes out low). With ``X`` the columns on the M fitted rows and ``D`` zero but for the inertia's
entry ``M σ_a²`` (per record in a pool)::

    θ = (XᵀX - D)⁻¹ Xᵀ F_in,d

which is least squares when the record's noise is nil (a position record: its noise is on the
position, where this estimate of σ_a² does not hold). The friction columns are functions of the
filtered speed, whose noise is far smaller than its signal, and their noise is uncorrelated with
the acceleration's at the same instant; they are not compensated.

and, for effects with shape parameters (Stribeck velocity, dead zone,
saturation level, backlash time), a coarse logarithmic grid refined by a
bounded scalar search around the best point (SciPy's bounded Brent search),
each point solved by least squares (variable projection), coordinate-wise over
the shape parameters.
Columns that add no rank to those before them (the Coulomb asymmetry beside an
offset) are dropped and their parameter reported as 0.

Several records of one drive (:class:`PooledBalance`) are fitted as one model: each
record's force and columns are built and decimated on its own (its own filters, edges
and moving samples), and their rows stacked into one least-squares problem, so the
parameters are shared and the residual sum of squares is the pooled one.

Free run: :meth:`RigidDrive.free_run <motorid.drive.rigid.RigidDrive.free_run>`
(exponential Euler with Karnopp's stick/slip rule at each zero of the speed, compiled in the drive), on the
same compiled terms as the regressor columns here.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motorid.diagnose.kinematics import Kinematics, acceleration_noise
from motorid.drive.effects import Effect, effect_order
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive

logger = logging.getLogger(__name__)

# --------------------------------------------------------------------------- data
#: Memory [bytes] :meth:`BalanceData.decimated` may keep cached columns in (between 16 and
#: 256 columns whatever their size).
CACHE_BYTES = 256e6


#: The longest input delay searched: this share of the record's settled span ...
DELAY_SHARE = 0.01
#: ... and at least this many samples (a driver's or a controller's latency), ...
DELAY_SAMPLES = 20
#: ... and at most this long [s] (a logger's delay on a small motor's bench reaches 200 ms).
DELAY_LONGEST = 0.5


def delay_reach(dt: float, samples: int) -> float:
    """Upper end of the input delay's search [s]: :data:`DELAY_SHARE` of the record's ``samples``
    settled samples of ``dt`` [s], at least :data:`DELAY_SAMPLES` samples and at most
    :data:`DELAY_LONGEST` (and never below the 20 samples), so a logger's delay of 100-200 ms at
    1 kHz is inside it; a delay found at its upper end is said
    (:attr:`~motorid.diagnose.results.Structure.at_reach`)."""
    return max(DELAY_SAMPLES * dt, min(DELAY_SHARE * samples * dt, DELAY_LONGEST))


@dataclass
class BalanceData:
    """The inverse-dynamics data of one record: decimated acceleration, velocity and masks.

    Parameters
    ----------
    kin : Kinematics
        Filtered velocity and acceleration at full rate.
    input_gain : float
        g: force per input unit [F/u].
    rows : ndarray of bool, optional
        Decimated samples used in fits (default: the moving ones).

    Attributes
    ----------
    accel_noise : float
        Variance of the noise on the decimated acceleration over the moving samples [v²/s²]
        (:func:`~motorid.diagnose.kinematics.acceleration_noise`), taken out of the fit.
    holds : ndarray of bool, shape (N,)
        The full-rate samples whose balance holds as written (see the module notes): on a
        velocity record, the samples whose two ends move the same way, both above the noise
        band; every sample of a position record.
    """

    kin: Kinematics
    input_gain: float
    idx: np.ndarray = field(init=False)
    a: np.ndarray = field(init=False)
    w: np.ndarray = field(init=False)
    moving: np.ndarray = field(init=False)
    w_threshold: float = field(init=False)
    accel_noise: float = field(init=False)
    holds: np.ndarray = field(init=False)
    scale: dict[str, float] = field(init=False)
    _cache: dict = field(init=False, default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        kin = self.kin
        self.idx = kin.decimated_index
        self.w = kin.w[self.idx]
        w_max = float(np.max(np.abs(kin.w[kin.valid]))) if kin.valid.any() else 1.0
        self.w_threshold = max(3.0 * kin.noise, 2e-3 * w_max)
        if kin.output_kind == "velocity":
            start = kin.balance_w - 0.5 * kin.dt * kin.balance_a
            end = kin.balance_w + 0.5 * kin.dt * kin.balance_a
            self.holds = (np.minimum(np.abs(start), np.abs(end)) > self.w_threshold) & (start * end > 0.0)
        else:
            self.holds = np.ones(kin.n, dtype=bool)
        self.a = self.decimated("a", kin.balance_a)
        # a decimated sample is "moving" when the full-rate speed stays above the threshold
        slow = (np.abs(kin.w) < self.w_threshold).astype(float)
        half = kin.factor
        width = 2 * half + 1
        near_slow = np.convolve(slow, np.ones(width), mode="same") > 0
        self.moving = ~near_slow[self.idx]
        self.accel_noise = acceleration_noise(kin, kin.valid & ~near_slow)
        u = kin.u[kin.valid] if kin.valid.any() else kin.u
        q = kin.q[kin.valid] if kin.valid.any() else kin.q
        self.scale = {
            "w_max": w_max,
            "w_noise": kin.noise,
            "u_max": float(np.max(np.abs(u))) if u.size else 1.0,
            "dt": kin.dt,
            "delay_reach": delay_reach(kin.dt, int(kin.valid.sum())),
            "dt_band": kin.dt * kin.factor,
            "band": kin.band,
            "q_span": float(np.ptp(q)) if q.size else 0.0,
        }

    @property
    def n(self) -> int:
        return int(self.idx.size)

    @property
    def dt(self) -> float:
        """Sample time [s]."""
        return self.kin.dt

    @property
    def parts(self) -> tuple[BalanceData, ...]:
        """The records whose rows a fit stacks: this one."""
        return (self,)

    def decimated(
        self, key: Hashable, column: np.ndarray | Callable[[], np.ndarray], held: bool = True
    ) -> np.ndarray:
        """Decimate a full-rate column of the balance, cached under ``key``.

        ``column`` is the column or a function that computes it, called only when
        ``key`` is not cached. With ``held``, the samples whose balance does not hold as
        written (:attr:`holds`) are set to zero first, in every column alike, so each
        decimated row is a filtered sum of balances that hold; without, the column as it is
        (the force and acceleration at rest, where :func:`~motorid.diagnose.measures.balance_residual`
        bounds the friction instead). The cache keeps the columns used last, as many as fit
        in :data:`CACHE_BYTES` (16 to 256): the columns every fit shares stay, the
        oldest points of past shape searches go first.
        """
        key = key if held else (key, "as is")
        value = self._cache.pop(key, None)
        if value is None:
            value = np.asarray(column() if callable(column) else column, dtype=float)
            value = self.kin.decimate(np.where(self.holds, value, 0.0) if held else value)
            limit = min(max(int(CACHE_BYTES // max(value.nbytes, 1)), 16), 256)
            while len(self._cache) >= limit:
                del self._cache[next(iter(self._cache))]
        self._cache[key] = value  # most recently used last
        return value

    @property
    def a_as_is(self) -> np.ndarray:
        """The decimated acceleration with no sample set to zero (``decimated(held=False)``)."""
        return self.decimated("a", self.kin.balance_a, held=False)

    def balance_inertia(self, inertia: float, viscous: float) -> float:
        """The coefficient of :attr:`a` in this record's balance for a drive of ``inertia`` J
        and viscous friction B: :func:`discrete_inertia` on a velocity record, J itself on a
        position record."""
        if self.kin.output_kind != "velocity":
            return float(inertia)
        return discrete_inertia(inertia, viscous, self.dt)

    def inertia(self, coefficient: float, viscous: float) -> float:
        """The inertia J whose balance coefficient is ``coefficient`` (the inverse of
        :meth:`balance_inertia`)."""
        if self.kin.output_kind != "velocity":
            return float(coefficient)
        return inertia_from_discrete(coefficient, viscous, self.dt)

    def inertia_slope(self, coefficient: float, viscous: float) -> float:
        """dJ/dJ_b of :meth:`inertia` at ``coefficient`` [-] (the delta method's factor on J_b's
        standard error): :func:`discrete_inertia_slope`, 1 on a position record."""
        if self.kin.output_kind != "velocity":
            return 1.0
        return discrete_inertia_slope(coefficient, viscous, self.dt)

    def balance_force(self, force: np.ndarray) -> np.ndarray:
        """The force of each sample's balance: on a velocity record the force held over sample
        k, ``F[k]`` (:attr:`~motorid.diagnose.kinematics.Kinematics.balance_a`); on a position
        record, whose speed and acceleration are taken at the output instant, the force held
        on either side of it, ``(F[k] + F[k+1]) / 2``."""
        if self.kin.output_kind == "velocity":
            return np.asarray(force, dtype=float)
        out = np.empty_like(force)
        out[:-1] = 0.5 * (force[:-1] + force[1:])
        out[-1] = force[-1]
        return out


@dataclass
class PooledBalance:
    """The balance data of several records of one drive, fitted as one model: their decimated
    rows stacked, record after record (each record keeps its own filters, edges and moving
    samples; :func:`fit_model` builds each column on each record and stacks them).

    Parameters
    ----------
    parts : tuple of BalanceData
        The records, at one sample time (to a part in 10⁶), decimated alike, at one input gain.
    noise : float
        The pooled noise floor [v] the Stribeck search bounds are set from.
    """

    parts: tuple[BalanceData, ...]
    noise: float
    a: np.ndarray = field(init=False)
    w: np.ndarray = field(init=False)
    moving: np.ndarray = field(init=False)
    scale: dict[str, float] = field(init=False)

    def __post_init__(self) -> None:
        first = self.parts[0]
        self.a = stacked([p.a for p in self.parts])
        self.w = stacked([p.w for p in self.parts])
        self.moving = stacked([p.moving for p in self.parts])
        self.scale = {
            **first.scale,
            "w_max": max(p.scale["w_max"] for p in self.parts),
            "u_max": max(p.scale["u_max"] for p in self.parts),
            "q_span": max(p.scale["q_span"] for p in self.parts),
            "delay_reach": max(p.scale["delay_reach"] for p in self.parts),
            "w_noise": self.noise,
        }

    @property
    def n(self) -> int:
        return int(self.moving.size)

    @property
    def dt(self) -> float:
        return self.parts[0].dt

    @property
    def input_gain(self) -> float:
        return self.parts[0].input_gain

    def balance_inertia(self, inertia: float, viscous: float) -> float:
        """:meth:`BalanceData.balance_inertia` (the records share one sample time)."""
        return self.parts[0].balance_inertia(inertia, viscous)

    def inertia(self, coefficient: float, viscous: float) -> float:
        """:meth:`BalanceData.inertia` (the records share one sample time)."""
        return self.parts[0].inertia(coefficient, viscous)

    def inertia_slope(self, coefficient: float, viscous: float) -> float:
        """:meth:`BalanceData.inertia_slope` (the records share one sample time)."""
        return self.parts[0].inertia_slope(coefficient, viscous)


def discrete_inertia(inertia: float, viscous: float, dt: float) -> float:
    """The coefficient J_b of the acceleration in a velocity record's balance [F s²/v].

    Over a sample of length dt whose input force F and friction T hold, ``J ẇ = F - B w - T``
    is solved exactly: ``w_k = e^{-x} w_{k-1} + (1 - e^{-x}) (F - T) / B`` with ``x = B dt / J``.
    Written on the sample's ends, with ``w̄ = (w_{k-1} + w_k) / 2`` and ``Δw = w_k - w_{k-1}``::

        F = J_b Δw / dt + B w̄ + T,    J_b = B dt / (1 - e^{-x}) - B dt / 2

    which holds at any ratio of dt to the time constant J / B; ``J_b = J (1 + x² / 12 + ...)``,
    J itself without viscous friction.

    Parameters
    ----------
    inertia : float
        J [F s²/v] (kg m² for a rotary drive in N m and rad/s), > 0.
    viscous : float
        B [F s/v], >= 0.
    dt : float
        Sample time [s].
    """
    x = viscous * dt / inertia if inertia > 0.0 else 0.0
    if x <= 0.0 or not math.isfinite(x):
        return float(inertia)
    return float(inertia * (x / -math.expm1(-x) - 0.5 * x))


def inertia_from_discrete(coefficient: float, viscous: float, dt: float) -> float:
    """The inertia J whose balance coefficient (:func:`discrete_inertia`) is ``coefficient``::

        J = -B dt / ln(1 - B dt / (J_b + B dt / 2))

    The coefficient itself where that is not defined (no viscous friction, or J_b <= B dt / 2,
    which no positive inertia gives).

    Parameters
    ----------
    coefficient : float
        J_b [F s²/v].
    viscous : float
        B [F s/v].
    dt : float
        Sample time [s].
    """
    terms = _discrete_terms(coefficient, viscous, dt)
    if terms is None:
        return float(coefficient)
    bdt, held = terms
    return float(-bdt / math.log1p(-bdt / held))


def _discrete_terms(coefficient: float, viscous: float, dt: float) -> tuple[float, float] | None:
    """``(c, H) = (B dt, J_b + B dt / 2)`` of :func:`inertia_from_discrete`, or None where the
    inverse is not defined (no viscous friction, or ``H <= c``, which no positive inertia gives)."""
    bdt = viscous * dt
    held = coefficient + 0.5 * bdt
    if not bdt > 0.0 or not held > bdt or not math.isfinite(held):
        return None
    return bdt, held


def discrete_inertia_slope(coefficient: float, viscous: float, dt: float) -> float:
    """dJ/dJ_b of :func:`inertia_from_discrete` [-]: with ``c = B dt`` and ``H = J_b + c / 2``,
    ``J = -c / ln(1 - c / H)`` and::

        dJ/dJ_b = J² / (H (H - c))

    1 where :func:`inertia_from_discrete` gives the coefficient itself.

    Parameters
    ----------
    coefficient : float
        J_b [F s²/v].
    viscous : float
        B [F s/v].
    dt : float
        Sample time [s].
    """
    terms = _discrete_terms(coefficient, viscous, dt)
    if terms is None:
        return 1.0
    bdt, held = terms
    inertia = inertia_from_discrete(coefficient, viscous, dt)
    return float(inertia**2 / (held * (held - bdt)))


def stacked(columns: list[np.ndarray]) -> np.ndarray:
    """The columns of the records of a pool one after the other (one record's column itself)."""
    return columns[0] if len(columns) == 1 else np.concatenate(columns)


# --------------------------------------------------------------------------- model
def model_key(model: RigidDrive) -> tuple:
    """All a rigid drive's free run and balance depend on, every number to the bit: two models
    with equal keys give equal outputs. A two-mass rig given to the doctor
    (:class:`~motorid.diagnose.given_rig.GivenRig`) adds the rig its free run simulates.

    Parameters
    ----------
    model : RigidDrive
        The model.
    """
    params = tuple((name, value.hex()) for name, value in model.params.items())
    return model.effects, params, model.dt.hex(), model.stribeck_shape, getattr(model, "rig", None)


def model_balance(model: RigidDrive, data: BalanceData) -> tuple[np.ndarray, np.ndarray]:
    """Measured and modelled force on the decimated samples: ``(F_in,d, J a_d + Σ T_e,d)``.

    The decimated input force and friction of a model are kept in the cache of
    :meth:`BalanceData.decimated` (the workflow asks for the same model's more than once).

    Parameters
    ----------
    model : RigidDrive
        The model.
    data : BalanceData
        The record's decimated balance data.
    """
    kin = data.kin
    key = model_key(model)
    f_in = data.decimated(("input force", key), lambda: data.balance_force(model.input_force(kin.u)))
    inertia = data.balance_inertia(model.inertia, model.params.get("viscous", 0.0))
    friction = data.decimated(("friction", key), lambda: model.friction(kin.balance_w, kin.q))
    f_model = inertia * data.a + friction
    return f_in, f_model


# --------------------------------------------------------------------------- fit
@dataclass
class FitResult:
    """A fitted model and its torque-balance residual on the fitted rows.

    ``rss`` is in acceleration units (RSS of the balance / J²) [(v/s)²],
    ``rss_force`` in force units [F²].

    Attributes
    ----------
    model : RigidDrive
        The fitted model.
    rss : float
        Residual sum of squares of the balance / J² [(v/s)²].
    rss_force : float
        Residual sum of squares of the balance [F²].
    n_rows : int
        Fitted rows.
    n_params : int
        Fitted parameters.
    residual : ndarray
        The balance residual on the fitted rows [F].
    param_std : dict
        Standard error of each linear parameter [its unit] (:func:`linear_param_std`). With an
        input delay in the model, the delay was estimated too, and its uncertainty goes into
        theirs (the delta method, :class:`DelayTrade`)::

            σ_θ² = σ_θ,held² + (∂θ/∂τ_d)² σ_τ²

        with σ_τ the delay's standard error set free in the balance: on records with a delay
        planted these hold the truth within 2 on 93 %, the held ones the inertia on 57 %
        (:mod:`.calibration`).
    param_share : dict
        Share of the input force each linear parameter's term carries (:func:`force_shares`).
    delay_trade : DelayTrade or None
        The fit with its input delay set free (:func:`delay_trade`).
    """

    model: RigidDrive
    rss: float
    rss_force: float
    n_rows: int
    n_params: int
    residual: np.ndarray  # on every decimated sample (F_in - F_model)
    param_std: dict[str, float] = field(default_factory=dict)
    param_share: dict[str, float] = field(default_factory=dict)
    delay_trade: DelayTrade | None = None


@dataclass
class LinearSolve:
    """One least-squares solve of the balance for fixed shape parameters (:func:`_linear_solve`).

    ``theta`` are the linear parameters θ [their units], ``rss`` the residual sum of squares on
    the fitted rows [F²], ``rank`` the number of columns kept, ``residual`` ``F_in - X θ`` on
    every decimated sample [F]. ``gram`` is the compensated normal matrix ``XsᵀXs - Ds`` of the
    unit-norm columns kept (indices ``keep``), whose norms are ``norms``.

    Attributes
    ----------
    theta : dict
        The linear parameters θ [their units].
    rss : float
        Residual sum of squares on the fitted rows [F²].
    rank : int
        Columns kept.
    residual : ndarray
        ``F_in - X θ`` on every decimated sample [F].
    gram : ndarray
        The compensated normal matrix of the kept unit-norm columns.
    keep : ndarray
        Indices of the kept columns.
    norms : ndarray
        The columns' norms.
    X : ndarray, shape (N, k)
        The regressor columns on every decimated sample (shared with the solve's cache, not a
        copy).
    """

    theta: dict[str, float]
    rss: float
    rank: int
    residual: np.ndarray
    gram: np.ndarray
    keep: np.ndarray
    norms: np.ndarray
    X: np.ndarray

    def unit_cov(self) -> np.ndarray:
        """C = (XᵀX - D)⁻¹ over the columns kept (zero rows and columns for a dropped one), in the
        parameters' units: θ's covariance is σ² C. Asked for by the final fit only.

        Unscaling unit column j divides its row and column of the inverse by norm_j.
        """
        k = self.norms.size
        if self.keep.size == 0:
            return np.zeros((k, k))
        norms = self.norms[self.keep]
        cov = np.linalg.inv(self.gram) / np.outer(norms, norms)
        if self.keep.size == k:
            return cov
        unit_cov = np.zeros((k, k))
        unit_cov[np.ix_(self.keep, self.keep)] = cov
        return unit_cov


@dataclass
class Regressors:
    """The regressor columns of one solve: ``X`` (N decimated samples, k columns) for the
    residual, and on the fitted rows (indices ``fitted``) the columns scaled to unit norm, one
    per row of ``scaled`` (k, M), with their ``norms``.

    Attributes
    ----------
    X : ndarray, shape (N, k)
        The regressor columns on the N decimated samples.
    fitted : ndarray
        Indices of the fitted rows.
    norms : ndarray, shape (k,)
        The columns' norms on the fitted rows.
    scaled : ndarray, shape (k, M)
        The columns on the fitted rows scaled to unit norm, one per row.
    """

    X: np.ndarray
    fitted: np.ndarray
    norms: np.ndarray
    scaled: np.ndarray

    @classmethod
    def of(cls, cols: list[np.ndarray], rows: np.ndarray) -> Regressors:
        """The regressors of the decimated columns ``cols`` fitted on the ``rows`` (bool)."""
        X = np.column_stack(cols)
        fitted = np.flatnonzero(rows)
        norms = np.linalg.norm(X.take(fitted, axis=0), axis=0)
        norms[norms == 0.0] = 1.0
        scaled = np.empty((len(cols), fitted.size))
        for j, col in enumerate(cols):
            np.divide(col.take(fitted), norms[j], out=scaled[j])
        return cls(X, fitted, norms, scaled)


def _input_effects(effects: tuple[str, ...]) -> list[Effect]:
    """The memoryless and dynamic input-path effects (all but backlash), in the path's order."""
    return sorted(
        (get_effect(n) for n in effects if get_effect(n).kind == "input" and n != "backlash"),
        key=lambda e: e.order,
    )


def _input_key(effects: tuple[str, ...], shape: dict[str, float]) -> list[str]:
    """The cache key of the input force for ``shape``: its input-path parameters."""
    key_parts = [f"{eff.name}={shape[eff.nonlinear[0]]:.12g}" for eff in _input_effects(effects)]
    if "backlash" in effects:
        key_parts.append(f"backlash={shape['backlash_time']:.12g}")
    return key_parts


def _input_force(
    part: BalanceData, effects: tuple[str, ...], shape: dict[str, float], gain: float
) -> np.ndarray:
    """The full-rate force of the input path ``g Δ(u)`` of one record, at the output instants
    (:meth:`BalanceData.balance_force`) [F]."""
    kin = part.kin
    x = np.asarray(kin.u, dtype=float)
    for eff in _input_effects(effects):
        x = eff.transform(x, kin.dt, shape)
    force = gain * x
    if "backlash" in effects:
        force = get_effect("backlash").transform(force, kin.dt, shape)
    return part.balance_force(force)


def _linear_solve(
    data: BalanceData | PooledBalance,
    effects: tuple[str, ...],
    shape: dict[str, float],
    gain: float,
    rows: np.ndarray,
    stribeck_shape: str,
    last: dict[tuple[str, ...], Regressors] | None = None,
) -> LinearSolve:
    """Least squares of the balance for fixed shape parameters (see the module notes).

    ``last`` holds the regressors of the previous solve on the same ``rows``, by their columns'
    keys: a search over an input-path shape (dead zone, delay, ...) changes the force only, and
    reuses them.
    """
    key_parts = _input_key(effects, shape)

    target = stacked(
        [
            part.decimated(
                "F|" + "|".join(key_parts), lambda part=part: _input_force(part, effects, shape, gain)
            )
            for part in data.parts
        ]
    )
    names = ["inertia"]
    keys = ["a"]
    cols = [data.a]
    # an offset goes first, so a column that repeats it (the Coulomb asymmetry) is the one dropped
    for name in sorted(effects, key=lambda n: n != "offset"):
        eff = get_effect(name)
        if eff.kind != "friction" or not eff.linear:
            continue
        key = name + "|" + "|".join(f"{p}={shape[p]:.12g}" for p in eff.nonlinear)
        if eff.nonlinear:
            key += "|" + stribeck_shape
        full: list[list[np.ndarray]] = [[] for _ in data.parts]  # computed on a cache miss, per record

        def column(k: int, j: int, eff: Effect = eff, full: list[list[np.ndarray]] = full) -> np.ndarray:
            if not full[k]:
                kin = data.parts[k].kin
                full[k].append(
                    eff.columns(kin.balance_w, shape, stribeck_shape, kin.q if eff.position else None)
                )
            col = full[k][0][:, j]
            if j == len(eff.linear) - 1:
                full[k].clear()  # the record's full-rate columns go once the last is decimated
            return col

        for j, pname in enumerate(eff.linear):
            names.append(pname)
            keys.append(f"{key}|{j}")
            cols.append(
                stacked([
                    part.decimated(keys[-1], lambda k=k, j=j, column=column: column(k, j))
                    for k, part in enumerate(data.parts)
                ])
            )  # fmt: skip
    k = len(cols)
    last = {} if last is None else last
    regressors = last.get(tuple(keys))
    if regressors is None:
        regressors = Regressors.of(cols, rows)
        last.clear()
        last[tuple(keys)] = regressors
    X, fitted, norms = regressors.X, regressors.fitted, regressors.norms
    # [Xs | y] on the fitted rows, the columns scaled to unit norm, one column after the other
    # (each contiguous: the QR works on columns)
    scaled_t = np.empty((k + 1, fitted.size))
    scaled_t[:k] = regressors.scaled
    target.take(fitted, out=scaled_t[k])
    # one QR of [Xs | y]: |R_jj| is the part of unit column j outside the span of those before
    # it (below 1e-3 it adds no rank), and ||Xs_keep θ - y|| = ||R_keep θ - R_y||, a small problem
    R = np.linalg.qr(scaled_t.T, mode="r")
    del scaled_t  # the rows' copy goes before the residual is computed on every sample
    keep = np.flatnonzero(np.abs(np.diag(R)[:k]) > 1e-3)
    theta = np.zeros(k)
    kept = R[:, keep]
    gram = kept.T @ kept
    if keep.size:
        sol, *_ = np.linalg.lstsq(kept, R[:, k], rcond=None)
        noise = _acceleration_noise_sum(data, rows)
        if noise > 0.0 and keep[0] == 0:
            # the inertia's unit column: its noise, M σ_a², divided by its squared norm
            compensated = gram.copy()
            compensated[0, 0] -= noise / norms[0] ** 2
            if np.all(np.linalg.eigvalsh(compensated) > 0.0):
                sol = np.linalg.solve(compensated, kept.T @ R[:, k])
                gram = compensated
            else:
                logger.info("the acceleration's noise is as large as its signal: the fit is not compensated")
        theta[keep] = sol / norms[keep]
    residual = target - X @ theta
    rss = float(np.sum(residual.take(fitted) ** 2))
    return LinearSolve(
        dict(zip(names, theta.tolist(), strict=True)), rss, int(keep.size), residual, gram, keep, norms, X
    )


def _acceleration_noise_sum(data: BalanceData | PooledBalance, rows: np.ndarray) -> float:
    """``Σ_records M_r σ_a,r²``: the noise the fitted ``rows`` (M_r of record r) put on the
    acceleration's normal-matrix entry [(v/s²)²]."""
    total, start = 0.0, 0
    for part in data.parts:
        total += int(np.count_nonzero(rows[start : start + part.n])) * part.accel_noise
        start += part.n
    return total


#: Contiguous blocks of fitted rows in the block sandwich of :func:`linear_param_std`.
STD_BLOCKS = 20


def linear_param_std(
    names: list[str], unit_cov: np.ndarray, residual: np.ndarray, rows: np.ndarray, rank: int,
    X: np.ndarray,
) -> dict[str, float]:  # fmt: skip
    """Standard errors of the linear parameters θ (inertia and the effects' levels) [their units].

    A block sandwich (batch-means) estimate, which holds for a residual correlated over any
    time shorter than a block: the fitted rows are cut into G = :data:`STD_BLOCKS` contiguous
    blocks b, and with the score of each, ``s_b = X_bᵀ r_b``, and C = (XᵀX)⁻¹::

        Cov(θ) = G / (G - 1) · (n / (n - rank)) · C (Σ_b (s_b - s̄)(s_b - s̄)ᵀ) C

    (s̄ the mean score: 0 for least squares; for the fit compensated for the acceleration's noise,
    C = (XᵀX - D)⁻¹ and s̄ = -D θ / G, the compensation spread over the blocks by their rows).

    The balance residual of filtered, decimated signals is not white: a lag-1 (AR(1))
    correction sees the filter's correlation only, while a misfit that changes along the
    record (a chirp through frequencies where the rigid model holds differently, the phases
    of a slow sine) correlates the residual over seconds. The blocks see both; what they
    cannot see is a misfit that repeats alike in every block (one frequency throughout), so
    records of different signals can still disagree by more than these errors. They hold the
    shape parameters (Stribeck velocity, dead zone, ...) at their fitted values, which get no
    standard error. A dropped column's parameter gets 0.

    Parameters
    ----------
    names : list of str
        The linear parameters, in column order.
    unit_cov : ndarray
        C = (XᵀX - D)⁻¹ of the columns, in the parameters' units.
    residual : ndarray
        The balance residual on every decimated sample [F].
    rows : ndarray of bool
        The fitted rows.
    rank : int
        Columns kept.
    X : ndarray, shape (N, k)
        The regressor columns on every decimated sample, in the order of ``names``.

    Returns
    -------
    dict
        Standard error of each parameter [its unit]; NaN for all when there are fewer fitted
        rows than columns or blocks.
    """
    cov = linear_param_cov(unit_cov, residual, rows, rank, X)
    if cov is None:
        return {name: math.nan for name in names}
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    return dict(zip(names, std.tolist(), strict=True))


def linear_param_cov(
    unit_cov: np.ndarray, residual: np.ndarray, rows: np.ndarray, rank: int, X: np.ndarray
) -> np.ndarray | None:
    """The block-sandwich covariance of the linear parameters θ of :func:`linear_param_std`
    [their units²], None when there are fewer fitted rows than columns or blocks.

    Parameters
    ----------
    unit_cov : ndarray
        C = (XᵀX - D)⁻¹ of the columns, in the parameters' units.
    residual : ndarray
        The balance residual on every decimated sample [F].
    rows : ndarray of bool
        The fitted rows.
    rank : int
        Columns kept.
    X : ndarray, shape (N, k)
        The regressor columns on every decimated sample.
    """
    idx = np.flatnonzero(rows)
    dof = idx.size - rank
    if dof <= 0 or idx.size < 2 * STD_BLOCKS:
        return None
    r = residual[idx]
    scores = np.add.reduceat(X[idx] * r[:, None], np.linspace(0, idx.size, STD_BLOCKS + 1).astype(int)[:-1])
    scores -= scores.mean(axis=0)
    meat = scores.T @ scores * (STD_BLOCKS / (STD_BLOCKS - 1)) * (idx.size / dof)
    return unit_cov @ meat @ unit_cov


#: An inertia that moves by more than this many of its standard errors (with the delay free) when
#: the input delay is set free in the balance depends on the delay taken, not on the record alone
#: (:class:`DelayTrade`).
DELAY_TRADE_LIMIT = 3.0
#: ... and by more than this share of its value: below it, the rigid model's own error on a filtered,
#: decimated record (:data:`~motorid.diagnose.calibration.INERTIA_TOLERANCE`, 1 %).
DELAY_TRADE_SHARE = 0.01


@dataclass
class DelayTrade:
    """What the input delay, set free in the balance, does to a fit's linear parameters
    (:func:`delay_trade`).

    The input force delayed by τ_d + δ is, to first order, ``F(t - τ_d) - δ Ḟ``, and since the
    balance holds ``F ≈ J a + B w + ...``, ``Ḟ ≈ J ȧ + B a + ...``: a change δ of the delay
    looks like a change ``B δ`` of the inertia, told apart only by its term in the jerk ``J δ ȧ``
    (and the friction's). On a sine ``ȧ = -ω² w`` is the speed's own column, so a sine cannot
    tell them apart; a chirp's frequencies can, where the rigid model holds. What the balance
    determines either way is::

        J_eff = J + B τ_d                                                  [F s²/v]

    The delay set free is the fit with the column ``Ḟ`` added (its coefficient δ), under the same
    compensation for the acceleration's noise and the same block sandwich
    (:func:`linear_param_cov`); its standard errors are those of the parameters when the delay is
    estimated with them. An inertia whose free value lies more than :data:`DELAY_TRADE_LIMIT` of
    them from the stated one depends on the delay the model took (:attr:`inertia_traded`).

    Attributes
    ----------
    delay : float
        The input delay of the fit as stated (0 without one) [s].
    delay_free, delay_free_std : float
        The delay set free (``τ_d + δ``; it may come out negative: an unconstrained linear
        estimate), and its standard error [s].
    stated : dict
        The linear parameters of the fit as stated [their units].
    free, free_std : dict
        The same parameters with the delay free, and their standard errors [their units].
    effective_inertia, effective_inertia_std : float
        ``J + B τ_d`` and its standard error with the delay free [F s²/v].
    sensitivity : dict
        ``∂θ/∂τ_d`` of each parameter of the fit as stated, the delay held [its unit / s]:
        ``-(XᵀX - D)⁻¹ Xᵀ Ḟ``.
    """

    delay: float
    delay_free: float
    delay_free_std: float
    stated: dict[str, float]
    free: dict[str, float]
    free_std: dict[str, float]
    effective_inertia: float
    effective_inertia_std: float
    sensitivity: dict[str, float]

    def moved(self, name: str) -> float:
        """How far setting the delay free moves parameter ``name``, in its standard errors with
        the delay free: ``|θ_free - θ| / σ_free`` [-] (0 for a parameter not fitted)."""
        if name not in self.free:
            return 0.0
        std = self.free_std[name]
        shift = abs(self.free[name] - self.stated[name])
        return shift / std if std > 0.0 else (math.inf if shift > 0.0 else 0.0)

    @property
    def inertia_traded(self) -> bool:
        """Whether the inertia depends on the delay taken: setting the delay free moves it by more
        than :data:`DELAY_TRADE_LIMIT` of its standard errors and by more than
        :data:`DELAY_TRADE_SHARE` of its value."""
        shift = abs(self.free["inertia"] - self.stated["inertia"])
        return self.moved("inertia") > DELAY_TRADE_LIMIT and shift > DELAY_TRADE_SHARE * abs(
            self.stated["inertia"]
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON shape: every attribute by its name, and ``inertia_moved`` (:meth:`moved`)."""
        return {**self.__dict__, "inertia_moved": self.moved("inertia")}


def delay_trade(
    data: BalanceData | PooledBalance,
    effects: tuple[str, ...],
    shape: dict[str, float],
    gain: float,
    rows: np.ndarray,
    solved: LinearSolve,
) -> DelayTrade | None:
    """The fit ``solved`` with its input delay set free (:class:`DelayTrade`); None for a model
    without viscous friction (nothing to trade the inertia through) or without an inertia column.

    Parameters
    ----------
    data : BalanceData or PooledBalance
        The records fitted.
    effects : tuple of str
        The model's effects.
    shape : dict
        Its shape parameters [their units] (``input_delay`` [s] among them when it has one).
    gain : float
        Input gain [F/u].
    rows : ndarray of bool
        The fitted rows.
    solved : LinearSolve
        The fit's linear solve.
    """
    names = list(solved.theta)
    keep = solved.keep
    if "viscous" not in names or keep.size == 0 or keep[0] != 0 or names.index("viscous") not in keep:
        return None
    dt = data.dt
    key = "dF/dt|" + "|".join(_input_key(effects, shape))
    rate = stacked(
        [
            part.decimated(key, lambda part=part: np.gradient(_input_force(part, effects, shape, gain), dt))
            for part in data.parts
        ]
    )
    fitted = np.flatnonzero(rows)
    X = np.column_stack([solved.X[:, keep], rate])
    target = solved.X @ np.array(list(solved.theta.values())) + solved.residual
    norms = np.linalg.norm(X[fitted], axis=0)
    norms[norms == 0.0] = 1.0
    scaled = X[fitted] / norms
    gram = scaled.T @ scaled
    noise = _acceleration_noise_sum(data, rows)
    if noise > 0.0:
        compensated = gram.copy()
        compensated[0, 0] -= noise / norms[0] ** 2
        if np.all(np.linalg.eigvalsh(compensated) > 0.0):
            gram = compensated
    try:
        unit_inv = np.linalg.inv(gram)
    except np.linalg.LinAlgError:
        return None
    theta = unit_inv @ (scaled.T @ target[fitted]) / norms
    cov = linear_param_cov(unit_inv / np.outer(norms, norms), target - X @ theta, rows, X.shape[1], X)
    if cov is None:
        return None
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    # the held fit θ(τ_d) = C Xᵀ F(t - τ_d), and ∂F(t - τ_d)/∂τ_d = -Ḟ
    slope = -solved.unit_cov() @ (solved.X[fitted].T @ rate[fitted])
    kept = [names[j] for j in keep]
    j_b = kept.index("viscous")
    delay = float(shape.get("input_delay", 0.0))
    delay_free = delay + float(theta[-1])
    grad = np.zeros(X.shape[1])  # of J + B τ_d over (J, ..., B, ..., δ)
    grad[0], grad[j_b], grad[-1] = 1.0, delay_free, theta[j_b]
    return DelayTrade(
        delay=delay,
        delay_free=delay_free,
        delay_free_std=float(std[-1]),
        stated={name: float(solved.theta[name]) for name in kept},
        free=dict(zip(kept, theta[:-1].tolist(), strict=True)),
        free_std=dict(zip(kept, std[:-1].tolist(), strict=True)),
        effective_inertia=float(theta[0] + theta[j_b] * delay_free),
        effective_inertia_std=float(math.sqrt(max(grad @ cov @ grad, 0.0))),
        sensitivity={name: float(slope[j]) for j, name in enumerate(names) if j in keep},
    )


def force_shares(
    names: list[str], theta: np.ndarray, residual: np.ndarray, rows: np.ndarray, X: np.ndarray
) -> dict[str, float]:
    """The share of the input force each linear parameter's term carries on the fitted rows.

    ``share_j = ||θ_j X_j|| / ||F_in||`` with ``F_in = X θ + r`` (the balance force): for the
    inertia, how much of the force goes into acceleration. A term that carries a small share
    is barely seen by the record (a slow sine spends its force on friction, little on
    acceleration), and its parameter is poorly determined whatever its standard error says.

    Parameters
    ----------
    names : list of str
        The linear parameters, in column order.
    theta : ndarray
        Their values [their units].
    residual : ndarray
        The balance residual on every decimated sample [F].
    rows : ndarray of bool
        The fitted rows.
    X : ndarray, shape (N, k)
        The regressor columns on every decimated sample.

    Returns
    -------
    dict
        The share of each parameter, 0..∞ (1: a term as large as the whole force) [-].
    """
    idx = np.flatnonzero(rows)
    terms = X[idx] * theta
    force = float(np.linalg.norm(terms.sum(axis=1) + residual[idx]))
    if force == 0.0:
        return {name: math.nan for name in names}
    return dict(zip(names, (np.linalg.norm(terms, axis=0) / force).tolist(), strict=True))


def fit_model(
    data: BalanceData | PooledBalance,
    effects: tuple[str, ...],
    rows: np.ndarray | None = None,
    start: dict[str, float] | None = None,
    stribeck_shape: str = "exponential",
    fixed: dict[str, float] | None = None,
) -> FitResult:
    """Fit a rigid model with ``effects`` to the torque balance of ``data``.

    Parameters
    ----------
    data : BalanceData or PooledBalance
        One record's balance data, or several records' of one drive (one model fitted to all).
    effects : tuple of str
        Effects in the model (besides inertia and input gain).
    rows : ndarray of bool, optional
        Decimated samples to fit on; default the moving samples.
    start : dict, optional
        Initial shape-parameter values (e.g. from a previous fit).
    stribeck_shape : {"exponential", "gaussian"}
        Shape of the Stribeck decay of the model.
    fixed : dict, optional
        Shape parameters held at these values, not searched (the base structure's delay
        and lag once chosen).

    Returns
    -------
    FitResult
        The model (a :class:`~motorid.drive.rigid.RigidDrive` at the record's sample time,
        all parameters in SI units), the residual sum of squares
        [F²] on ``rows``, their number and the number of free parameters.
    """
    from scipy.optimize import minimize_scalar

    effects = effect_order(tuple(effects))
    rows = data.moving if rows is None else rows & data.moving
    gain = float(data.input_gain)
    # a rest-only effect (static friction) keeps the value it starts from: the moving samples
    # do not see it
    rest = {
        p: float((start or {}).get(p, 0.0))
        for n in effects
        if get_effect(n).rest_only
        for p in get_effect(n).nonlinear
    }
    # what the records never reach (a saturation above their largest input) keeps its start value
    unreached = {p: v for n in effects for p, v in get_effect(n).unreached(start or {}, data.scale).items()}
    fixed = {**rest, **unreached, **(fixed or {})}
    bounds = {n: get_effect(n).bounds(data.scale) for n in effects}
    shape: dict[str, float] = {p: float(v) for p, v in fixed.items() if p in _shape_params(effects)}
    for n in effects:
        for p, (lo, hi) in bounds[n].items():
            if p not in fixed:
                shape[p] = math.sqrt(lo * hi) if not start or p not in start else float(start[p])
    for n in effects:
        if type(get_effect(n)).locate is not Effect.locate and not set(bounds[n]) <= set(fixed):
            # found where the residual of the model without it shows it (a period in position)
            others = tuple(e for e in effects if e != n)
            fitted = np.flatnonzero(rows)
            residual = _linear_solve(data, others, shape, gain, rows, stribeck_shape).residual[fitted]
            position = stacked([part.kin.q[part.idx] for part in data.parts])[fitted]
            bounds[n] = get_effect(n).locate(bounds[n], residual, position)
            del residual, position
            for p, (lo, hi) in bounds[n].items():
                if p not in fixed and not lo <= shape[p] <= hi:
                    shape[p] = 0.5 * (lo + hi)
    shaped = [(p, bounds[n][p]) for n in effects for p in get_effect(n).nonlinear if p not in fixed]

    nonnegative = [
        p
        for n in effects
        if get_effect(n).nonlinear
        for p in get_effect(n).nonnegative
        if p in get_effect(n).linear
    ]

    # the search's best point so far and its solve: the final fit is that point, solved once
    last: dict[tuple[str, ...], Regressors] = {}  # the regressors of the last solve on these rows
    best: dict[str, object] = {"cost": math.inf, "point": None, "solve": None}

    def cost(p: str, value: float) -> float:
        point = {**shape, p: value}
        solved = _linear_solve(data, effects, point, gain, rows, stribeck_shape, last)
        if any(solved.theta[q] < 0.0 for q in nonnegative):
            return math.inf  # the shape that needs a negative level is not the physical effect
        value_cost = _accel_rss(solved.rss, solved.theta["inertia"])
        if value_cost <= best["cost"]:
            best.update(cost=value_cost, point=point, solve=solved)
        return value_cost

    for _ in range(2 if len(shaped) > 1 else 1):
        for p, (lo, hi) in shaped:
            grid = np.geomspace(lo, hi, 17)
            costs = [cost(p, v) for v in grid]
            i = int(np.argmin(costs))
            if not np.isfinite(costs[i]):
                continue
            a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
            found = minimize_scalar(
                lambda z, p=p: min(cost(p, math.exp(z)), 1e300),
                bounds=(math.log(a), math.log(b)),
                method="bounded",
                options={"xatol": 1e-3, "maxiter": 500},
            )
            shape[p] = math.exp(found.x) if found.fun <= costs[i] else float(grid[i])
    solved = best["solve"] if best["point"] == shape else None
    if not isinstance(solved, LinearSolve):
        solved = _linear_solve(data, effects, shape, gain, rows, stribeck_shape, last)
    theta, rss, k, residual = dict(solved.theta), solved.rss, solved.rank, solved.residual
    param_std = linear_param_std(list(theta), solved.unit_cov(), residual, rows, k, solved.X)
    param_share = force_shares(list(theta), np.array(list(theta.values())), residual, rows, solved.X)
    trade = delay_trade(data, effects, shape, gain, rows, solved)
    if trade is not None and "input_delay" in effects:
        # the delay was estimated: its uncertainty goes into the rest (delta method)
        for name, slope in trade.sensitivity.items():
            param_std[name] = math.hypot(param_std[name], slope * trade.delay_free_std)
    coefficient = theta.pop("inertia")
    inertia = data.inertia(coefficient, theta.get("viscous", 0.0))
    if "inertia" in param_std:  # the delta method: σ_J = |dJ/dJ_b| σ_Jb
        param_std["inertia"] *= data.inertia_slope(coefficient, theta.get("viscous", 0.0))
    params = {"inertia": inertia, "input_gain": gain, **theta, **shape}
    model = RigidDrive(effects, params, data.dt, stribeck_shape)
    return FitResult(
        model,
        _accel_rss(rss, coefficient),
        rss,
        int(rows.sum()),
        k + len(shaped),
        residual,
        param_std,
        param_share,
        trade,
    )


def _shape_params(effects: tuple[str, ...]) -> set[str]:
    return {p for n in effects for p in get_effect(n).nonlinear}


def _accel_rss(rss: float, inertia: float) -> float:
    """RSS of the balance divided by J² (acceleration units): an input path that starves the
    drive of force cannot fit by shrinking every parameter with it; J <= 0 is no fit."""
    return rss / inertia**2 if inertia > 0.0 and math.isfinite(inertia) else math.inf


# --------------------------------------------------------------------------- output error
#: Lower bound of each parameter an output-error fit keeps it above: a level or a viscous
#: coefficient >= 0, an inertia or a Stribeck velocity > 0 (the others are free).
OUTPUT_ERROR_LOWER = {
    "inertia": 1e-12, "stribeck_velocity": 1e-12, "viscous": 0.0, "coulomb": 0.0, "stribeck": 0.0,
    "quadratic_drag": -np.inf,
}  # fmt: skip


def refitted_parameters(model: RigidDrive) -> tuple[str, ...]:
    """The parameters :func:`fit_output_error` fits: the inertia and every parameter of the
    model's effects but the structure's (delay, lag) and a rest-only one (static friction); the
    input gain stays (it sets the force scale).

    Parameters
    ----------
    model : RigidDrive
        The model whose effects name the parameters.
    """
    names = ["inertia"]
    for effect in model.effects:
        spec = get_effect(effect)
        if not (spec.structure or spec.rest_only):
            names += (p.name for p in spec.parameters)
    return tuple(names)


def fit_output_error(
    model: RigidDrive,
    error: Callable[[RigidDrive], np.ndarray],
    names: Sequence[str] | None = None,
    declared_signs: bool = False,
) -> RigidDrive:
    """``model`` with its :func:`refitted_parameters` (or ``names``) fitted to an output error::

        θ* = argmin_θ Σ_k e_k(θ)²,    e = error(model with θ)

    started from ``model``'s values (SciPy's ``least_squares``, trust region reflective, each
    parameter above its :data:`OUTPUT_ERROR_LOWER`). The free run does not change smoothly with
    the delay, the lag or a static friction's breakaway, so they stay.

    Parameters
    ----------
    model : RigidDrive
        The starting model (the doctor's, fitted to the torque balance).
    error : callable
        ``error(trial)`` -> the output error of a trial model, one entry per sample compared
        (measured minus simulated speed [v], or simulated minus measured position); the entries
        not finite for the starting model are left out of every trial's sum.
    names : sequence of str, optional
        The parameters fitted, the others held (default: :func:`refitted_parameters`).
    declared_signs : bool
        Also hold each parameter its effect declares non-negative (a dead zone, a Stribeck level)
        at or above 0, where :data:`OUTPUT_ERROR_LOWER` names no bound.

    Returns
    -------
    RigidDrive
        The same effects, the fitted parameters replaced.
    """
    from scipy.optimize import least_squares

    names = refitted_parameters(model) if names is None else tuple(names)
    x0 = np.array([model.params[n] for n in names])
    signed = (
        {p for effect in model.effects for p in get_effect(effect).nonnegative} if declared_signs else set()
    )
    lower = np.array([OUTPUT_ERROR_LOWER.get(n, 0.0 if n in signed else -np.inf) for n in names])
    x0 = np.maximum(x0, np.where(np.isfinite(lower), lower, x0))
    kept = np.isfinite(error(model))

    def residual(x: np.ndarray) -> np.ndarray:
        out = error(model.with_params(**dict(zip(names, x.tolist(), strict=True))))[kept]
        return np.where(np.isfinite(out), out, 0.0)

    fit = least_squares(residual, x0, bounds=(lower, np.full(x0.size, np.inf)), x_scale=np.abs(x0) + 1e-3,
                        diff_step=1e-4)  # fmt: skip
    logger.info(
        "fitted to the output error: RMS %.4g -> %.4g (%d evaluations)",
        float(np.sqrt(np.mean(residual(x0) ** 2))), float(np.sqrt(np.mean(fit.fun**2))), fit.nfev,
    )  # fmt: skip
    return model.with_params(**dict(zip(names, fit.x.tolist(), strict=True)))


__all__ = [
    "DELAY_TRADE_LIMIT",
    "DELAY_TRADE_SHARE",
    "BalanceData",
    "DelayTrade",
    "FitResult",
    "LinearSolve",
    "PooledBalance",
    "Regressors",
    "delay_trade",
    "discrete_inertia",
    "discrete_inertia_slope",
    "fit_model",
    "fit_output_error",
    "force_shares",
    "inertia_from_discrete",
    "linear_param_cov",
    "linear_param_std",
    "model_balance",
    "model_key",
    "refitted_parameters",
]
