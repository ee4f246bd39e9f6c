"""Find the missing effect: where a model and a measurement disagree, which effect is
missing, and how much better the model is once it is added.

The workflow (:func:`diagnose`):

0. **Structure**: choose the input delay and lag of the drive from the record
   (:func:`choose_structure`), held fixed in every later fit; once the effects are
   found, the delay is read again on the final model's free run, and a delay the
   base hid is taken there (:meth:`~motorid.diagnose.search.Search.final_delay`).
1. **Fit** the current rigid model (inertia, input gain, the ``base`` effects) to
   the torque balance of the record (:mod:`.model`), simulate it free-run on the
   measured input and compare with the measured velocity. Gaps: the RMS of
   ``w_meas - w_sim`` overall and in the located region [v], and the force
   error ``100 ||F_in - F_model|| / ||F_in||`` [%] on the decimated samples
   (the EMPS figure of merit). The measured velocity is the zero-phase
   low-passed one (for position records: the velocity derived from position).
2. **Locate** where the torque-balance residual concentrates (:mod:`.locate`).
3. **Name**: fit each candidate effect added to the current model and rank by
   the evidence

       ΔBIC = N_eff ln(RSS_0 / RSS_1) - Δk ln N_eff,
       N_eff = N (1 - ρ) / (1 + ρ)

   on the decimated moving samples (N of them, RSS the residual sum of squares
   without and with the candidate, Δk the parameters it adds, ρ the lag-one
   autocorrelation of the candidate's residual, so coloured residuals count
   as fewer independent samples). Candidates with ΔBIC above ``threshold``
   pass. Static friction acts on a resting drive only, which the balance of the
   moving samples cannot see: its level is fitted to the free run
   (:func:`fit_static_friction`), and its ΔBIC, held-out error and gap are those of
   the free-run output (RSS of measured minus free-run velocity, the held-out
   blocks at full rate). Candidates that explain the torque balance alike (each removes at
   least 80 % of what the best removes, as Coulomb friction and an input dead
   zone do) are re-simulated free-run and the smallest output gap decides.
4. **Add** a passing candidate only if (a) fitted on the training blocks it
   lowers the torque-balance RMS error on held-out blocks (or on a second
   record) by at least ``min_holdout_gain`` over every held-out row or, for an effect that
   acts in one place, over the held-out rows in its speed band (fewer than a quarter of them)
   without raising every row's (:meth:`~motorid.diagnose.search.Search.held_balance`) and (b)
   refitted on everything, its
   free-run output gap is at least ``min_gap_shrink`` smaller and (c) for a
   second or later step, it accounts for more than ``noise_explained`` times
   the record's noise floor σ_w of the gap, ``sqrt(g0² - g1²) > noise_explained σ_w``
   (:func:`~motorid.diagnose.search.explained`; below); then refit and repeat until no
   candidate passes, all are in the model or ``max_steps`` is reached.
   :attr:`Diagnosis.stop_reason` says which, and how far the final gap is from
   the noise floor.

   **Lookalikes**: effects that are forms of one physics
   (:meth:`Effect.physics <motorid.drive.effects.base.Effect.physics>`: Coulomb
   friction, an input dead zone and, in a model without either, a Stribeck decay
   are kinetic friction; beside a kinetic level, Stribeck and static friction are
   breakaway friction) fit alike when both pass the evidence threshold and their
   free-run gaps lie within :data:`~motorid.diagnose.search.ALIKE_GAP` (half a) noise floor of each other: the data
   cannot tell them apart (a drive that never reverses while moving is held back
   alike by Coulomb friction and a dead zone). **The rule**: of effects that fit
   alike, the first in the library's order
   (:func:`motorid.drive.effects.names`: ``coulomb_friction``,
   ``stribeck_friction``, ..., ``input_dead_zone``, ..., ``static_friction``) is
   named, whichever the evidence ranked first, so one physics gets one name on
   every record of a motor; the step reports the others beside it with their
   levels and free-run gaps (:class:`Lookalike`). It prefers the effect the
   balance of the moving drive measures (a Coulomb or Stribeck level, with a
   standard error) over one that only a dead zone's input path or the free run
   at rest sees.
   **Position records**: a candidate must also lower, by ``min_holdout_gain``, the free-run
   position error on held-out halves of the records (each half predicted in position by the
   model fitted to the other halves: :func:`~motorid.diagnose.position.held_out_position_error`).
   A position integrates the force error twice, and an effect that lowers the balance's
   residual but predicts a held-out half's position worse is not named. The final model's
   parameters are then fitted to the records' free-run position
   (:func:`~motorid.diagnose.position.refit_records_in_position`) and reported beside it
   (:attr:`Diagnosis.position_model`, both position errors).
5. **Show**: the gaps before and after each step (:meth:`Diagnosis.table`) and
   figures (:meth:`Diagnosis.write_figures`). Several records: each record's gaps, and
   whether the records agree on each parameter the joint run determines, each fitted alone
   with the joint model's structure (:mod:`.agreement`, :attr:`Diagnosis.agreement`).

The stages, in their modules: :mod:`.prepare` (the records made ready and pooled, the held-out
blocks), :mod:`.measures` (gaps, the balance residual, the evidence, breakaway at the rests),
:mod:`.search` (the structure, then the effects: each one tried a
:class:`~motorid.diagnose.search.Candidate`, each check a
:class:`~motorid.diagnose.search.Decision`) and :mod:`motorid.diagnose.results` (:class:`Diagnosis`, and every
sentence of a stop reason: :data:`~motorid.diagnose.results.STOP_SENTENCES`). :func:`diagnose`
calls them in that order.

The noise floor σ_w [v] is the standard deviation of the measurement noise left
on the low-passed measured velocity the free run is compared with
(:attr:`Kinematics.noise <motorid.diagnose.kinematics.Kinematics.noise>`, from
the high-frequency part of the measured output): a model that reproduces the
drive exactly still leaves a free-run gap of about σ_w. A second effect must
therefore account for a clear multiple of σ_w, not only pass the held-out
blocks (an effect that moves a gap of 1.5 σ_w by 0.05 σ_w fits noise). What it accounts for
is ``sqrt(g0² - g1²)``, its own error beside whatever else the model misses (errors that add in
quadrature), not the shrink ``g0 - g1``: the shrink of one effect falls as the rest of the gap
grows, so a drive's viscous asymmetry that accounts for 2.8-3.9 σ_w on each of the kit motor's
six records shrank the gaps of its sines (at 5 σ_w) by 0.8-1.2 σ_w and of its chirps (at
9.7 σ_w, more missing there) by 0.4 σ_w only, and was named on four records of six. A gap
already within ``noise_explained`` σ_w of the floor ends the search (no effect can account
for more than all of it). A final gap
above ``missing_factor`` σ_w says that something is still missing, and where
the torque-balance residual of the final model concentrates.

**Where an effect acts.** An encoder's speed noise grows with speed, so one record-wide σ_w is
too high near rest and too low at speed. An effect that acts in one place
(:attr:`Effect.acts <motorid.drive.effects.base.Effect.acts>`) is judged there: its free-run gap
where it acts (static friction: the rests and breakaways; Stribeck friction: below a tenth of the
largest speed; quadratic drag: above 0.6 of it) must shrink by ``min_gap_shrink``, and the part
of it the effect accounts for exceed ``noise_explained`` times the noise floor of that speed band (:meth:`Pool.band_floor <motorid.diagnose.prepare.Pool.band_floor>`), and a search
whose gap is already at the record-wide floor still tries them.

**Static friction** is measured where it shows: at the rests of the record
(:mod:`.rests`: each rest's length and the input it breaks away at). The force at breakaway
above the model's kinetic level, fitted against the input's rate there (:class:`~motorid.diagnose.measures.Breakaway`: a
lag between input and force raises the input at breakaway as the input rises faster, stiction
does not), is its level ΔF_s; its ΔBIC is that of the rests (:func:`~motorid.diagnose.measures.breakaway_evidence`), its
held-out check rest by rest: each fold of rests predicted from the others
(:func:`~motorid.diagnose.measures.breakaway_cross_check`; the search's held-out blocks may hold
none of them), or a second record's rests. A record with fewer
than :data:`~motorid.diagnose.measures.MIN_RESTS` rests read (or rests that read it below the kinetic level) fits it
to the free run instead (:func:`fit_static_friction`) and holds it out rest by rest
(:func:`~motorid.diagnose.measures.static_friction_cross_check`), judged at the rests. The final model reads its level
again against its own kinetic level, and takes the step back where the free run comes no closer with it
(:meth:`~motorid.diagnose.search.Search.final_static_friction`).

A model given with a friction effect of its own (``model=``) stands where a step would have put
it: what comes next is judged by the rules of a second step, so a run from a saved model with
Coulomb friction names what a run from the default base names after Coulomb friction.

The default ``threshold`` was calibrated on records with no hidden effect, and
``noise_explained`` and ``missing_factor`` on records with one, also with an encoder's speed; see
:mod:`motorid.diagnose.calibration` for the measured false-alarm rates.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Sequence
from typing import Any, Literal, NamedTuple

import numpy as np
import pandas as pd

from motorid.diagnose.agreement import agreement
from motorid.diagnose.closed_loop import instrumental_kept, instrumental_refit, kinetic_split, loop_records
from motorid.diagnose.given_rig import GivenRig, rig_note
from motorid.diagnose.locate import Region, locate
from motorid.diagnose.measures import fit_static_friction, free_run_error, gaps
from motorid.diagnose.model import FitResult, fit_model
from motorid.diagnose.position import position_unit, refit_records_in_position
from motorid.diagnose.prepare import (
    ONE_STEP_BELOW,
    Pool,
    Prepared,
    common_timing,
    held_out,
    normalised_records,
    one_step_noise_pool,
    pool_records,
    prepare,
    sampled_slowly,
)
from motorid.diagnose.results import (
    INERTIA_SHARE_LIMIT,
    MISSING_FACTOR,
    Diagnosis,
    Lookalike,
    PositionError,
    Settings,
    Step,
    Structure,
    final_gap_sentence,
    record_summaries,
    rest_summaries,
    slow_sampling_note,
)
from motorid.diagnose.search import (
    ALIKE_GAP,
    DEFAULT_BASE,
    DEFAULT_THRESHOLD,
    NOISE_EXPLAINED,
    STRUCTURES,
    Search,
    SearchOutcome,
    addable,
    candidate_names,
    choose_structure,
    effect_names,
    explained,
    friction_given,
    keep_given,
)
from motorid.diagnose.timing import DelayDrift, delay_drift
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import TwoMassRig
from motorid.errors import DataError
from motorid.io.records import RecordOptions

logger = logging.getLogger(__name__)

#: Passes of ``align`` at most: the records aligned, diagnosed again, and the drift they still
#: show compounded in (:meth:`DelayDrift.compounded <motorid.diagnose.timing.DelayDrift.compounded>`) ...
ALIGN_PASSES = 4
#: ... until it moves their delay by less than this many samples over the record. The drift
#: measured against a model fitted to the drifting record is off by what that model's inertia
#: took of the delay (1.34 times the truth on ``bench("drifting_delay", "static_friction", 2)``, a
#: 10 ms chirp; 1.18 on ``("input_dead_zone", 1)``, two sines at 2 ms); the aligned record's model
#: is the drive's own, and the second pass brings the drift within 1 % of the truth. A tenth of a
#: sample: on ``("none", 2)`` the first pass left 0.24 samples over its 30 s and a final gap of
#: 3.2 noise floors, the next 0.05 samples and 1.6 floors (the same drive logged without a drift:
#: 1.15).
ALIGN_SAMPLES = 0.1
#: The share of the drift left that an aligned record's model shows, where two passes measure
#: one (:func:`next_rate`): 0.44 and 0.5 on ``bench("drifting_delay", None, 4)``; outside these
#: bounds it is taken as 1.
ALIGN_SHARE = (0.25, 2.0)


def diagnose(
    record: pd.DataFrame | Sequence[pd.DataFrame],
    output_kind: Literal["velocity", "position"] = "velocity",
    input_gain: float | None = None,
    base: Sequence[str] | str | None = None,
    candidates: Sequence[str] | str | None = None,
    holdout: float | pd.DataFrame = 0.3,
    max_steps: int = 3,
    progress: bool = False,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    min_holdout_gain: float = 0.01,
    min_gap_shrink: float = 0.01,
    noise_explained: float = NOISE_EXPLAINED,
    missing_factor: float = MISSING_FACTOR,
    timing: Literal["hold", "sampled", "auto"] | None = None,
    band: float | None = None,
    model: RigidDrive | TwoMassRig | None = None,
    structure: bool = True,
    labels: Sequence[str] | None = None,
    align: bool = False,
    reference_column: str | None = None,
    record_options: RecordOptions | None = None,
    as_read: bool = False,
    **record_fields: Any,
) -> Diagnosis:
    """Find the effects missing from a rigid drive model of ``record`` (see the module notes).

    Parameters
    ----------
    record : pandas.DataFrame or sequence of DataFrame
        The measurement, as the user's own code holds it: the columns and units
        are named by ``record_options``, the same as the command line's, and
        brought to motorid's by :func:`motorid.io.records.normalise_record`;
        ``attrs["dt"]`` is used when ``dt`` is None. Several records of one
        drive (at one sample time, read with the same options) are fitted as one model
        (:class:`Pool`): shared parameters, each record its own initial state and time origin;
        each candidate is judged on the pooled evidence, and :attr:`Diagnosis.records` holds
        the gaps of each record.
    output_kind : {"velocity", "position"}
        What the output is. Position records are differentiated (zero-phase
        low-pass and central differences); their output gap is then measured
        on the velocity derived from position, since a free-run position drifts.
    input_gain : float, optional
        Force or torque per input unit g [N/V or N m/V], > 0, so the model's
        parameters come out in N or N m. Without it (None) the fit takes g = 1
        and forces are per input unit: a Coulomb level of 0.8 is 0.8 V when the
        input is in V (the torque balance fixes them only up to this scale).
        :attr:`Diagnosis.units` states which.
    base : sequence of str or comma-separated str, optional
        Effects already in the model (inertia and input gain always are); default
        :data:`DEFAULT_BASE`, or the effects of ``model``.
    candidates : sequence of str, optional
        Effects to try; default every effect of the library not in ``base`` but those tried on
        request only (``cogging``: name it here).
    holdout : float or DataFrame
        Share of the record held out (in 10 interleaved blocks), in (0, 0.9),
        or a second record for the held-out check.
    max_steps : int
        Most effects added, >= 0.
    progress : bool
        Show a progress bar on stderr (:func:`motorid.progress.progress_bar`).
    threshold : float
        ΔBIC a candidate needs to pass.
    min_holdout_gain, min_gap_shrink : float
        Smallest relative improvement of the held-out torque-balance error and
        of the free-run output gap for a candidate to be accepted.
    noise_explained : float
        Smallest free-run error a second or later step accounts for, in noise floors, >= 0
        (:func:`~motorid.diagnose.search.explained`).
    missing_factor : float
        Final gap, in noise floors, above which :attr:`Diagnosis.stop_reason` says
        that something is still missing, > 0.
    timing : {"hold", "sampled", "auto"}, optional
        Input/output timing (:func:`prepare`); ``auto`` takes the one whose
        base model fits the torque balance better (a base model that lacks an
        effect can mislead it). By default the record's ``attrs["timing"]``
        (:func:`motorid.datasets.load_emps` sets ``"sampled"``: the controller
        reads the position, then holds its output), else ``"hold"``, the
        motorid convention of :mod:`motorid.drive`.
    band : float, optional
        Useful band [Hz] (:mod:`.kinematics`).
    model : RigidDrive or TwoMassRig, optional
        The user's own model of the drive. The initial gap is then this model, as
        given, against the measurement ("where does my simulation disagree"); the
        workflow refits its effects (every parameter free; its Stribeck shape kept),
        then names, adds and refits as without it. Its input gain is the force scale
        unless ``input_gain`` is given; its effects are the base (give no ``base``).
        A two-mass rig (:class:`~motorid.drive.two_mass.TwoMassRig`, its input the command [V],
        its output the load speed [rad/s]): the initial gap is the rig's own simulation, noise
        free, from rest; the search runs on its rigid equivalent
        (:meth:`~motorid.drive.two_mass.TwoMassRig.rigid_equivalent`: a record rarely shows the
        shaft mode, a note says where it lies against the record's band) and
        :attr:`Diagnosis.improved_model` hands the result back to the rig.
    structure : bool
        Choose the input delay and lag from the record before any other effect is
        judged (:func:`choose_structure`; skipped when the base already holds one);
        the chosen values are held in every later fit (on a closed loop, checked by a run
        without them: :func:`loop_structure`). False: the base as given.
    labels : sequence of str, optional
        A name for each record in the report (e.g. its file); default ``record 1``, ``record 2``...
    align : bool
        Where a record's input delay drifts along it (a logger's time base:
        :func:`~motorid.diagnose.timing.delay_drift`, said in :attr:`Diagnosis.notes` either way),
        put its input on its output's time and diagnose again (:func:`aligned_record`: each
        output sample as logged, with the input the drive had over its span on the input's time,
        the line ``d(t) = d_0 + r t`` through the segments' delays taken out), so the drift goes
        and the delay at the record's start stays for the structure search to take; the drift's
        line is then reported from that delay (:meth:`DelayDrift.starting_at
        <motorid.diagnose.timing.DelayDrift.starting_at>`). The report says what was moved. Where the
        aligned records fit no better (their final gap in noise floors not below the record's own,
        or no drive model describes them), the diagnosis on the record's own time is kept and a
        note says so.
    reference_column : str, optional
        The column of a closed loop's reference; default a column named ``reference`` or ``r``.
        A record with one is identified as a closed loop (:mod:`.closed_loop`): read with the
        timing its feedback shows where it names none
        (:func:`~motorid.diagnose.closed_loop.loop_timing`), the balance's linear parameters
        refitted with the reference as instrument, a delay or lag of the structure search kept
        only where it accounts for a noise floor of the final gap (:func:`loop_structure`), and
        :attr:`Diagnosis.closed_loop` says so.
    record_options : RecordOptions, optional
        How the records are read (:class:`motorid.io.records.RecordOptions`): the time, input
        and output columns (any text; default ``t``, ``u``, ``y``, the time column not needed
        when ``dt`` is known), the sample time ``dt`` [s] (default from ``attrs["dt"]`` or
        the time column), the units, the span.
    **record_fields :
        Fields of :class:`~motorid.io.records.RecordOptions` given one by one, in place of those
        of ``record_options``: ``diagnose(df, input="pwm", output="rpm", input_unit="%",
        output_unit="rpm")``.
    as_read : bool
        The records (and a holdout DataFrame) are motorid records already, as
        :func:`~motorid.io.records.read_record` or :func:`~motorid.io.records.normalise_record`
        give them (``t`` [s], ``u``, ``y`` in motorid's units, ``attrs["dt"]``): taken as they are,
        not read again; ``record_options`` and its fields then do not apply.

    Returns
    -------
    Diagnosis
    """
    from motorid.io.records import normalise_record
    from motorid.progress import progress_bar

    # the arguments, checked before any record is read
    given = RecordOptions.of(record_options, **record_fields)
    time, dt = given.time, given.dt
    columns = {"time": time, "input": given.input or "u", "output": given.output or "y"}
    reading = given.normalising()
    if as_read and given != RecordOptions():
        raise DataError("record_options: records as_read are not read again; give either")
    holdout_given = holdout  # for a closed loop's run without the structure
    if isinstance(holdout, pd.DataFrame) and not as_read:
        holdout = normalise_record(holdout, **columns, **reading)
    input, output = "u", "y"
    rig = model if isinstance(model, TwoMassRig) else None
    if rig is not None:
        # the search runs on the rig's rigid equivalent; its free run stays the rig's own
        try:
            model = GivenRig.of(rig)
        except ValueError as exc:
            raise DataError(f"model: {exc}") from None
    if model is not None and not isinstance(model, RigidDrive):
        raise DataError(f"model must be a RigidDrive or a TwoMassRig, got {type(model).__name__}")
    if model is not None and base is not None:
        raise DataError("base: give either base effects or a model (its effects are the base), not both")
    if model is not None:
        base_names = model.effects
        if input_gain is None:
            input_gain = model.input_gain
    else:
        base_names = effect_names(DEFAULT_BASE if base is None else base, "base")
    stribeck_shape = "exponential" if model is None else model.stribeck_shape
    cand_names = candidate_names(base_names, candidates, output_kind)
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps < 0:
        raise DataError(f"max_steps must be an integer >= 0, got {max_steps!r}")
    if not isinstance(holdout, pd.DataFrame):
        if isinstance(holdout, bool) or not isinstance(holdout, int | float) or not 0.0 < holdout < 0.9:
            raise DataError(f"holdout must be a fraction in (0, 0.9) or a DataFrame, got {holdout!r}")
    records = [record] if isinstance(record, pd.DataFrame) else record
    if isinstance(records, str) or not isinstance(records, Sequence) or not records:
        raise DataError(
            f"record must be a pandas DataFrame or a non-empty sequence of them, got {type(record).__name__}"
        )
    labels = [f"record {k + 1}" for k in range(len(records))] if labels is None else [str(x) for x in labels]
    if len(labels) != len(records):
        raise DataError(f"labels: {len(labels)} labels for {len(records)} records")
    given_records = list(records)
    timing_given = timing
    records = list(given_records) if as_read else normalised_records(given_records, labels, columns, reading)
    # a closed loop's reference, kept (the pool lets the records go), and its timing; a corrupt cell
    # (1e300) overflows the loop's regressions before the record's checks name it (in prepare)
    with np.errstate(over="ignore", invalid="ignore"):
        records, loops, references = loop_records(
            given_records, records, labels, reference_column, timing, output_kind
        )
    # a closed loop's records as given, for its run without the structure (below)
    loop_given = given_records if structure and any(loop.closed for loop in loops) else None
    del given_records
    if timing is None:
        timing = common_timing(records, labels)  # type: ignore[assignment]
    if timing not in ("auto", "hold", "sampled"):
        raise DataError(f"timing must be 'auto', 'hold' or 'sampled', got {timing!r}")
    if not isinstance(structure, bool):
        raise DataError(f"structure must be True or False, got {structure!r}")
    if not isinstance(align, bool):
        raise DataError(f"align must be True or False, got {align!r}")
    normalised = list(records) if align else []  # the records as read, for a second run on their time
    if not math.isfinite(threshold):
        raise DataError(f"threshold must be finite, got {threshold!r}")
    if not (
        isinstance(noise_explained, int | float) and math.isfinite(noise_explained) and noise_explained >= 0
    ):
        raise DataError(
            f"noise_explained must be a finite number >= 0 (noise floors), got {noise_explained!r}"
        )
    if not (isinstance(missing_factor, int | float) and math.isfinite(missing_factor) and missing_factor > 0):
        raise DataError(f"missing_factor must be a finite number > 0 (noise floors), got {missing_factor!r}")

    # preparation: the records of one drive, and what a candidate is held out on
    opts = {"dt": dt, "input": input, "output": output, "output_kind": output_kind,
            "input_gain": input_gain, "band": band}  # fmt: skip
    pool = pool_records(records, labels, timing, opts, base_names, stribeck_shape)  # type: ignore[arg-type]
    first = pool.parts[0]
    settings = Settings(
        dt=first.kin.dt, input=columns["input"], output=columns["output"], output_kind=output_kind,
        input_gain=input_gain, band=first.kin.band,
        reading={"time": time, **{k: v for k, v in reading.items() if k != "dt"}},
        timing=first.timing, base=tuple(base_names), candidates=tuple(cand_names), threshold=threshold,
        noise_explained=noise_explained, missing_factor=missing_factor,
        holdout="record" if isinstance(holdout, pd.DataFrame) else holdout,
        max_steps=int(max_steps), model="given" if model is not None else "fitted",
        stribeck_shape=stribeck_shape, structure=structure, records=tuple(labels) if len(labels) > 1 else (),
    )  # fmt: skip

    # stages: the initial fit, each step, the final gaps (after the checks: an error shows no bar)
    bar = progress_bar(show=progress, total=max_steps + 2, desc="doctor", unit="stage")

    def searched(pool: Pool) -> Searched:
        """The search on ``pool``: the initial fit, the base structure, the effects."""
        search = Search(
            pool, held_out(pool, holdout, opts), stribeck_shape, threshold, min_holdout_gain, min_gap_shrink,
            noise_explained, friction_given(base_names), progress,
        )  # fmt: skip
        bar.set_postfix_str(f"initial fit on {pool.data.n} decimated samples")
        fit0 = search.fit_base(tuple(base_names), model)
        # the user's model as given (at the record's sample time), else the fitted base
        initial_model = fit0.model if model is None else model.replace(dt=pool.dt)
        first_region = locate(pool.balance_residual(initial_model)[0], pool.feats_dec, pool.units)
        chosen, fit, current, structure_model = search.base_structure(fit0, tuple(base_names), structure, bar)
        bar.update(1)
        outcome = search.run(fit, current, cand_names, first_region, bool(chosen.effects), max_steps, bar)
        if structure:
            outcome.fit, chosen = search.final_delay(outcome.fit, chosen)
        return Searched(search, fit0, initial_model, first_region, chosen, structure_model, outcome)

    def closest_models(run: Searched) -> list[RigidDrive]:
        """The model ``run`` found, then each candidate effect fitted beside it."""
        fit = run.outcome.fit
        ranking = run.search.rank(fit, fit.model.effects, addable(cand_names, fit.model.effects))
        return [fit.model, *(c.fit.model for c in ranking)]

    run = searched(pool)
    if output_kind == "velocity":
        # a record sampled slowly for its time constant: its noise measured by the one-step prediction of the
        # model found or a candidate beside it, and the search run again on it; once more where the model it
        # then finds predicts closer
        measured = pool
        for _ in range(2):
            if not sampled_slowly(pool, run.outcome.fit.model):
                break
            by_one_step = one_step_noise_pool(measured, closest_models(run))
            if by_one_step is measured or not by_one_step.noise < ONE_STEP_BELOW * pool.noise:
                break
            pool, first = by_one_step, by_one_step.parts[0]
            bar.reset(total=max_steps + 2)
            run = searched(pool)
    _, fit0, initial_model, first_region, chosen, structure_model, outcome = run
    refitted_model = fit0.model
    bar.total = bar.n + 1  # a diagnosis that stops early skips the steps it did not take

    # the results: the gaps before and after, and why the search stopped
    bar.set_postfix_str("final gaps")
    final_model = outcome.fit.model
    if any(r is not None for r in references):
        iv_model, refitted_iv = instrumental_refit(pool, final_model, references)
        kept = (
            instrumental_kept(pool, final_model, iv_model, first_region, ALIKE_GAP) if refitted_iv else None
        )
        if refitted_iv and kept is None:
            final_model = iv_model
        for loop in loops:
            loop.instrumental = refitted_iv if loop.reference is not None else {}
            loop.least_squares_kept = kept if loop.reference is not None else None
    if model is not None and outcome.steps:
        # the given model's own values stand where the records do not contradict them
        given_kept = keep_given(pool, model, final_model)
        final_model = given_kept.model
        outcome.notes.extend(given_kept.notes)
    final_model, held = levels_at_zero(pool, final_model, dict(chosen.params), stribeck_shape)
    outcome.notes.extend(held)
    final_model, level_std = run.search.final_static_friction(final_model, outcome)
    initial_gap = pool.gaps(initial_model, first_region)
    refitted_gap = None if model is None else pool.gaps(refitted_model, first_region)
    if outcome.steps or chosen.effects or final_model is not outcome.fit.model:
        final_gap = pool.gaps(final_model, first_region)
    else:
        final_gap = initial_gap if refitted_gap is None else refitted_gap
    # the standard errors of the parameters the instrumental fit gave, its own where it was taken; and no
    # delay set free by least squares in a loop's balance (:mod:`.closed_loop`: it would take the loop's
    # own correlation)
    instrumental = next((loop.instrumental for loop in loops if loop.instrumental), {})
    taken = next((loop.instrumental for loop in loops if loop.method == "instrumental variables"), {})
    param_std = {**outcome.fit.param_std, **{k: v["standard_error"] for k, v in taken.items()}}
    if math.isfinite(level_std):  # static friction's level, read on the rests or the free run
        param_std["breakaway_excess"] = level_std
    refuse_unphysical(final_model, final_gap.overall, pool.units)
    drifts = [d for d in delay_drift(pool, final_model) if d.drifts]
    final_region = locate(pool.balance_residual(final_model)[0], pool.feats_dec, pool.units)
    stop_reason = outcome.stop.sentence() + "; " + final_gap_sentence(
        final_gap.overall, pool.gaps(final_model, final_region).region, final_region, pool.noise,
        missing_factor, pool.units["v"],
    )  # fmt: skip
    position_model, position_error = None, None
    if output_kind == "position":
        position_model, fitted, refitted = refit_records_in_position(pool, final_model)
        position_error = PositionError(fitted, refitted, position_unit(pool.units["v"]))
    bar.update(1)
    bar.close()
    notes = [
        f"{label}: {note}" if len(labels) > 1 else note
        for label, prep in zip(labels, pool.parts, strict=True)
        for note in prep.notes
    ]
    notes += [f"{d.label}: {d.sentence()}" if len(labels) > 1 else d.sentence() for d in drifts]
    slow = slow_sampling_note(final_model, pool.dt)
    if slow:
        notes.append(slow)
    notes += outcome.notes
    if rig is not None:
        notes.append(rig_note(rig, pool.parts[0].kin.band))
    diagnosis = Diagnosis(
        initial_gap=initial_gap, final_gap=final_gap, steps=outcome.steps, stop_reason=stop_reason,
        stop=outcome.stop, noise_floor=pool.noise, final_region=final_region,
        model=final_model, initial_model=initial_model, region=first_region, units=pool.units,
        settings=settings, rejected=outcome.rejected, refitted_model=None if model is None else refitted_model,
        refitted_gap=refitted_gap, param_std=param_std, param_share=outcome.fit.param_share,
        delay_trade=None if instrumental else outcome.fit.delay_trade,
        structure=chosen, structure_model=structure_model,
        records=record_summaries(pool, initial_model, final_model, first_region), _pool=pool,
        noise_bands=pool.noise_bands(), quantisation_step=pool.quantisation,
        rests=rest_summaries(pool, final_model), notes=notes, rig=rig, position_model=position_model,
        position_error=position_error,
    )  # fmt: skip
    diagnosis.agreement = agreement(
        pool, final_model, diagnosis.param_std, set(diagnosis.undetermined), diagnosis.delay_trade
    )
    diagnosis.delay_drift = drifts
    diagnosis.closed_loop = [loop for loop in loops if loop.closed]
    split = kinetic_split(final_model, pool.units) if diagnosis.closed_loop else None
    if split is not None:
        diagnosis.notes.append(split)
    if loop_given is not None and diagnosis.structure.effects:
        # a closed loop's delay or lag stands only where it accounts for a noise floor of the final gap
        plain = diagnose(
            loop_given, output_kind=output_kind, input_gain=input_gain,
            base=None if model is not None else base_names, candidates=candidates, holdout=holdout_given,
            max_steps=max_steps, progress=False, threshold=threshold, min_holdout_gain=min_holdout_gain,
            min_gap_shrink=min_gap_shrink, noise_explained=noise_explained, missing_factor=missing_factor,
            timing=timing_given, band=band, model=rig if rig is not None else model, structure=False,
            labels=labels, align=False, reference_column=reference_column, record_options=given,
            as_read=as_read,
        )  # fmt: skip
        diagnosis = loop_structure(diagnosis, plain, noise_explained)
        structure = bool(diagnosis.structure.effects)  # a second run on the aligned records as this one
    if not (align and drifts):
        return diagnosis
    # the drift found: each drifting record's input put on its output's time, then again; the
    # drift the aligned records still show (against their own, better, model) taken in, until it
    # moves their delay by less than ALIGN_SAMPLES (see the constants' notes)
    taken = {d.label: d for d in drifts}
    tried: dict[str, tuple[float, float]] = {}  # each record's last rate and the drift left at it
    best: tuple[float, Diagnosis, dict[str, DelayDrift]] | None = None  # the pass that fits best
    for passes in range(1, ALIGN_PASSES + 1):
        aligned = [
            aligned_record(r, taken[label]) if label in taken else r
            for r, label in zip(normalised, labels, strict=True)
        ]
        try:
            again = diagnose(
                aligned, dt=first.kin.dt, output_kind=output_kind, input_gain=input_gain,
                base=None if model is not None else base_names, candidates=candidates, holdout=holdout,
                max_steps=max_steps, progress=progress, threshold=threshold,
                min_holdout_gain=min_holdout_gain, min_gap_shrink=min_gap_shrink,
                noise_explained=noise_explained, missing_factor=missing_factor, timing=first.timing, band=band,
                model=rig if rig is not None else model, structure=structure, labels=labels,
            )  # fmt: skip
        except DataError:
            break  # no drive model describes the aligned records
        floors = again.final_gap.overall / again.noise_floor
        if best is None or floors < best[0]:
            best = (floors, again, dict(taken))
        if passes == ALIGN_PASSES:
            break
        left = [
            d for d in delay_drift(again._pool, again.model)
            if d.label in taken and abs(d.rate) * (d.span[1] - d.span[0]) > ALIGN_SAMPLES * first.kin.dt
        ]  # fmt: skip
        if not left:
            break
        for d in left:
            rate = taken[d.label].rate
            taken[d.label] = taken[d.label].with_rate(next_rate(rate, d.rate, tried.get(d.label)))
            tried[d.label] = (rate, d.rate)
    own = diagnosis.final_gap.overall / pool.noise
    if best is None or best[0] >= own:
        # the drift said was no logger's (a segment's delay the input barely shows): the record as it is
        why = (
            "no drive model describes the aligned records"
            if best is None
            else f"its final gap {best[0]:.1f} noise floors"
        )
        diagnosis.notes.append(
            f"align: the input put on the output's time fits no better ({why}, against {own:.1f} on the "
            "record's own time): the record's own time kept"
        )
        return diagnosis
    _, again, taken = best
    # the delay left at the start is the aligned records' own: the drift's line starts there
    start = float(again.model.params.get("input_delay", 0.0))
    out = [taken[d.label].starting_at(start) for d in drifts]
    said = [
        f"{d.label + ': ' if len(labels) > 1 else ''}the input put on the output's time (align): the delay's "
        f"drift of {1e3 * d.rate:.3g} ms a second taken out, {1e3 * d.first:.3g} ms left at the start (the "
        f"structure search's), {1e3 * d.last:.3g} ms at the end"
        for d in out
    ]
    again.notes = [*diagnosis.notes, *said, *again.notes]
    again.delay_drift = out  # what was taken out
    return again


class Searched(NamedTuple):
    """One search of :func:`diagnose` on a pool: the search, its initial fit and the model as
    given or fitted, the region the first gap concentrates in, the base structure chosen (and its
    model, None where none is taken) and what the search of effects ended with."""

    search: Search
    fit0: FitResult
    initial_model: RigidDrive
    first_region: Region
    chosen: Structure
    structure_model: RigidDrive | None
    outcome: SearchOutcome


def loop_structure(searched: Diagnosis, plain: Diagnosis, noise_explained: float) -> Diagnosis:
    """A closed loop's diagnosis with the delay or lag the structure search took, or without it.

    The structure is chosen on the base model, before any effect: in a closed loop the
    controller's answer to the speed and an effect the base lacks (a dead zone the loop crosses
    at each reversal) can pass for an input delay or lag there, and the effects then found beside
    it come out wrong. **The rule**: on a closed loop the doctor is run again without the
    structure search, and the delay or lag stands only where it accounts for more than
    ``noise_explained`` noise floors of the final free-run gap (:func:`~motorid.diagnose.search.explained`,
    the structure search's own rule, here on the final models). Measured on the bank's
    closed-loop benches (:func:`motorid.diagnose.calibration.bank`, seeds 0-9): a dead zone
    behind a 5 ms lag or a 10 ms delay the base took, final gaps 12.6 and 13.1 noise floors and the
    dead zone 13 % and 27 % low; without them 0.96 floors and within 0.4 %.

    Parameters
    ----------
    searched : Diagnosis
        The run with the structure search, which took a delay or a lag.
    plain : Diagnosis
        The run without it (``structure=False``) on the same records.
    noise_explained : float
        The noise floors the structure must account for.
    """
    floor = searched.noise_floor
    part = explained(plain.final_gap.overall, searched.final_gap.overall, floor)
    if part > noise_explained:
        return searched
    taken = ", ".join(searched.structure.effects)
    plain.structure = dataclasses.replace(
        searched.structure, effects=(), params={},
        reason=(
            f"closed loop: the {taken} taken on the base "
            + (f"accounts for {part:.2f} noise floors of the final gap, not more than {noise_explained:g}"
               if part >= 0.0 else "makes the final gap larger")
            + f" (the final gap {searched.final_gap.overall / floor:.2f} noise floors with it, "
            f"{plain.final_gap.overall / floor:.2f} without): left out"
        ),
    )  # fmt: skip
    plain.notes.append(plain.structure.reason)
    return plain


def next_rate(rate: float, left: float, before: tuple[float, float] | None) -> float:
    """The drift rate to align a record with next [s/s], from the ``rate`` it was just aligned
    with and the drift ``left`` measured on that aligned record [s/s]; ``before``: the pair of
    the pass before, if any.

    The aligned record's model takes part of what is left into its own delay and inertia, so the
    drift measured left is a share c of what is: about half on a 1 ms chirp
    (``bench("drifting_delay", None, 4)``: 0.12 ms a second measured where 0.27 was left, then
    0.068 where 0.14 was). Two passes measure it, ``c = -(f - f_b) / (r - r_b)`` (f the drift left
    at the rate r, f_b at the rate before, r_b), and the next rate takes what is left in full,

        1 - r_next = (1 - r)(1 - f / c),

    (the aligned record's time runs ``1 - r`` as fast, so the two compound). A share outside
    :data:`ALIGN_SHARE` is two passes' noise, not the model's (``(None, 6)``: 0.021 and 0.018 ms a
    second left, c = 0.11, which would have stepped past the logger's rate by 2 %), and the first
    pass has none: c = 1.

    Parameters
    ----------
    rate : float
        The rate the record was aligned with [s/s].
    left : float
        The drift its aligned record still shows [s/s].
    before : tuple of float, optional
        The rate and the drift left of the pass before [s/s].
    """
    share = 1.0
    if before is not None and rate != before[0]:
        measured = -(left - before[1]) / (rate - before[0])
        if ALIGN_SHARE[0] <= measured <= ALIGN_SHARE[1]:
            share = measured
    return 1.0 - (1.0 - rate) * (1.0 - left / share)


def aligned_record(record: pd.DataFrame, drift: DelayDrift) -> pd.DataFrame:
    """``record`` with its input put on its output's time: the drift of its delay taken out, the
    delay at its first sample kept.

    A logger whose delay grows by r seconds a second (:attr:`DelayDrift.rate
    <motorid.diagnose.timing.DelayDrift.rate>`) read its output sample k at ``(1 - r) k dt`` on
    the input's time, plus the delay at the first sample. The aligned record keeps every output
    sample as logged (its noise, its quantisation and its sample time untouched) and gives it the
    input the drive had over ``[(1 - r) k dt, (1 - r)(k + 1) dt)``: the exact mean of the held
    input over that span,

        u'_k = (H((1 - r)(k + 1)) - H((1 - r) k)) / (1 - r),    H(x) = Σ_{j < ⌊x⌋} u_j + (x - ⌊x⌋) u_⌊x⌋

    (x in samples). Every column but ``t`` and the output ``y`` is on the input's time (the
    input, a closed loop's reference) and is moved alike. The drive's time then runs ``1 - r`` as
    fast as the record's: its time constants read longer by the share r (at most 0.3 % at the
    bank's 3 ms a second). Samples whose span runs past the input's last are left out (a delay
    that shrinks).

    Parameters
    ----------
    record : DataFrame
        A normalised record (columns ``t``, ``u``, ``y``, ``attrs["dt"]``).
    drift : DelayDrift
        Its delay along it.
    """
    n = len(record)
    edges = (1.0 - drift.rate) * np.arange(n + 1, dtype=float)  # each output sample's span [input samples]
    kept = int(np.searchsorted(edges, float(n), side="right")) - 1  # output samples whose span lies inside
    edges = edges[: kept + 1]
    whole = np.minimum(np.floor(edges).astype(np.int64), n - 1)
    part = edges - whole
    out = {"t": record["t"].to_numpy()[:kept]}
    for name in record.columns:
        if name in ("t", "y"):
            continue
        x = record[name].to_numpy(dtype=float)
        held = np.concatenate(([0.0], np.cumsum(x)))[whole] + part * x[whole]  # H at each edge
        out[name] = np.diff(held) / np.diff(edges)
    out["y"] = record["y"].to_numpy()[:kept]
    aligned = pd.DataFrame({name: out[name] for name in record.columns})
    aligned.attrs = dict(record.attrs)
    return aligned


def levels_at_zero(
    pool: Pool, model: RigidDrive, fixed: dict[str, float], stribeck_shape: str
) -> tuple[RigidDrive, list[str]]:
    """``model`` with every level that cannot be negative (:attr:`Effect.nonnegative
    <motorid.drive.effects.base.Effect.nonnegative>`) and was fitted below zero held at zero, and a
    note for each; the other parameters refitted to the torque balance without those effects.

    A level fitted below zero by more than two standard errors is no physical effect and is not
    taken (:func:`~motorid.diagnose.search.negative_levels`); one within its errors of zero is a
    drive without it that fitted a small level of either sign. The least-squares fit with the level
    held at its bound, zero, is the fit without its column (the balance is linear in the levels),
    so a model file holds no negative level. ``model`` itself where none is negative.

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The final model.
    fixed : dict
        Shape parameters held in the refit (the base structure's delay and lag).
    stribeck_shape : str
        The Stribeck shape of the refit.
    """
    below = [
        (e, p) for e in model.effects for p in get_effect(e).nonnegative if model.params.get(p, 0.0) < 0.0
    ]
    if not below:
        return model, []
    dropped = {e for e, _ in below}
    kept = tuple(e for e in model.effects if e not in dropped)
    refit = fit_model(pool.data, kept, start=model.params, stribeck_shape=stribeck_shape, fixed=fixed or None)
    params = {**model.params, **refit.model.params, **{p: 0.0 for _, p in below}}
    notes = [
        f"{p} = {model.params[p]:.3g} fitted below zero within its errors: held at 0 (the drive shows no "
        f"{e}), the other parameters refitted"
        for e, p in below
    ]
    return model.with_effects(model.effects, params), notes


def refuse_unphysical(model: RigidDrive, gap: float, units: dict[str, str]) -> None:
    """Refuse a record that no drive model describes: the fit's inertia is not positive, or the
    final model's free run does not stay finite. A report then holds no ``nan`` and a model file
    no negative inertia; the :class:`~motorid.errors.DataError` says what the record shows and
    what to do.

    Parameters
    ----------
    model : RigidDrive
        The final model.
    gap : float
        Its free-run gap [v].
    units : dict
        The pool's units (``v``, ``F``, ``u``).
    """
    inertia = float(model.params["inertia"])
    if inertia > 0.0 and math.isfinite(gap):
        return
    shown = (
        f"the fitted inertia is {inertia:.3g} {units['F']} s²/{units['v']}, not physical"
        if not inertia > 0.0
        else "the final model's free run does not stay finite"
    )
    raise DataError(
        f"no drive model describes this record: {shown}. The output does not follow the input as a "
        "driven mass does: check that the output is the speed (or with output_kind the position) of "
        "the drive the input drives, with the sign the input turns it, and that the input is the "
        "command averaged over whole PWM periods"
    )


#: The doctor's names, importable from here as from their stages (:mod:`.prepare`,
#: :mod:`.measures`, :mod:`.search`, :mod:`.results`).
__all__ = [
    "DEFAULT_BASE",
    "DEFAULT_THRESHOLD",
    "INERTIA_SHARE_LIMIT",
    "MISSING_FACTOR",
    "NOISE_EXPLAINED",
    "STRUCTURES",
    "Diagnosis",
    "Lookalike",
    "Pool",
    "Prepared",
    "Step",
    "Structure",
    "choose_structure",
    "diagnose",
    "fit_static_friction",
    "free_run_error",
    "gaps",
    "prepare",
]
