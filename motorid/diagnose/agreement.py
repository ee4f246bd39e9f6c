"""Whether the records of one drive tell one story: each record's parameters under the joint model.

A joint run (:func:`~motorid.diagnose.workflow.diagnose` on several records) fits one model to all
records. Its standard errors say how well the pooled records determine a parameter if they all
measure the same drive under the same model; they do not say whether they do. Here the joint
model's structure (its effects, with every shape parameter held: Stribeck velocity, delay, ...) is
fitted to each record alone, by the same torque balance, giving each record's value θ_i of each
linear parameter with its standard error σ_i (:func:`~motorid.diagnose.model.linear_param_std`),
and the records are tested for one common value (Cochran's test of homogeneity)::

    θ̄ = Σ w_i θ_i / Σ w_i,    w_i = 1/σ_i²
    Q = Σ w_i (θ_i - θ̄)²          ~ χ²(k - 1) when the k records share one value
    τ² = max(0, (Q - (k - 1)) / (Σ w_i - Σ w_i² / Σ w_i))       (DerSimonian-Laird)

τ is the spread between the records beyond their own errors, in the parameter's unit: what a
next record of the drive is likely to differ by (temperature, wear, a signal that excites a part
the model misses). A record's value is then a measurement of the drive's level with the
uncertainty ``sqrt(σ_i² + τ²)``, which a fit of the pooled records leaves out: its standard error
σ_joint treats the records as one long record of one unchanging drive. The drive's level has the
standard error (:attr:`Agreement.drive_std`) σ_joint widened by what the spread adds to the error
of a weighted mean of the records::

    σ_drive = σ_joint sqrt(Σ w_i / Σ w_i*),    w_i* = 1/(σ_i² + τ²)

(σ_joint where τ = 0; it carries what σ_joint carries besides, such as an input delay's
uncertainty). Records whose p-value ``P(χ²(k-1) > Q)`` lies below :data:`AGREEMENT_LEVEL`
disagree, and each record more than :data:`OUTLIER_Z` of its own standard errors from the joint
value is named (:attr:`Agreement.outliers`). Where the joint run's inertia trades with the input delay (it is not determined:
:class:`~motorid.diagnose.model.DelayTrade`), the records are tested on what each determines
instead, ``effective_inertia`` J + B τ_d.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from motorid.diagnose.model import DelayTrade, fit_model
from motorid.diagnose.prepare import Pool
from motorid.drive.effects.registry import get as get_effect
from motorid.drive.rigid import RigidDrive

#: Records whose test of one common value has a p-value below this disagree: on 100 joint runs of
#: three simulated records of one drive with Coulomb friction, 1 of the 310 parameters tested was
#: said to differ (0.3 %, on 1 run; ``python -m motorid.diagnose.calibration --agreement --seeds
#: 100 --first 0``), so the block-sandwich errors hold what one drive's records scatter by.
AGREEMENT_LEVEL = 0.01
#: The name J + B τ_d is tested under where the inertia trades with the input delay.
EFFECTIVE_INERTIA = "effective_inertia"
#: A record further than this many of its own standard errors from the joint value is named.
OUTLIER_Z = 2.0


@dataclass(frozen=True)
class Agreement:
    """How the records of a joint run agree on one linear parameter (:func:`agreement`).

    Attributes
    ----------
    parameter : str
        The parameter's name (``effective_inertia``: J + B τ_d, in the inertia's unit).
    labels : tuple of str
        The records.
    values, std : tuple of float
        Each record's value θ_i and standard error σ_i under the joint model's structure [its unit].
    joint, joint_std : float
        The joint run's value and standard error [its unit].
    q : float
        Cochran's Q [-], on ``len(labels) - 1`` degrees of freedom.
    p_value : float
        P(χ²(k - 1) > Q) [-].
    spread : float
        τ, the DerSimonian-Laird spread between the records beyond their errors [its unit].
    """

    parameter: str
    labels: tuple[str, ...]
    values: tuple[float, ...]
    std: tuple[float, ...]
    joint: float
    joint_std: float
    q: float
    p_value: float
    spread: float

    @property
    def dof(self) -> int:
        """Degrees of freedom of Q: the records less one."""
        return len(self.labels) - 1

    @property
    def agree(self) -> bool:
        """Whether the records share one value within their errors (p >= :data:`AGREEMENT_LEVEL`)."""
        return self.p_value >= AGREEMENT_LEVEL

    def z(self) -> tuple[float, ...]:
        """Each record's distance from the joint value in its own standard errors, (θ_i - θ) / σ_i."""
        return tuple((v - self.joint) / s for v, s in zip(self.values, self.std, strict=True))

    @property
    def outliers(self) -> tuple[str, ...]:
        """Where the records disagree, those further than :data:`OUTLIER_Z` of their standard errors
        from the joint value (none where they agree: a record 2.1 errors off among records that
        share one value is what their errors allow)."""
        if self.agree:
            return ()
        return tuple(label for label, z in zip(self.labels, self.z(), strict=True) if abs(z) > OUTLIER_Z)

    @property
    def drive_std(self) -> float:
        """σ_drive [its unit]: the standard error of the drive's level, the joint run's own and the
        spread τ between records together (module notes); ``joint_std`` where τ = 0."""
        fixed = sum(1.0 / (s * s) for s in self.std)
        spread = sum(1.0 / (s * s + self.spread**2) for s in self.std)
        return float(self.joint_std * math.sqrt(fixed / spread))

    @property
    def unit_of(self) -> str:
        """The model parameter whose unit it has."""
        return "inertia" if self.parameter == EFFECTIVE_INERTIA else self.parameter

    def describe(self, unit: str) -> str:
        """One line, e.g. (the kit motor's joint run) ``viscous_asymmetry: the records disagree beyond
        their errors (Q = 32.2 on 5 dof, p = 5.5e-06); spread between records 0.00088 % s/(rad/s)
        (11 % of 0.007828); kit_sine_1hz_run2 0.009423 ± 0.00038, 4.2 standard errors above; ...``.

        Parameters
        ----------
        unit : str
            The parameter's unit.
        """
        test = f"Q = {self.q:.3g} on {self.dof} dof, p = {self.p_value:.2g}"
        share = 100.0 * self.spread / abs(self.joint) if self.joint else math.inf
        if self.agree:
            spread = (
                f"; spread between records {self.spread:.2g} {unit} ({share:.2g} %): the drive's level "
                f"± {self.drive_std:.2g}"
                if self.spread > 0.0
                else ""
            )
            return (
                f"{self.parameter}: the records agree within their errors ({test}); "
                f"{min(self.values):.4g} to {max(self.values):.4g} {unit}{spread}"
            )
        named = [
            f"{label} {v:.4g} ± {s:.2g}, {abs(z):.1f} standard errors {'above' if z > 0 else 'below'}"
            for label, v, s, z in zip(self.labels, self.values, self.std, self.z(), strict=True)
            if label in self.outliers
        ]
        return (
            f"{self.parameter}: the records disagree beyond their errors ({test}); spread between "
            f"records {self.spread:.2g} {unit} ({share:.2g} % of {self.joint:.4g}): the drive's level "
            f"± {self.drive_std:.2g}" + ("; " + "; ".join(named) if named else "")
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "records": list(self.labels), "values": list(self.values), "std": list(self.std),
            "joint": self.joint, "joint_std": self.joint_std, "q": self.q, "dof": self.dof,
            "p_value": self.p_value, "spread": self.spread, "drive_std": self.drive_std, "agree": self.agree,
            "outliers": list(self.outliers),
        }  # fmt: skip


