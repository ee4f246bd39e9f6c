"""The doctor's measures of a model against records: the gaps, the torque-balance residual, the
evidence, and what the rests say of static friction.

- :func:`gaps`: the free-run output gap overall and in a region [v] and the force error [%];
  :func:`balance_residual`: the force residual on the decimated samples; :func:`free_run_error`.
- :func:`evidence`: ΔBIC on the effective sample size (:mod:`motorid.diagnose.workflow`, step 3);
  :func:`holdout_rows`: the blocks a candidate is checked on.
- :class:`Breakaway` (:func:`breakaway`, :func:`breakaway_evidence`, :func:`breakaway_holdout`)
  and :func:`fit_static_friction`: static friction measured at the rests.

The noise floors per speed band are :meth:`Pool.noise_bands
<motorid.diagnose.prepare.Pool.noise_bands>` and :meth:`Pool.band_floor
<motorid.diagnose.prepare.Pool.band_floor>`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from motorid.diagnose.kinematics import CUTOFF_PER_BAND, lowpass
from motorid.diagnose.locate import Region
from motorid.diagnose.model import BalanceData, model_balance, model_key
from motorid.drive.rigid import RigidDrive

if TYPE_CHECKING:
    from motorid.diagnose.prepare import Pool, Prepared


def balance_residual(model: RigidDrive, data: BalanceData) -> tuple[np.ndarray, np.ndarray]:
    """Force residual ``F_in - F_model`` on the decimated samples, and the commanded force ``g u``.

    On samples near rest (not moving) static friction holds whatever force lies
    between the model's friction levels at 0- and 0+ (widened by its static friction
    ``ΔF_s``, moved by a position ripple's torque ``T_q`` where the drive rests): there the
    model force is ``J a + clip(F_in - J a, T(0-) - ΔF_s + T_q, T(0+) + ΔF_s + T_q)``, on the
    force and acceleration as they are (the moving samples' balance leaves out the samples it
    does not hold on, :meth:`~motorid.diagnose.model.BalanceData.decimated`). ``J`` is the
    acceleration's coefficient in the balance (:meth:`~motorid.diagnose.model.BalanceData.balance_inertia`).
    """
    f_in, f_model = model_balance(model, data)
    kin = data.kin
    f_meas = data.decimated("F|", data.balance_force(data.input_gain * kin.u), held=False)
    f_as_is = data.decimated(
        ("input force", model_key(model)), lambda: data.balance_force(model.input_force(kin.u)), held=False
    )
    eps = max(1e-9, 1e-6 * data.scale["w_max"])
    t_pos, t_neg = model.without(*model.position_effects).friction(np.array([eps, -eps]))
    excess = model.params.get("breakaway_excess", 0.0)  # static friction widens the band at rest
    rest = ~data.moving
    ripple = model.position_torque(data.kin.q[data.idx[rest]])  # moves the band where it rests
    lo, hi = min(t_pos, t_neg) - excess + ripple, max(t_pos, t_neg) + excess + ripple
    ja = data.balance_inertia(model.inertia, model.params.get("viscous", 0.0)) * data.a_as_is[rest]
    f_in, f_model = f_in.copy(), f_model.copy()
    f_in[rest] = f_as_is[rest]
    f_model[rest] = ja + np.clip(f_in[rest] - ja, lo, hi)
    return f_in - f_model, f_meas


def one_step_noise(model: RigidDrive, data: BalanceData) -> float:
    """Standard deviation σ [v] of white noise on a velocity record's speed, from ``model``'s
    one-step prediction of each sample its balance holds on (:attr:`BalanceData.holds
    <motorid.diagnose.model.BalanceData.holds>`).

    With the input force F and the friction T held over sample k, the drive's speed is
    ``w_k = a w_{k-1} + (1 - a) (F_k - T_k) / B``, ``a = e^{-x}``, ``x = B dt / J``
    (:func:`~motorid.diagnose.model.discrete_inertia`). On measured speeds ``y_k = w_k + n_k`` the
    prediction's error is ``e_k = y_k - a y_{k-1} - (1 - a) (F_k - T_k) / B = n_k - a n_{k-1}``,
    which is the balance's residual ``r_k`` scaled by ``(1 - a) / B``, so for white noise::

        σ² = mean(e_k²) / (1 + a²)

    A model that misses an effect leaves its share of the force in ``e_k`` too: the figure is the
    noise and what the model does not describe, one sample at a time. NaN on a position record,
    a model without viscous friction or inertia, or a record with no sample that holds.

    Parameters
    ----------
    model : RigidDrive
        The fitted model (inertia J [F s²/v], viscous friction B [F s/v]).
    data : BalanceData
        The record's balance data.
    """
    kin = data.kin
    inertia, viscous = float(model.inertia), float(model.params.get("viscous", 0.0))
    if kin.output_kind != "velocity" or not (inertia > 0.0 and viscous > 0.0):
        return math.nan
    x = viscous * kin.dt / inertia
    a = math.exp(-x)
    residual = (
        model.input_force(kin.u)
        - data.balance_inertia(inertia, viscous) * kin.balance_a
        - model.friction(kin.balance_w, kin.q)
    )
    held = data.holds & kin.valid
    held[0] = False  # the first sample has no sample before it
    if not held.any():
        return math.nan
    e = residual[held] * (-math.expm1(-x)) / viscous
    return float(np.sqrt(np.mean(e**2) / (1.0 + a * a)))


def rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


@dataclass(frozen=True)
class Gap:
    """How far a model's free run lies from a record, and its force error.

    Attributes
    ----------
    overall : float
        RMS of measured minus free-run velocity over the settled samples [v].
    region : float
        The same over a located region's samples [v] (NaN where none was asked).
    force_error_percent : float
        ``100 ||F_in - F_model|| / ||F_in||`` over the decimated moving samples of the torque
        balance [%] (the EMPS figure of merit).
    """

    overall: float
    region: float
    force_error_percent: float

    def to_dict(self) -> dict[str, float]:
        return {
            "overall": self.overall,
            "region": self.region,
            "force_error_percent": self.force_error_percent,
        }


def gaps(model: RigidDrive, prep: Prepared, region: Region | None) -> Gap:
    """Output gap overall and in ``region`` [v] (free run) and force error [%].

    Parameters
    ----------
    model : RigidDrive
        The model run free on the record's input.
    prep : Prepared
        The record.
    region : Region or None
        Where the second gap is measured (None: NaN).

    Returns
    -------
    Gap
    """
    return gaps_and_weights(model, prep, region)[0]


def gaps_and_weights(
    model: RigidDrive, prep: Prepared, region: Region | None
) -> tuple[Gap, dict[str, float]]:
    """:func:`gaps` and what a pool weighs them by: the samples each RMS is over (``overall``,
    ``region``) and the norm of the commanded force (``force_error_percent``)."""
    key = (model_key(model), region)
    if key not in prep._gaps:
        err = free_run_error(prep, model)
        valid = np.isfinite(err)
        in_region = valid & prep.region_mask(region) if region is not None else np.zeros_like(valid)
        r, f_in = balance_residual(model, prep.data)
        f_norm = float(np.linalg.norm(f_in))
        prep._gaps[key] = (
            Gap(
                overall=rms(err[valid]),
                region=rms(err[in_region]) if region is not None else float("nan"),
                force_error_percent=100.0 * float(np.linalg.norm(r) / max(f_norm, 1e-300)),
            ),
            {"overall": int(valid.sum()), "region": int(in_region.sum()), "force_error_percent": f_norm},
        )
    return prep._gaps[key]


def free_run_error(prep: Prepared, model: RigidDrive) -> np.ndarray:
    """Measured minus free-run velocity [v] at every sample (NaN outside the settled span).

    The measured velocity is the record's filtered one (:attr:`Kinematics.w
    <motorid.diagnose.kinematics.Kinematics.w>`); on a velocity record the free run passes the
    same zero-phase low-pass, so the error is the low-passed difference of the measured and the
    free-run speed: the filter takes the noise out of it and leaves the model's error, also where
    it cuts into the speed's own band (a record sampled near its time constant J / B, whose
    speed changes much within each sample).

    Parameters
    ----------
    prep : Prepared
        The record.
    model : RigidDrive
        The model run free on its input.
    """
    kin = prep.kin
    run = prep.simulate(model)
    start = prep.free_run_start(model)
    if kin.output_kind == "velocity" and np.isfinite(run[start:]).all():
        run[start:] = lowpass(run[start:], kin.dt, CUTOFF_PER_BAND * kin.band)
    err = kin.w - run
    err[~kin.valid] = np.nan
    return err


#: Fewest rests a record (or pool) needs before its breakaway says anything.
MIN_RESTS = 5
#: Folds the rests are held out in, rest by rest, in static friction's held-out checks
#: (:func:`breakaway_cross_check`, :func:`static_friction_cross_check`).
REST_FOLDS = 5
#: Relative difference of two free-run costs [-] below which :func:`fit_static_friction` takes them
#: for one (two free runs whose rests all break away in the same samples are equal to the bit).
PLATEAU_TOLERANCE = 1e-9


#: What the rests of a drive say of its breakaway (:attr:`Breakaway.reading`).
READINGS = ("static_friction", "lag", "lookalike", "none")


@dataclass(frozen=True)
class Breakaway:
    """What the rests of a pool say of static friction, against a model's kinetic level.

    A breakaway excess is a level of the force; a lag is a time. The force at breakaway above the
    kinetic level at 0±, ``e_i`` [F] at rest i (:meth:`Pool.breakaway_excess
    <motorid.diagnose.prepare.Pool.breakaway_excess>`), is fitted by least squares as a level and
    a lag::

        e_i = ΔF_s + τ r_i

    with ``r_i`` the rate of the force of the input at breakaway [F/s] (:class:`~motorid.diagnose.rests.Rests`):
    a lag τ [s] between input and force (an armature's electrical time constant) raises the input
    a drive breaks away at in proportion to how fast the input rises, static friction ΔF_s does
    not. ΔF_s is the breakaway at an input that rises infinitely slowly. The rule
    (:attr:`reading`): where the rates spread (by :data:`RATE_SPREAD` of their mean: a chirp, or the
    records of a joint run at other frequencies), a level above twice its standard error is static
    friction, else a slope above twice its standard error is a lag. Where they do not spread (a
    sine's reversals all alike), one excess ``ē`` at one rate ``r̄`` is read both ways, ``ΔF_s = ē``
    or ``τ = ē / r̄``: a lookalike, which the rests alone cannot tell (the moving drive can:
    :meth:`Search.static_friction <motorid.diagnose.search.Search.static_friction>`).

    Attributes
    ----------
    rests : int
        Rests counted.
    excess : float
        ΔF_s [F]; at one rate, the mean excess ``ē`` (NaN for fewer than 3 rests).
    standard_error : float
        Standard error of ΔF_s [F] from the fit's residual, and at least ``g q / sqrt(12 n)``
        where the input is quantised in steps ``q`` [u] (an integer PWM duty; ``g`` the input
        gain [F/u], n the rests): each breakaway's input is known only to within a step
        (rounding's standard deviation ``q / sqrt(12)``), so rests that break away at one held
        level, which agree exactly, do not make ΔF_s exact.
    lag : float
        τ [s]; at one rate, ``ē / r̄`` (0 where every breakaway is under a held input).
    lag_std : float
        Standard error of τ [s].
    one_rate : bool
        The rates do not spread: ``excess`` and ``lag`` are two readings of one excess.
    rate_per_record : bool
        A joint run whose records each break away at one rate of their own (:func:`rates_per_record`):
        the rates spread between the records only, and the fit's level ``excess`` and the lag
        ``lag`` that would hold the whole excess (``Σ r_i e_i / Σ r_i²``; ``lag_std`` NaN) are two
        readings the moving drive tells apart, as at one rate.
    record_rates : tuple of float
        With ``rate_per_record``, each record's mean rate at breakaway [F/s].
    bracketed : int
        The rests whose input's force stepped past the breakaway within a sample
        (:data:`~motorid.diagnose.prepare.BRACKET_SHARE`), which bracket it and do not read it
        (not among ``rests``).
    shown : bool
        The rests show breakaway above the kinetic level: at least :data:`MIN_RESTS` rests at
        spread rates (or held inputs) and ΔF_s above twice its standard error.
    """

    rests: int
    excess: float
    standard_error: float
    lag: float
    lag_std: float = math.nan
    one_rate: bool = False
    shown: bool = False
    rate_per_record: bool = False
    record_rates: tuple[float, ...] = ()
    bracketed: int = 0

    def rates_words(self, unit: str) -> str:
        """How the rests' rates lie, for a sentence (``unit`` the force's): ``all at one input rate
        (19 V/s)``, or in a joint run ``each record's at one input rate of its own (9.32 to 36.9 V/s)``."""
        if self.rate_per_record:
            low, high = min(self.record_rates), max(self.record_rates)
            return f"each record's at one input rate of its own ({low:.3g} to {high:.3g} {unit}/s)"
        rate = self.excess / self.lag if self.lag else math.nan
        return f"all at one input rate ({rate:.3g} {unit}/s)"

    @property
    def apart_words(self) -> str:
        """What would tell the two readings apart, for a sentence."""
        if self.rate_per_record:
            return "rests whose rates spread within a record (a chirp) tell them apart"
        return (
            "rests at other input rates (a chirp, or records at other frequencies in one run) tell them apart"
        )

    @property
    def measures(self) -> bool:
        """The rests measure the breakaway: at least :data:`MIN_RESTS` of them, and their level not
        more than two standard errors below the kinetic one (which no friction breaks away at: the
        input stepped past the breakaway within a sample, and the last sample at rest holds the
        level before the step)."""
        return (
            self.rests >= MIN_RESTS
            and math.isfinite(self.excess)
            and not self.excess < -2.0 * self.standard_error
        )

    @property
    def reading(self) -> str:
        """What the rests say (:data:`READINGS`): ``static_friction`` (:attr:`shown`), ``lag`` (the
        rates spread within a record and τ lies above twice its standard error, ΔF_s not),
        ``lookalike`` (one rate, or one rate per record of a joint run: a level above twice its
        standard error, which the moving drive tells from a lag) or ``none`` (too few rests, or a
        level more than two standard errors below the kinetic one, which no friction breaks away
        at: the rests do not measure the breakaway, as where the input steps past it within a
        sample)."""
        if not self.measures:
            return "none"
        if self.shown:
            return "static_friction"
        if self.one_rate or self.rate_per_record:
            return "lookalike" if self.excess > 2.0 * self.standard_error else "none"
        return "lag" if self.lag > 2.0 * self.lag_std else "none"

    def to_dict(self) -> dict[str, Any]:
        return {"rests": self.rests, "excess": self.excess, "standard_error": self.standard_error,
                "lag": self.lag, "lag_std": self.lag_std, "one_rate": self.one_rate,
                "rate_per_record": self.rate_per_record, "record_rates": list(self.record_rates), "shown": self.shown,
                "bracketed": self.bracketed,
                "reading": self.reading}  # fmt: skip


#: The rates at breakaway spread enough to tell a level from a lag when their standard deviation
#: is at least this share of their mean magnitude (a sine's reversals: 0.1-0.5 %; a chirp's: 40 %).
RATE_SPREAD = 0.2


def one_rate(rate: np.ndarray) -> bool:
    """The rates at breakaway do not spread by :data:`RATE_SPREAD` of their mean magnitude
    (and are not all 0, breakaways under held inputs, which have no lag to tell).

    Parameters
    ----------
    rate : ndarray
        The rate of the input's force at each breakaway [F/s].
    """
    return bool(np.any(rate)) and float(np.std(rate)) < RATE_SPREAD * float(np.mean(np.abs(rate)))


def _breakaway_fit(excess: np.ndarray, rate: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares ``excess = ΔF_s + τ rate``: the coefficients, their covariance and the RSS.
    The covariance is inf where the rates do not spread (:func:`one_rate`): reversals at one
    input rate cannot tell a level from a lag."""
    x = np.column_stack([np.ones(excess.size), rate])
    coef, *_ = np.linalg.lstsq(x, excess, rcond=None)
    resid = excess - x @ coef
    rss = float(resid @ resid)
    xtx = x.T @ x
    if not np.any(rate):  # every breakaway under a held input: no lag to tell, the level alone
        level = float(np.mean(excess))
        rss = float(np.sum((excess - level) ** 2))
        var = rss / max(excess.size - 1, 1) / excess.size
        return np.array([level, 0.0]), np.array([[var, 0.0], [0.0, 0.0]]), rss
    if one_rate(rate) or np.linalg.cond(xtx) > 1e12:
        return coef, np.full((2, 2), np.inf), rss
    return coef, rss / max(excess.size - 2, 1) * np.linalg.inv(xtx), rss


def _typical(excess: np.ndarray, rate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rests that look like a breakaway: the input rising (or held) in the direction the
    drive then moves (a drive that leaves a rest while its input falls was not held by friction
    but crept off), and, of those, the ones whose breakaway lies within 3 robust standard
    deviations (1.4826 MAD) of the fit of :class:`Breakaway`, refitted until none is left out
    (at most 3 times: a rest the filtered speed left by noise would pull a least-squares level).
    A rest whose breakaway a step of the force brackets (NaN) reads nothing."""
    keep = (rate >= 0.0) & np.isfinite(excess)  # NaN: a step of the force brackets the breakaway
    excess, rate = excess[keep], rate[keep]
    for _ in range(3):
        if excess.size < 3:
            break
        coef, *_ = _breakaway_fit(excess, rate)
        resid = excess - coef[0] - coef[1] * rate
        centre = float(np.median(resid))
        spread = 1.4826 * float(np.median(np.abs(resid - centre)))
        keep = np.abs(resid - centre) <= 3.0 * spread
        if spread <= 0 or keep.all():
            break
        excess, rate = excess[keep], rate[keep]
    return excess, rate


def rates_per_record(
    pool: Pool, excess: np.ndarray, rate: np.ndarray, samples: list[np.ndarray] | None = None
) -> tuple[float, ...] | None:
    """Each record's mean rate at breakaway [F/s] where the rates of a joint run spread between
    its records only (else None): at least two records show 3 typical rests or more
    (:func:`_typical`), and each of them breaks away at one rate of its own (:func:`one_rate`), as
    sines of other frequencies do.

    Their rests then lie in one cluster per record, and a level and a slope fitted through the
    clusters rest on as many points as there are records: the residual of the rests about them
    (none, for a sine's identical reversals) says nothing of how well the clusters decide the
    level. A lag that acts unlike a pure time (the rests end a little after the shaft leaves
    zero, sooner at a faster input) bends the clusters off a line through zero: a 10 ms input lag
    on a kit-like motor, sines at 0.25 and 1 Hz, gave a level of 0.043 V "within 7e-14 V".

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    excess, rate : ndarray
        The excess [F] and the rate [F/s] at each rest of each record, in the records' order
        (:meth:`Pool.breakaway_excess <motorid.diagnose.prepare.Pool.breakaway_excess>` with ``samples``).
    samples : list of ndarray or None
        Each record's full-rate samples the rests break away in (None: all).
    """
    counts = [
        (p.rests if samples is None else p.rests.within(samples[k])).count for k, p in enumerate(pool.parts)
    ]
    edges = np.cumsum(counts)[:-1]
    means = []
    for own_excess, own_rate in zip(np.split(excess, edges), np.split(rate, edges), strict=True):
        own_excess, own_rate = _typical(own_excess, own_rate)
        if own_excess.size < 3:
            continue
        if not one_rate(own_rate):
            return None
        means.append(float(np.mean(own_rate)))
    return tuple(means) if len(means) >= 2 else None


def breakaway(pool: Pool, model: RigidDrive, samples: list[np.ndarray] | None = None) -> Breakaway:
    """The breakaway the rests of ``pool`` show above ``model``'s kinetic level (see
    :class:`Breakaway`; the rests that break away in the full-rate ``samples``, the typical ones:
    :func:`_typical`)."""
    raw = pool.breakaway_excess(model, samples)
    return dataclasses.replace(_breakaway(pool, model, raw, samples), bracketed=int(np.sum(np.isnan(raw[0]))))


def _breakaway(
    pool: Pool, model: RigidDrive, raw: tuple[np.ndarray, np.ndarray], samples: list[np.ndarray] | None
) -> Breakaway:
    excess, rate = _typical(*raw)
    n = int(excess.size)
    if n < 3:
        return Breakaway(n, math.nan, math.nan, math.nan)
    rounding = model.params.get("input_gain", 1.0) * pool.input_quantisation / math.sqrt(12.0 * n)
    if one_rate(rate):
        # one excess at one rate, read as a level ē or as a lag ē / r̄
        level = float(np.mean(excess))
        se = max(float(np.std(excess, ddof=1)) / math.sqrt(n), rounding)
        mean_rate = float(np.mean(rate))
        return Breakaway(n, level, se, level / mean_rate, se / mean_rate, one_rate=True)
    coef, cov, _ = _breakaway_fit(excess, rate)
    se = math.sqrt(cov[0, 0])
    if not math.isfinite(se):  # the rates spread, yet the fit is singular: nothing told
        return Breakaway(n, math.nan, math.inf, math.nan, math.inf)
    se = max(se, rounding)
    level = float(coef[0])
    record_rates = rates_per_record(pool, *raw, samples) if len(pool.parts) > 1 else None
    if record_rates is not None:
        # one rate per record: the level, or the lag that holds the whole excess (τ = Σ r e / Σ r²)
        lag = float(rate @ excess / (rate @ rate))
        return Breakaway(n, level, se, lag, math.nan, rate_per_record=True, record_rates=record_rates)
    return Breakaway(
        n, level, se, float(coef[1]), math.sqrt(cov[1, 1]), False, n >= MIN_RESTS and level > 2.0 * se
    )


def breakaway_evidence(excess: np.ndarray, rate: np.ndarray, lag_allowed: bool = True) -> dict[str, float]:
    """ΔBIC of static friction on the rests: the fit of :class:`Breakaway` against the lag alone
    (``e_i = τ r_i``, no level above the kinetic one)::

        ΔBIC = n ln(RSS_lag / RSS_lag+level) - ln n

    (:func:`evidence` with the typical rests as its samples: one per reversal). Where the moving
    drive rules the lag out (``lag_allowed`` False: rests at one rate, whose excess a lag would
    need the balance to take), the level ``ē`` against no excess at all: ``RSS_0 = Σ e_i²``,
    ``RSS_1 = Σ (e_i - ē)²``."""
    excess, rate = _typical(excess, rate)
    n = int(excess.size)
    if n < 3:
        return {"delta_bic": -math.inf, "n": n, "n_eff": float(n), "rho": 0.0, "rss_ratio": 1.0}
    if not lag_allowed:
        resid1 = excess - float(np.mean(excess))
        return evidence(float(excess @ excess), float(resid1 @ resid1), n, 1, resid1)
    coef, _, rss1 = _breakaway_fit(excess, rate)
    slope = float(rate @ excess / (rate @ rate)) if float(rate @ rate) > 0 else 0.0
    resid0 = excess - slope * rate
    return evidence(float(resid0 @ resid0), rss1, n, 1, excess - coef[0] - coef[1] * rate)


def breakaway_holdout(
    train: Pool,
    train_samples: list[np.ndarray] | None,
    held: Pool,
    held_samples: list[np.ndarray] | None,
    model: RigidDrive,
    lag_allowed: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Held-out check of static friction on the rests: the fits of :class:`Breakaway` on the
    rests of ``train`` (in ``train_samples``), with and without the level ΔF_s, predict the
    breakaway of the rests of ``held`` (in ``held_samples``; those with the input rising) above
    ``model``'s kinetic level; the absolute errors [F] at each held-out rest without and with it
    (empty without at least 3 training rests or a held-out rest to check). Where the moving drive
    rules the lag out (``lag_allowed`` False), no excess at all against the training rests' mean
    level."""
    e_t, r_t = _typical(*train.breakaway_excess(model, train_samples))
    e_h, r_h = held.breakaway_excess(model, held_samples)
    read = (r_h >= 0.0) & np.isfinite(e_h)
    e_h, r_h = e_h[read], r_h[read]
    if e_t.size < 3 or e_h.size == 0:
        return np.empty(0), np.empty(0)
    if not lag_allowed:
        level = max(float(np.mean(e_t)), 0.0)
        return np.abs(e_h), np.abs(e_h - level)
    coef, _, _ = _breakaway_fit(e_t, r_t)
    lag_only = float(r_t @ e_t / (r_t @ r_t)) if float(r_t @ r_t) > 0 else 0.0
    level = max(float(coef[0]), 0.0)
    return np.abs(e_h - lag_only * r_h), np.abs(e_h - level - coef[1] * r_h)


def breakaway_cross_check(
    pool: Pool, model: RigidDrive, lag_allowed: bool = True, other: Pool | None = None
) -> tuple[float, float]:
    """Held-out check of static friction read on the rests, rest by rest: the rests dealt into
    :data:`REST_FOLDS` folds (:meth:`Pool.rest_folds <motorid.diagnose.prepare.Pool.rest_folds>`),
    each fold's rests predicted in turn from the others' (:func:`breakaway_holdout`), or, with a
    second record ``other``, its rests from all of the pool's; the median absolute errors [F] over
    every held-out rest without and with the level (a median: a few rests cannot be sifted for the
    typical ones; NaN without a rest to check).

    The search's held-out blocks (a share of the record) hold a few rests or none; dealt into
    folds, every rest is held out once (a record sampled at 36 ms with 10 rests had none in its
    held-out blocks, and a static friction its rests read within 5 % had no check at all).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model static friction is added to (its kinetic level is the reference).
    lag_allowed : bool
        Whether the moving drive leaves a lag to tell the level from (:func:`breakaway_holdout`).
    other : Pool, optional
        A second record of the drive, held out whole.
    """
    if other is not None:
        checks = [breakaway_holdout(pool, None, other, None, model, lag_allowed)]
    else:
        checks = [
            breakaway_holdout(pool, [~m for m in held], pool, held, model, lag_allowed)
            for held in pool.rest_folds(REST_FOLDS)
        ]
    base, cand = (np.concatenate(errors) for errors in zip(*checks, strict=True))
    if base.size == 0:
        return math.nan, math.nan
    return float(np.median(base)), float(np.median(cand))


def static_friction_cross_check(pool: Pool, model: RigidDrive) -> tuple[float, float]:
    """Held-out check of static friction fitted on the free run (:func:`fit_static_friction`,
    where the rests do not measure it), rest by rest: the rests of the records dealt into
    :data:`REST_FOLDS` folds (:meth:`Pool.rest_folds <motorid.diagnose.prepare.Pool.rest_folds>`),
    each fold's rests and breakaways held out in turn and the level fitted on the free run
    of every other sample; the RMS free-run error [v] over the held-out rests without and with it
    (NaN without rests).

    A few held levels that the drive does not break away from carry the whole of static friction's
    free-run gap; the search's held-out blocks (a share of the record) seldom hold them, so there
    the level would have no evidence either way. Dealt into folds, every rest is held out once.

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model static friction is added to (its kinetic level is the reference).
    """
    base, cand = [], []
    for held in pool.rest_folds(REST_FOLDS):
        if not any(m.any() for m in held):
            return math.nan, math.nan
        trained = fit_static_friction(pool, model, [~m for m in held])
        base.append(pool.free_run_error(model, held))
        cand.append(pool.free_run_error(trained, held))
    return rms(np.concatenate(base)), rms(np.concatenate(cand))


def fit_static_friction(pool: Pool, model: RigidDrive, samples: list[np.ndarray] | None) -> RigidDrive:
    """``model`` with ``static_friction`` and its ``breakaway_excess`` ΔF_s [F], from the full-rate
    ``samples`` of each record of ``pool`` (None: all).

    Static friction acts on a drive at rest only, so the balance of the moving samples cannot
    fit it. Where the records' typical rests measure it (:attr:`Breakaway.measures`: at least
    :data:`MIN_RESTS`, not read below the kinetic level), they give it: the force at breakaway
    above the model's kinetic level (:func:`breakaway`; 0 when they show none above it).
    Otherwise the free run fits it (:func:`free_run_levels`): the free run moves only where a level
    changes whether the drive breaks away in some sample, so the gap is flat over the levels
    between two such changes, and the reading is the middle of the flat stretch around the best.
    Where the input's steps bracket every rest, the stretch is the bracket they leave: on an
    encoder's held levels with 7 rests, 6 bracketed, 0.47-1.42 times the planted level, read at
    0.94 (a bounded search inside it had ended at 1.26).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model static friction is added to (its kinetic level is the reference).
    samples : list of ndarray or None
        Each record's full-rate samples to fit on (the training blocks), None for all.
    """
    return static_friction_reading(pool, model, samples)[0]


def static_friction_reading(
    pool: Pool, model: RigidDrive, samples: list[np.ndarray] | None
) -> tuple[RigidDrive, float]:
    """:func:`fit_static_friction`'s model, and one standard error [F] of its level ΔF_s: the
    rests' (:attr:`Breakaway.standard_error`) where they measure it; else from the stretch
    ``(low, high)`` of levels the free run cannot tell apart (:func:`free_run_levels`), as a level
    equally likely anywhere in it, ``(high - low) / √12``; NaN where the free run reads none or a
    single level (its gap not flat around it: a lag in the input path moves the breakaway inside a
    sample as the level moves).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model static friction is added to (its kinetic level is the reference).
    samples : list of ndarray or None
        Each record's full-rate samples to fit on, None for all.
    """
    found = breakaway(pool, model, samples)
    if found.measures:
        excess = max(found.excess, 0.0) if math.isfinite(found.excess) else 0.0
        return with_static_friction(model, excess), found.standard_error
    level, low, high = free_run_levels(pool, model, samples)
    return with_static_friction(model, level), (high - low) / math.sqrt(12.0) if high > low else math.nan


def with_static_friction(model: RigidDrive, excess: float) -> RigidDrive:
    """``model`` with ``static_friction`` at the level ``excess`` ΔF_s [F] above its kinetic one
    (in place of the one it holds).

    Parameters
    ----------
    model : RigidDrive
        The drive.
    excess : float
        The breakaway level above the kinetic one [F].
    """
    effects = tuple(dict.fromkeys((*model.effects, "static_friction")))
    return model.with_effects(effects, {**model.params, "breakaway_excess": float(excess)})


def free_run_levels(
    pool: Pool, model: RigidDrive, samples: list[np.ndarray] | None
) -> tuple[float, float, float]:
    """Static friction's level ΔF_s [F] above ``model``'s kinetic level read on the free run of the
    full-rate ``samples`` of each record of ``pool`` (None: all), and the stretch of levels
    ``(low, high)`` [F] whose free runs are as close: ``(level, low, high)``.

    A grid of 17 levels on [0, half the largest input force], a bounded search between the best
    one's neighbours, then each edge of the stretch around the best by bisection to 10⁻⁴ of the
    range (costs within :data:`PLATEAU_TOLERANCE` of each other are one). The level is the middle
    of the stretch; 0 where it reaches 0 (no level runs closer than none; the stretch then (0, 0)),
    its lower edge where it reaches the range's top (``high`` the top).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model static friction is added to (its kinetic level is the reference).
    samples : list of ndarray or None
        Each record's full-rate samples to fit on, None for all.
    """
    from scipy.optimize import minimize_scalar

    top = 0.5 * pool.data.scale["u_max"] * abs(model.input_gain)
    xatol = 1e-4 * top

    def cost(excess: float) -> float:
        err = pool.free_run_error(with_static_friction(model, excess), samples)
        err = err[np.isfinite(err)]
        return float(np.mean(err**2)) if err.size else math.inf

    grid = np.linspace(0.0, top, 17)
    costs = [cost(e) for e in grid]
    i = int(np.argmin(costs))
    best = minimize_scalar(
        cost,
        bounds=(grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]),
        method="bounded",
        options={"xatol": xatol, "maxiter": 500},
    )
    x, least = (best.x, best.fun) if best.fun <= costs[i] else (grid[i], costs[i])
    same = least * (1.0 + PLATEAU_TOLERANCE)
    left = [g for g, c in zip(grid, costs, strict=True) if g < x and c > same]
    right = [g for g, c in zip(grid, costs, strict=True) if g > x and c > same]
    if not left:
        return 0.0, 0.0, 0.0  # no level at all runs as close

    def edge(inside: float, outside: float) -> float:
        while abs(outside - inside) > xatol:
            middle = 0.5 * (inside + outside)
            inside, outside = (middle, outside) if cost(middle) <= same else (inside, middle)
        return inside

    low = edge(x, left[-1])
    if not right:
        return low, low, top
    high = edge(x, right[0])
    return 0.5 * (low + high), low, high


def _lag1(r: np.ndarray) -> float:
    r = r - r.mean()
    den = float(np.dot(r, r))
    return float(np.dot(r[1:], r[:-1]) / den) if den > 0 and r.size > 2 else 0.0


def evidence(rss0: float, rss1: float, n: int, dk: int, residual: np.ndarray) -> dict[str, float]:
    """ΔBIC on the effective sample size (see the module notes)."""
    rho = min(max(_lag1(residual), 0.0), 0.95)
    n_eff = max(n * (1.0 - rho) / (1.0 + rho), 2.0)
    ratio = rss0 / rss1 if rss1 > 0 else np.inf
    if 0.0 < ratio < np.inf:
        dbic = n_eff * math.log(ratio) - max(dk, 0) * math.log(n_eff)
    else:  # a candidate that leaves nothing of a residual, or one of a fit that has none (or none finite)
        dbic = np.inf if ratio == np.inf and rss0 > 0 else -np.inf
    return {
        "delta_bic": float(dbic),
        "n": int(n),
        "n_eff": float(n_eff),
        "rho": float(rho),
        "rss_ratio": float(ratio),
    }


def holdout_rows(n: int, fraction: float, blocks: int = 10) -> np.ndarray:
    """Held-out decimated rows: ``round(blocks * fraction)`` of ``blocks`` equal blocks, spread out."""
    m = min(max(round(blocks * fraction), 1), blocks - 1)
    chosen = np.unique(np.round(np.linspace(0, blocks - 1, m + 2)[1:-1]).astype(int))
    block = np.minimum((np.arange(n) * blocks) // max(n, 1), blocks - 1)
    return np.isin(block, chosen)


__all__ = [
    "MIN_RESTS",
    "PLATEAU_TOLERANCE",
    "READINGS",
    "REST_FOLDS",
    "Breakaway",
    "Gap",
    "breakaway_cross_check",
    "fit_static_friction",
    "free_run_error",
    "free_run_levels",
    "one_rate",
    "rates_per_record",
    "static_friction_cross_check",
    "static_friction_reading",
    "with_static_friction",
]  # fmt: skip
