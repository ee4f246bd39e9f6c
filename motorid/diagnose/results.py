"""The doctor's results: what :func:`~motorid.diagnose.workflow.diagnose` found and how it says it.

:class:`Diagnosis` (with its :class:`Step` per effect added, the :class:`Lookalike` effects the
data cannot tell apart and the base :class:`Structure`), the per-record summaries
(:func:`record_summaries`, :func:`rest_summaries`) and the sentences of a stop reason, all built
in one place (:class:`Stop`, :data:`STOP_SENTENCES`, :func:`final_gap_sentence`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from motorid.diagnose.agreement import Agreement
from motorid.diagnose.closed_loop import ClosedLoop
from motorid.diagnose.kinematics import NoiseBand
from motorid.diagnose.locate import Region
from motorid.diagnose.measures import Breakaway, Gap, breakaway, gaps
from motorid.diagnose.model import DelayTrade
from motorid.diagnose.prepare import Pool, prepare
from motorid.diagnose.timing import DelayDrift
from motorid.drive.effects import param_unit
from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import TwoMassRig

if TYPE_CHECKING:
    from motorid.diagnose.search import LagTest

#: Share of the input force below which the inertia is not determined by a record, calibrated on
#: 300 records of a kit-like motor read by an encoder (:func:`~motorid.diagnose.calibration.inertia_shares`,
#: ``python -m motorid.diagnose.calibration --inertia --seeds 50 --first 0``): every record at or
#: above 7.5 % fits the inertia within 2 standard errors or 1 % of the truth (185 of 185), and 100
#: of the 115 below do not (the 0.25 and 0.5 Hz sines, 1.4-7.1 %, fit it 1.1-9.2 % low); 95 % of
#: those above 6.4 % do. The kit motor's 0.5 Hz sines put 4.6 % of it into acceleration, its 1 Hz
#: sines 9.5 %, its chirps 20 % (``scripts/realmotors_doctor.py``).
INERTIA_SHARE_LIMIT = 0.075
#: Relative standard error above which a parameter is not determined by a record.
RELATIVE_STD_LIMIT = 0.5
#: A final gap above this many noise floors says an effect is still missing, within it "at the
#: noise floor": above the largest final gap (3.18) of 899 models that found their one planted
#: effect, and above the 99th percentile (3.04) of 191 on an encoder's speed (quantised, noise
#: growing with speed) (:mod:`.calibration`).
MISSING_FACTOR = 3.5
#: A sample time above this share of the fitted mechanical time constant τ = J / B is said: the
#: speed changes much within each sample, so what happens within one (a breakaway, an input delay
#: of less than a sample, the low speeds a reversal passes through) is seen coarsely. The balance
#: itself holds there (it is written on each sample's ends, :func:`~motorid.diagnose.model.discrete_inertia`)
#: and the noise is measured by the one-step prediction (:func:`~motorid.diagnose.prepare.one_step_noise_pool`):
#: on the bank's 20-40 ms benches (:mod:`motorid.diagnose.bench`) nothing is named on 23 that hide
#: nothing and the planted effect first on 7 of 12, all 7 where it shows (:mod:`.calibration`).
#: No real record of ``realmotors/`` comes near (the L298N's 10 ms against 0.28 s).
SLOW_SAMPLING = 0.5


def slow_sampling_note(model: RigidDrive, dt: float) -> str | None:
    """A note where the sample time ``dt`` [s] exceeds :data:`SLOW_SAMPLING` of the mechanical time
    constant τ = J / B of the fitted ``model`` (a rigid drive with viscous friction); None else."""
    viscous = float(model.params.get("viscous", 0.0))
    if not viscous > 0.0:
        return None
    tau = float(model.params["inertia"]) / viscous
    if not (tau > 0.0 and dt > SLOW_SAMPLING * tau):
        return None
    return (
        f"the sample time {1e3 * dt:.3g} ms is {dt / tau:.2g} of the fitted mechanical time constant "
        f"J/B = {1e3 * tau:.3g} ms: the speed changes much within a sample, so a breakaway, a delay of "
        f"less than a sample and the low speeds of a reversal are seen coarsely; record at {1e3 * tau / 5:.2g} "
        "ms or faster to see them"
    )


@dataclass
class StructureCandidate:
    """A base structure tried (:func:`~motorid.diagnose.search.choose_structure`): a row of
    :attr:`Structure.candidates`.

    Attributes
    ----------
    effects : tuple of str
        Its effects (``input_delay``, ``input_lag`` or both).
    params : dict
        Their fitted parameters [s].
    delta_bic : float
        Its ΔBIC against the probe model (the pair: against the best single effect) [-]
        (:func:`~motorid.diagnose.measures.evidence`).
    gap : float
        The free-run gap of the probe model with it [v]; NaN where it did not pass ``delta_bic``
        and its gap was not measured.
    """

    effects: tuple[str, ...]
    params: dict[str, float]
    delta_bic: float
    gap: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return {
            "effects": list(self.effects),
            "params": self.params,
            "delta_bic": self.delta_bic,
            "gap": self.gap,
        }


@dataclass
class Structure:
    """The base structure chosen from the record before any other effect is judged.

    Attributes
    ----------
    effects : tuple of str
        The structure effects taken (``input_delay``, ``input_lag``; none for a drive
        that answers its input at once).
    params : dict
        Their parameters [s], held fixed in every later fit; the delay then read again on the
        final model's free run (:meth:`~motorid.diagnose.search.Search.final_delay`, which may
        also add one the base hid).
    probe : tuple of str
        The effects of the model the structures were compared in (the base and
        Coulomb friction: a missing friction level must not pass for a lag).
    gap_before, gap_after : float
        Free-run output gap [v] of the probe model without and with the structure.
    candidates : list of StructureCandidate
        Each structure tried, in the order tried.
    reason : str
        Why this structure.
    reach : float
        The upper end of the input delay's search [s]
        (:func:`~motorid.diagnose.model.delay_reach`; NaN where not searched).
    """

    effects: tuple[str, ...] = ()
    params: dict[str, float] = field(default_factory=dict)
    probe: tuple[str, ...] = ()
    gap_before: float = float("nan")
    gap_after: float = float("nan")
    candidates: list[StructureCandidate] = field(default_factory=list)
    reason: str = "not searched"
    reach: float = float("nan")

    @property
    def at_reach(self) -> bool:
        """Whether the delay taken lies at the upper end of its search (within 2 %): the record's
        delay may be longer than the search let it be."""
        return self.params.get("input_delay", 0.0) >= 0.98 * self.reach

    def describe(self, dt: float) -> str:
        """One line for the report, e.g. ``input_delay = 0.012 s (1.20 samples)``."""
        if not self.effects:
            return "no input delay or lag"
        line = ", ".join(f"{p} = {v:.4g} s ({v / dt:.2f} samples)" for p, v in self.params.items())
        if self.at_reach:
            line += (
                f"; the delay sits at the end of its search, {self.reach:.4g} s: the record's may be longer "
                "(a logger's delay: correct the record's timing)"
            )
        return line

    def to_dict(self) -> dict[str, Any]:
        return {
            "effects": list(self.effects), "params": self.params, "probe": list(self.probe),
            "gap_before": self.gap_before, "gap_after": self.gap_after,
            "candidates": [c.to_dict() for c in self.candidates], "reason": self.reason, "delay_reach": self.reach,
            "delay_at_reach": self.at_reach,
        }  # fmt: skip


@dataclass
class Lookalike:
    """Effects the data cannot tell apart: one physics, fitted alike by two or more effects.

    Attributes
    ----------
    physics : str
        What they are forms of (:meth:`Effect.physics <motorid.drive.effects.base.Effect.physics>`),
        e.g. ``kinetic friction``.
    named : str
        The effect the lookalike rule named (:func:`~motorid.diagnose.workflow.diagnose`, step 4).
    gaps : dict
        Effect -> free-run gap [v] of the model with it, the named one first.
    levels : dict
        Effect -> the size of the physics in that model [F] (:meth:`Effect.level <motorid.drive.effects.base.Effect.level>`).
    tolerance : float
        Two gaps closer than this [v] fit alike: :data:`~motorid.diagnose.search.ALIKE_GAP`
        noise floors.
    """

    physics: str
    named: str
    gaps: dict[str, float]
    levels: dict[str, float]
    tolerance: float

    def describe(self, units: dict[str, str]) -> str:
        """One line, e.g. ``kinetic friction 0.73 V: coulomb_friction and input_dead_zone fit alike
        (free-run gap 4.771 vs 4.802 rad/s, within 0.21 rad/s); named coulomb_friction by the
        lookalike rule (the first in the library's order)``."""
        names = list(self.gaps)
        figures = " vs ".join(f"{g:.4g}" for g in self.gaps.values())
        return (
            f"{self.physics} {self.levels[self.named]:.3g} {units['F']}: {' and '.join(names)} fit alike "
            f"(free-run gap {figures} {units['v']}, within {self.tolerance:.3g} {units['v']}); named "
            f"{self.named} by the lookalike rule (the first in the library's order)"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "physics": self.physics, "named": self.named, "effects": list(self.gaps),
            "free_run_gaps": self.gaps, "levels": self.levels, "tolerance": self.tolerance,
        }  # fmt: skip


@dataclass(frozen=True)
class CandidateEvidence:
    """One candidate's evidence against a step's model: a row of the step's ranking
    (:attr:`Evidence.ranking`).

    Attributes
    ----------
    effect : str
        The candidate effect.
    delta_bic : float
        ΔBIC = n_eff ln(RSS_0 / RSS_1) - Δk ln n_eff [-] of the step's model with it against
        without (:func:`~motorid.diagnose.measures.evidence`; static friction on the rests:
        :func:`~motorid.diagnose.measures.breakaway_evidence`); -inf where its fit is not physical
        or the rests show no breakaway (:attr:`note` says which).
    n : int
        The samples compared: the torque balance's rows (decimated samples), the typical rests,
        or the free run's settled samples.
    n_eff : float
        The effective samples n (1 - ρ) / (1 + ρ) [-].
    rho : float
        ρ, the lag-1 autocorrelation of the candidate's residual, within [0, 0.95] [-].
    rss_ratio : float
        RSS_0 / RSS_1 [-].
    measure : str or None
        Static friction: what it is judged on (``rests``, or the free run on too few rests);
        None for the other effects.
    breakaway : Breakaway or None
        Static friction judged on the rests: what they say of a breakaway above the kinetic level.
    lag_test : LagTest or None
        Static friction on rests at one input rate: whether the moving drive tells its level from
        a lag (:meth:`Search.lag_test <motorid.diagnose.search.Search.lag_test>`).
    note : str or None
        Why it cannot pass (a parameter of the wrong sign, a breakaway the rests do not show).
    """

    effect: str
    delta_bic: float
    n: int
    n_eff: float
    rho: float
    rss_ratio: float
    measure: str | None = None
    breakaway: Breakaway | None = None
    lag_test: LagTest | None = None
    note: str | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "effect": self.effect, "delta_bic": self.delta_bic, "n": self.n, "n_eff": self.n_eff,
            "rho": self.rho, "rss_ratio": self.rss_ratio,
        }  # fmt: skip
        if self.measure is not None:
            out["measure"] = self.measure
        if self.breakaway is not None:
            out["breakaway"] = self.breakaway.to_dict()
        if self.lag_test is not None:
            out["lag_test"] = self.lag_test.to_dict()
        if self.note is not None:
            out["note"] = self.note
        return out


