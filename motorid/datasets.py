"""Loaders for real measured data.

EMPS
----
The electro-mechanical positioning system of Janot, Gautier and Brunot (2019,
"Data set and reference models of EMPS", Workshop on Nonlinear System
Identification Benchmarks): a DC motor drives a ball-screw prismatic axis, one
rigid mass in linear motion with viscous and Coulomb friction, run in closed
loop (a proportional position loop around a velocity loop) and sampled at 1 kHz.
The published reference model is the inverse dynamics

.. math::

    g_\\tau v_{ir} = M \\ddot q + F_v \\dot q + F_c \\operatorname{sgn}(\\dot q) + \\text{offset}

with ``M = 95.1089 kg``, ``Fv = 203.5034 N s/m``, ``Fc = 20.3935 N`` and
``offset = -3.1648 N`` (force error 4.08 % on the estimation set, 5.98 % on the
validation set). Please cite the authors when you use the data.

The benchmark's protocol (nonlinearbenchmark.org): train on the estimation set
``DATA_EMPS``; on the test set ``DATA_EMPS_PULSES`` simulate the position from the
controller output ``vir`` alone, the model's state set from the first
:data:`EMPS_INIT_SAMPLES` measured positions, and score the simulation by its RMSE in
mm over the samples after them (:func:`emps_benchmark_rmse`; published figures in
:data:`EMPS_BENCHMARK_RESULTS`).

The files are not shipped with motorid. Pass their path, or set the environment
variable ``MOTORID_DATA`` to a folder holding them (directly or in an ``emps/``
sub-folder).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np
import pandas as pd

if TYPE_CHECKING:
    from motorid.drive.rigid import RigidDrive

#: Environment variable naming the folder with measured data.
DATA_ENV_VAR = "MOTORID_DATA"

#: File of each EMPS set.
EMPS_FILES: dict[str, str] = {
    "estimation": "DATA_EMPS.mat",
    "validation": "DATA_EMPS_PULSES.mat",
}

#: Published symmetric reference model (Janot et al. 2019), SI units.
EMPS_REFERENCE: dict[str, float] = {
    "mass": 95.1089,  # [kg]
    "viscous": 203.5034,  # [N s/m]
    "coulomb": 20.3935,  # [N]
    "offset": -3.1648,  # [N]
    "force_error_estimation": 4.08,  # [%]
    "force_error_validation": 5.98,  # [%]
}

#: Measured positions at the start of the test set a model may use to set its state.
EMPS_INIT_SAMPLES = 20

#: Published simulation RMSE on the EMPS test set [mm] by the benchmark's protocol
#: (:func:`emps_benchmark_rmse`), from the benchmark's table of results.
EMPS_BENCHMARK_RESULTS: dict[str, float] = {
    "LTI state space": 5.53,
    "polynomial NARX": 5.17,
    "dynoNet": 0.452,
}

_SIGNALS = ("t", "qm", "qg", "vir")
_SCALARS = ("gtau", "kp", "kv")
_UNITS = {"t": "s", "u": "V", "force": "N", "y": "m", "reference": "m", "pulses": "N"}


def emps_path(
    path: str | os.PathLike | None = None, which: Literal["estimation", "validation"] = "estimation"
) -> Path:
    """Locate an EMPS file.

    Parameters
    ----------
    path : path-like, optional
        The ``.mat`` file itself, or a folder holding it (directly or in ``emps/``).
        When omitted, the folder named by the ``MOTORID_DATA`` environment variable.
    which : {"estimation", "validation"}
        ``DATA_EMPS.mat`` or ``DATA_EMPS_PULSES.mat``.

    Raises
    ------
    ValueError
        For an unknown ``which``.
    FileNotFoundError
        When the file is not there; the message lists where it looked.
    """
    if which not in EMPS_FILES:
        raise ValueError(f"which must be one of {sorted(EMPS_FILES)}, got {which!r}")
    if path is None:
        root = os.environ.get(DATA_ENV_VAR)
        if not root:
            raise FileNotFoundError(
                f"no path given and {DATA_ENV_VAR} is not set: pass the path of {EMPS_FILES[which]} "
                f"or set {DATA_ENV_VAR} to the folder holding it"
            )
        path = root
    path = Path(path).expanduser()
    if path.is_file():
        return path
    candidates = [path / EMPS_FILES[which], path / "emps" / EMPS_FILES[which]]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    looked = ", ".join(str(c) for c in candidates)
    raise FileNotFoundError(f"EMPS {which} file {EMPS_FILES[which]} not found; looked at {looked}")


def load_emps(
    path: str | os.PathLike | None = None, which: Literal["estimation", "validation"] = "estimation"
) -> pd.DataFrame:
    """Read an EMPS measurement as a motorid record.

    Parameters
    ----------
    path : path-like, optional
        The ``.mat`` file or a folder holding it; see :func:`emps_path`.
    which : {"estimation", "validation"}
        Which set, when ``path`` is a folder.

    Returns
    -------
    DataFrame
        Columns ``t`` [s], ``u`` = controller output ``vir`` [V], ``force`` =
        ``gtau * vir`` [N], ``y`` = measured load position ``qm`` [m],
        ``reference`` = position set-point ``qg`` [m], and in the validation set
        ``pulses`` [N], the 0/5 N force pulses added on the load. ``attrs`` carry
        ``dt`` [s] (mean sample interval), ``units``, ``input_gain`` (gtau [N/V]),
        ``kp`` [1/s], ``kv`` [V/(m/s)], ``output_kind`` ("position"), ``timing`` ("sampled": the
        controller reads ``qm[k]``, then holds ``vir[k]`` over the next interval; see
        :func:`motorid.diagnose.diagnose`) and ``source``.

    Raises
    ------
    FileNotFoundError
        When the file is missing.
    ValueError
        When the file lacks a variable, the signals differ in length, a sample is
        not finite (the message names the variable and the sample index), or time
        does not increase.
    """
    import scipy.io  # here, not at the top: the doctor imports this module for its position fits only

    file = emps_path(path, which)
    try:
        mat = scipy.io.loadmat(file)
    except (ValueError, OSError, scipy.io.matlab.MatReadError) as err:
        raise ValueError(f"{file} is not a readable MATLAB file: {err}") from err
    missing = [name for name in (*_SIGNALS, *_SCALARS) if name not in mat]
    if missing:
        raise ValueError(f"{file} lacks the variable(s) {', '.join(missing)}")
    signals = {name: np.asarray(mat[name], dtype=float).ravel() for name in _SIGNALS}
    if "pulses_N" in mat:
        signals["pulses_N"] = np.asarray(mat["pulses_N"], dtype=float).ravel()
    n = len(signals["t"])
    for name, values in signals.items():
        if len(values) != n:
            raise ValueError(f"{file}: variable {name} has {len(values)} samples, t has {n}")
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ValueError(f"{file}: variable {name} is not finite at sample {bad[0]}")
    steps = np.diff(signals["t"])
    if n < 2 or np.any(steps <= 0):
        index = int(np.flatnonzero(steps <= 0)[0]) + 1 if n >= 2 else 0
        raise ValueError(f"{file}: t does not increase at sample {index}")
    scalars = {name: float(np.asarray(mat[name], dtype=float).ravel()[0]) for name in _SCALARS}
    frame = pd.DataFrame(
        {
            "t": signals["t"],
            "u": signals["vir"],
            "force": scalars["gtau"] * signals["vir"],
            "y": signals["qm"],
            "reference": signals["qg"],
        }
    )
    if "pulses_N" in signals:
        frame["pulses"] = signals["pulses_N"]
    frame.attrs.update(
        dt=float(np.mean(steps)),
        units={name: _UNITS[name] for name in frame.columns},
        input_gain=scalars["gtau"],
        kp=scalars["kp"],
        kv=scalars["kv"],
        output_kind="position",
        timing="sampled",
        source=f"EMPS {which} set ({file.name}), Janot, Gautier and Brunot 2019",
    )
    return frame


def load_emps_benchmark(path: str | os.PathLike | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The benchmark's train set (``DATA_EMPS``) and test set (``DATA_EMPS_PULSES``), as
    :func:`load_emps` reads them; ``path`` as in :func:`emps_path` (a folder)."""
    return load_emps(path, "estimation"), load_emps(path, "validation")


