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
"""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd

from motorid.datasets import EMPS_INIT_SAMPLES, simulate_position
from motorid.drive.effects import get as get_effect
from motorid.drive.rigid import RigidDrive

logger = logging.getLogger(__name__)

#: Lower bound of each parameter that must be >= 0 (a level, a viscous coefficient) or > 0.
_LOWER = {
    "inertia": 1e-12, "stribeck_velocity": 1e-12, "viscous": 0.0, "coulomb": 0.0, "stribeck": 0.0,
    "quadratic_drag": -np.inf,
}  # fmt: skip


def refitted_parameters(model: RigidDrive) -> tuple[str, ...]:
    """The parameters :func:`refit_in_position` fits: the inertia and every parameter of the
    model's effects but the structure's (delay, lag) and a rest-only one (static friction).

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
        The same effects; :func:`refitted_parameters` refitted.
    """
    from scipy.optimize import least_squares

    names = refitted_parameters(model)
    y = record["y"].to_numpy(dtype=float)[init_samples:]
    x0 = np.array([model.params[n] for n in names])
    lower = np.array([_LOWER.get(n, -np.inf) for n in names])
    x0 = np.maximum(x0, np.where(np.isfinite(lower), lower, x0))

    def residual(x: np.ndarray) -> np.ndarray:
        trial = model.with_params(**dict(zip(names, x.tolist(), strict=True)))
        return simulate_position(trial, record, init_samples)[init_samples:] - y

    fit = least_squares(residual, x0, bounds=(lower, np.full(x0.size, np.inf)), x_scale=np.abs(x0) + 1e-3,
                        diff_step=1e-4)  # fmt: skip
    refitted = model.with_params(**dict(zip(names, fit.x.tolist(), strict=True)))
    logger.info(
        "refitted in position: RMS %.4g -> %.4g (%d evaluations)",
        float(np.sqrt(np.mean(residual(x0) ** 2))), float(np.sqrt(np.mean(fit.fun**2))), fit.nfev,
    )  # fmt: skip
    return refitted


__all__ = ["refit_in_position", "refitted_parameters"]