def homogeneity(values: np.ndarray, std: np.ndarray) -> tuple[float, float, float]:
    """Cochran's Q, its p-value and the DerSimonian-Laird spread τ of estimates of one value.

    Parameters
    ----------
    values : numpy.ndarray, shape (k,)
        The estimates θ_i [a unit].
    std : numpy.ndarray, shape (k,)
        Their standard errors σ_i > 0 [the same unit].

    Returns
    -------
    tuple of float
        ``(Q, p, τ)``: Q [-], P(χ²(k - 1) > Q) [-] and τ [the unit] (module notes).
    """
    from scipy.stats import chi2

    w = 1.0 / np.square(std)
    mean = float(np.sum(w * values) / np.sum(w))
    q = float(np.sum(w * np.square(values - mean)))
    dof = values.size - 1
    c = float(np.sum(w) - np.sum(np.square(w)) / np.sum(w))
    tau2 = max(0.0, (q - dof) / c) if c > 0.0 else 0.0
    return q, float(chi2.sf(q, dof)), math.sqrt(tau2)


def agreement(
    pool: Pool, model: RigidDrive, joint_std: dict[str, float], undetermined: set[str],
    trade: DelayTrade | None,
) -> list[Agreement]:  # fmt: skip
    """How the records of ``pool`` agree on each linear parameter of the joint ``model``.

    Each record is fitted alone with ``model``'s effects and shape parameters held; a parameter is
    tested when every record gives it a finite standard error > 0 and the joint run determines it
    (not in ``undetermined``); an inertia that trades with the input delay is tested as J + B τ_d
    (``effective_inertia``), what each record determines. Empty for a pool of one record.

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    model : RigidDrive
        The joint run's final model.
    joint_std : dict
        The joint run's standard errors [their units].
    undetermined : set of str
        The parameters the joint run does not determine.
    trade : DelayTrade or None
        The joint run's :class:`~motorid.diagnose.model.DelayTrade`.
    """
    if len(pool.parts) < 2:
        return []
    shape = {p: model.params[p] for name in model.effects for p in get_effect(name).nonlinear}
    fits = [
        fit_model(part.data, model.effects, fixed=shape, stribeck_shape=model.stribeck_shape)
        for part in pool.parts
    ]
    tested = {
        name: (
            [f.model.params[name] for f in fits], [f.param_std.get(name, math.nan) for f in fits],
            model.params[name], joint_std[name],
        )
        for name in joint_std
        if name not in undetermined
    }  # fmt: skip
    if trade is not None and trade.inertia_traded and all(f.delay_trade is not None for f in fits):
        tested[EFFECTIVE_INERTIA] = (
            [f.delay_trade.effective_inertia for f in fits], [f.delay_trade.effective_inertia_std for f in fits],
            trade.effective_inertia, trade.effective_inertia_std,
        )  # fmt: skip
    out = []
    for name, (values, std, joint, joint_error) in tested.items():
        values, std = np.array(values), np.array(std)
        if not (np.all(np.isfinite(std)) and np.all(std > 0.0)):
            continue
        q, p, spread = homogeneity(values, std)
        labels, found = tuple(pool.labels), (tuple(values.tolist()), tuple(std.tolist()))
        out.append(Agreement(name, labels, *found, float(joint), float(joint_error), q, p, spread))
    return out


__all__ = ["AGREEMENT_LEVEL", "EFFECTIVE_INERTIA", "OUTLIER_Z", "Agreement", "agreement", "homogeneity"]
