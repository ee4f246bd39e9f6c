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

import pandas as pd

from motorid.datasets import EMPS_INIT_SAMPLES, simulate_position
from motorid.diagnose.model import fit_output_error
from motorid.drive.rigid import RigidDrive


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


__all__ = ["refit_in_position"]