@dataclass(frozen=True)
class Evidence:
    """Why a step's effect was added: its evidence against the step's model, the checks it passed
    (:meth:`Search.judge <motorid.diagnose.search.Search.judge>`) and every candidate's ranking.

    Attributes
    ----------
    candidate : CandidateEvidence
        The accepted candidate's evidence (:attr:`delta_bic`, :attr:`n`, :attr:`n_eff`,
        :attr:`rss_ratio` are its figures).
    threshold : float
        The ΔBIC a candidate needed [-].
    held_out_error_before, held_out_error_after : float
        The held-out error without and with it, where it acts ([v/s] on the balance, [F] on the rests, [v] on
        the free run).
    gap_shrink_noise_floors : float
        The free-run gap's shrink where it is judged, in noise floors of that band [-].
    explained_noise_floors : float
        The part of that gap it accounts for, in the same noise floors [-]
        (:func:`~motorid.diagnose.search.explained`).
    noise_floor : float
        The record's noise floor σ_w [v].
    chosen_by : str
        ``evidence`` (the highest ΔBIC that passed), ``free-run gap among alike candidates`` or
        ``the lookalike rule``.
    ranking : tuple of CandidateEvidence
        Every candidate tried, highest ΔBIC first.
    held_out_position_error_before, held_out_position_error_after : float or None
        On position records, the free-run position error on held-out halves without and with it
        [m or rad]; None otherwise.
    """

    candidate: CandidateEvidence
    threshold: float
    held_out_error_before: float
    held_out_error_after: float
    gap_shrink_noise_floors: float
    explained_noise_floors: float
    noise_floor: float
    chosen_by: str
    ranking: tuple[CandidateEvidence, ...]
    held_out_position_error_before: float | None = None
    held_out_position_error_after: float | None = None

    @property
    def delta_bic(self) -> float:
        """The accepted candidate's ΔBIC [-]."""
        return self.candidate.delta_bic

    @property
    def n(self) -> int:
        """The samples its ΔBIC compared."""
        return self.candidate.n

    @property
    def n_eff(self) -> float:
        """Their effective number [-]."""
        return self.candidate.n_eff

    @property
    def rss_ratio(self) -> float:
        """RSS_0 / RSS_1 of its fit [-]."""
        return self.candidate.rss_ratio

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "delta_bic": self.delta_bic, "threshold": self.threshold, "n": self.n, "n_eff": self.n_eff,
            "rss_ratio": self.rss_ratio, "held_out_error_before": self.held_out_error_before,
            "held_out_error_after": self.held_out_error_after,
            "gap_shrink_noise_floors": self.gap_shrink_noise_floors,
            "explained_noise_floors": self.explained_noise_floors, "noise_floor": self.noise_floor,
        }  # fmt: skip
        if self.held_out_position_error_before is not None:
            out["held_out_position_error_before"] = self.held_out_position_error_before
            out["held_out_position_error_after"] = self.held_out_position_error_after
        out["chosen_by"] = self.chosen_by
        out["ranking"] = [r.to_dict() for r in self.ranking]
        return out


