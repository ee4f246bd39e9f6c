"""The doctor's search: the base structure, then the effects, one step at a time.

:func:`choose_structure` takes the input delay and lag from the record before any other effect is
judged. :class:`Search` runs the steps of :func:`~motorid.diagnose.workflow.diagnose` (the module
notes there give the rules): each effect tried is a :class:`Candidate` (its fit and its evidence),
each check of one a :class:`Decision` (held-out error, free-run gap, noise), the lookalike rule
(:func:`lookalike_rule`) names one effect of a physics, and the search ends with a
:class:`~motorid.diagnose.results.Stop` (:class:`SearchOutcome`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motorid.diagnose.locate import Region, locate
from motorid.diagnose.measures import (
    MIN_RESTS,
    PLATEAU_TOLERANCE,
    Breakaway,
    Gap,
    breakaway,
    breakaway_cross_check,
    breakaway_evidence,
    evidence,
    fit_static_friction,
    free_run_error,
    rms,
    static_friction_cross_check,
    static_friction_reading,
)
from motorid.diagnose.model import FitResult, fit_model, fit_output_error, refitted_parameters
from motorid.diagnose.position import held_out_position_error, position_unit
from motorid.diagnose.prepare import HeldOut, Pool
from motorid.diagnose.results import (
    CandidateEvidence,
    Evidence,
    Lookalike,
    RecordGap,
    Rejected,
    Step,
    Stop,
    Structure,
    StructureCandidate,
)
from motorid.drive.effects import effect_order, parameter_owner
from motorid.drive.effects import get as get_effect
from motorid.drive.effects import names as effect_library
from motorid.drive.rigid import RigidDrive
from motorid.errors import DataError

logger = logging.getLogger(__name__)

#: Default evidence threshold on ΔBIC: above the 95th percentile (3.8) of the best candidate's
#: ΔBIC on 200 no-effect records; the held-out and free-run checks stop the 4 that pass it, and
#: the workflow names nothing on any (:mod:`.calibration`).
DEFAULT_THRESHOLD = 10.0
#: Share of the best candidate's RSS reduction above which two candidates are "alike".
ALIKE = 0.8
DEFAULT_BASE = ("viscous_friction", "offset")
#: Smallest free-run error a second or later effect accounts for (:func:`explained`), in noise
#: floors σ_w: its own error must exceed the noise (:mod:`.calibration` measures the false
#: alarms with it and without it). A gap of at most ``sqrt(1 + NOISE_EXPLAINED²)`` floors ends
#: the search: no model's gap falls below the noise, so no effect can account for more.
NOISE_EXPLAINED = 1.0
#: Two candidates of one physics whose free-run gaps lie within this many noise floors of each
#: other fit alike (the lookalike rule).
ALIKE_GAP = 0.5


def explained(before: float, after: float, floor: float) -> float:
    """The free-run error an effect accounts for, in noise floors: ``sqrt(g0² - g1²) / σ``.

    An RMS gap ``g0`` [v] holds the effect's own error and everything else the model still
    misses, which add in quadrature where they are uncorrelated; the effect accounts for the
    part ``sqrt(g0² - g1²)`` of it, ``g1`` the gap with it. Unlike the shrink ``g0 - g1``, this
    does not fall as the rest of the gap grows: one effect gets one figure on records of one
    drive that miss more or less besides (an effect of 1 σ on a gap of 10 σ shrinks it by
    0.05 σ only).

    Parameters
    ----------
    before, after : float
        The RMS free-run gap [v] without and with the effect.
    floor : float
        The noise floor σ [v] it is judged against (0: infinitely many floors).

    Returns
    -------
    float
        The part accounted for in noise floors; negative, ``-sqrt(g1² - g0²) / σ``, where the
        gap grows.
    """
    power = before * before - after * after
    if floor <= 0:
        return math.copysign(math.inf, power)
    return math.copysign(math.sqrt(abs(power)), power) / floor


def figure(value: float) -> str:
    """A gap or an error for a sentence: four significant digits, or ``diverges`` where the free
    run that measures it did not stay finite (a report never says ``nan``)."""
    return f"{value:.4g}" if math.isfinite(value) else "diverges"


#: The structures tried, each single effect first; the pair only when a single one passes.
STRUCTURES: tuple[tuple[str, ...], ...] = (("input_delay",), ("input_lag",), ("input_delay", "input_lag"))


def choose_structure(
    pool: Pool,
    base: tuple[str, ...],
    start: dict[str, float],
    stribeck_shape: str,
    threshold: float,
    min_gap_shrink: float,
    noise_explained: float,
) -> Structure:
    """Choose the input delay and lag of the drive from its records, before friction is judged.

    The base and Coulomb friction (the probe) are fitted to the torque balance on the moving
    samples with each structure of :data:`STRUCTURES` added (the delay and the time constant
    by the bounded search of :func:`~motorid.diagnose.model.fit_model`). A structure is taken
    when its ΔBIC against the probe (for the pair: against the best single effect) exceeds
    ``threshold`` and its free-run output gap shrinks by more than ``min_gap_shrink`` of the
    probe's and it accounts for more than ``noise_explained`` noise floors of the probe's gap
    (:func:`explained`): the same rules as a step. The delay's value is read again on the final
    model's free run (:meth:`Search.final_delay`).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    base : tuple of str
        The base effects.
    start : dict
        Parameters the fits start from (the base's fit).
    stribeck_shape : str
        The Stribeck shape of the fits.
    threshold : float
        ΔBIC a structure needs.
    min_gap_shrink : float
        Smallest relative shrink of the probe's free-run gap.
    noise_explained : float
        Smallest part of it accounted for, in noise floors (:func:`explained`).

    Returns
    -------
    Structure
    """
    data = pool.data
    floor = pool.noise
    probe = effect_order((*base, "coulomb_friction"))
    fit_p = fit_model(data, probe, start=start, stribeck_shape=stribeck_shape)
    gap_p = pool.gaps(fit_p.model, None).overall
    tried: list[StructureCandidate] = []
    fits: dict[tuple[str, ...], FitResult] = {}

    def fit_pair(against: FitResult) -> FitResult:
        """The pair's fit: a delay and a lag trade along a valley (their sum is what the balance
        sees first), where a search one coordinate at a time stalls; so the delay is searched at
        each lag of a grid up to the single effect's total (a profile), then both refined."""
        names = STRUCTURES[-1]
        total = sum(against.model.params.get(p, 0.0) for p in ("input_delay", "lag_time_constant"))
        lo = get_effect("input_lag").bounds(data.scale)["lag_time_constant"][0]
        profile = [
            fit_model(data, (*probe, *names), start=against.model.params, stribeck_shape=stribeck_shape,
                      fixed={"lag_time_constant": lag})
            for lag in np.geomspace(lo, max(total, 2.0 * lo), 9)
        ]  # fmt: skip
        best = min(profile, key=lambda f: f.rss)
        fit = fit_model(data, (*probe, *names), start=best.model.params, stribeck_shape=stribeck_shape)
        return fit if fit.rss <= best.rss else best

    def try_structure(names: tuple[str, ...], against: FitResult) -> StructureCandidate:
        if len(names) > 1:
            fit = fit_pair(against)
        else:
            fit = fit_model(data, (*probe, *names), start=against.model.params, stribeck_shape=stribeck_shape)
        ev = evidence(
            against.rss, fit.rss, fit.n_rows, fit.n_params - against.n_params, fit.residual[data.moving]
        )
        params = {p: fit.model.params[p] for n in names for p in get_effect(n).nonlinear}
        row = StructureCandidate(names, params, ev["delta_bic"])
        fits[names] = fit
        tried.append(row)
        return row

    singles = [try_structure(names, fit_p) for names in STRUCTURES if len(names) == 1]
    passing = sorted((r for r in singles if r.delta_bic > threshold), key=lambda r: -r.delta_bic)
    # ΔBIC alone decides between the single effects: a delay and a lag of 1-2 samples fit alike,
    # and on 24 records with one planted the balance named the right one 23 times, the free-run
    # gap (biased towards the lag) only 18 times
    if passing:
        pair = try_structure(STRUCTURES[-1], fits[passing[0].effects])
        if pair.delta_bic > threshold:
            passing.insert(0, pair)
    reasons = []
    for row in passing:
        names = row.effects
        row.gap = gap1 = pool.gaps(fits[names].model, None).overall
        part = explained(gap_p, gap1, floor)
        if gap1 < (1.0 - min_gap_shrink) * gap_p and part > noise_explained:
            reason = (
                f"chosen from the moving samples: ΔBIC {row.delta_bic:.1f} > {threshold:g}, free-run gap of "
                f"{' + '.join(probe)} {gap_said(gap_p, pool)} -> {gap1:.4g} (it accounts for "
                f"{'all of it' if gap_said(gap_p, pool) == 'diverges' else f'{part:.1f} noise floors'})"
            )
            return Structure(names, row.params, probe, gap_p, gap1, tried, reason, data.scale["delay_reach"])
        reasons.append(
            f"{'+'.join(names)} (free-run gap {gap_said(gap_p, pool)} -> {gap_said(gap1, pool)}, it accounts for "
            f"{part:.2f} noise floors)"
        )
    if reasons:
        reason = (
            "no delay or lag: the structures that pass ΔBIC do not shrink the free-run gap: "
            + ", ".join(reasons)
        )
    else:
        best = max(tried, key=lambda r: r.delta_bic)
        reason = (
            f"no delay or lag: the best, {'+'.join(best.effects)}, has ΔBIC {best.delta_bic:.1f} "
            f"<= {threshold:g}"
        )
    return Structure((), {}, probe, gap_p, gap_p, tried, reason, data.scale["delay_reach"])


