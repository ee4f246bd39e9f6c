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

The files are not shipped with motorid. Pass their path, or set the environment
variable ``MOTORID_DATA`` to a folder holding them (directly or in an ``emps/``
sub-folder).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
import scipy.io

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