@dataclass(frozen=True)
class RecordGap:
    """One record's overall free-run gaps before and after a step of a joint run
    (:attr:`Step.record_gaps`).

    Attributes
    ----------
    record : str
        Its label.
    gap_before, gap_after : float
        Its gap [v] of the step's model without and with the step's effect.
    """

    record: str
    gap_before: float
    gap_after: float

    def to_dict(self) -> dict[str, Any]:
        return {"record": self.record, "gap_before": self.gap_before, "gap_after": self.gap_after}


@dataclass(frozen=True)
class Rejected:
    """A candidate that passed the evidence threshold but not the checks of its step
    (:attr:`Diagnosis.rejected`).

    Attributes
    ----------
    step : int
        The step it was judged in (1 the first).
    effect : str
        The candidate effect.
    reason : str
        Each check it failed, separated by semicolons.
    delta_bic : float
        Its ΔBIC [-].
    held_out_error_before, held_out_error_after : float
        The held-out error without and with it, where it acts ([v/s] on the balance, [F] on the rests, [v] on
        the free run).
    gap_before, gap_after : float
        The overall free-run gap [v] of the step's model and of the model with it, in the
        step's region.
    gap_shrink_noise_floors : float
        The free-run gap's shrink where it is judged, in noise floors of that band [-].
    explained_noise_floors : float
        The part of that gap it accounts for, in the same noise floors [-].
    judged : str or None
        Where it was judged when it acts in one place (``at the rests``, ``near rest``,
        ``at speed``); None: everywhere.
    acting_gap_before, acting_gap_after, acting_noise_floor : float or None
        There: the free-run gap without and with it and the noise floor [v].
    held_out_position_error_before, held_out_position_error_after : float or None
        On position records, the free-run position error on held-out halves without and with
        it [m or rad].
    """

    step: int
    effect: str
    reason: str
    delta_bic: float
    held_out_error_before: float
    held_out_error_after: float
    gap_before: float
    gap_after: float
    gap_shrink_noise_floors: float
    explained_noise_floors: float
    judged: str | None = None
    acting_gap_before: float | None = None
    acting_gap_after: float | None = None
    acting_noise_floor: float | None = None
    held_out_position_error_before: float | None = None
    held_out_position_error_after: float | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "step": self.step, "effect": self.effect, "delta_bic": self.delta_bic,
            "held_out_error_before": self.held_out_error_before, "held_out_error_after": self.held_out_error_after,
            "gap_before": self.gap_before, "gap_after": self.gap_after,
            "gap_shrink_noise_floors": self.gap_shrink_noise_floors,
            "explained_noise_floors": self.explained_noise_floors,
        }  # fmt: skip
        if self.judged is not None:
            out.update({"judged": self.judged, "acting_gap_before": self.acting_gap_before,
                        "acting_gap_after": self.acting_gap_after, "acting_noise_floor": self.acting_noise_floor})  # fmt: skip
        if self.held_out_position_error_before is not None:
            out["held_out_position_error_before"] = self.held_out_position_error_before
            out["held_out_position_error_after"] = self.held_out_position_error_after
        out["reason"] = self.reason
        return out