#: The least delay [samples] :meth:`Search.final_delay` gives a model that has none: below
#: it, a delay is a share of the hold's own half-sample lag. Where the free run is sensitive to
#: the least change (a cogging drive's, when its ripple was taken at the free run's own position,
#: which drifts out of phase with the record's), a delay of 0.05 samples moved the free-run gap
#: of a bench that has none by 11 noise floors; an aligned
#: record's 0.96-sample delay (quadratic drag on a chirp at 10 ms) took its final gap from 4.5
#: noise floors to 1.1.
FINAL_DELAY_LEAST = 0.5
#: Points of the grid the free run's delay is searched on over its reach, before the bounded
#: search between the best point's neighbours.
DELAY_GRID = 17
#: ... and whole samples either side of the balance's delay it is also tried at (the coarse
#: grid's points lie several samples apart on a long reach).
NEAR_SAMPLES = 2


def delay_by_free_run(pool: Pool, fit: FitResult, stribeck_shape: str, noise_explained: float) -> FitResult:
    """The input delay of ``fit`` taken where the free run comes closest to the records, the rest
    refitted to the torque balance at each delay tried (the other shapes held there, a dead zone's
    width or a Stribeck velocity, so that each point is one linear solve; refitted at the delay
    found, the other structure parameters held).

    The balance sees the delay τ_d and the inertia J together first (``J + B τ_d``): on a
    smooth input, and with an effect still missing from the model, its least squares put part of
    the delay into the inertia. A logger's 10.6-sample delay on two sines, quadratic drag not yet
    in the model: the balance's best delay was 6 samples (inertia 2.4 times the truth), held
    while the drag was named (final gap 8.1 noise floors); the free-run gap,
    ``sqrt(mean((w - w_sim)²))`` [v], of the final model is least at 10.5 samples (final gap 0.9
    floors). The free run integrates the inertia over the whole record, where a wrong one shows
    as a wrong time constant, so it is the measure the delay is read on; the balance's ΔBIC
    still decides whether there is a delay at all.

    The delay is searched on :data:`DELAY_GRID` points from the lower bound of
    :class:`~motorid.drive.effects.InputDelay` to the records' reach (:func:`~motorid.diagnose.
    model.delay_reach`) and on :data:`NEAR_SAMPLES` whole samples either side of ``fit``'s own,
    then refined by a bounded search between the best point's neighbours.

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    fit : FitResult
        The balance's fit with ``input_delay`` among its effects.
    stribeck_shape : str
        The Stribeck shape of the fits.
    noise_explained : float
        The noise floors of ``fit``'s free-run gap the delay found must account for
        (:func:`explained`) to replace ``fit``'s: the structure's own rule.

    Returns
    -------
    FitResult
        The balance's fit at the delay whose free run comes closest; ``fit`` itself where that
        accounts for no more than ``noise_explained`` noise floors of its gap.
    """
    from scipy.optimize import minimize_scalar

    data = pool.data
    effects = fit.model.effects
    lo, hi = get_effect("input_delay").bounds(data.scale)["input_delay"]
    shapes = {p: fit.model.params[p] for n in effects for p in get_effect(n).nonlinear if p != "input_delay"}
    structure = {p: v for p, v in shapes.items() if get_effect(parameter_owner(p)).structure}
    tried: dict[tuple[float, bool], tuple[float, FitResult]] = {}  # (delay, shapes refitted): gap, fit

    def gap(delay: float, refit_shapes: bool = False) -> float:
        key = (delay, refit_shapes)
        if key not in tried:
            f = fit_model(data, effects, start=fit.model.params, stribeck_shape=stribeck_shape,
                          fixed={**(structure if refit_shapes else shapes), "input_delay": delay})  # fmt: skip
            tried[key] = (free_run_gap(pool, f.model), f)
        return tried[key][0]

    own_delay = fit.model.params["input_delay"]
    near = own_delay + pool.dt * np.arange(-NEAR_SAMPLES, NEAR_SAMPLES + 1)
    grid = np.unique(np.clip(np.concatenate([np.linspace(lo, hi, DELAY_GRID), near]), lo, hi))
    costs = np.array([gap(float(d)) for d in grid])
    i = int(np.argmin(costs))
    if not np.isfinite(costs[i]):
        return fit
    minimize_scalar(
        lambda d: min(gap(float(d)), 1e300), bounds=(grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]),
        method="bounded", options={"xatol": 0.05 * pool.dt},
    )  # fmt: skip
    # the search holds the other shapes (a dead zone's width, a Stribeck velocity): each point one linear
    # solve; at the delay found they are fitted again
    gap(min(tried, key=lambda k: tried[k][0])[0], refit_shapes=True)
    best_gap, best = min(tried.values(), key=lambda t: t[0])
    return best if explained(free_run_gap(pool, fit.model), best_gap, pool.noise) > noise_explained else fit


#: A free-run gap beyond this many times the records' largest speed [-] is a free run that left
#: them (an unstable fit: a base without the delay a record holds, its viscous friction below
#: zero, ran to 1.7e34 rad/s): a report says it diverges rather than give the figure.
DIVERGED = 10.0


def gap_said(gap: float, pool: Pool) -> str:
    """A free-run gap [v] as a report says it: its figure, or ``diverges`` where it is not finite
    or beyond :data:`DIVERGED` times the records' largest speed.

    Parameters
    ----------
    gap : float
        The free-run gap [v].
    pool : Pool
        The records it was measured on.
    """
    if not math.isfinite(gap) or gap > DIVERGED * pool.data.scale["w_max"]:
        return "diverges"
    return f"{gap:.4g}"


def free_run_gap(pool: Pool, model: RigidDrive) -> float:
    """The overall free-run gap of ``model`` on ``pool`` [v]; inf where its free run diverges or
    its inertia is not positive (no drive: a cost, never a figure)."""
    if not model.params["inertia"] > 0.0:
        return math.inf
    with np.errstate(over="ignore", invalid="ignore"):
        g = pool.gaps(model, None).overall
    return g if math.isfinite(g) else math.inf


def effect_names(value: Sequence[str] | str | None, what: str) -> tuple[str, ...]:
    """Effect names checked against the library, each once, in the order given.

    Parameters
    ----------
    value : sequence of str, comma-separated str or None
        The names (None: none).
    what : str
        The argument they came in, named by the error on an unknown one.
    """
    if value is None:
        return ()
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip()]
    out = []
    for name in value:
        if name not in effect_library():
            raise DataError(f"{what}: unknown effect {name!r}; known effects: {', '.join(effect_library())}")
        if get_effect(name).not_on_a_rigid_drive:
            raise DataError(
                f"{what}: {name}: the doctor's rigid drive cannot hold it ({get_effect(name).not_on_a_rigid_drive})"
            )
        out.append(name)
    return tuple(dict.fromkeys(out))


def candidate_names(
    base: tuple[str, ...], candidates: Sequence[str] | str | None, output_kind: str = "velocity"
) -> tuple[str, ...]:
    """The effects to try: ``candidates`` (checked) or every effect of the library but the
    structure effects, and on a velocity record those that need a measured position
    (:attr:`~motorid.drive.effects.base.Effect.measured_position`), less those in ``base``.

    Parameters
    ----------
    base : tuple of str
        The effects already in the model.
    candidates : sequence of str, comma-separated str or None
        The effects asked for (None: the library's).
    output_kind : {"velocity", "position"}
        What the records measure.
    """
    if candidates is None:
        return tuple(
            n
            for n in effect_library()
            if n not in base
            and not get_effect(n).structure
            and not get_effect(n).not_on_a_rigid_drive
            and (output_kind == "position" or not get_effect(n).measured_position)
        )
    return tuple(n for n in effect_names(candidates, "candidates") if n not in base)


def friction_given(base: tuple[str, ...]) -> bool:
    """Whether a model's ``base`` holds an effect beyond :data:`DEFAULT_BASE` and the structure:
    it then stands where a step would have put it, and what comes next is judged by the rules
    of a second step.

    Parameters
    ----------
    base : tuple of str
        The effects of the model the search starts from.
    """
    return any(n not in DEFAULT_BASE and not get_effect(n).structure for n in base)


#: Where static friction fitted on the free run is judged when its held-out test is blind (its
#: held-out free run the base's to the last bit) on records without rests to hold out one by one:
#: near rest, the gap there accounting for more than ``noise_explained`` noise floors there. With
#: rests, a blind test (a two-mass rig's held levels with 2 rests, the one that shows the level
#: held out: no level fitted without it) is judged at the rests by the same noise rule. Blind:
#: the held-out errors within :data:`~motorid.diagnose.measures.PLATEAU_TOLERANCE` of each other.
BLIND_HELD_OUT_JUDGED = "rest"
#: Where an effect that acts in one place is judged, in the words of a decision.
WHERE = {"rests": " at the rests", "rest": " near rest", "speed": " at speed"}


