"""Closed-loop records: a drive measured while a controller computed its input from its output.

A closed loop changes three things the doctor otherwise takes for granted:

- **Timing.** A controller reads the speed, then commands: ``y[k]`` is measured at ``t[k]`` and
  ``u[k]`` held over ``[t[k], t[k] + dt)`` (``timing="sampled"``, :data:`motorid.records.TIMINGS`).
  Read with the open loop's ``"hold"`` timing, every command seems to act one sample late, and the
  delay search takes that sample, and the loop's own correlation around it, for an input delay
  (60 ms on ``motorid control``'s 40 ms loop). **The rule**: a record recognised as closed loop
  whose attributes name no timing is read with ``"sampled"`` timing, and the report says so.
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
  consistent where least squares is not.
- **What the record can tell.** A loop that keeps the input beyond the dead zone whenever the
  drive moves (a compensation that jumps across it at each reversal) leaves Coulomb friction and
  the dead zone one kinetic level: the doctor then names one and reports the other as its
  lookalike (:class:`~motorid.diagnose.results.Lookalike`), with their common level.

A record is recognised as closed loop by its reference column (named ``reference`` or ``r``, as
``motorid control --out`` writes it, or given: ``reference_column``). A record without one whose
input follows its output's past beyond what the input's own past explains (:func:`input_feedback`)
is said to look closed: it is fitted as an open loop, and the sentence asks for its reference.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from motorid.diagnose.kinematics import kinematics
from motorid.diagnose.model import model_balance
from motorid.diagnose.prepare import Pool
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive
from motorid.errors import DataError

logger = logging.getLogger(__name__)

#: Column names a closed loop's reference goes by (``motorid control --out`` writes ``reference``).
REFERENCE_COLUMNS = ("reference", "r")
#: Past samples of the input and of the output in :func:`input_feedback`'s regressions.
FEEDBACK_LAGS = 4
#: Share of the input's innovation the output's past explains above which a record without a
#: reference is said to look closed [-] (with :data:`FEEDBACK_F`).
FEEDBACK_SHARE = 0.05
#: F statistic of the output's past above which its share counts (far beyond chance: an F of 20 on
#: 4 and hundreds of degrees of freedom has a p-value below 1e-14).
FEEDBACK_F = 20.0


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
    """How much of the input its output's past explains (:func:`input_feedback`).

    Attributes
    ----------
    share : float
        ``1 - RSS_1 / RSS_0`` [-]: the share of the input's innovation (what its own past leaves
        unexplained) the output's past explains.
    statistic : float
        The F statistic of the output's lags, ``((RSS_0 - RSS_1) / p) / (RSS_1 / (M - 2p - 1))``.
    """

    share: float
    statistic: float

    @property
    def looks_closed(self) -> bool:
        """Whether the share exceeds :data:`FEEDBACK_SHARE` with an F beyond :data:`FEEDBACK_F`."""
        return self.share > FEEDBACK_SHARE and self.statistic > FEEDBACK_F


def input_feedback(u: np.ndarray, y: np.ndarray, lags: int = FEEDBACK_LAGS) -> Feedback:
    """Whether the output's past predicts the input beyond the input's own past (Granger's test).

    Two least-squares fits of ``u[k]`` over the M samples that have p = ``lags`` past ones::

        u[k] = c + Σ_i α_i u[k-i]                    (RSS_0)
        u[k] = c + Σ_i α_i u[k-i] + Σ_i β_i y[k-i]   (RSS_1),    i = 1..p

    In an open loop the input is the experimenter's: the output is a response to the input's past
    and its noise never reaches the input, so ``β`` only fits chance (F near 1). A controller
    computes the input from the measured output, so its past explains a share of the input.

    Parameters
    ----------
    u, y : ndarray
        The input and the output, one sample each per row.
    lags : int
        p, >= 1.

    Returns
    -------
    Feedback
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    n = u.size
    m = n - lags
    if m <= 2 * lags + 1:
        return Feedback(0.0, 0.0)
    past_u = np.column_stack([np.ones(m)] + [u[lags - i : n - i] for i in range(1, lags + 1)])
    past_y = np.column_stack([y[lags - i : n - i] for i in range(1, lags + 1)])
    target = u[lags:]

    def rss(X: np.ndarray) -> float:
        X = X / np.maximum(np.linalg.norm(X, axis=0), 1e-300)
        theta, *_ = np.linalg.lstsq(X, target, rcond=None)
        return float(np.sum((target - X @ theta) ** 2))

    rss0 = rss(past_u)
    rss1 = rss(np.column_stack([past_u, past_y]))
    if not rss0 > 0.0:
        return Feedback(0.0, 0.0)
    share = max(1.0 - rss1 / rss0, 0.0)
    dof = m - 2 * lags - 1
    statistic = ((rss0 - rss1) / lags) / (rss1 / dof) if rss1 > 0.0 else math.inf
    return Feedback(share, float(statistic))


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
    timing_set : bool
        Whether its timing was set to ``"sampled"`` by the rule of the module notes.
    instrumental : dict
        Per linear parameter refitted by instrumental variables: ``value``, ``standard_error`` and
        ``least_squares`` (the search's value) [the parameter's unit]; empty without a reference.
    """

    label: str
    reference: str | None
    feedback: Feedback
    timing_set: bool = False
    instrumental: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def closed(self) -> bool:
        """A reference column, or an input that follows the output's past."""
        return self.reference is not None or self.feedback.looks_closed

    @property
    def method(self) -> str:
        """How the record was identified: ``instrumental variables`` or ``least squares``."""
        return "instrumental variables" if self.instrumental else "least squares"

    def sentence(self, units: dict[str, str] | None = None) -> str:
        """The report's line on the loop."""
        share = f"{self.feedback.share:.0%} of the input's innovation follows the output's past"
        if self.reference is None:
            return (
                f"the input follows the output ({share}, F = {self.feedback.statistic:.3g}): the record looks "
                "like a closed loop; fitted by least squares as an open loop, which the loop's feedback of "
                "the noise can bias: give its reference column (reference_column, --reference-column)"
            )
        timing = "; read with timing 'sampled' (the loop reads, then commands)" if self.timing_set else ""
        moved = ", ".join(
            f"{name} {entry['least_squares']:.4g} -> {entry['value']:.4g} ± {entry['standard_error']:.2g}"
            for name, entry in self.instrumental.items()
        )
        return (
            f"closed loop: the reference is column {self.reference!r} ({share}){timing}; the balance's linear "
            f"parameters refitted with the reference as instrument ({moved or 'none'})"
        )

    def to_dict(self) -> dict[str, Any]:
        """For ``--json``."""
        return {
            "record": self.label, "closed": self.closed, "reference": self.reference,
            "feedback_share": self.feedback.share, "feedback_statistic": self.feedback.statistic,
            "timing_set": self.timing_set, "method": self.method,
            "instrumental": {name: dict(entry) for name, entry in self.instrumental.items()},
            "sentence": self.sentence(),
        }  # fmt: skip


def loop_records(
    given_records: list[pd.DataFrame],
    records: list[pd.DataFrame],
    labels: list[str],
    given: str | None,
    timing: str | None,
) -> tuple[list[pd.DataFrame], list[ClosedLoop], list[np.ndarray | None]]:
    """The records with the timing rule applied, what each says of its loop, and each one's
    reference (None: it has none).

    A record with a reference column whose attributes name no timing (and no ``timing`` given) is
    given ``attrs["timing"] = "sampled"`` (a copy; the module notes' rule). The reference is taken
    from the record as given, in its own unit: an instrument's scale changes nothing of θ_IV.

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
    """
    out, loops, references = [], [], []
    for raw, record, label in zip(given_records, records, labels, strict=True):
        column = reference_column(raw, given) if isinstance(raw, pd.DataFrame) else None
        reference = None if column is None else raw[column].to_numpy(dtype=float)
        if reference is not None and reference.size != len(record):
            logger.info("%s: the reference is not row for row with the record as read: no instruments", label)
            reference = None
        feedback = input_feedback(record["u"].to_numpy(dtype=float), record["y"].to_numpy(dtype=float))
        timing_set = column is not None and timing is None and "timing" not in record.attrs
        if timing_set:
            record = record.copy()
            record.attrs["timing"] = "sampled"
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
            on_w = eff.columns(kin.w, model.params, model.stribeck_shape, None)
            on_r = eff.columns(kin_r.w, model.params, model.stribeck_shape, None)
            for j in range(len(eff.linear)):
                x_cols.append(kin.decimate(on_w[:, j]))
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
    for j, col in enumerate(used):
        name = names[col]
        value = float(theta[j])  # [the parameter's unit]: the balance is in force units, as the model
        changes[name] = value
        entries[name] = {"value": value, "standard_error": float(std[j]),
                         "least_squares": float(model.params[name])}  # fmt: skip
    try:
        return model.with_params(**changes), entries
    except ValueError as exc:  # a parameter of the wrong sign (a negative inertia or Coulomb level)
        logger.info("instrumental variables give a non-physical model (%s): least squares kept", exc)
        return model, {}


__all__ = [
    "FEEDBACK_F",
    "FEEDBACK_LAGS",
    "FEEDBACK_SHARE",
    "REFERENCE_COLUMNS",
    "ClosedLoop",
    "Feedback",
    "input_feedback",
    "instrumental_refit",
    "loop_records",
    "reference_column",
]