@dataclass
class Step:
    """One accepted effect.

    Attributes
    ----------
    effect : str
        The effect's name.
    params : dict
        Its parameters (SI units) in the refitted model.
    region : Region
        Where the disagreement concentrated before it was added.
    gap_before, gap_after : Gap
        The output gaps overall and in ``region`` [v] and the force error [%].
    evidence : Evidence
        ΔBIC and its threshold, held-out errors, the candidate ranking.
    model : RigidDrive
        The refitted model after this step.
    record_gaps : list of RecordGap
        Several records: each record's overall gaps before and after [v] (the step's gaps are
        the pooled ones); empty for one record.
    lookalike : Lookalike or None
        The effects that fit alike here, and which one the lookalike rule named.
    """

    effect: str
    params: dict[str, float]
    region: Region
    gap_before: Gap
    gap_after: Gap
    evidence: Evidence
    model: RigidDrive
    record_gaps: list[RecordGap] = field(default_factory=list)
    lookalike: Lookalike | None = None

    def to_dict(self) -> dict[str, Any]:
        out = {
            "effect": self.effect,
            "params": self.params,
            "region": self.region.to_dict(),
            "gap_before": self.gap_before.to_dict(),
            "gap_after": self.gap_after.to_dict(),
            "evidence": self.evidence.to_dict(),
            "model_params": self.model.params,
        }
        if self.record_gaps:
            out["record_gaps"] = [g.to_dict() for g in self.record_gaps]
        if self.lookalike is not None:
            out["lookalike"] = self.lookalike.to_dict()
        return out


@dataclass(frozen=True)
class Settings:
    """The options a diagnosis ran with, as used (:attr:`Diagnosis.settings`): what
    :meth:`Diagnosis.evaluate` reads another record with, and the JSON's ``settings``.

    Attributes
    ----------
    dt : float
        The sample time [s] (the first record's).
    input, output : str
        The columns read as the input and the output.
    output_kind : str
        ``velocity`` or ``position``.
    input_gain : float or None
        The input gain given [N m or N per input unit]; None: forces per input unit.
    band : float
        The useful band [Hz] (:mod:`.kinematics`).
    reading : dict
        How the records were read: the keywords of :func:`~motorid.io.records.normalise_record`
        but the columns and ``dt`` (``time``, ``input_unit``, ``output_unit``, ...).
    timing : str
        The input/output timing, ``hold`` or ``sampled`` (the first record's).
    base : tuple of str
        The effects of the base model.
    candidates : tuple of str
        The effects tried.
    threshold : float
        The ΔBIC a candidate needs [-].
    noise_explained : float
        The part of the free-run gap a later effect must account for [noise floors].
    missing_factor : float
        The final gap, in noise floors, above which something is still missing.
    holdout : float or str
        The share of the record held out [-], or ``record`` for a held-out record.
    max_steps : int
        The most effects added.
    model : str
        ``given`` (a model was given) or ``fitted``.
    stribeck_shape : str
        The Stribeck curve's shape.
    structure : bool
        Whether an input delay and lag were searched first.
    records : tuple of str
        Several records: their labels; empty for one record.
    """

    dt: float
    input: str
    output: str
    output_kind: str
    input_gain: float | None
    band: float
    reading: dict[str, Any]
    timing: str
    base: tuple[str, ...]
    candidates: tuple[str, ...]
    threshold: float
    noise_explained: float
    missing_factor: float
    holdout: float | str
    max_steps: int
    model: str
    stribeck_shape: str
    structure: bool
    records: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "records"}
        out.update(reading=dict(self.reading), base=list(self.base), candidates=list(self.candidates))
        if self.records:
            out["records"] = list(self.records)
        return out