@dataclass(frozen=True)
class LagTest:
    """Whether the moving drive tells a breakaway level from a lag where rests at one input rate
    cannot (:meth:`Search.lag_test`).

    Attributes
    ----------
    lag : float
        The lag τ the rests' excess would need [s] (:attr:`Breakaway.lag
        <motorid.diagnose.measures.Breakaway.lag>`).
    own : float
        The model's own input lag T_l [s] (0 without one); the lag reading holds T_l + τ.
    gap_level, gap_lag : float
        The free-run gaps [v] of the model with the level (static friction) and with the lag.
    z : float
        The paired test of their squared free-run errors (:func:`paired_z`): positive where the
        lag's are smaller.
    """

    lag: float
    own: float
    gap_level: float
    gap_lag: float
    z: float

    @property
    def reading(self) -> str:
        """``static_friction`` (the level's errors smaller: ``z < -TOLD_Z``), ``lag`` (``z >
        TOLD_Z``) or ``lookalike``; a free run that does not stay finite loses."""
        if not math.isfinite(self.gap_lag) or self.z < -TOLD_Z:
            return "static_friction" if math.isfinite(self.gap_level) else "lookalike"
        return "lag" if not math.isfinite(self.gap_level) or self.z > TOLD_Z else "lookalike"

    def to_dict(self) -> dict[str, Any]:
        return {"lag": self.lag, "own": self.own, "gap_level": self.gap_level, "gap_lag": self.gap_lag,
                "z": self.z, "reading": self.reading}  # fmt: skip


#: The share of the held-out rows [-] below which an effect's speed band is one place of the record,
#: where its held-out check may be passed on those rows (:meth:`Search.held_balance`). A quarter
#: parts the bands of a sine: below a tenth of its peak it spends (2/π) asin(0.1) = 6 % of its time,
#: above 0.6 of it 1 - (2/π) asin(0.6) = 59 %. At half, a two-mass rig's chirp (49 % of its held-out
#: rows at speed) took quadratic drag for what the lumped drive misses of its shaft.
ONE_PLACE = 0.25
#: Blocks the paired test of two free runs (:func:`paired_z`) averages over.
PAIRED_BLOCKS = 30
#: Two free runs differ where their paired test lies beyond this many standard errors.
TOLD_Z = 3.0


def paired_z(first: np.ndarray, second: np.ndarray, blocks: int = PAIRED_BLOCKS) -> float:
    """A paired test of two models' free-run errors [v] on the same samples (Diebold-Mariano's,
    with block means for the errors' correlation in time)::

        d_k = e1_k² - e2_k²,    D_b = mean of d over block b,    z = mean(D) / (std(D) / sqrt(B))

    over ``blocks`` equal blocks of the samples where both are finite (B of them with samples).
    Positive: the second model's errors are smaller. NaN with fewer than 3 blocks.

    Parameters
    ----------
    first, second : ndarray
        The two models' errors at each sample (NaN where not settled).
    blocks : int
        How many blocks.
    """
    ok = np.isfinite(first) & np.isfinite(second)
    d = (first**2 - second**2)[ok]
    means = np.array([b.mean() for b in np.array_split(d, blocks) if b.size])
    if means.size < 3:
        return math.nan
    spread = float(np.std(means, ddof=1))
    centre = float(np.mean(means))
    return math.copysign(math.inf, centre) if spread == 0.0 else centre / (spread / math.sqrt(means.size))


def breakaway_sentence(found: Breakaway, told: LagTest | None, units: dict[str, str]) -> str:
    """What the rests say of a breakaway that is not named static friction, in one sentence with
    its figures (the level ΔF_s [F], the lag τ [ms]), e.g. ``40 rests break away 0.52 ± 0.01 V
    above the kinetic level, all at one input rate (19 V/s): static friction of 0.52 V and a lag
    of 28 ms between input and force fit alike ...``.

    Parameters
    ----------
    found : Breakaway
        The rests' breakaway.
    told : LagTest or None
        The moving drive's test of the lag, for rests at one rate.
    units : dict
        The pool's units (``F``).
    """
    f = units["F"]
    above = f"{found.rests} rests break away {found.excess:.3g} ± {found.standard_error:.2g} {f} above the kinetic level"
    lag = f"{1e3 * found.lag:.3g} ms"
    if found.reading == "lag":
        return (
            f"{above} at an input rising infinitely slowly, higher as the input rises faster: a lag of "
            f"{1e3 * found.lag:.3g} ± {1e3 * found.lag_std:.2g} ms between input and force (or in the time the "
            "drive takes to leave rest), not static friction"
        )
    if found.reading != "lookalike":
        return f"{above}: not shown"
    one = f"{above}, {found.rates_words(f)}"
    v = units["v"]
    apart = found.apart_words
    if told is not None and told.reading == "lag":
        return (
            f"{one}: a lag of {lag} between input and force runs the drive closer than static friction of "
            f"{found.excess:.3g} {f} (free-run gap {told.gap_lag:.4g} vs {told.gap_level:.4g} {v}, z = {told.z:.2g}): "
            f"the lag, though a smaller level beside it is not ruled out at one rate; {apart}"
        )
    gaps = (
        ""
        if told is None
        else f" (free-run gap {told.gap_level:.4g} vs {told.gap_lag:.4g} {v}, z = {told.z:.2g})"
    )
    return (
        f"{one}: static friction of {found.excess:.3g} {f} and a lag of {lag} between input and force fit "
        f"alike{gaps}; {apart}"
    )


@dataclass(eq=False)
class Candidate:
    """An effect tried in a step: its fit added to the step's model, and its evidence.

    Attributes
    ----------
    fit : FitResult
        The step's model with it, fitted (static friction: from the rests or the free run).
    evidence : CandidateEvidence
        Its effect, ΔBIC and the figures behind it; for static friction what it is judged on and
        its breakaway; a note where it cannot pass.
    acts : str
        Where it is judged (:attr:`Effect.acts <motorid.drive.effects.base.Effect.acts>`; empty:
        everywhere, as static friction on too few rests).
    free_run_gap : float
        Its free-run gap [v] in the step's region, measured for the candidates alike in the
        torque balance (NaN otherwise).
    lag_allowed : bool
        Static friction judged on the rests: False where the moving drive rules out the lag that
        rests at one input rate would need (:meth:`Search.lag_test`), so that its held-out check
        sets the level against no excess rather than against a lag.
    """

    fit: FitResult
    evidence: CandidateEvidence
    acts: str
    free_run_gap: float = math.nan
    lag_allowed: bool = True

    @property
    def effect(self) -> str:
        """The effect's name."""
        return self.evidence.effect

    @property
    def delta_bic(self) -> float:
        """Its ΔBIC."""
        return self.evidence.delta_bic


@dataclass(frozen=True)
class StepStart:
    """Where a step starts: the model so far and what a candidate is measured against.

    Attributes
    ----------
    fit : FitResult
        The model so far, fitted.
    effects : tuple of str
        Its effects.
    region : Region
        Where its disagreement concentrates.
    gap : Gap
        Its gaps (:meth:`Pool.gaps <motorid.diagnose.prepare.Pool.gaps>`) in ``region``.
    held_residual : ndarray
        Its held-out torque-balance residual [v/s] (:meth:`Search.held_residual`).
    later : bool
        A second or later step (or a given model with friction of its own): a candidate must
        account for more than ``noise_explained`` noise floors of the gap (:func:`explained`).
    held_position : float
        On position records, its free-run position error on held-out halves [m or rad]
        (:func:`~motorid.diagnose.position.held_out_position_error`); NaN otherwise.
    """

    fit: FitResult
    effects: tuple[str, ...]
    region: Region
    gap: Gap
    held_residual: np.ndarray
    later: bool
    held_position: float = math.nan


@dataclass(eq=False)
class Decision:
    """The checks of one candidate (step 4 of the workflow's notes) and their outcome.

    Attributes
    ----------
    candidate : Candidate
        The candidate checked.
    held_before, held_after : float
        Held-out error without and with it, where it acts ([v/s] on the balance, [F] on the rests, [v] on the
        free run).
    gap_before, gap_after : Gap
        The step model's and the candidate's gaps in the step's region.
    shrink : float
        The free-run gap's shrink where it is judged, in noise floors of that band.
    explained : float
        The part of that gap it accounts for, in the same noise floors (:func:`explained`).
    acts : str
        Where it was judged (empty: everywhere).
    acting : tuple of float or None
        Where it acts: the gap before and after [v] and the noise floor there [v].
    reasons : list of str
        Each check it fails; none when it is accepted.
    position : tuple of float or None
        On position records, the held-out free-run position error without and with it
        [m or rad] (:func:`~motorid.diagnose.position.held_out_position_error`).
    """

    candidate: Candidate
    held_before: float
    held_after: float
    gap_before: Gap
    gap_after: Gap
    shrink: float
    explained: float
    acts: str
    acting: tuple[float, float, float] | None
    reasons: list[str] = field(default_factory=list)
    position: tuple[float, float] | None = None

    @property
    def accepted(self) -> bool:
        """It passes every check."""
        return not self.reasons

    @property
    def reason(self) -> str:
        """Why it was not accepted ("" when it was)."""
        return "; ".join(self.reasons)

    def rejected(self, step: int) -> Rejected:
        """The candidate as rejected in ``step`` (1 the first), with the figures of its checks.

        Parameters
        ----------
        step : int
            The step it was judged in.
        """
        acting: dict[str, Any] = {}
        if self.acting is not None:
            before, after, floor = self.acting
            acting = {"judged": WHERE.get(self.acts, "").strip(), "acting_gap_before": before,
                      "acting_gap_after": after, "acting_noise_floor": floor}  # fmt: skip
        position: dict[str, float] = {}
        if self.position is not None:
            position = {"held_out_position_error_before": self.position[0],
                        "held_out_position_error_after": self.position[1]}  # fmt: skip
        return Rejected(
            step=step, effect=self.candidate.effect, reason=self.reason, delta_bic=self.candidate.delta_bic,
            held_out_error_before=self.held_before, held_out_error_after=self.held_after,
            gap_before=self.gap_before.overall, gap_after=self.gap_after.overall,
            gap_shrink_noise_floors=self.shrink, explained_noise_floors=self.explained, **acting, **position,
        )  # fmt: skip


