"""The card a command writes beside the model it fits (:class:`motorid.drive.files.ModelCard`), and
the check of a model's card against a record or a command's settings.

- :func:`record_card`: what the records a model is fitted on say: the input's unit (and the
  supply voltage that made a duty volts), the output's, the sample time and timing, and each
  record's file, SHA-256 and span.
- :func:`input_scale`: the factor that puts a record's input in the unit a model was fitted on
  (% duty <-> V with a supply voltage), or a one-line refusal naming the model file, the two units
  and what to give.
- :func:`check_output`: a record's output against the model's (a speed, or the position it
  integrates to).
- :func:`estimator_parameters`: an identified estimator's parameters for its card, each with its
  standard error and whether the record determined it.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from motorid.drive.files import ModelCard, file_sha256
from motorid.errors import DataError
from motorid.io.records import record_timing

logger = logging.getLogger(__name__)

__all__ = [
    "check_output",
    "check_record",
    "estimator_parameters",
    "input_scale",
    "record_card",
    "with_parameters",
]

#: A parameter is determined by the records where they shrank its variance below this share of
#: the prior's (the information the records carried on it is at least the prior's).
DETERMINED_SHARE = 0.5

#: The speed whose integral each position unit is.
SPEED_OF_POSITION = {"rad": "rad/s", "m": "m/s"}


def record_card(
    records: Sequence[pd.DataFrame],
    paths: Sequence[str | os.PathLike[str] | None],
    *,
    supply_voltage: float | None = None,
    input_full_scale: float | None = None,
) -> ModelCard:
    """The card of a model fitted on ``records``, read from the files ``paths``.

    Parameters
    ----------
    records : sequence of DataFrame
        The records as read (columns ``t`` [s], ``u``, ``y``; ``attrs["units"]``, ``dt``, ``timing``).
    paths : sequence of path or None
        Each record's file; None (a DataFrame of the user's own) leaves the record out of the
        card's ``records``, which name files and their SHA-256.
    supply_voltage : float, optional
        The supply voltage [V] that made a duty volts on reading (``--supply-voltage``).
    input_full_scale : float, optional
        The count of full duty of an input read in counts.

    Returns
    -------
    ModelCard
        The output unit is a speed: a record of positions gives the speed it is the integral of
        (the model's free run is a speed, run in position where the record is one).
    """
    first = records[0]
    units = first.attrs.get("units") or {}
    input_unit = units.get("u") if units.get("u") in ("V", "%") else None
    output = units.get("y")
    output = SPEED_OF_POSITION.get(output, output) if output in ("rad/s", "m/s", "rad", "m") else None
    converted = (first.attrs.get("converted_from") or {}).get("u")
    listed = []
    for record, path in zip(records, paths, strict=True):
        if path is None or not Path(path).is_file():
            continue
        t = record["t"].to_numpy(dtype=float)
        listed.append({"file": Path(path).name, "sha256": file_sha256(path), "samples": len(record),
                       "start": float(t[0]), "stop": float(t[-1])})  # fmt: skip
    timing = record_timing(first.attrs)
    return ModelCard(
        input_unit=input_unit,
        supply_voltage=supply_voltage if (input_unit == "V" and converted in ("%", "counts")) else None,
        input_full_scale=input_full_scale if converted == "counts" else None,
        output_unit=output,
        dt=float(first.attrs["dt"]) if first.attrs.get("dt") else None,
        timing=timing,
        records=tuple(listed),
    )


def with_parameters(
    card: ModelCard, standard_errors: Mapping[str, float], params: Sequence[str], undetermined: Sequence[str]
) -> ModelCard:
    """``card`` with each parameter of ``params``: its standard error (None where none is known)
    and whether the records determined it (not in ``undetermined``).

    Parameters
    ----------
    card : ModelCard
        The card to complete.
    standard_errors : mapping of str to float
        Parameter name -> its standard error [the parameter's unit].
    params : sequence of str
        The model's parameters.
    undetermined : sequence of str
        The parameters the records did not determine.
    """
    table = {
        name: {"standard_error": standard_errors.get(name), "determined": name not in undetermined}
        for name in params
    }
    return dataclasses.replace(card, parameters=table)


def estimator_parameters(estimator: Any, residual_variance: float) -> dict[str, dict[str, Any]]:
    """The ``parameters`` of an identified estimator's card: each parameter's standard error
    [its unit] and whether the record determined it.

    - An RLS on a lagged regression (ARX, Hammerstein; :class:`~motorid.estimators.rls.LaggedRegressionRLS`).
      With the forgetting factor λ = 1, RLS is the Kalman filter of ``y = φᵀθ + e`` with
      ``Var e = R``, so ``P⁻¹ = P₀⁻¹ + Σ φφᵀ / R`` with ``P₀ = δ I``; the least-squares covariance
      ``σ² (Σ φφᵀ)⁻¹`` of the estimate is then, where the data outweigh the prior,

          Cov θ = (σ² / R) P,

      with ``σ²`` ``residual_variance``: the mean square of the one-step prediction errors over
      the scored samples [output unit²] (a priori errors, a little above the a posteriori
      residuals: the standard errors err on the large side). With λ < 1, P weights the record's
      end, and so do the standard errors. The parameters are ARX's ``a1..a_na``, ``b_k0..b_nb``;
      Hammerstein's ``a1..``, ``b_k0..`` and ``gamma2..`` of step 2
      (:meth:`~motorid.estimators.hammerstein.HammersteinRLS.factorize`; ``gamma1 = 1`` by the
      normalisation, so none), their covariance ``J Cov θ Jᵀ`` with J the Jacobian of step 2 by
      central differences (the delta method). A parameter is determined where the record shrank
      its variance below :data:`DETERMINED_SHARE` of the prior's, ``(J P Jᵀ)_ii < ½ δ (J Jᵀ)_ii``.
    - A friction filter (EKF, UKF): its ``params`` give each parameter's standard deviation
      ``<name>_std``, the square root of the diagonal of P: the posterior covariance for the
      speed variance R the filter was given. Determined where ``P_ii < ½ P₀_ii``.
    - Any other estimator: none (an empty table).

    Parameters
    ----------
    estimator : Estimator
        The identified estimator.
    residual_variance : float
        The one-step prediction errors' mean square [output unit²] (``motorid identify``'s
        ``scores.one_step.mse``).

    Returns
    -------
    dict
        Parameter name -> ``{"standard_error": float or None, "determined": bool}`` (None where
        the covariance is not finite).
    """
    from motorid.estimators.rls import LaggedRegressionRLS

    if isinstance(estimator, LaggedRegressionRLS):
        return _regression_parameters(estimator, residual_variance)
    params = getattr(estimator, "params", {})
    names = list(getattr(estimator, "state_names", ()))
    prior = getattr(estimator, "P0", None)
    table: dict[str, dict[str, Any]] = {}
    for name in params:
        std = params.get(f"{name}_std")
        if name.endswith("_std") or std is None or name not in names or prior is None:
            continue
        i = names.index(name)
        table[name] = {
            "standard_error": float(std) if math.isfinite(std) else None,
            "determined": bool(estimator.P[i, i] < DETERMINED_SHARE * prior[i, i]),
        }
    return table


def _regression_parameters(estimator: Any, residual_variance: float) -> dict[str, dict[str, Any]]:
    """:func:`estimator_parameters` of an RLS on a lagged regression."""
    theta = np.asarray(estimator.x, dtype=float)
    P = np.asarray(estimator.P, dtype=float)

    def named(x: np.ndarray) -> tuple[list[str], np.ndarray]:
        if not hasattr(estimator, "factorize"):
            return list(estimator.state_names), x
        b, gamma = estimator.factorize(x)
        a = x[: len(estimator.a)]
        names = [f"a{i}" for i in range(1, a.size + 1)]
        names += [f"b{k}" for k in range(estimator.k0, estimator.k0 + b.size)]
        names += [f"gamma{j}" for j in range(2, gamma.size + 1)]
        return names, np.concatenate([a, b, gamma[1:]])

    names, values = named(theta)
    # the Jacobian of the parameters in theta, by central differences (the identity for ARX)
    steps = 1e-7 * (np.abs(theta) + np.sqrt(np.abs(np.diag(P)))) + 1e-300
    jacobian = np.empty((values.size, theta.size))
    for j, h in enumerate(steps):
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        jacobian[:, j] = (named(up)[1] - named(down)[1]) / (2.0 * h)
    posterior = np.einsum("ij,jk,ik->i", jacobian, P, jacobian)  # diag(J P Jᵀ)
    prior = float(estimator.delta) * np.einsum("ij,ij->i", jacobian, jacobian)  # diag(J δI Jᵀ)
    variance = residual_variance / float(estimator.R) * posterior  # Cov = (σ²/R) J P Jᵀ
    return {
        name: {
            "standard_error": float(math.sqrt(max(v, 0.0))) if math.isfinite(v) else None,
            "determined": bool(math.isfinite(v) and post < DETERMINED_SHARE * pri),
        }
        for name, v, post, pri in zip(names, variance, posterior, prior, strict=True)
    }


def input_scale(
    card: ModelCard | None,
    units: Mapping[str, str] | None,
    name: str,
    supply_voltage: float | None = None,
    given_as: str = "this record is",
) -> tuple[float, str | None]:
    """The factor ``k`` such that ``k u`` is the record's input in the unit the model was fitted on,
    and a note when it is not 1.

    ``u_% = 100 u_V / V_s`` and ``u_V = u_% V_s / 100``, with the supply voltage ``V_s`` [V] the
    record was converted with (``supply_voltage``, ``--supply-voltage``) or the model's card holds.

    Parameters
    ----------
    card : ModelCard or None
        The model's card (None: nothing to check, factor 1).
    units : mapping, optional
        The record's ``attrs["units"]`` as read (``u`` in V or %).
    name : str
        The model file's name in the messages.
    supply_voltage : float, optional
        The supply voltage [V] that made the record's duty volts.
    given_as : str
        What gives the input, in the messages (``this record is``; a controller's commands).

    Raises
    ------
    DataError
        One line, naming the model file, the two units and what to give, where no supply voltage
        is known to convert.
    """
    fitted = None if card is None else card.input_unit
    given = (units or {}).get("u")
    if fitted is None or given is None or given == fitted or given not in ("V", "%"):
        return 1.0, None
    supply = supply_voltage if supply_voltage is not None else card.supply_voltage  # type: ignore[union-attr]
    fitted_words = "% duty" if fitted == "%" else fitted
    given_words = "% duty" if given == "%" else given
    if supply is None:
        raise DataError(
            f"{name} was fitted on {fitted_words}; {given_as} in {given_words}: give supply_voltage=... or "
            f"use a model fitted in {given_words}"
        )
    factor = 100.0 / supply if fitted == "%" else supply / 100.0
    whose = (
        "the record's input"
        if given_as == "this record is"
        else given_as.removesuffix(" commands") + "'s commands"
    )
    note = f"{name}: {whose} in {given_words} converted to the model's {fitted_words} ({supply:g} V supply)"
    logger.info(note)
    return factor, note


def check_output(card: ModelCard | None, units: Mapping[str, str] | None, name: str) -> None:
    """Refuse a record whose output is not the model's: another speed, or a position of another
    speed (a rigid drive runs in position on a record of positions).

    Parameters
    ----------
    card : ModelCard or None
        The model's card (None: nothing to check).
    units : mapping, optional
        The record's ``attrs["units"]`` as read (``y`` in SI units).
    name : str
        The model file's name in the message.

    Raises
    ------
    DataError
        One line naming the model file and the two units.
    """
    fitted = None if card is None else card.output_unit
    given = (units or {}).get("y")
    if fitted is None or given is None or SPEED_OF_POSITION.get(given, given) == fitted:
        return
    raise DataError(f"{name} was fitted on an output in {fitted}; this record's output is in {given}")


def check_record(
    cards: Mapping[str, ModelCard | None],
    units: Mapping[str, str] | None,
    supply_voltage: float | None = None,
) -> dict[str, tuple[float, str | None]]:
    """Each model's card against a record's units: its output checked (:func:`check_output`), and,
    for a card that names its input's unit, the factor and note of :func:`input_scale` (the
    ``input_scales`` of :func:`motorid.comparison.compare_models`).

    Parameters
    ----------
    cards : mapping of str to ModelCard or None
        Label (the model file's name) -> its card.
    units : mapping, optional
        The record's ``attrs["units"]`` as read.
    supply_voltage : float, optional
        The supply voltage [V] the record's duty was converted with.

    Raises
    ------
    DataError
        The first model whose card does not fit the record, in one line.
    """
    scales = {}
    for name, card in cards.items():
        check_output(card, units, name)
        if card is not None and card.input_unit is not None:
            scales[name] = input_scale(card, units, name, supply_voltage)
    return scales