@dataclass
class Diagnosis:
    """What :func:`~motorid.diagnose.workflow.diagnose` found.

    Attributes
    ----------
    initial_gap, final_gap : Gap
        The output gap [v] (RMS of measured minus free-run velocity) overall and in the first
        located region, and the torque-balance error on the decimated samples [%].
    steps : list of Step
    stop_reason : str
        Why the search stopped, then the final gap against the noise floor: at it, or
        many times it ("something is still missing") and where it concentrates.
    stop : Stop or None
        Why the search stopped, with its figures (the first sentence of :attr:`stop_reason`;
        e.g. the best candidate's ΔBIC where none passed the threshold).
    noise_floor : float
        σ_w [v]: standard deviation of the noise on the measured velocity the free
        run is compared with, estimated from the record (see the module notes; several
        records: pooled over them, :class:`Pool`).
    final_region : Region
        Where the final model's torque-balance residual concentrates.
    model : RigidDrive
        The final fitted model (``model.params``: inertia, input_gain, viscous, ...),
        at the record's sample time; ``model.save(path)`` writes it as a model file.
    initial_model : RigidDrive
        The user's model as given (``diagnose(model=...)``), else the fitted base.
    region : Region
        The region located on the initial model's residual.
    units : dict
        Units of velocity (``v``), force (``F``) and input (``u``): ``F`` is
        N or N m with a known input gain, else the input's unit.
    settings : Settings
        Options used (for :meth:`evaluate` on another record).
    rejected : list of Rejected
        Candidates that passed the evidence threshold but were not accepted, and why.
    refitted_model, refitted_gap : RigidDrive and Gap, or None
        With a given model: its effects refitted to the record, and their gaps (the
        start of the first step).
    param_std : dict
        Standard error of each linear parameter of the final model (inertia and the
        effects' levels, in the units of ``param_units``), from the fit's residual
        (:func:`motorid.diagnose.model.linear_param_std`); shape parameters have none.
    param_share : dict
        Share of the input force each linear parameter's term carries
        (:func:`motorid.diagnose.model.force_shares`) [-].
    delay_trade : DelayTrade or None
        The final fit with its input delay set free in the balance
        (:func:`motorid.diagnose.model.delay_trade`): the parameters that depend on the delay
        taken, and ``J + B τ_d``, what the record determines where the inertia is one of them.
    structure : Structure
        The input delay and lag chosen from the record before any other effect was judged.
    structure_model : RigidDrive or None
        The base refitted with that structure, when one was taken.
    noise_bands : list of NoiseBand
        The noise floor per speed band (:meth:`Pool.noise_bands`). An encoder's noise often
        grows with speed, where :attr:`noise_floor` is one figure over every speed.
    quantisation_step : float or None
        The step the output is quantised in [its unit] (an encoder's count per sample), when it
        shows (:func:`~motorid.diagnose.kinematics.quantisation_step`).
    rests : list of RestSummary
        Per record (:func:`rest_summaries`): its rests and the breakaway they show above the
        final model's kinetic level.
    notes : list of str
        One line per logging artefact left out of a record (a held start, drop-out spikes:
        :mod:`.artefacts`); with several records each begins with the record's label. With a
        two-mass rig given, a last line says the search ran on its rigid equivalent
        (:func:`~motorid.diagnose.given_rig.rig_note`).
    rig : TwoMassRig or None
        The two-mass rig given (``diagnose(model=rig)``); :attr:`improved_model` puts the
        final model back on it.
    position_model : RigidDrive or None
        On position records, :attr:`model`'s parameters refitted to the records' free-run
        position (:func:`~motorid.diagnose.position.refit_records_in_position`); None otherwise.
    position_error : PositionError or None
        With it, the RMS free-run position errors of :attr:`model` and of :attr:`position_model`.
    records : list of RecordSummary
        Several records of one drive (:class:`Pool`): each record's gaps alone; the gaps above
        are the pooled ones. Empty for one record.
    agreement : list of Agreement
        Several records: how they agree on each linear parameter the joint run determines, each
        record fitted alone with the joint model's structure (:mod:`.agreement`: Cochran's test
        of one common value, the spread between the records beyond their errors, the records
        that lie off). Empty for one record.
    delay_drift : list of DelayDrift
        The records whose input delay drifts along them (:func:`~motorid.diagnose.timing.delay_drift`:
        a logger's time base); each is said in :attr:`notes`. Empty where none drifts. With
        ``align``, the drifts taken out before the records were diagnosed again.
    closed_loop : list of ClosedLoop
        The records recognised as closed loops, or whose input looks like one's
        (:mod:`.closed_loop`): how each was read and identified. Empty for open loops.
    """

    initial_gap: Gap
    final_gap: Gap
    steps: list[Step]
    stop_reason: str
    noise_floor: float
    final_region: Region
    model: RigidDrive
    initial_model: RigidDrive
    region: Region
    units: dict[str, str]
    settings: Settings
    rejected: list[Rejected] = field(default_factory=list)
    refitted_model: RigidDrive | None = None
    refitted_gap: Gap | None = None
    param_std: dict[str, float] = field(default_factory=dict)
    param_share: dict[str, float] = field(default_factory=dict)
    delay_trade: DelayTrade | None = None
    structure: Structure = field(default_factory=Structure)
    structure_model: RigidDrive | None = None
    records: list[RecordSummary] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    noise_bands: list[NoiseBand] = field(default_factory=list)
    quantisation_step: float | None = None
    rests: list[RestSummary] = field(default_factory=list)
    rig: TwoMassRig | None = None
    position_model: RigidDrive | None = None
    position_error: PositionError | None = None
    agreement: list[Agreement] = field(default_factory=list)
    delay_drift: list[DelayDrift] = field(default_factory=list)
    closed_loop: list[ClosedLoop] = field(default_factory=list)
    stop: Stop | None = None
    _pool: Pool | None = field(default=None, repr=False)

    @property
    def improved_model(self) -> RigidDrive | TwoMassRig:
        """The model the doctor improved, of the kind it was given: :attr:`model`, or with a
        two-mass rig given, that rig with :attr:`model`'s effects and parameters put back
        (:meth:`TwoMassRig.with_rigid_equivalent
        <motorid.drive.two_mass.TwoMassRig.with_rigid_equivalent>`; it keeps its own sample
        time). ValueError naming an effect the rig cannot carry."""
        if self.rig is None:
            return self.model
        return self.rig.with_rigid_equivalent(self.model)

    @property
    def named(self) -> list[str]:
        """The effects added, in order."""
        return [s.effect for s in self.steps]

    @property
    def lookalikes(self) -> list[Lookalike]:
        """The steps' lookalikes: effects that fit alike and the one the rule named."""
        return [s.lookalike for s in self.steps if s.lookalike is not None]

    @property
    def undetermined(self) -> dict[str, str]:
        """The linear parameters the record(s) cannot determine, each with why.

        A parameter is not determined when its standard error exceeds
        :data:`RELATIVE_STD_LIMIT` of its value, and the inertia also when its term carries less
        than :data:`INERTIA_SHARE_LIMIT` of the input force (a slow sine spends its force on
        friction; the inertia then follows whatever the rigid model leaves unexplained, and
        records of other signals disagree with it by more than its standard error). The fitted
        value stays in :attr:`model` for the free run; the report does not present it as a
        finding. A dropped column (value and standard error 0) is not listed.

        An inertia that depends on the input delay taken (:attr:`delay_trade`: set free in the
        balance, the delay moves it by more than :data:`~motorid.diagnose.model.DELAY_TRADE_LIMIT`
        of its standard errors) is not determined either: it trades with the delay through the
        viscous friction, and the reason gives ``J + B τ_d``, the figure the record determines.
        """
        out = {}
        trade = self.delay_trade
        for name, std in self.param_std.items():
            value = self.model.params.get(name, math.nan)
            share = self.param_share.get(name, math.nan)
            if value == 0.0 and std == 0.0:
                continue
            if name == "inertia" and share < INERTIA_SHARE_LIMIT:
                out[name] = (
                    f"its term carries {100 * share:.1f} % of the input force, below {100 * INERTIA_SHARE_LIMIT:g} %"
                )
            elif name == "inertia" and trade is not None and trade.inertia_traded:
                out[name] = self._traded_reason(trade)
            elif not std <= RELATIVE_STD_LIMIT * abs(value):
                out[name] = (
                    f"standard error {std:.2g} is above {100 * RELATIVE_STD_LIMIT:.0f} % of {value:.3g}"
                )
        return out

    @staticmethod
    def _traded_reason(trade: DelayTrade) -> str:
        """Why the inertia depends on the delay taken, with the figures of :class:`DelayTrade`."""
        return (
            "it trades with the input delay through the viscous friction: with the delay set free in "
            f"the balance ({1e3 * trade.delay_free:.3g} ± {1e3 * trade.delay_free_std:.2g} ms, against "
            f"{1e3 * trade.delay:.3g} ms taken) it is {trade.free['inertia']:.4g} ± "
            f"{trade.free_std['inertia']:.2g}, {trade.moved('inertia'):.1f} standard errors away; the "
            f"record determines J + B τ_d = {trade.effective_inertia:.4g} ± {trade.effective_inertia_std:.2g}"
        )

    @property
    def param_units(self) -> dict[str, str]:
        """Concrete unit of each parameter of the final model, e.g. ``{"coulomb": "N m"}``, and of
        the figures a step reports beside them (the cogging's amplitude and phase)."""
        names = dict.fromkeys([*self.model.params, *(p for step in self.steps for p in step.params)])
        return {name: param_unit(name, self.units) for name in names}

    @property
    def models(self) -> list[tuple[str, RigidDrive]]:
        """``(label, model)`` for the initial model and after each step."""
        out = [("initial", self.initial_model)]
        if self.refitted_model is not None:
            out.append(("refitted", self.refitted_model))
        if self.structure_model is not None:
            out.append(("+" + "+".join(self.structure.effects), self.structure_model))
        out += [(f"+{s.effect}", s.model) for s in self.steps]
        return out

    def to_dict(self) -> dict[str, Any]:
        """The JSON shape of ``motorid doctor --json``."""
        return {
            "initial_gap": self.initial_gap.to_dict(),
            "final_gap": self.final_gap.to_dict(),
            "steps": [s.to_dict() for s in self.steps],
            "stop_reason": self.stop_reason,
            "noise_floor": self.noise_floor,
            "noise_bands": [b.to_dict() for b in self.noise_bands],
            "quantisation_step": self.quantisation_step,
            "at_noise_floor_factor": self.settings.missing_factor,
            "rests": [r.to_dict() for r in self.rests],
            "region": self.region.to_dict(),
            "final_region": self.final_region.to_dict(),
            "model": {
                "effects": list(self.model.effects),
                "params": self.model.params,
                "params_std": self.param_std,
                "params_share": self.param_share,
                "params_undetermined": self.undetermined,
                "delay_trade": None if self.delay_trade is None else self.delay_trade.to_dict(),
            },
            "rejected": [r.to_dict() for r in self.rejected],
            "units": {
                "gap": f"{self.units['v']} (RMS of measured minus free-run velocity"
                + ("; velocity derived from position)" if self.settings.output_kind == "position" else ")"),
                "force_error_percent": "%",
                "force": self.units["F"],
                "velocity": self.units["v"],
                "input": self.units["u"],
                "params": self.param_units,
            },
            "settings": self.settings.to_dict(),
            "initial_model": {
                "effects": list(self.initial_model.effects),
                "params": self.initial_model.params,
            },
            "refitted_gap": None if self.refitted_gap is None else self.refitted_gap.to_dict(),
            "structure": self.structure.to_dict(),
            **({"records": [r.to_dict() for r in self.records]} if self.records else {}),
            **({"agreement": {a.parameter: a.to_dict() for a in self.agreement}} if self.agreement else {}),
            **({"lookalikes": [x.to_dict() for x in self.lookalikes]} if self.lookalikes else {}),
            **({"notes": self.notes} if self.notes else {}),
            **({"delay_drift": [x.to_dict() for x in self.delay_drift]} if self.delay_drift else {}),
            **({"closed_loop": [x.to_dict() for x in self.closed_loop]} if self.closed_loop else {}),
            **({"two_mass_rig": self._rig_dict()} if self.rig is not None else {}),
            **({"position_refit": self._position_dict()} if self.position_model is not None else {}),
        }

    def _position_dict(self) -> dict[str, Any]:
        """The final model refitted in position (:attr:`position_model`) and the RMS free-run
        position errors of both models (:attr:`position_error`)."""
        assert self.position_model is not None and self.position_error is not None
        return {
            "effects": list(self.position_model.effects),
            "params": self.position_model.params,
            "position_error_fitted": self.position_error.fitted,
            "position_error_refitted": self.position_error.refitted,
            "unit": self.position_error.unit,
        }

    def _rig_dict(self) -> dict[str, Any]:
        """The given rig and the improved one (:attr:`improved_model`), or why the rig cannot
        carry the final model (``refused``)."""
        out: dict[str, Any] = {
            "searched_on": "rigid equivalent",
            "given": self.rig.to_dict() if self.rig else None,
        }
        try:
            out["improved"] = self.improved_model.to_dict()
        except ValueError as exc:
            out["improved"] = None
            out["refused"] = str(exc)
        return out

    def table(self) -> pd.DataFrame:
        """Gap before and after each step, overall and in the step's region."""
        rows = []
        for s in self.steps:
            rows.append(
                {
                    "effect": s.effect,
                    "region": s.region.description,
                    "gap_before": s.gap_before.overall,
                    "gap_after": s.gap_after.overall,
                    "region_gap_before": s.gap_before.region,
                    "region_gap_after": s.gap_after.region,
                    "force_error_before_percent": s.gap_before.force_error_percent,
                    "force_error_after_percent": s.gap_after.force_error_percent,
                    "delta_bic": s.evidence.delta_bic,
                }
            )
        df = pd.DataFrame(rows, columns=[
            "effect", "region", "gap_before", "gap_after", "region_gap_before", "region_gap_after",
            "force_error_before_percent", "force_error_after_percent", "delta_bic",
        ])  # fmt: skip
        df.index = pd.RangeIndex(1, len(df) + 1, name="step")
        df.attrs["units"] = {"gap": self.units["v"], "force_error": "%"}
        return df

    def evaluate(self, record: pd.DataFrame, **overrides: Any) -> pd.DataFrame:
        """Gaps of the initial model and of the model after each step on another record.

        No refitting: the models found here are simulated on ``record``'s input
        and their torque balance evaluated on its data. Column names, output
        kind, input gain, timing and band, and the way the record is read (its
        columns and units, :func:`motorid.io.records.normalise_record`), are those of
        this diagnosis unless overridden (``input=``, ``output=``, ``dt=`` ...).

        Returns
        -------
        pandas.DataFrame
            One row per model (``initial``, ``+effect``...), columns ``overall``
            and ``region`` [v] (the region located on this record's initial
            residual) and ``force_error_percent`` [%].
        """
        from motorid.io.records import normalise_record

        used = self.settings
        reading = {"input": used.input, "output": used.output, "dt": None, **used.reading}
        reading.update({k: v for k, v in overrides.items() if k in reading})
        record = normalise_record(record, **reading)
        opts = {"output_kind": used.output_kind, "input_gain": used.input_gain, "timing": used.timing,
                "band": used.band}  # fmt: skip
        opts.update({k: v for k, v in overrides.items() if k not in reading})
        prep = prepare(record, input="u", output="y", dt=reading["dt"], **opts)
        rows = {label: gaps(model, prep, self.region) for label, model in self.models}
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "model"
        df.attrs["units"] = {
            "overall": self.units["v"],
            "region": self.units["v"],
            "force_error_percent": "%",
        }
        return df

    def write_figures(self, out_dir: str | Path) -> list[Path]:
        """PNG figures: residual against speed before/after each step; simulation against measurement.

        Several records: one pair of figures per record, named with its number (``doctor_2_...``).
        """
        from motorid.diagnose.figures import write_figures

        if self._pool is None:
            raise ValueError("this diagnosis holds no record data to plot")
        parts = self._pool.parts
        if len(parts) == 1:
            return write_figures(self, parts[0], Path(out_dir))
        return [
            path
            for k, prep in enumerate(parts, 1)
            for path in write_figures(self, prep, Path(out_dir), prefix=f"doctor_{k}_")
        ]