def lookalike_rule(
    accepted: Decision,
    passing: list[Candidate],
    judge: Callable[[Candidate], Decision],
    pool: Pool,
    region: Region,
    tolerance: float,
    model: tuple[str, ...],
) -> tuple[Decision, Lookalike | None]:
    """The lookalike rule (step 4 of the workflow's notes): among the accepted candidate and the
    passing candidates of the same physics (:meth:`Effect.physics
    <motorid.drive.effects.base.Effect.physics>` in the ``model`` they are added to) whose
    free-run gap lies within ``tolerance`` [v] of its own, the first in the library's order
    (:func:`motorid.drive.effects.names`) is named, when it passes the checks too.

    Parameters
    ----------
    accepted : Decision
        The candidate the checks accepted.
    passing : list of Candidate
        The candidates that passed the evidence threshold.
    judge : callable
        The checks of a candidate (:meth:`Search.judge` at this step).
    pool : Pool
        The records of the drive.
    region : Region
        The step's region.
    tolerance : float
        Two free-run gaps closer than this [v] fit alike.
    model : tuple of str
        The effects of the model the candidates are added to.

    Returns
    -------
    Decision, Lookalike or None
        The decision accepted and the lookalike (None when nothing fits alike).
    """
    c, gap1 = accepted.candidate, accepted.gap_after
    physics = get_effect(c.effect).physics(model)
    if not physics:
        return accepted, None
    alike = [(c, gap1)]
    for m in passing:
        if m is not c and get_effect(m.effect).physics(model) == physics:
            gap_m = pool.gaps(m.fit.model, region)
            if abs(gap_m.overall - gap1.overall) <= tolerance:
                alike.append((m, gap_m))
    if len(alike) == 1:
        return accepted, None
    order = list(effect_library())
    preferred = min(alike, key=lambda item: order.index(item[0].effect))[0]
    if preferred is not c:
        decision = judge(preferred)
        if decision.accepted:
            accepted = decision
    named = accepted.candidate
    alike.sort(key=lambda item: item[0] is not named)
    lookalike = Lookalike(
        physics=physics,
        named=named.effect,
        gaps={m.effect: g.overall for m, g in alike},
        levels={m.effect: get_effect(m.effect).level(m.fit.model.params) for m, _ in alike},
        tolerance=tolerance,
    )
    return accepted, lookalike


#: A level (a parameter that cannot be negative) below this many of its standard errors under
#: zero makes a fit not physical; within them it is zero within the record's noise (a drive
#: without Coulomb friction fits a level of either sign).
NEGATIVE_ERRORS = 2.0


def addable(candidates: Sequence[str], effects: tuple[str, ...]) -> list[str]:
    """The ``candidates`` a model of ``effects`` can take next: not in it, the effects each
    requires in it, and no second torque that depends on the position (a drive holds one).

    Parameters
    ----------
    candidates : sequence of str
        The effects to try.
    effects : tuple of str
        The model's effects.
    """
    return [
        c
        for c in candidates
        if c not in effects
        and all(r in effects for r in get_effect(c).requires)
        and not (get_effect(c).position and any(get_effect(e).position for e in effects))
    ]


def negative_levels(fit: FitResult) -> str:
    """The parameters of ``fit`` that cannot be negative (:attr:`Effect.nonnegative`, the levels,
    the dead zone) and are, by more than :data:`NEGATIVE_ERRORS` standard errors, as
    ``name = value < 0``; empty where none.

    Parameters
    ----------
    fit : FitResult
        A fitted model with its standard errors.
    """
    found = []
    for name in fit.model.effects:
        for p in get_effect(name).nonnegative:
            value = float(fit.model.params.get(p, 0.0))
            if value < -NEGATIVE_ERRORS * float(fit.param_std.get(p, 0.0)):
                found.append(f"{p} = {value:.3g} < 0")
    return ", ".join(found)


#: Beside Stribeck friction, a Coulomb level whose standard error in the free run exceeds this
#: share of it is not separated from the Stribeck level (:func:`keep_given`).
SPLIT_APART = 0.1


@dataclass(frozen=True)
class GivenKept:
    """A given model improved by the search, its own parameters kept where the records do not
    contradict them (:func:`keep_given`).

    Attributes
    ----------
    model : RigidDrive
        The improved model: the given values kept, the released ones and the added effects'
        fitted to the free run.
    kept, released : tuple of str
        The given model's parameters kept at their given values, and those the records contradict.
    z : dict
        Each given parameter tried -> the paired test (:func:`paired_z`) of setting it free
        against keeping it, at the last round it was tried (positive: free runs closer).
    notes : list of str
        What the report says: the rule's outcome, and where the records cannot separate Coulomb
        from Stribeck friction.
    """

    model: RigidDrive
    kept: tuple[str, ...]
    released: tuple[str, ...]
    z: dict[str, float]
    notes: list[str]


def keep_given(pool: Pool, given: RigidDrive, found: RigidDrive) -> GivenKept:
    """The given model's parameters kept where the records do not contradict them, the effects the
    search added fitted beside them.

    The rule: the search's model ``found`` (every parameter refitted to the balance) with each of
    the given model's own parameters (:func:`~motorid.diagnose.model.refitted_parameters` of
    ``given``, less those the records never reach) back at its given value, and the parameters of
    the effects the search added fitted to the free run (:func:`~motorid.diagnose.model.fit_output_error`).
    Then, one at a time, the given parameter whose release (fitted to the free run with the
    added effects' and those already released) runs the drive closest to the records is released
    where the paired test of the two free runs (:func:`paired_z`) exceeds :data:`TOLD_Z`: a given
    value stands until the records pull beyond what their free run's scatter allows. Where the
    given Coulomb level is kept beside Stribeck friction added, and set free together with the
    Stribeck level and velocity its standard error in the free run (:func:`free_run_std`) exceeds
    :data:`SPLIT_APART` of it, the records cannot separate Coulomb from Stribeck friction, and a
    note says so with both levels. The balance's own fit is not the judge: it lets Coulomb and
    Stribeck friction trade along the Stribeck velocity it fixes (the default rig with Stribeck friction planted: Coulomb 0.006 ->
    0.0045 N m and the velocity at 20 rad/s, against 9).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    given : RigidDrive
        The model the user gave (its effects and values).
    found : RigidDrive
        The search's final model (the given effects and those added).

    Returns
    -------
    GivenKept
    """
    scale = pool.data.scale
    unreached = {p for n in given.effects for p in get_effect(n).unreached(given.params, scale)}
    own = [p for p in refitted_parameters(given) if p in found.params and p not in unreached]
    added = [p for p in refitted_parameters(found) if p not in given.params and p not in unreached]
    held = found.with_params(**{p: given.params[p] for p in own})

    def refit(free: list[str]) -> RigidDrive:
        names = [p for p in refitted_parameters(found) if p in set(free)]
        return fit_output_error(held, pool.free_run_error, names, declared_signs=True) if names else held

    current, released = refit(added), []
    z: dict[str, float] = {}
    candidates = {}
    while len(released) < len(own):
        for p in own:
            if p not in released:
                candidates[p] = refit([*added, *released, p])
                z[p] = paired_z(pool.free_run_error(current), pool.free_run_error(candidates[p]))
        best = max((p for p in own if p not in released), key=lambda p: np.nan_to_num(z[p], nan=-np.inf))
        if not z[best] > TOLD_Z:
            break
        released.append(best)
        current = candidates[best]
    kept = tuple(p for p in own if p not in released)
    notes = [
        "the given model's parameters kept where the records do not contradict them (set free, each runs the "
        f"drive no closer than {TOLD_Z:g} standard errors of the paired free-run test): "
        + (", ".join(f"{p} (z = {z[p]:.2g})" for p in kept) or "none")
        + "; released: "
        + (
            ", ".join(
                f"{p} {given.params[p]:.4g} -> {current.params[p]:.4g} (z = {z[p]:.2g})" for p in released
            )
            or "none"
        )
    ]
    shapes = [q for q in ("stribeck", "stribeck_velocity") if q in added]
    if "coulomb" in kept and "stribeck" in shapes:
        names = ["coulomb", *shapes]
        std, corr = free_run_std(pool, current, names)
        if not std[0] <= SPLIT_APART * current.params["coulomb"]:
            F = pool.units["F"]
            notes.append(
                f"the records cannot separate Coulomb from Stribeck friction: set free together in the free run, "
                f"Coulomb {current.params['coulomb']:.4g} ± {std[0]:.2g} {F} and Stribeck "
                f"{current.params['stribeck']:.4g} ± {std[1]:.2g} {F} (correlation {corr:.2f}); the given "
                "Coulomb level kept"
            )
    return GivenKept(current, kept, tuple(released), z, notes)


