"""A rigid drive's parameters fitted to a position record's free run (output error in position).

The doctor fits the torque balance (equation error): every sample weighs alike, whatever
its frequency. A position simulated free from a record's input weighs the slow part of the
force balance far more: a force error ΔF held over a move of T seconds moves the end
position by about ΔF T / B (B the viscous coefficient). On the EMPS axis 0.1 N, half a
percent of its Coulomb friction, is about 1 mm over a 2 s move. So the doctor's model,
right to 2-3 % in force, can still drift millimetres in position.

:func:`refit_in_position` keeps the doctor's effects and fits their parameters to the
position itself::

    θ* = argmin_θ Σ_{k >= n0} (y[k] - q_sim[k; θ])²

with ``q_sim`` the free run of the record (:func:`motorid.datasets.simulate_position`: its
state read from the first ``n0`` positions, then the input alone), started from the
doctor's values (SciPy's ``least_squares``, trust region reflective, within each
parameter's sign). The input gain stays (it sets the force scale), and so do the input
delay and lag the doctor chose and a static friction's breakaway (the free run does not
change smoothly with them).

:func:`held_out_position_error` is the check the doctor adds on a position record
(:meth:`Search.judge <motorid.diagnose.search.Search.judge>`): each half of every record is
predicted in position by the model fitted to the torque balance of the other halves. A
position free run integrates the force error twice, so what an effect does to the slow force
balance shows only over a long horizon: the two halves are the longest held-out parts a
record has. Over the EMPS train set's ten 2.5 s blocks (each predicted by the model fitted to
the other nine) the viscous asymmetry lowers the held-out position error from 3.9 to 1.6 mm;
over its two 12 s halves it raises it (6.45 -> 6.51 mm), as it raises the benchmark's test
set's (6.7 -> 9.1 mm).

:func:`refit_records_in_position` is the doctor's last stage on position records: the final
model's parameters fitted to the free-run position of every record, reported beside the
model fitted to the balance.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from motorid.datasets import EMPS_INIT_SAMPLES, simulate_position
from motorid.diagnose.measures import fit_static_friction, rms
from motorid.diagnose.model import fit_model, fit_output_error, stacked
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive

if TYPE_CHECKING:
    from motorid.diagnose.prepare import Pool, Prepared

#: The held-out parts of a position record's free-run check: its halves.
POSITION_FOLDS = 2


def refit_in_position(
    model: RigidDrive, record: pd.DataFrame, init_samples: int = EMPS_INIT_SAMPLES
) -> RigidDrive:
    """``model`` with its parameters fitted to the position of ``record`` by output error.

    Parameters
    ----------
    model : RigidDrive
        The starting model (the doctor's), in the record's units: input through its input
        gain, position in ``y`` [m or rad].
    record : DataFrame
        Columns ``u`` and ``y`` (a position), ``attrs["dt"]`` and ``attrs["timing"]``, as
        :func:`motorid.datasets.load_emps` reads the EMPS train set.
    init_samples : int
        Positions the free run reads its state from (:func:`motorid.datasets.initial_state`);
        the error is summed after them.

    Returns
    -------
    RigidDrive
        The same effects; :func:`~motorid.diagnose.model.refitted_parameters` refitted
        (:func:`~motorid.diagnose.model.fit_output_error`).
    """
    y = record["y"].to_numpy(dtype=float)[init_samples:]
    return fit_output_error(
        model, lambda trial: simulate_position(trial, record, init_samples)[init_samples:] - y
    )


def position_unit(v: str) -> str:
    """The position unit of a speed unit ``v`` (``"m/s"`` -> ``"m"``).

    Parameters
    ----------
    v : str
        The speed unit.
    """
    return v[: -len("/s")] if v.endswith("/s") else f"{v} s"


def record_part(prep: Prepared, fold: int, folds: int = POSITION_FOLDS) -> tuple[pd.DataFrame, np.ndarray]:
    """One of ``folds`` equal parts of a prepared position record's settled span, in time.

    Parameters
    ----------
    prep : Prepared
        The record (a position record: ``kin.q`` is its low-passed measured position).
    fold : int
        Which part, from 0.
    folds : int
        How many parts.

    Returns
    -------
    DataFrame, ndarray of bool, ndarray of bool
        The part as a record (``u``, ``y`` the position, ``attrs`` ``dt`` and ``timing``), and the
        record's decimated rows and full-rate samples that lie outside it (what a model that
        predicts it is fitted on).
    """
    kin = prep.kin
    valid = np.flatnonzero(kin.valid)
    edges = np.linspace(valid[0], valid[-1] + 1, folds + 1).round().astype(int)
    lo, hi = int(edges[fold]), int(edges[fold + 1])
    part = pd.DataFrame({"u": kin.u[lo:hi], "y": kin.q[lo:hi]})
    part.attrs.update(dt=kin.dt, timing=prep.timing)
    idx, samples = prep.data.idx, np.arange(kin.n)
    return part, (idx < lo) | (idx >= hi), (samples < lo) | (samples >= hi)


def held_out_position_error(
    pool: Pool,
    effects: tuple[str, ...],
    start: dict[str, float] | None,
    stribeck_shape: str,
    fixed: dict[str, float] | None,
    init_samples: int = EMPS_INIT_SAMPLES,
) -> float:
    """RMS free-run position error [m or rad] of a model on held-out halves of position records.

    Each record's settled span is cut in :data:`POSITION_FOLDS` parts in time. For each part
    ``f`` the model with ``effects`` is fitted to the torque balance of the other parts of every
    record (:func:`~motorid.diagnose.model.fit_model`; static friction to their rests,
    :func:`~motorid.diagnose.measures.fit_static_friction`), and each record's part ``f`` is simulated
    from its input alone, its state read from its first ``init_samples`` positions
    (:func:`motorid.datasets.simulate_position`)::

        e = sqrt(mean_{f, k >= n0} (y_f[k] - q_sim,f[k; θ_(-f)])²)

    Parameters
    ----------
    pool : Pool
        The records of the drive (position records).
    effects : tuple of str
        The model's effects.
    start : dict or None
        Parameters the fits start from.
    stribeck_shape : str
        The Stribeck shape of the fits.
    fixed : dict or None
        Parameters held fixed in the fits (the structure's delay and lag).
    init_samples : int
        Positions each part's state is read from; the error is summed after them.
    """
    errors = []
    for fold in range(POSITION_FOLDS):
        parts = [record_part(p, fold) for p in pool.parts]
        rows = stacked([outside for _, outside, _ in parts])
        model = fit_model(pool.data, effects, rows=rows, start=start, stribeck_shape=stribeck_shape,
                          fixed=fixed).model  # fmt: skip
        if any(get_effect(n).rest_only for n in effects):
            model = fit_static_friction(pool, model, [outside for _, _, outside in parts])
        for part, _, _ in parts:
            y = part["y"].to_numpy(dtype=float)[init_samples:]
            errors.append(simulate_position(model, part, init_samples)[init_samples:] - y)
    return rms(np.concatenate(errors))


def refit_records_in_position(
    pool: Pool, model: RigidDrive, init_samples: int = EMPS_INIT_SAMPLES
) -> tuple[RigidDrive, float, float]:
    """``model`` with its parameters fitted to the free-run position of every record of ``pool``
    (the doctor's last stage on position records), and the position error before and after.

    Each record's settled span is simulated from its input alone, its state read from its first
    ``init_samples`` positions (:func:`motorid.datasets.simulate_position`), and the parameters
    minimise the pooled error (:func:`~motorid.diagnose.model.fit_output_error`)::

        θ* = argmin_θ Σ_i Σ_{k >= n0} (y_i[k] - q_sim,i[k; θ])²

    Parameters
    ----------
    pool : Pool
        The records of the drive (position records).
    model : RigidDrive
        The doctor's final model, fitted to the torque balance.
    init_samples : int
        Positions each record's state is read from; the error is summed after them.

    Returns
    -------
    RigidDrive, float, float
        The refitted model, and the RMS free-run position error [m or rad] of ``model`` and of
        the refitted model on the records.
    """
    parts = [record_part(p, 0, folds=1)[0] for p in pool.parts]

    def error(trial: RigidDrive) -> np.ndarray:
        return np.concatenate([
            simulate_position(trial, part, init_samples)[init_samples:]
            - part["y"].to_numpy(dtype=float)[init_samples:]
            for part in parts
        ])  # fmt: skip

    refitted = fit_output_error(model, error)
    return refitted, rms(error(model)), rms(error(refitted))


__all__ = [
    "POSITION_FOLDS",
    "held_out_position_error",
    "position_unit",
    "record_part",
    "refit_in_position",
    "refit_records_in_position",
]