@dataclass(frozen=True)
class PositionError:
    """The RMS free-run position error on a position record's samples of the doctor's final model
    and of the same model refitted in position
    (:func:`~motorid.diagnose.position.refit_records_in_position`).

    Attributes
    ----------
    fitted, refitted : float
        The two errors [unit].
    unit : str
        The position's unit (``m`` or ``rad``; ``position_unit`` of the velocity's).
    """

    fitted: float
    refitted: float
    unit: str


@dataclass(frozen=True)
class RecordSummary:
    """One record of a joint run: its gaps of the initial and final models, alone.

    Attributes
    ----------
    record : str
        Its label.
    samples : int
        Its samples.
    noise_floor : float
        Its noise floor [v].
    initial_gap, final_gap : Gap
        Its gaps of the initial and the final model.
    """

    record: str
    samples: int
    noise_floor: float
    initial_gap: Gap
    final_gap: Gap

    @property
    def final_gap_noise_floors(self) -> float:
        """The final gap in its noise floors [-]."""
        return self.final_gap.overall / self.noise_floor if self.noise_floor > 0 else math.inf

    def to_dict(self) -> dict[str, Any]:
        return {
            "record": self.record, "samples": self.samples, "noise_floor": self.noise_floor,
            "initial_gap": self.initial_gap.to_dict(), "final_gap": self.final_gap.to_dict(),
            "final_gap_noise_floors": self.final_gap_noise_floors,
        }  # fmt: skip