def free_run_std(pool: Pool, model: RigidDrive, names: list[str]) -> tuple[np.ndarray, float]:
    """Standard errors of the parameters ``names`` fitted together to the records' free run, and
    the correlation of the first two: from the Jacobian ``G`` of the free-run error (central
    differences, a step of 1e-4 of each value)::

        C = s² (GᵀG)⁻¹ (1 + ρ) / (1 - ρ),    s² = Σ e² / (n - k)

    with ρ the lag-one autocorrelation of the errors (clipped to [0, 0.95]: correlated errors
    carry fewer independent samples, as in :func:`~motorid.diagnose.measures.evidence`).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model, at the values the errors are taken at.
    names : list of str
        At least two of its parameters.

    Returns
    -------
    ndarray, float
        Each parameter's standard error [its unit] (inf where they are not determined), and the
        correlation of the first two.
    """
    base = pool.free_run_error(model)
    ok = np.isfinite(base)
    columns = []
    for name in names:
        h = 1e-4 * max(abs(model.params[name]), 1e-9)
        up = pool.free_run_error(model.with_params(**{name: model.params[name] + h}))
        down = pool.free_run_error(model.with_params(**{name: model.params[name] - h}))
        ok &= np.isfinite(up) & np.isfinite(down)
        columns.append((up - down) / (2.0 * h))
    e = base[ok]
    jac = np.column_stack([c[ok] for c in columns])
    if e.size <= len(names) + 2:
        return np.full(len(names), np.inf), math.nan
    r = e - e.mean()
    rho = min(max(float(r[1:] @ r[:-1] / (r @ r)) if r @ r > 0 else 0.0, 0.0), 0.95)
    s2 = float(e @ e) / (e.size - len(names)) * (1.0 + rho) / (1.0 - rho)
    try:
        cov = s2 * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(len(names), np.inf), math.nan
    std = np.sqrt(np.abs(np.diag(cov)))
    return std, float(cov[0, 1] / (std[0] * std[1])) if std[0] * std[1] > 0 else math.nan


@dataclass
class SearchOutcome:
    """What an effect search ends with.

    Attributes
    ----------
    steps : list of Step
        The effects added, in order.
    rejected : list of Rejected
        The candidates that passed the evidence threshold but not the checks
        (:meth:`Decision.rejected`).
    stop : Stop
        Why the search stopped.
    fit : FitResult
        The final model, fitted.
    notes : list of str
        What the search found and did not name: rests that show a lag, or a breakaway level and a
        lag that look alike (:func:`breakaway_sentence`); :func:`~motorid.diagnose.workflow.diagnose`
        adds what :func:`keep_given` says of a given model.
    """

    steps: list[Step]
    rejected: list[Rejected]
    stop: Stop
    fit: FitResult
    notes: list[str] = field(default_factory=list)


