"""Closed-loop records: a drive measured while a controller computed its input from its output.

A closed loop changes three things the doctor otherwise takes for granted:

- **Timing.** A controller reads the speed, then commands: ``y[k]`` is measured at ``t[k]`` and
  ``u[k]`` held over ``[t[k], t[k] + dt)`` (``timing="sampled"``, :data:`motorid.io.records.TIMINGS`).
  Read with the open loop's ``"hold"`` timing, every command seems to act one sample late, and the
  delay search takes that sample, and the loop's own correlation around it, for an input delay
  (55 ms on ``motorid control``'s 40 ms loop). A loop that commands, then reads the speed at the end
  of the sample (``y[k]`` the speed at ``t[k] + dt``, the open loop's ``"hold"`` timing) is the other
  way round: read as ``"sampled"``, the speed answers each command a sample early, which no delay
  mends (the bank's closed-loop benches logged that way: final gaps of 3-20 noise floors, against
  1.4 read as ``"hold"``). The input's answer to the output's noise tells the two apart
  (:attr:`Feedback.lag`: the controller's command follows the speed it read in the same row, lag 0,
  or in the next, lag 1). **The rule**: a record recognised as closed loop (or whose input looks like
  a controller's: below) whose attributes name no timing is read with the timing its feedback lag
  shows (:func:`loop_timing`: ``"hold"`` for lag 1, else ``"sampled"``), and the report says so.
  Measured on 20 closed-loop benches (seeds 0-3, each effect) logged both ways: lag 1 on all 20 logged
  with ``"hold"`` timing, lag 0 on all 20 logged with ``"sampled"``, the correlation -0.60 to -0.86
  either way. And where the balance is refitted by instrumental
  variables (below), no delay is set free in it by least squares
  (:attr:`~motorid.diagnose.results.Diagnosis.delay_trade` is None): on ``motorid control``'s loop
  that fit took the loop's correlation for a 14.6 ms delay the structure search had rejected, and
  called the inertia undetermined for it. A delay or lag the structure search takes on a loop's
  base stands only where it accounts for a noise floor of the final gap
  (:func:`motorid.diagnose.workflow.loop_structure`).
- **Noise fed back.** The input holds the controller's answer to the measured speed's noise, so
  the input and the noise on the regressors of the torque balance (the filtered speed and its
  derivative) are correlated, and least squares is biased. With the loop's reference ``r`` (a
  signal the noise never reaches) the linear part of the balance is refitted by instrumental
  variables (:func:`instrumental_refit`)::

      F_in,d = X θ + e,        X = [a_d, c_1(w_d), ..., c_m(w_d)]      (the balance's columns)
      Z = [a_r,d, c_1(r_d), ..., c_m(r_d)]                              (the same at the reference)
      θ_IV = (Zᵀ X)⁻¹ Zᵀ F_in,d
      cov θ_IV = σ² (Zᵀ X)⁻¹ Zᵀ Z (Xᵀ Z)⁻¹,    σ² = ||F_in,d - X θ_IV||² / (M - k)

  on the M decimated moving rows, ``r`` filtered, differentiated and decimated as the speed is
  (:func:`~motorid.diagnose.kinematics.kinematics`), the shape parameters (a Stribeck velocity, a
  dead zone, a delay) held at the search's values. The instruments are correlated with the
  regressors (the loop makes the speed follow the reference) and not with the noise, so θ_IV is
  consistent where least squares is not. It is taken unless its free run lies clearly further
  from the record than least squares' (:func:`instrumental_kept`).
- **What the record can tell.** A loop that keeps the input beyond the dead zone whenever the
  drive moves (a compensation that jumps across it at each reversal) leaves Coulomb friction and
  the dead zone one kinetic level: the doctor then names one and reports the other as its
  lookalike (:class:`~motorid.diagnose.results.Lookalike`), with their common level. Where it names
  both (a PI alone winds through the dead zone at each reversal), their split rests on the few
  samples where the command crosses it, and a note gives their sum (:func:`kinetic_split`).

A record is recognised as closed loop by its reference column (named ``reference`` or ``r``, as
``motorid control --out`` writes it, or given: ``reference_column``). A record without one whose
input answers its output's noise as a controller does (:func:`input_feedback`: the input's
innovation correlated negatively with the output's, beyond what an open loop's plant gives) is
said to look closed: it is read with the loop's timing and fitted by least squares, and the
sentence asks for its reference. Closed loops are recognised on speed records only (a position
loop's reference, EMPS's, is a position).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from motorid.diagnose.kinematics import kinematics
from motorid.diagnose.locate import Region
from motorid.diagnose.model import model_balance, model_key
from motorid.diagnose.prepare import Pool
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive
from motorid.errors import DataError

logger = logging.getLogger(__name__)

#: Column names a closed loop's reference goes by (``motorid control --out`` writes ``reference``).
REFERENCE_COLUMNS = ("reference", "r")
#: Order of the autoregressions whose residuals are the input's and the output's innovations
#: (:func:`input_feedback`).
FEEDBACK_LAGS = 8
#: Correlation of the innovations below which a record without a reference is said to look closed
#: [-] (with :data:`FEEDBACK_Z`), measured by :func:`input_feedback` (reversals left out, the output's
#: innovation net of the plant's answer): -0.46 to -0.92 on 45 closed loops (``motorid control``'s
#: four: compensated from the reference with and without a dead zone, from the measured speed, the
#: PI alone; the tests' PI loop; 40 closed-loop benches of :mod:`motorid.diagnose.bench`, 8 seeds,
#: 21 of them compensated); -0.17 to 0 on 137 open loops (the simulated rig's two-sine record, the
#: 15 records of ``realmotors`` read as they are, 21 planted records of
#: :mod:`motorid.diagnose.synthetic`, 100 benches: two seeds per open-loop imperfection and effect).
FEEDBACK_CORRELATION = -0.3
#: Standard errors of a correlation of nothing (1/sqrt(M)) the correlation must lie beyond.
FEEDBACK_Z = 5.0
#: Samples left out on each side of a reversal of the measured speed (and the autoregressions'
#: order after it) by :func:`input_feedback` [samples]: a friction compensation switches there.
#: With 6 or 8 every closed loop of :data:`FEEDBACK_CORRELATION`'s list lies below -0.44 and every
#: open loop above -0.17; 4 leaves a compensated bench's chirp at 10 ms at -0.18, 10 and more leave
#: too few samples of ``motorid control``'s short loops (300 samples, 6 reversals) to pass
#: :data:`FEEDBACK_Z`.
REVERSAL_GUARD = 6
#: Most samples (the first) :func:`input_feedback` looks at: a loop shows in far fewer, and the
#: autoregressions' columns of a day at 1 kHz would take gigabytes.
FEEDBACK_SAMPLES = 100_000


def reference_column(record: pd.DataFrame, given: str | None = None) -> str | None:
    """The column of ``record`` that holds a closed loop's reference: ``given`` (a DataError naming
    it where the record has no such column), else the first of :data:`REFERENCE_COLUMNS` it holds,
    else None.

    Parameters
    ----------
    record : DataFrame
        A record.
    given : str, optional
        The column named by the user (``reference_column``, ``--reference-column``).
    """
    if given is not None:
        if given not in record.columns:
            raise DataError(
                f"reference_column={given!r}: the record has no such column (it has "
                f"{', '.join(map(str, record.columns))})"
            )
        return given
    return next((c for c in REFERENCE_COLUMNS if c in record.columns), None)


@dataclass(frozen=True)
class Feedback:
    """How the input answers its output's noise (:func:`input_feedback`).

    Attributes
    ----------
    correlation : float
        The most negative correlation of the input's innovation with the output's (net of the
        plant's answer to the input) one sample before or at the same sample, on the samples away
        from the speed's reversals [-].
    lag : int
        Its lag [samples]: the input's innovation ``lag`` samples after the output's.
    samples : int
        M, the innovations correlated.
    """

    correlation: float
    lag: int
    samples: int

    @property
    def looks_closed(self) -> bool:
        """A correlation below :data:`FEEDBACK_CORRELATION` and :data:`FEEDBACK_Z` standard errors."""
        return (
            self.correlation < FEEDBACK_CORRELATION
            and -self.correlation * math.sqrt(self.samples) > FEEDBACK_Z
        )


def innovation(
    x: np.ndarray,
    order: int = FEEDBACK_LAGS,
    exogenous: np.ndarray | None = None,
    current: bool = False,
    kept: np.ndarray | None = None,
) -> np.ndarray:
    """What a signal's own past (and an input's) does not predict: the residual of the least-squares
    regression::

        x[k] = c + Σ_i α_i x[k-i] + Σ_j β_j v[k-j]      (i = 1..p; j = 1..p, or 0..p with ``current``)

    fitted on the rows ``kept``, clipped at 3 robust standard deviations of those rows (1.4826 times
    the median absolute deviation) so a few jumps do not decide a correlation; one value per sample
    from ``p`` on.

    Parameters
    ----------
    x : ndarray
        The signal.
    order : int
        p, the regression's order, >= 1.
    exogenous : ndarray, optional
        v, an input of ``x`` (the drive's input for its output): its terms leave out of the residual
        what the plant answers to it. None: an autoregression of ``x`` alone.
    current : bool
        Take v[k] too (an output measured at the end of the sample its input was held over).
    kept : ndarray of bool, optional
        The rows (samples ``p`` on) the fit and the spread are taken on; None: all.
    """
    n = x.size
    columns = [np.ones(n - order)] + [x[order - i : n - i] for i in range(1, order + 1)]
    if exogenous is not None:
        columns += [exogenous[order - j : n - j] for j in range(0 if current else 1, order + 1)]
    X = np.column_stack(columns)
    rows = np.ones(n - order, dtype=bool) if kept is None else kept
    scale = np.maximum(np.linalg.norm(X[rows], axis=0), 1e-300)
    theta, *_ = np.linalg.lstsq(X[rows] / scale, x[order:][rows], rcond=None)
    e = x[order:] - (X / scale) @ theta
    spread = 1.4826 * float(np.median(np.abs(e[rows] - np.median(e[rows]))))
    return np.clip(e, -3.0 * spread, 3.0 * spread) if spread > 0.0 else e


def away_from_reversals(y: np.ndarray, order: int = FEEDBACK_LAGS, guard: int = REVERSAL_GUARD) -> np.ndarray:
    """The samples ``order`` on that lie away from every reversal of ``y``: not within ``guard``
    samples before a change of its sign, nor within ``guard + order`` after one (the regressions of
    :func:`innovation` look ``order`` samples back).

    Parameters
    ----------
    y : ndarray
        The measured speed.
    order : int
        The regressions' order p.
    guard : int
        [samples] on each side of a reversal.
    """
    quiet = np.ones(y.size, dtype=bool)
    flips = np.flatnonzero(np.diff(np.sign(y)) != 0) + 1  # the first sample of the new sign
    if flips.size:
        starts = np.maximum(flips - guard, 0)
        stops = np.minimum(flips + guard + order + 1, y.size)
        edges = np.zeros(y.size + 1, dtype=int)
        np.add.at(edges, starts, 1)
        np.add.at(edges, stops, -1)
        quiet = np.cumsum(edges[:-1]) == 0
    return quiet[order:]


def input_feedback(u: np.ndarray, y: np.ndarray, order: int = FEEDBACK_LAGS) -> Feedback:
    """Whether the input answers the output's noise, as a controller does.

    With ``ε_u`` the input's innovation and ``ε_y,τ`` the output's net of what the plant answers to
    the input (:func:`innovation`, ``v = u``, u[k] among the regressors for τ = 1)::

        ρ_τ = corr(ε_u[k + τ], ε_y,τ[k]),    τ = 0, 1,   k away from reversals

    A controller answers the noise of the speed it reads with a command of the opposite sign
    (negative feedback, ``u = -K_p y + ...``), in the same sample (a loop that reads, then
    commands: y[k] then u[k]) or the next (a loop that commands, then reads at the end of the
    sample: u[k + 1] after y[k], whose answer to u[k] the ``current`` term explains): ρ is clearly
    negative. In an open loop the input is the experimenter's and never sees the output's noise:
    ρ lies near zero.

    The samples near a reversal of the speed are left out of the regressions and the correlation
    (:func:`away_from_reversals`): there a friction compensation switches its Coulomb term (the
    sign of the reference, which the speed follows), an input innovation far larger than the
    controller's answer to the noise, which the plant answers with the same sign. On
    ``motorid control``'s compensated loop the rows near its 6 reversals (117 of 292) hold 98 % of
    the input innovation's energy (0.34 V RMS there, 0.041 V away from them): with them ρ is
    +0.09 and the loop looks open, without them -0.46.

    Parameters
    ----------
    u, y : ndarray
        The input and the output, one sample each per row (the first :data:`FEEDBACK_SAMPLES`
        are looked at).
    order : int
        The regressions' order, >= 1.

    Returns
    -------
    Feedback
    """
    u = np.asarray(u, dtype=float)[:FEEDBACK_SAMPLES]
    y = np.asarray(y, dtype=float)[:FEEDBACK_SAMPLES]
    if u.size < 4 * order + 4:
        return Feedback(0.0, 0, 0)
    quiet = away_from_reversals(y, order)
    if int(quiet.sum()) < 4 * order + 4:
        return Feedback(0.0, 0, int(quiet.sum()))
    eu = innovation(u, order, kept=quiet)
    best = Feedback(0.0, 0, int(quiet.sum()))
    for lag in (0, 1):
        ey = innovation(y, order, exogenous=u, current=lag == 1, kept=quiet)
        rows = quiet[lag:] & quiet[: quiet.size - lag]
        a = eu[lag:][rows] - eu[lag:][rows].mean()
        b = ey[: ey.size - lag][rows] - ey[: ey.size - lag][rows].mean()
        norm = math.sqrt(float(a @ a) * float(b @ b))
        rho = float(a @ b) / norm if norm > 0.0 else 0.0
        if rho < best.correlation:
            best = Feedback(rho, lag, a.size)
    return best


@dataclass
class ClosedLoop:
    """What the doctor found of one record's loop, and how it identified it.

    Attributes
    ----------
    label : str
        The record.
    reference : str or None
        Its reference column (None: it has none).
    feedback : Feedback
        How much of its input the output's past explains.
    timing : str or None
        The timing the rule of the module notes set (:func:`loop_timing`); None: the record's own
        or the one given to the doctor.
    instrumental : dict
        Per linear parameter refitted by instrumental variables: ``value``, ``standard_error`` and
        ``least_squares`` (the search's value) [the parameter's unit]; empty without a reference.
    least_squares_kept : str or None
        Why the search's least squares were kept over the instrumental fit
        (:func:`instrumental_kept`); None where the instrumental fit was taken or not made.
    """

    label: str
    reference: str | None
    feedback: Feedback
    timing: str | None = None
    instrumental: dict[str, dict[str, float]] = field(default_factory=dict)
    least_squares_kept: str | None = None

    @property
    def closed(self) -> bool:
        """A reference column, or an input that follows the output's past."""
        return self.reference is not None or self.feedback.looks_closed

    @property
    def timing_set(self) -> bool:
        """Whether the rule of the module notes set the record's timing."""
        return self.timing is not None

    @property
    def method(self) -> str:
        """How the record was identified: ``instrumental variables`` or ``least squares``."""
        return (
            "instrumental variables"
            if self.instrumental and self.least_squares_kept is None
            else "least squares"
        )

    def sentence(self, units: dict[str, str] | None = None) -> str:
        """The report's line on the loop."""
        timing = (
            f"; read with timing {self.timing!r} ({LOOP_ORDER[self.timing]})"
            if self.timing is not None
            else ""
        )
        if self.reference is None:
            fb = self.feedback
            return (
                f"the input answers the output's noise (their innovations correlate at {fb.correlation:.2f}, the "
                f"input's {fb.lag} sample{'s' if fb.lag != 1 else ''} after){timing}: the record looks "
                "like a closed loop; fitted by least squares as an open loop, which the loop's feedback of "
                "the noise can bias: give its reference column (reference_column=...)"
            )
        moved = ", ".join(
            f"{name} {entry['least_squares']:.4g} -> {entry['value']:.4g} ± {entry['standard_error']:.2g}"
            for name, entry in self.instrumental.items()
        )
        kept = f"; {self.least_squares_kept}" if self.least_squares_kept else ""
        return (
            f"closed loop: the reference is column {self.reference!r}{timing}; the balance's linear "
            f"parameters refitted with the reference as instrument ({moved or 'none'}){kept}"
        )

    def to_dict(self) -> dict[str, Any]:
        """For ``--json``."""
        return {
            "record": self.label, "closed": self.closed, "reference": self.reference,
            "feedback_correlation": self.feedback.correlation, "feedback_lag": self.feedback.lag,
            "timing_set": self.timing_set, "timing": self.timing, "method": self.method,
            "instrumental": {name: dict(entry) for name, entry in self.instrumental.items()},
            "least_squares_kept": self.least_squares_kept,
            "sentence": self.sentence(),
        }  # fmt: skip


#: What each timing the rule sets says of the loop (:class:`ClosedLoop`'s sentence).
LOOP_ORDER = {
    "sampled": "the loop reads, then commands",
    "hold": "the loop commands, then reads the speed at the end of the sample",
}


def loop_timing(feedback: Feedback) -> str:
    """The timing of a closed loop's record that names none: ``"hold"`` where the input answers the
    output's noise a sample later (:attr:`Feedback.lag` 1 of an input that looks closed: ``y[k]``,
    the speed at the end of the sample ``u[k]`` was held over, read before ``u[k + 1]`` is
    computed), else ``"sampled"`` (``y[k]`` read, then ``u[k]`` computed from it, as ``motorid
    control`` logs; also the loop whose feedback does not show, a reference alone naming it closed).

    Parameters
    ----------
    feedback : Feedback
        The record's (:func:`input_feedback`).
    """
    return "hold" if feedback.looks_closed and feedback.lag == 1 else "sampled"


def kinetic_split(model: RigidDrive, units: dict[str, str]) -> str | None:
    """On a closed loop's model that holds both Coulomb friction ``F_c`` and an input dead zone
    ``d``, the sentence that their sum is what the loop determines, ``F_c + g d`` [F] (``g`` the
    input gain); None for a model without both.

    A loop keeps its input out of the dead zone while the drive moves, except for the few samples
    where the command crosses it (at a reversal, or while a PI winds through it at rest), so the two
    hold the moving drive back as one level and their split rests on those samples.

    Parameters
    ----------
    model : RigidDrive
        The final model.
    units : dict
        The diagnosis's units (``F``, ``u``).
    """
    if not {"coulomb_friction", "input_dead_zone"} <= set(model.effects):
        return None
    coulomb, dead_zone = model.params["coulomb"], model.params["dead_zone"]
    level = coulomb + model.input_gain * dead_zone
    return (
        f"closed loop: Coulomb friction {coulomb:.3g} {units['F']} and the dead zone {dead_zone:.3g} {units['u']} "
        f"hold the moving drive back as one level, {level:.3g} {units['F']}, which the loop's record determines; "
        "their split rests on the few samples where the command crosses the dead zone (an open-loop record "
        "separates them)"
    )


def loop_records(
    given_records: list[pd.DataFrame],
    records: list[pd.DataFrame],
    labels: list[str],
    given: str | None,
    timing: str | None,
    output_kind: str = "velocity",
) -> tuple[list[pd.DataFrame], list[ClosedLoop], list[np.ndarray | None]]:
    """The records with the timing rule applied, what each says of its loop, and each one's
    reference (None: it has none).

    A record with a reference column, or whose input looks like a controller's
    (:attr:`Feedback.looks_closed`), whose attributes name no timing (and no ``timing`` given) is
    given ``attrs["timing"]`` from its feedback's lag (a copy; :func:`loop_timing`, the module
    notes' rule). The reference is taken from the record as given, in its own unit: an
    instrument's scale changes nothing of θ_IV.

    Parameters
    ----------
    given_records : list of DataFrame
        The records as the user gave them (the reference among their columns).
    records : list of DataFrame
        The same records normalised (columns ``u``, ``y``).
    labels : list of str
        Their names.
    given : str, optional
        The reference column named by the user.
    timing : str, optional
        The timing given to the doctor (None: the records').
    output_kind : {"velocity", "position"}
        What the records measure. Closed loops are recognised on speed records only: a position
        loop's reference is a position (EMPS's), which the instruments here do not take, and
        :func:`input_feedback`'s bounds were measured on speeds.
    """
    if given is not None and output_kind != "velocity":
        raise DataError(
            f"reference_column={given!r}: closed loops are identified on speed records; a position loop's "
            "reference (a position) is not taken as an instrument"
        )
    out, loops, references = [], [], []
    for raw, record, label in zip(given_records, records, labels, strict=True):
        if output_kind != "velocity":
            out.append(record)
            references.append(None)
            loops.append(ClosedLoop(label, None, Feedback(0.0, 0, 0)))
            continue
        column = reference_column(raw, given) if isinstance(raw, pd.DataFrame) else None
        reference = None if column is None else raw[column].to_numpy(dtype=float)
        if reference is not None and reference.size != len(record):
            logger.info("%s: the reference is not row for row with the record as read: no instruments", label)
            reference = None
        feedback = input_feedback(record["u"].to_numpy(dtype=float), record["y"].to_numpy(dtype=float))
        closed = column is not None or feedback.looks_closed
        timing_set = None
        if closed and timing is None and "timing" not in record.attrs:
            timing_set = loop_timing(feedback)
            record = record.copy()
            record.attrs["timing"] = timing_set
        out.append(record)
        references.append(reference)
        loops.append(ClosedLoop(label, column, feedback, timing_set))
    return out, loops, references


def instrumental_refit(
    pool: Pool, model: RigidDrive, references: list[np.ndarray | None]
) -> tuple[RigidDrive, dict[str, dict[str, float]]]:
    """The model with the linear parameters of its torque balance refitted by instrumental
    variables, the reference as instrument (the module notes' equations), its shape parameters
    held.

    Parameters
    ----------
    pool : Pool
        The prepared records.
    model : RigidDrive
        The search's model (least squares).
    references : list of ndarray or None
        Each record's reference, row for row with the record as read (None: the record has none
        and adds no rows).

    Returns
    -------
    RigidDrive, dict
        The refitted model (``model`` itself where no record has a reference or the instruments
        do not determine the parameters), and per refitted parameter its ``value``,
        ``standard_error`` and ``least_squares`` value.
    """
    effects = [
        get_effect(n) for n in sorted(model.effects, key=lambda n: n != "offset")
        if get_effect(n).kind == "friction" and get_effect(n).linear and not get_effect(n).position
    ]  # fmt: skip
    names = ["inertia"] + [p for eff in effects for p in eff.linear]
    X_rows, Z_rows, F_rows = [], [], []
    for prep, r in zip(pool.parts, references, strict=True):
        if r is None:
            continue
        kin, data = prep.kin, prep.data
        r = np.asarray(r, dtype=float)
        if prep.timing == "sampled":
            r = r[1:]  # paired as the output is (prepare)
        r = r[r.size - kin.n :]  # the samples a bad start left out go here too
        kin_r = kinematics(kin.u, r, kin.dt, "velocity", kin.band)
        if kin_r.factor != kin.factor or not np.array_equal(kin_r.decimated_index, data.idx):
            logger.info("the reference decimates unlike the speed: no instruments from it")
            continue
        rows = data.moving
        f_in = model_balance(model, data)[0]
        x_cols, z_cols = [data.a], [kin_r.decimate(kin_r.a)]
        for eff in effects:
            on_w = eff.columns(kin.balance_w, model.params, model.stribeck_shape, None)
            on_r = eff.columns(kin_r.w, model.params, model.stribeck_shape, None)
            for j in range(len(eff.linear)):
                x_cols.append(data.decimated(("instrument", model_key(model), eff.name, j), on_w[:, j]))
                z_cols.append(kin_r.decimate(on_r[:, j]))
        X_rows.append(np.column_stack(x_cols)[rows])
        Z_rows.append(np.column_stack(z_cols)[rows])
        F_rows.append(f_in[rows])
    if not X_rows:
        return model, {}
    X, Z, F = np.vstack(X_rows), np.vstack(Z_rows), np.concatenate(F_rows)
    # columns the instruments carry nothing of (a zero column on the moving rows) keep their values
    used = np.flatnonzero((np.linalg.norm(X, axis=0) > 0.0) & (np.linalg.norm(Z, axis=0) > 0.0))
    X, Z = X[:, used], Z[:, used]
    scale = np.linalg.norm(X, axis=0)
    Xs, Zs = X / scale, Z / np.linalg.norm(Z, axis=0)
    ZX = Zs.T @ Xs
    m, k = X.shape
    if m <= k or np.linalg.cond(ZX) > 1e8:
        logger.info("the reference does not determine the balance's parameters: least squares kept")
        return model, {}
    theta_s = np.linalg.solve(ZX, Zs.T @ F)  # θ_IV = (ZᵀX)⁻¹ ZᵀF, on unit-norm columns
    residual = F - Xs @ theta_s
    sigma2 = float(residual @ residual) / (m - k)  # σ² = ||F - X θ||² / (M - k)
    inv = np.linalg.inv(ZX)
    cov_s = sigma2 * inv @ (Zs.T @ Zs) @ inv.T  # cov θ = σ² (ZᵀX)⁻¹ ZᵀZ (XᵀZ)⁻¹
    theta = theta_s / scale
    std = np.sqrt(np.clip(np.diag(cov_s), 0.0, None)) / scale
    changes, entries = {}, {}
    fitted = {names[col]: float(theta[j]) for j, col in enumerate(used)}
    viscous = fitted.get("viscous", model.params.get("viscous", 0.0))
    for j, col in enumerate(used):
        name = names[col]
        value = fitted[name]  # [the parameter's unit]: the balance is in force units, as the model
        slope = 1.0  # dθ/dθ_b: the balance's coefficient and the parameter it gives
        if name == "inertia":
            data = pool.parts[0].data
            value, slope = data.inertia(value, viscous), data.inertia_slope(value, viscous)
        changes[name] = value
        entries[name] = {"value": value, "standard_error": float(std[j]) * slope,
                         "least_squares": float(model.params[name])}  # fmt: skip
    try:
        return model.with_params(**changes), entries
    except ValueError as exc:  # a parameter of the wrong sign (a negative inertia or Coulomb level)
        logger.info("instrumental variables give a non-physical model (%s): least squares kept", exc)
        return model, {}


def instrumental_kept(
    pool: Pool, least_squares: RigidDrive, instrumental: RigidDrive, region: Region | None, alike: float
) -> str | None:
    """Why the search's least-squares model is kept over the instrumental fit, or None where the
    instrumental fit is taken.

    The instrumental fit is consistent where the balance's columns are linear in what the loop
    makes of its noise; the shape parameters it holds (a Stribeck velocity, a dead zone) and a
    reference the speed does not follow near its reversals leave it noisy or off there, where
    least squares, biased by the loop's noise, may stand nearer. The free run of the recorded
    input judges both as it judges every model: its error at ``k + 1`` is the noise of the
    speed read then, which no command up to ``k`` has seen, so the loop biases neither gap.
    **The rule**: the instrumental fit is taken unless its free-run gap exceeds the least-squares
    model's by more than ``alike`` noise floors (the doctor's gaps that fit alike,
    :data:`~motorid.diagnose.search.ALIKE_GAP`), or is not finite. Measured on the bank's
    closed-loop benches (:func:`motorid.diagnose.calibration.bank`, seeds 0-9, 50 benches): the
    instrumental fit's gap larger by 0.75 and 0.91 floors on two Stribeck benches (the Stribeck
    level 11 % and 55 % off where least squares held it within 2 % and 13 %, gaps 2.45 and 1.98
    noise floors against 1.70 and 1.07), by 0.06-0.12 on two, within 0.05 of least squares' on the
    46 others; on a PI loop whose speed is read with 1 rad/s of noise
    (``tests/test_diagnose_closed_loop.py``) least squares takes the inertia 40 % high and its gap
    is 1.89 floors against the instrumental fit's 0.83.

    Parameters
    ----------
    pool : Pool
        The prepared records.
    least_squares, instrumental : RigidDrive
        The search's model and its instrumental refit (:func:`instrumental_refit`).
    region : Region
        The located region the gaps are also taken in (:meth:`Pool.gaps`).
    alike : float
        Noise floors within which two free-run gaps fit alike.
    """
    g_iv = pool.gaps(instrumental, region).overall
    g_ls = pool.gaps(least_squares, region).overall
    if math.isfinite(g_iv) and g_iv <= g_ls + alike * pool.noise:
        return None
    unit = pool.units["v"]
    return (
        f"least squares kept: its free run lies closer to the record ({g_ls:.4g} {unit} against the "
        f"instrumental fit's {g_iv:.4g} {unit}, more than {alike:g} noise floor apart)"
    )


__all__ = [
    "FEEDBACK_CORRELATION",
    "FEEDBACK_LAGS",
    "FEEDBACK_SAMPLES",
    "FEEDBACK_Z",
    "LOOP_ORDER",
    "REFERENCE_COLUMNS",
    "REVERSAL_GUARD",
    "ClosedLoop",
    "Feedback",
    "away_from_reversals",
    "innovation",
    "input_feedback",
    "instrumental_kept",
    "instrumental_refit",
    "kinetic_split",
    "loop_records",
    "loop_timing",
    "reference_column",
]