@dataclass(frozen=True)
class RestSummary:
    """The rests of one record and the breakaway they show above a model's kinetic level.

    Attributes
    ----------
    record : str
        Its label.
    count : int
        Its rests (:mod:`.rests`).
    median_length : float
        Their median length [s] (NaN for none).
    median_breakaway_input : float
        The median input the drive breaks away at, in the direction it then moves [u].
    median_input_rate : float
        The median rate of the input there [u/s].
    w_rest : float
        The speed at or below which the drive counts as at rest [v].
    kinetic_level : float
        The model's kinetic friction level at 0± (the mean of both directions) [F].
    breakaway_excess, breakaway_excess_std : float
        The force at breakaway above it, at an input rising infinitely slowly, and its
        standard error [F] (:class:`~motorid.diagnose.measures.Breakaway`).
    breakaway_lag, breakaway_lag_std : float
        The lag between input and force the rests show, and its standard error [s].
    breakaway_reading : str
        What the rests say (:attr:`Breakaway.reading <motorid.diagnose.measures.Breakaway.reading>`):
        ``static_friction``, ``lag``, ``lookalike`` (an excess at one input rate) or ``none``.
    breakaway_one_rate : bool
        Every breakaway came at one input rate: ``breakaway_excess`` as a level and
        ``breakaway_lag`` as a lag are two readings of one excess.
    breakaway_bracketed : int
        The rests whose input stepped past the breakaway within a sample, which bracket it and do
        not read it (:attr:`Breakaway.bracketed <motorid.diagnose.measures.Breakaway.bracketed>`).
    """

    record: str
    count: int
    median_length: float
    median_breakaway_input: float
    median_input_rate: float
    w_rest: float
    kinetic_level: float
    breakaway_excess: float
    breakaway_excess_std: float
    breakaway_lag: float
    breakaway_lag_std: float = math.nan
    breakaway_reading: str = "none"
    breakaway_one_rate: bool = False
    breakaway_bracketed: int = 0

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def record_summaries(
    pool: Pool, initial: RigidDrive, final: RigidDrive, region: Region
) -> list[RecordSummary]:
    """Each record's gaps of the ``initial`` and ``final`` models and its noise floor
    (:attr:`Diagnosis.records`); none for a pool of one record.

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    initial, final : RigidDrive
        The models before and after the search.
    region : Region
        The region the gaps are also measured in.
    """
    if len(pool.parts) == 1:
        return []
    out = []
    for label, prep, before, after in zip(
        pool.labels,
        pool.parts,
        pool.record_gaps(initial, region),
        pool.record_gaps(final, region),
        strict=True,
    ):
        out.append(RecordSummary(label, prep.kin.n, prep.kin.noise, before, after))
    return out