@dataclass
class Search:
    """The effect search on the records of one drive (:func:`~motorid.diagnose.workflow.diagnose`).

    Attributes
    ----------
    pool : Pool
        The records of the drive.
    held : HeldOut
        What a candidate's held-out error is measured on.
    stribeck_shape : str
        The Stribeck shape of every fit.
    threshold : float
        ΔBIC a candidate needs to pass.
    min_holdout_gain, min_gap_shrink : float
        Smallest relative improvement of the held-out error and of the free-run gap.
    noise_explained : float
        Smallest free-run error a later step accounts for, in noise floors (:func:`explained`).
    given : bool
        The model given holds friction of its own (:func:`friction_given`).
    progress : bool
        Show a progress bar over each step's candidates.
    fixed : dict
        Parameters held fixed in every fit: the structure's delay and lag once chosen.
    """

    pool: Pool
    held: HeldOut
    stribeck_shape: str
    threshold: float
    min_holdout_gain: float
    min_gap_shrink: float
    noise_explained: float
    given: bool
    progress: bool = False
    fixed: dict[str, float] = field(default_factory=dict)

    def fit_base(self, base: tuple[str, ...], model: RigidDrive | None) -> FitResult:
        """The base effects fitted to the pooled torque balance; a rest-only effect of the user's
        ``model`` (static friction) keeps its value: the balance cannot refit it; nor can it refit
        what the records never reach (:meth:`Effect.unreached
        <motorid.drive.effects.base.Effect.unreached>`: a saturation above their largest input).

        Parameters
        ----------
        base : tuple of str
            The base effects.
        model : RigidDrive or None
            The user's model, when given.
        """
        kept: dict[str, float] = {}
        if model is not None:
            for n in base:
                effect = get_effect(n)
                if effect.rest_only:
                    kept.update({p: model.params[p] for p in effect.nonlinear})
                kept.update(effect.unreached(model.params, self.pool.data.scale))
        return fit_model(self.pool.data, base, stribeck_shape=self.stribeck_shape, start=kept or None)

    def base_structure(
        self, fit: FitResult, effects: tuple[str, ...], wanted: bool, bar: Any
    ) -> tuple[Structure, FitResult, tuple[str, ...], RigidDrive | None]:
        """Choose the input delay and lag (:func:`choose_structure`) unless not ``wanted`` or the
        base holds one, and hold them fixed from now on.

        Parameters
        ----------
        fit : FitResult
            The base, fitted.
        effects : tuple of str
            Its effects.
        wanted : bool
            Search the structure at all.
        bar : progress bar
            Told what runs.

        Returns
        -------
        Structure, FitResult, tuple of str, RigidDrive or None
            The structure, the model fitted with it and its effects (as given when none is
            taken), and that model (None when none is taken).
        """
        chosen = Structure(
            reason="not searched: " + ("structure=False" if not wanted else "the base holds it")
        )
        if not wanted or any(get_effect(n).structure for n in effects):
            return chosen, fit, effects, None
        bar.set_postfix_str("base structure")
        chosen = choose_structure(
            self.pool, effects, fit.model.params, self.stribeck_shape, self.threshold, self.min_gap_shrink,
            self.noise_explained,
        )  # fmt: skip
        logger.info("structure: %s", chosen.reason)
        if not chosen.effects:
            return chosen, fit, effects, None
        self.fixed.update(chosen.params)
        fit = fit_model(
            self.pool.data, (*effects, *chosen.effects), start=fit.model.params, stribeck_shape=self.stribeck_shape,
            fixed=self.fixed,
        )  # fmt: skip
        return chosen, fit, fit.model.effects, fit.model

    def final_delay(self, fit: FitResult, chosen: Structure) -> tuple[FitResult, Structure]:
        """The input delay read again on the free run of the model the search ended with.

        The structure is chosen on the base, before any effect: a missing effect moves the
        delay the free run puts it at, and hides a delay the balance trades with the inertia
        (a logger's 6-sample delay on two sines at 2 ms with quadratic drag still missing: ΔBIC
        −5.7, so no delay, and the inertia 1.45 times the truth). With the effects found, the
        delay the model holds is searched again (:func:`delay_by_free_run`); a model without one
        is given one of at least :data:`FINAL_DELAY_LEAST` samples where it passes the structure's
        own rules on the final model: ΔBIC above ``threshold`` on the balance, and on the free run
        (at the delay read there) the gap shrinks by more than ``min_gap_shrink`` and the delay
        accounts for more than ``noise_explained`` noise floors of it (:func:`explained`), or the
        balance and the free run read it within a sample of each other. A record whose final
        model misses only its delay stands near the floor, and a delay that brings it from 1.3
        noise floors to the floor accounts for ``sqrt(1.3² - 1) = 0.83`` of one: a drifting logger's
        two sines at 2 ms, the start's 2.2-sample delay read by the balance (1.9 samples, ΔBIC 66)
        and by the free run (2.1), had been left at none, the inertia 14 % high. Two readings that
        agree say a time the record shows, not a share of a missing effect the balance took in.
        Neither is done where the base held its own structure or took a lag alone.

        Parameters
        ----------
        fit : FitResult
            The model the search ended with.
        chosen : Structure
            The structure chosen on the base (:meth:`base_structure`).

        Returns
        -------
        FitResult, Structure
            The model with its delay read again, and the structure that says so (the same two
            where nothing moves).
        """
        effects = fit.model.effects
        if any(get_effect(n).structure for n in effects) and "input_delay" not in chosen.effects:
            return fit, chosen  # a lag alone, or the base's own structure
        pool, dt = self.pool, self.pool.dt
        if "input_delay" in effects:
            found = delay_by_free_run(pool, fit, self.stribeck_shape, self.noise_explained)
            delay = found.model.params["input_delay"]
            dropped = self.without_lag(found)
            if dropped is not None:
                found, delay = dropped, dropped.model.params["input_delay"]
                said = (f"; on the final model's free run the delay is {delay:.4g} s ({delay / dt:.2f} samples) "
                        "and no lag: it comes closer without the lag the base took")  # fmt: skip
            elif found is fit or abs(delay - fit.model.params["input_delay"]) < 0.05 * dt:
                return fit, chosen
            else:
                said = (
                    f"; on the final model's free run the delay is {delay:.4g} s ({delay / dt:.2f} samples)"
                )
        else:
            held = {p: fit.model.params[p] for n in effects for p in get_effect(n).nonlinear}
            with_delay = fit_model(
                pool.data, effect_order((*effects, "input_delay")), start=fit.model.params,
                stribeck_shape=self.stribeck_shape, fixed=held,
            )  # fmt: skip
            ev = evidence(
                fit.rss, with_delay.rss, with_delay.n_rows, with_delay.n_params - fit.n_params,
                with_delay.residual[pool.data.moving],
            )  # fmt: skip
            if not ev["delta_bic"] > self.threshold:
                return fit, chosen
            found = delay_by_free_run(pool, with_delay, self.stribeck_shape, -math.inf)
            before, after = free_run_gap(pool, fit.model), free_run_gap(pool, found.model)
            part = explained(before, after, pool.noise)
            delay = found.model.params["input_delay"]
            # the balance and the free run read one delay: a time the record shows, not a share of a
            # missing effect the balance took into it
            agree = abs(delay - with_delay.model.params["input_delay"]) <= dt
            if not (
                delay >= FINAL_DELAY_LEAST * dt
                and after < (1.0 - self.min_gap_shrink) * before
                and (part > self.noise_explained or agree)
            ):
                return fit, chosen
            said = (
                f"; an input delay of {delay:.4g} s ({delay / dt:.2f} samples) taken on the final model: ΔBIC "
                f"{ev['delta_bic']:.1f} > {self.threshold:g} on its balance, free-run gap {before:.4g} -> {after:.4g} "
                f"(it accounts for {part:.1f} noise floors)"
            )
        self.fixed["input_delay"] = delay
        kept = {p: v for p, v in chosen.params.items() if p in found.model.params}
        for p in set(self.fixed) - set(found.model.params):
            del self.fixed[p]  # the lag dropped
        structure = dataclasses.replace(
            chosen, effects=tuple(n for n in found.model.effects if get_effect(n).structure),
            params={**kept, "input_delay": delay}, reason=chosen.reason + said,
        )  # fmt: skip
        return found, structure

    def final_static_friction(self, model: RigidDrive, outcome: SearchOutcome) -> tuple[RigidDrive, float]:
        """``model`` (the diagnosis's final model) with the level of the static friction a step named
        read again (:func:`~motorid.diagnose.measures.static_friction_reading`, against its kinetic
        level), and that level's standard error [F]; where the free run with the level read again
        comes no closer than without it, without static friction (standard error NaN), the step
        that named it taken back from ``outcome`` and a note added there. ``model`` itself, and NaN,
        where no step named it.

        The level ΔF_s is read above the kinetic level of the step's model, and the balance's refits
        after it (a later step, :meth:`final_delay`, a closed loop's instrumental fit) leave it
        where it was. A closed loop's Stribeck decay, its level fitted 42 % low by the step's
        least squares, took a static friction of 0.98 mN m above it; with the final model's
        Stribeck level within 5 % of the truth (the loop's reference as an instrument) the stale
        level put the free run at 1.71 noise floors, 1.33 without it.

        Parameters
        ----------
        model : RigidDrive
            The final model.
        outcome : SearchOutcome
            What the search ended with: a step naming static friction is taken back, a note added.
        """
        named = [k for k, s in enumerate(outcome.steps) if s.effect == "static_friction"]
        if not named or "static_friction" not in model.effects:
            return model, math.nan
        pool = self.pool
        bare = model.without("static_friction")
        again, std = static_friction_reading(pool, bare, None)
        with_it, without = free_run_gap(pool, again), free_run_gap(pool, bare)
        if with_it < without:
            return again, std
        step = outcome.steps.pop(named[0])
        outcome.notes.append(
            f"static_friction, named at step {named[0] + 1} at {figure(step.params['breakaway_excess'])} "
            f"{pool.units['F']} above the kinetic level, is left out: on the final model its level reads "
            f"{figure(again.params['breakaway_excess'])} {pool.units['F']} and its free run comes no closer "
            f"({figure(with_it)} against {figure(without)} {pool.units['v']} without it)"
        )
        return bare, math.nan

    def without_lag(self, fit: FitResult) -> FitResult | None:
        """``fit`` without the input lag the base's structure took, its delay read again on the free
        run (:func:`delay_by_free_run`), where that free run's gap is smaller than ``fit``'s by more
        than ``min_gap_shrink`` (the structure's own rule); None where ``fit`` has no lag or keeps
        it. The wheel motors 3 and 4 keep theirs: without it their free runs come 0.5 % closer on
        one record and 0.1-2.6 % further on the three others.

        The structure is chosen on the base, before any effect: there a lag can take part of what a
        missing effect does. A Stribeck decay on a chirp logged 7.8 samples late: the base took a
        4.2-sample delay and a 5.0 ms lag (the truth has none); with the decay named, the free run
        without the lag reads the delay at 8.0 samples and comes closer (0.176 against 0.212 rad/s,
        the floor 0.171), the inertia at 0.999 of the truth.
        """
        if "input_lag" not in fit.model.effects:
            return None
        model = fit.model.without("input_lag")
        held = {p: model.params[p] for n in model.effects for p in get_effect(n).nonlinear}
        bare = fit_model(self.pool.data, model.effects, start=model.params, stribeck_shape=self.stribeck_shape,
                         fixed=held)  # fmt: skip
        found = delay_by_free_run(self.pool, bare, self.stribeck_shape, -math.inf)
        closer = free_run_gap(self.pool, found.model) < (1.0 - self.min_gap_shrink) * free_run_gap(
            self.pool, fit.model
        )
        return found if closer else None

    def free_run_holdout(self, model: RigidDrive) -> tuple[float, float, str]:
        """Held-out check of static friction fitted on the free run beside ``model``: the RMS
        held-out free-run errors [v] without and with it, and where it is then judged. Rest by
        rest (:func:`~motorid.diagnose.measures.static_friction_cross_check`), judged at the rests
        (``"rests"``); on records without rests, on the held-out blocks, and with a held-out record,
        on its free run, the level fitted on the rest (``""``: judged on the whole free run).

        Parameters
        ----------
        model : RigidDrive
            The step's model.
        """
        pool, held = self.pool, self.held
        if held.samples is None:
            trained = fit_static_friction(pool, model, None)
            return rms(free_run_error(held.other, model)), rms(free_run_error(held.other, trained)), ""
        base, cand = static_friction_cross_check(pool, model)
        if math.isfinite(base):
            return base, cand, "rests"
        trained = fit_static_friction(pool, model, [~m for m in held.samples])
        return (
            rms(pool.free_run_error(model, held.samples)),
            rms(pool.free_run_error(trained, held.samples)),
            "",
        )

    def held_residual(self, effects: tuple[str, ...], start: dict[str, float] | None) -> np.ndarray:
        """Torque-balance residual / J [v/s] on each held-out row, fitted on the training rows
        (infinite where the fitted inertia is not positive).

        Parameters
        ----------
        effects : tuple of str
            The model's effects.
        start : dict or None
            Parameters the fit starts from.
        """
        fit = fit_model(
            self.pool.data, effects, rows=self.held.train, start=start, stribeck_shape=self.stribeck_shape,
            fixed=self.fixed,
        )  # fmt: skip
        residual = self.held.balance_residual(self.pool, fit.model)
        inertia = fit.model.params["inertia"]
        return residual / inertia if inertia > 0 else np.full(residual.shape, math.inf)

    def held_balance(self, at: StepStart, c: Candidate) -> tuple[float, float, str]:
        """Held-out check of candidate ``c`` on the torque balance: the RMS held-out residuals
        [v/s] of the step's model and with ``c``, both fitted on the training rows, and why it
        fails (empty where it passes). It must lower the error by ``min_holdout_gain`` over every
        held-out row or, for an effect that acts in one place, where it acts (the held-out rows
        in its speed band, :meth:`Pool.acting_rows <motorid.diagnose.prepare.Pool.acting_rows>`,
        fewer than :data:`ONE_PLACE` of them) without raising it over every row; the figures are
        those it passed on (every row's where it passed on neither).

        An effect that acts in one place changes the residual of a few rows, and over every row
        the noise of the others can dilute it: a Stribeck decay on a PWM drive's held levels
        lowered it 0.8 % over every held-out row, 3.8 % near rest (where its paired test lies 5.6
        standard errors out). A band of a few rows alone judges worse than every row: a record
        sampled at 36 ms holds 2 of its 44 held-out rows near rest, and there a Stribeck decay that
        lowers every row's error from 6.4 to 2.1 rad/s² raised theirs from 0.63 to 0.76. A band
        that holds most rows is the record, not one place of it: the kit motor's second chirp holds
        60 % of its held-out rows at speed, and quadratic drag, 0.75 % over every row, 1.3 % there,
        would have been named on that one of the motor's six records (:data:`ONE_PLACE`).

        Parameters
        ----------
        at : StepStart
            The step.
        c : Candidate
            The candidate.
        """
        base = at.held_residual
        cand = self.held_residual((*at.effects, c.effect), c.fit.model.params)
        unit = self.pool.units["v"] + "/s"
        before, after = rms(base), rms(cand)
        why = self.held_shortfall(before, after, unit)
        if why and c.acts and after <= before:
            rows = self.pool.acting_rows(self.held.speeds(self.pool), c.acts)
            there = rms(base[rows]), rms(cand[rows])
            if 0.0 < rows.mean() < ONE_PLACE and not self.held_shortfall(*there, unit):
                return *there, ""
        return before, after, why

    def held_shortfall(self, before: float, after: float, unit: str) -> str:
        """Why a held-out error ``after`` [unit] with a candidate falls short of ``before`` without
        it: it must lower it by ``min_holdout_gain``; empty where it does (NaN never does).

        Parameters
        ----------
        before, after : float
            The held-out error without and with the candidate [unit].
        unit : str
            Its unit.
        """
        if after < (1.0 - self.min_holdout_gain) * before:
            return ""
        return f"held-out error {figure(after)} vs {figure(before)} {unit}"

    def static_friction(self, fit: FitResult) -> Candidate:
        """Static friction as a candidate: measured by the rests (the input it takes to start the
        drive again), the evidence theirs, judged on the free run at the rests; where the rests do
        not read it (fewer than :data:`~motorid.diagnose.measures.MIN_RESTS`, bracketed, or below
        the kinetic level), fitted on the whole free run, its evidence that free run's, held out
        rest by rest (:func:`~motorid.diagnose.measures.static_friction_cross_check`) and judged at
        the rests.

        Rests at spread input rates tell a level from a lag themselves
        (:class:`~motorid.diagnose.measures.Breakaway`). Rests at one rate read their excess both
        ways; the moving drive then tells them (:meth:`lag_test`): where it rules out the lag the
        excess would need, the excess is a level, and its evidence that of the level against no
        excess at all.

        Parameters
        ----------
        fit : FitResult
            The step's model, fitted.
        """
        name = "static_friction"
        pool = self.pool
        found = breakaway(pool, fit.model)
        fitted = fit_static_friction(pool, fit.model, None)
        with_it = FitResult(fitted, fit.rss, fit.rss_force, fit.n_rows, fit.n_params + 1, fit.residual)
        if not found.measures:
            err0, err1 = pool.free_run_error(fit.model), pool.free_run_error(fitted)
            ok = np.isfinite(err0) & np.isfinite(err1)
            ev = evidence(
                float(np.sum(err0[ok] ** 2)), float(np.sum(err1[ok] ** 2)), int(ok.sum()), 1, err1[ok]
            )
            if found.rests < MIN_RESTS:
                bracketed = f", {found.bracketed} bracketed by a step of the input" if found.bracketed else ""
                why = f"{found.rests} rests read, fewer than {MIN_RESTS}{bracketed}"
            else:
                why = f"{found.rests} rests read below the kinetic level"
            measure = f"free run ({why})"
            return Candidate(with_it, CandidateEvidence(name, **ev, measure=measure), "")
        told = self.lag_test(fit, found, fitted) if found.reading == "lookalike" else None
        lag_allowed = told is None or told.reading != "static_friction"
        ev = CandidateEvidence(
            name, **breakaway_evidence(*pool.breakaway_excess(fit.model), lag_allowed=lag_allowed),
            measure="rests", breakaway=found, lag_test=told,
        )  # fmt: skip
        if found.shown or not lag_allowed:
            return Candidate(with_it, ev, get_effect(name).acts, lag_allowed=lag_allowed)
        # the rests do not show breakaway above the kinetic level
        ev = dataclasses.replace(ev, delta_bic=-math.inf, note=breakaway_sentence(found, told, pool.units))
        return Candidate(with_it, ev, get_effect(name).acts)

    def lag_test(self, fit: FitResult, found: Breakaway, level: RigidDrive) -> LagTest:
        """Whether the moving drive tells a level from a lag where rests at one input rate read
        their excess both ways: the free-run gap of the step's model with the level
        (``level``: static friction ΔF_s = ē) against that of the step's model refitted to the
        balance with its input lag held at ``T_l + τ`` (``T_l`` its own, 0 without one;
        ``τ = ē / r̄``, :attr:`Breakaway.lag <motorid.diagnose.measures.Breakaway.lag>`). Both
        break away where the rests do; only the lag changes how the drive moves. The paired test
        of their free-run errors (:func:`paired_z`) decides (:attr:`LagTest.reading`). The free
        run, not the balance, judges: a lag trades with the inertia in the balance
        (a 10 ms lag planted on a kit-like motor at 1 kHz: the balance's RSS grows from 0 to
        20 ms as the inertia falls, while the free-run gap is least at 10 ms).

        Parameters
        ----------
        fit : FitResult
            The step's model, fitted.
        found : Breakaway
            The rests' breakaway, at one rate.
        level : RigidDrive
            The step's model with static friction ΔF_s = ē.
        """
        pool = self.pool
        own = fit.model.params.get("lag_time_constant", 0.0)
        effects = effect_order((*fit.model.effects, "input_lag"))
        fixed = {**self.fixed, "lag_time_constant": own + max(found.lag, 0.0)}
        lagged = fit_model(
            pool.data, effects, start=fit.model.params, stribeck_shape=self.stribeck_shape, fixed=fixed
        )
        gap_level, gap_lag = pool.gaps(level, None).overall, pool.gaps(lagged.model, None).overall
        e_level, e_lag = pool.free_run_error(level), pool.free_run_error(lagged.model)
        return LagTest(found.lag, own, gap_level, gap_lag, paired_z(e_level, e_lag))

    def rank(self, fit: FitResult, effects: tuple[str, ...], names: list[str]) -> list[Candidate]:
        """Each effect of ``names`` fitted added to the step's model, highest ΔBIC first.

        Parameters
        ----------
        fit : FitResult
            The step's model, fitted.
        effects : tuple of str
            Its effects.
        names : list of str
            The effects to try.
        """
        from motorid.progress import progress_bar

        data = self.pool.data
        ranking = []
        for name in progress_bar(names, show=self.progress, desc="candidates", unit="effect", leave=False):
            effect = get_effect(name)
            if effect.rest_only:
                ranking.append(self.static_friction(fit))
                continue
            fit1 = fit_model(
                data,
                (*effects, name),
                start=fit.model.params,
                stribeck_shape=self.stribeck_shape,
                fixed=self.fixed,
            )
            ev = CandidateEvidence(name, **evidence(
                fit.rss, fit1.rss, fit1.n_rows, fit1.n_params - fit.n_params, fit1.residual[data.moving]
            ))  # fmt: skip
            negative = [p for p in effect.nonnegative if fit1.model.params[p] < 0.0]
            if negative:  # fitted with the wrong sign: not this physical effect
                note = f"{negative[0]} = {fit1.model.params[negative[0]]:.4g} < 0 is not physical"
                ev = dataclasses.replace(ev, delta_bic=-math.inf, note=note)
            ranking.append(Candidate(fit1, ev, effect.acts))
        ranking.sort(key=lambda c: -c.delta_bic)
        return ranking

    def judge_order(self, passing: list[Candidate], fit: FitResult, region: Region) -> list[Candidate]:
        """The order the passing candidates are checked in: by evidence, except that of the
        candidates alike in the torque balance (each removes at least :data:`ALIKE` of what the
        best removes) the one with the smallest free-run gap goes first when it is 2 % below the
        best's.

        Parameters
        ----------
        passing : list of Candidate
            The candidates above the threshold, highest ΔBIC first.
        fit : FitResult
            The step's model, fitted.
        region : Region
            The step's region.
        """
        best = passing[0]
        drop_best = fit.rss - best.fit.rss
        alike = [c for c in passing if fit.rss - c.fit.rss >= ALIKE * drop_best]
        for c in alike:
            c.free_run_gap = self.pool.gaps(c.fit.model, region).overall
        order = list(passing)
        if len(alike) > 1:
            pick = min(alike, key=lambda c: np.nan_to_num(c.free_run_gap, nan=np.inf))
            if pick.free_run_gap < 0.98 * best.free_run_gap:
                order.remove(pick)
                order.insert(0, pick)
        return order

    @property
    def position(self) -> bool:
        """The records measure a position: a candidate must predict it on held-out halves."""
        return self.pool.parts[0].kin.output_kind == "position"

    def held_position(self, effects: tuple[str, ...], start: dict[str, float] | None) -> float:
        """On position records, the free-run position error on held-out halves
        (:func:`~motorid.diagnose.position.held_out_position_error`) [m or rad]; NaN otherwise.

        Parameters
        ----------
        effects : tuple of str
            The model's effects.
        start : dict or None
            Parameters the fits start from.
        """
        if not self.position:
            return math.nan
        return held_out_position_error(self.pool, effects, start, self.stribeck_shape, self.fixed)

    def judge(self, c: Candidate, at: StepStart) -> Decision:
        """Whether candidate ``c`` improves held-out data and shrinks the free-run gap beyond the
        noise, against the step's model, with no level below zero beyond its errors
        (:func:`negative_levels`: a dead zone that drives the Coulomb level below zero explains
        nothing a drive does).

        On position records a candidate must also lower the free-run position
        error on held-out halves (:meth:`held_position`) by ``min_holdout_gain``: a position free
        run integrates the force error twice, and an effect that lowers the torque balance's
        residual (even on held-out blocks) but predicts a held-out half's position worse has
        fitted what the record's slow force balance does not repeat.

        Parameters
        ----------
        c : Candidate
            The candidate.
        at : StepStart
            The step it is judged in.
        """
        pool, held = self.pool, self.held
        v = pool.units["v"]
        effect = get_effect(c.effect)
        acts = c.acts
        blind = False
        model0 = at.fit.model
        if effect.rest_only and not acts:  # the rests do not read it: held out on the free run
            base_held, cand_held, acts = self.free_run_holdout(model0)
            # where the held-out free run is the base's to the last bit (no level fitted without the
            # one rest that shows it), no evidence either way: judged where it acts (near rest without
            # rests) by the noise rule, as a later step is
            blind = math.isclose(cand_held, base_held, rel_tol=PLATEAU_TOLERANCE)
            acts = acts or (BLIND_HELD_OUT_JUDGED if blind else "")
            held_why = "" if blind else self.held_shortfall(base_held, cand_held, v)
        elif effect.rest_only:  # held out on the rests: ΔF_s and τ from the training rests
            other = (
                None if held.other is None else Pool([held.other], ["held out"])
            )  # the second record's rests
            base_held, cand_held = breakaway_cross_check(pool, model0, c.lag_allowed, other)
            held_why = self.held_shortfall(base_held, cand_held, pool.units["F"])
        else:
            base_held, cand_held, held_why = self.held_balance(at, c)
        gap1 = pool.gaps(c.fit.model, at.region)
        # judged where it acts: the gap there against the noise floor there
        where = WHERE.get(acts, "")
        if acts:
            before, after = pool.acting_gap(model0, acts), pool.acting_gap(c.fit.model, acts)
            ok_gap = after < (1.0 - self.min_gap_shrink) * before and gap1.overall <= at.gap.overall
        else:
            before, after = at.gap.overall, gap1.overall
            ok_gap = after < (1.0 - self.min_gap_shrink) * before
        floor = pool.band_floor(acts)
        shrink = (before - after) / floor if floor > 0 else math.inf
        part = explained(before, after, floor)
        ok_noise = (not at.later and not blind) or part > self.noise_explained
        why = [held_why] if held_why else []
        if not ok_gap:
            why.append(f"free-run gap{where} {figure(after)} vs {figure(before)} {v}")
        elif not ok_noise:
            why.append(
                f"free-run gap{where} {figure(after)} vs {figure(before)} {v}: it accounts for {part:.2f} "
                f"noise floors{where} ({floor:.3g} {v}) of it, not above {self.noise_explained:g}"
            )
        below = negative_levels(c.fit)
        if below:
            why.append(f"not physical: {below}")
        position = None
        if self.position:
            position = (at.held_position, self.held_position((*at.effects, c.effect), c.fit.model.params))
            if not position[1] < (1.0 - self.min_holdout_gain) * position[0]:
                why.append(
                    f"held-out free-run position error {position[1]:.4g} vs {position[0]:.4g} "
                    f"{position_unit(v)}"
                )
        acting = (before, after, floor) if acts else None
        return Decision(c, base_held, cand_held, at.gap, gap1, shrink, part, acts, acting, why, position)

    def step(
        self, decision: Decision, lookalike: Lookalike | None, at: StepStart, ranking: list[Candidate],
        passing: list[Candidate],
    ) -> Step:  # fmt: skip
        """The step that adds the accepted candidate: its parameters, gaps and evidence.

        Parameters
        ----------
        decision : Decision
            The candidate accepted and its checks.
        lookalike : Lookalike or None
            The effects that fit alike, when the lookalike rule named it.
        at : StepStart
            The step.
        ranking : list of Candidate
            Every candidate tried, highest ΔBIC first.
        passing : list of Candidate
            Those above the threshold.
        """
        pool = self.pool
        c = decision.candidate
        fit1 = c.fit
        eff = get_effect(c.effect)
        params = {p: fit1.model.params[p] for p in (*eff.linear, *eff.nonlinear)}
        params.update(eff.derived(params))
        if lookalike is not None:
            chosen_by = "the lookalike rule"
        else:
            chosen_by = "free-run gap among alike candidates" if c is not passing[0] else "evidence"
        position = (None, None) if decision.position is None else decision.position
        ev = Evidence(
            candidate=c.evidence, threshold=self.threshold, held_out_error_before=decision.held_before,
            held_out_error_after=decision.held_after, gap_shrink_noise_floors=decision.shrink,
            explained_noise_floors=decision.explained, noise_floor=pool.noise, chosen_by=chosen_by,
            ranking=tuple(r.evidence for r in ranking), held_out_position_error_before=position[0],
            held_out_position_error_after=position[1],
        )  # fmt: skip
        before, after = pool.record_gaps(at.fit.model, at.region), pool.record_gaps(fit1.model, at.region)
        per_record = [
            RecordGap(label, g0.overall, g1.overall)
            for label, g0, g1 in zip(pool.labels, before, after, strict=True)
        ]
        step = Step(
            c.effect, params, at.region, at.gap, decision.gap_after, ev, fit1.model, lookalike=lookalike
        )
        step.record_gaps = per_record if len(pool.labels) > 1 else []
        return step

    def run(
        self,
        fit: FitResult,
        effects: tuple[str, ...],
        candidates: tuple[str, ...],
        first_region: Region,
        relocate: bool,
        max_steps: int,
        bar: Any,
    ) -> SearchOutcome:
        """Add effects one step at a time until none passes, all are in, or ``max_steps``.

        Parameters
        ----------
        fit : FitResult
            The model the search starts from, fitted.
        effects : tuple of str
            Its effects.
        candidates : tuple of str
            The effects to try.
        first_region : Region
            The region located on the initial model's residual: the first step's, unless
            ``relocate``.
        relocate : bool
            Locate the first step's region on ``fit``'s residual (a structure was taken).
        max_steps : int
            Most effects added.
        bar : progress bar
            Told each step.
        """
        pool = self.pool
        floor = pool.noise
        steps: list[Step] = []
        rejected: list[Rejected] = []
        stop = Stop("max_steps", {"max_steps": max_steps})
        for _ in range(max_steps):
            bar.set_postfix_str(f"step {len(steps) + 1}")
            remaining = addable(candidates, effects)
            if not remaining:
                stop = Stop("all_in_model")
                break
            r_cur, _ = pool.balance_residual(fit.model)
            region = first_region if not steps and not relocate else locate(r_cur, pool.feats_dec, pool.units)
            gap0 = pool.gaps(fit.model, region)
            later = bool(steps) or self.given
            at_floor = later and gap0.overall <= math.hypot(1.0, self.noise_explained) * floor
            if at_floor:
                # at the record-wide floor: only an effect judged where it acts, against the floor
                # there (near rest, where an encoder's noise is least), can still show
                remaining = [c for c in remaining if get_effect(c).acts]
            if at_floor and not remaining:
                stop = Stop("at_noise_floor", {
                    "gap": gap0.overall, "ratio": gap0.overall / floor, "floor": floor,
                    "v": pool.units["v"], "noise_explained": self.noise_explained,
                })  # fmt: skip
                break
            ranking = self.rank(fit, effects, remaining)
            passing = [c for c in ranking if c.delta_bic > self.threshold]
            if not passing:
                best = ranking[0]
                stop = Stop("no_evidence", {"effect": best.effect, "delta_bic": best.delta_bic,
                                            "threshold": self.threshold})  # fmt: skip
                break
            order = self.judge_order(passing, fit, region)
            at = StepStart(
                fit, effects, region, gap0, self.held_residual(effects, fit.model.params), later,
                self.held_position(effects, fit.model.params),
            )  # fmt: skip
            accepted = None
            reasons = []
            for c in order:
                decision = self.judge(c, at)
                if decision.accepted:
                    accepted = decision
                    break
                rejected.append(decision.rejected(len(steps) + 1))
                reasons.append(f"{c.effect} ({decision.reason})")
            if accepted is None:
                stop = Stop("no_improvement", {"rejected": ", ".join(reasons)})
                break
            accepted, lookalike = lookalike_rule(
                accepted, passing, lambda c, at=at: self.judge(c, at), pool, region, ALIKE_GAP * floor,
                effects,
            )  # fmt: skip
            steps.append(self.step(accepted, lookalike, at, ranking, passing))
            logger.info("added %s: %s", steps[-1].effect, steps[-1].params)
            fit = accepted.candidate.fit
            effects = fit.model.effects
            bar.update(1)
        notes = []
        if "static_friction" in candidates and "static_friction" not in effects:
            # what the final model's rests say of a breakaway the search did not name
            said = self.static_friction(fit).evidence
            if (
                said.note is not None
                and said.breakaway is not None
                and said.breakaway.reading in ("lag", "lookalike")
            ):
                notes.append(said.note)
        return SearchOutcome(steps, rejected, stop, fit, notes)


__all__ = [
    "ALIKE",
    "ALIKE_GAP",
    "DEFAULT_BASE",
    "DEFAULT_THRESHOLD",
    "DIVERGED",
    "NOISE_EXPLAINED",
    "ONE_PLACE",
    "PAIRED_BLOCKS",
    "SPLIT_APART",
    "STRUCTURES",
    "TOLD_Z",
    "Candidate",
    "Decision",
    "GivenKept",
    "LagTest",
    "Search",
    "SearchOutcome",
    "StepStart",
    "breakaway_sentence",
    "candidate_names",
    "choose_structure",
    "effect_names",
    "explained",
    "free_run_std",
    "friction_given",
    "gap_said",
    "keep_given",
    "lookalike_rule",
    "paired_z",
]