def _positions(
    drive: RigidDrive, u: np.ndarray, sampled: bool, w0: float, q0: float, samples: int | None = None
) -> np.ndarray:
    """Positions for ``y[0], y[1], ...`` of a drive started at speed ``w0``, position ``q0``:
    on a sampled record ``y[0]`` is the start and ``u[k]`` ends at ``y[k + 1]``; on a hold
    record ``u[k]`` ends at ``y[k]``. ``samples``: only the first ones."""
    n = u.size if samples is None else samples
    if sampled:
        _, position = drive.motion(u[: n - 1], w0=w0, q0=q0)
        return np.r_[q0, position]
    return drive.motion(u[:n], w0=w0, q0=q0)[1]


def initial_state(
    model: RigidDrive, record: pd.DataFrame, samples: int = EMPS_INIT_SAMPLES
) -> tuple[float, float]:
    """The state of a rigid drive at the start of ``record`` read from its first ``samples``
    positions: speed ``w0`` [m/s or rad/s] and position ``q0`` [m or rad].

    A rigid drive's state is its position and speed. They are the start from which the
    model's own free run on the record's input fits ``y[:samples]`` best::

        (w0, q0) = argmin Σ_{k < samples} (y[k] - q_sim[k; w0, q0])²

    The position enters the run as an added constant, so for each ``w0`` its best ``q0`` is
    the mean gap; ``w0`` is found by a bounded scalar search (SciPy's ``minimize_scalar``)
    within twice the largest speed the window's differences show. On a record the model
    made, this is the state it started from; unlike a polynomial through the window, it
    holds when the acceleration changes within the window.

    Raises
    ------
    ValueError
        For fewer than 3 samples, or a record shorter than ``samples``.
    """
    from scipy.optimize import minimize_scalar

    from motorid.io.records import record_timing

    if samples < 3:
        raise ValueError(f"samples must be at least 3 (a position and a speed from them), got {samples}")
    y = record["y"].to_numpy(dtype=float)
    if y.size < samples:
        raise ValueError(f"the record has {y.size} samples, fewer than the {samples} of the initialisation")
    u = record["u"].to_numpy(dtype=float)
    dt = float(record.attrs["dt"])
    drive = model.replace(dt=dt)
    sampled = record_timing(record.attrs) == "sampled"
    window = y[:samples]

    def gap(w0: float) -> np.ndarray:
        return window - _positions(drive, u, sampled, w0, 0.0, samples)

    def spread(w0: float) -> float:
        e = gap(w0)
        return float(np.sum((e - e.mean()) ** 2))

    reach = 2.0 * float(np.max(np.abs(np.diff(window)))) / dt + 1e-12
    w0 = float(
        minimize_scalar(spread, bounds=(-reach, reach), method="bounded", options={"xatol": 1e-9 * reach}).x
    )
    return w0, float(np.mean(gap(w0)))