def rest_summaries(pool: Pool, model: RigidDrive) -> list[RestSummary]:
    """Each record's rests (:meth:`Rests.summary <motorid.diagnose.rests.Rests.summary>`) and the
    breakaway they show above ``model``'s kinetic level (:func:`~motorid.diagnose.measures.breakaway`)
    (:attr:`Diagnosis.rests`).

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The model whose kinetic level the breakaway is measured above.
    """
    eps = max(1e-9, 1e-6 * pool.data.scale["w_max"])
    t_pos, t_neg = model.without(*model.position_effects).friction(
        np.array([eps, -eps])
    )  # a ripple averages out
    out = []
    for k, (label, prep) in enumerate(zip(pool.labels, pool.parts, strict=True)):
        only = [np.full(p.kin.n, j == k) for j, p in enumerate(pool.parts)]
        found = breakaway(pool, model, only)
        out.append(RestSummary(
            label, **prep.rests.summary(), kinetic_level=0.5 * float(t_pos - t_neg),
            breakaway_excess=found.excess, breakaway_excess_std=found.standard_error, breakaway_lag=found.lag,
            breakaway_lag_std=found.lag_std, breakaway_reading=found.reading, breakaway_one_rate=found.one_rate,
            breakaway_bracketed=found.bracketed,
        ))  # fmt: skip
    return out


#: The sentences of a stop reason, by the :attr:`Stop.kind` that ends a search: every one the
#: doctor says is here, its figures filled in by :meth:`Stop.sentence`.
STOP_SENTENCES: dict[str, str] = {
    "max_steps": "max_steps = {max_steps} reached",
    "all_in_model": "every candidate effect is already in the model (or needs one that is not)",
    "at_noise_floor": (
        "the free-run gap {gap:.4g} {v} is {ratio:.2f} x the noise floor {floor:.4g} {v}: no further effect "
        "can account for more than {noise_explained:g} x the noise of it (and none acts where the noise is lower)"
    ),
    "no_evidence": (
        "no candidate passes the evidence threshold: the best, {effect}, has ΔBIC = {delta_bic:.1f} <= {threshold:g}"
    ),
    "no_improvement": (
        "no candidate improves held-out data and shrinks the free-run gap beyond the noise: {rejected}"
    ),
    # the final gap against the noise floor, said after any of the above
    "final_at_floor": (
        "final gap {gap:.4g} {v} = {ratio:.1f} x the noise floor {floor:.3g} {v}: at the noise floor, "
        "nothing more to explain"
    ),
    "final_missing": (
        "final gap {gap:.4g} {v} = {ratio:.1f} x the noise floor {floor:.3g} {v}: something is still "
        "missing; the gap concentrates where {where} (final gap there {region_gap:.4g} {v})"
    ),
}


@dataclass(frozen=True)
class Stop:
    """Why an effect search stopped: a kind of :data:`STOP_SENTENCES` and the figures its sentence
    names.

    Attributes
    ----------
    kind : str
        A key of :data:`STOP_SENTENCES`.
    figures : dict
        The values its sentence is filled with (names as in the sentence).
    """

    kind: str
    figures: dict[str, Any] = field(default_factory=dict)

    def sentence(self) -> str:
        """The stop reason in words."""
        return STOP_SENTENCES[self.kind].format(**self.figures)


def final_gap_sentence(
    gap: float, region_gap: float, region: Region, floor: float, missing_factor: float, unit: str
) -> str:
    """The final gap against the noise floor, and where it concentrates when far above.

    Parameters
    ----------
    gap : float
        The final model's overall free-run gap [unit].
    region_gap : float
        Its gap in ``region`` [unit].
    region : Region
        Where the final model's torque-balance residual concentrates.
    floor : float
        The noise floor σ_w [unit].
    missing_factor : float
        Gap, in noise floors, above which something is still missing.
    unit : str
        The velocity's unit.
    """
    ratio = gap / floor if floor > 0 else (0.0 if gap == 0 else math.inf)
    figures = {"gap": gap, "ratio": ratio, "floor": floor, "v": unit}
    if ratio <= missing_factor:
        return Stop("final_at_floor", figures).sentence()
    return Stop(
        "final_missing", {**figures, "where": region.description, "region_gap": region_gap}
    ).sentence()


__all__ = [
    "INERTIA_SHARE_LIMIT",
    "MISSING_FACTOR",
    "RELATIVE_STD_LIMIT",
    "STOP_SENTENCES",
    "CandidateEvidence",
    "Diagnosis",
    "Evidence",
    "Gap",
    "Lookalike",
    "NoiseBand",
    "PositionError",
    "RecordGap",
    "RecordSummary",
    "Rejected",
    "RestSummary",
    "Settings",
    "Step",
    "Stop",
    "Structure",
    "StructureCandidate",
    "final_gap_sentence",
    "record_summaries",
    "rest_summaries",
]
