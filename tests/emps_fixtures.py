"""Where the tests find the measured data (EMPS, real small motors), and EMPS's published recipe.

The data folder is ``$MOTORID_DATA`` or, in a checkout with the shared data beside
it, ``../shared/data``. Tests that need the files skip with the reason otherwise.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from motorid.datasets import DATA_ENV_VAR, EMPS_FILES

REPO = Path(__file__).resolve().parents[1]


def data_roots() -> list[Path]:
    """``$MOTORID_DATA`` when set, then ``../shared/data`` beside the checkout."""
    roots = [Path(os.environ[DATA_ENV_VAR])] if os.environ.get(DATA_ENV_VAR) else []
    return [*roots, REPO.parent / "shared" / "data"]


def real_motor_file(name: str) -> Path:
    """``realmotors/NAME`` in the first data root that has it (the first root's path otherwise)."""
    candidates = [root / "realmotors" / name for root in data_roots()]
    return next((path for path in candidates if path.is_file()), candidates[0])


def emps_folder() -> Path | None:
    """Folder holding the EMPS files, or None."""
    for root in data_roots():
        for folder in (root, root / "emps"):
            if all((folder / name).is_file() for name in EMPS_FILES.values()):
                return folder
    return None


requires_emps = pytest.mark.skipif(
    emps_folder() is None,
    reason=f"EMPS files ({', '.join(EMPS_FILES.values())}) not found in ${DATA_ENV_VAR} or ../shared/data",
)


def published_inverse_dynamics(t: np.ndarray, q: np.ndarray, force: np.ndarray, decimate: int = 12):
    """The EMPS README recipe, written out independently of motorid.diagnose.

    4th-order Butterworth low-pass at 100 Hz applied forward and backward to the
    position, velocity and acceleration by central differences, 50 edge samples
    dropped, every column (force too) decimated by ``decimate`` (1 kHz / 12 keeps
    about 40 Hz).

    Returns
    -------
    qd, qdd, force : ndarray
        Velocity [m/s], acceleration [m/s^2] and force [N] on the decimated grid.
    """
    dt = float(np.mean(np.diff(t)))
    b, a = scipy.signal.butter(4, 100.0, fs=1.0 / dt)
    qf = scipy.signal.filtfilt(b, a, q)
    qd = np.gradient(qf, dt)
    qdd = np.gradient(qd, dt)
    keep = slice(50, len(q) - 50)
    columns = [qd[keep], qdd[keep], force[keep]]
    return tuple(scipy.signal.decimate(c, decimate, ftype="fir", zero_phase=True) for c in columns)


def force_error_percent(force: np.ndarray, model: np.ndarray) -> float:
    """100 ||F - F_model|| / ||F||, the EMPS figure of merit."""
    return float(100.0 * np.linalg.norm(force - model) / np.linalg.norm(force))