def simulate_position(
    model: RigidDrive, record: pd.DataFrame, init_samples: int = EMPS_INIT_SAMPLES
) -> np.ndarray:
    """The position of ``record`` simulated by ``model`` from its input ``u`` alone, started from
    the state read off the first ``init_samples`` measured positions ``y`` (:func:`initial_state`).

    The model runs at the record's sample time (``attrs["dt"]``) and pairs input and output by
    the record's timing (:func:`motorid.io.records.record_timing`): on a ``"sampled"`` record
    (EMPS: the controller reads ``y[k]``, then holds ``u[k]``) ``u[k]`` moves the drive to
    ``y[k + 1]``; on a ``"hold"`` record (motorid's own) ``u[k]`` ends at ``y[k]``.

    Returns
    -------
    numpy.ndarray, shape (N,)
        The measured positions for the first ``init_samples`` samples, the simulated ones after.
    """
    from motorid.io.records import record_timing

    w0, q0 = initial_state(model, record, init_samples)
    u = record["u"].to_numpy(dtype=float)
    drive = model.replace(dt=float(record.attrs["dt"]))
    position = _positions(drive, u, record_timing(record.attrs) == "sampled", w0, q0)
    return np.r_[record["y"].to_numpy(dtype=float)[:init_samples], position[init_samples:]]


def emps_benchmark_rmse(
    model: RigidDrive, test: pd.DataFrame | None = None, path: str | os.PathLike | None = None
) -> float:
    """The EMPS benchmark's figure of a model: the RMSE [mm] of the simulated position of the
    test set after its first :data:`EMPS_INIT_SAMPLES` samples::

        RMSE = 1000 sqrt(mean_k (y[k] - y_sim[k])²),   k >= 20      [mm]

    with ``y_sim`` of :func:`simulate_position`. Compare it with :data:`EMPS_BENCHMARK_RESULTS`.

    Parameters
    ----------
    model : RigidDrive
        A drive in the record's units: input in V (``vir``) through its input gain [N/V],
        velocity in m/s, position in m (``motorid doctor --output-kind position
        --input-gain GTAU`` on the train set gives one).
    test : DataFrame, optional
        The test set as :func:`load_emps` reads it (or any record in those units); by default
        ``DATA_EMPS_PULSES`` from ``path``.
    path : path-like, optional
        Where the EMPS files are (:func:`emps_path`), when ``test`` is not given.
    """
    if test is None:
        test = load_emps(path, "validation")
    y = test["y"].to_numpy(dtype=float)
    error = y[EMPS_INIT_SAMPLES:] - simulate_position(model, test)[EMPS_INIT_SAMPLES:]
    return float(1000.0 * np.sqrt(np.mean(error**2)))
