"""PNG figures of a diagnosis: residual against speed before and after each step, and
the free-run simulation of each model against the measurement."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from motorid.figures import save, set_title, subplots

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from motorid.diagnose.prepare import Prepared
    from motorid.diagnose.results import Diagnosis


#: Most points of one series in the residual scatter; longer series show every k-th sample.
MAX_SCATTER = 50_000
#: Most time buckets of one line in the simulation figure; longer lines show each bucket's
#: minimum and maximum (a PNG a thousand pixels wide shows no more).
MAX_BUCKETS = 4_000


def envelope(t: np.ndarray, x: np.ndarray, buckets: int = MAX_BUCKETS) -> tuple[np.ndarray, np.ndarray, int]:
    """A long line thinned for plotting: the minimum and maximum of each run of samples.

    Parameters
    ----------
    t, x : ndarray, shape (N,)
        Time [s] and values (NaN allowed: a bucket of NaN stays NaN).
    buckets : int
        Most runs; with ``N <= 2 buckets`` the line is returned as it is.

    Returns
    -------
    t, x : ndarray
        Two points per run, at the run's first time: its minimum, then its maximum.
    size : int
        Samples per run (1: not thinned).
    """
    n = x.size
    if n <= 2 * buckets:
        return t, x, 1
    size = -(-n // buckets)
    padded = np.full(size * (-(-n // size)), np.nan)
    padded[:n] = x
    runs = padded.reshape(-1, size)
    lo, hi = np.fmin.reduce(runs, axis=1), np.fmax.reduce(runs, axis=1)
    starts = t[::size]
    return np.repeat(starts, 2), np.column_stack([lo, hi]).ravel(), size


def residual_figure(diagnosis: Diagnosis, prep: Prepared) -> Figure:
    """Torque-balance residual [F] against velocity [v]: one panel per step (before, after).

    The axes name the units of ``prep.units``: ``F`` is N or N m with a known
    input gain, else the input's unit (the model's forces per input unit).
    Above :data:`MAX_SCATTER` decimated samples every k-th is shown, and the
    title says so.

    Parameters
    ----------
    diagnosis : Diagnosis
        The doctor's result: its models before and after each step.
    prep : Prepared
        The record, prepared (decimated balance data and units).
    """
    step = -(-prep.data.n // MAX_SCATTER)
    w = prep.data.w[::step]
    models = diagnosis.models
    pairs = list(itertools.pairwise(models)) or [(models[0], models[0])]
    fig, axes = subplots(len(pairs), 1, figsize=(8, 3.2 * len(pairs)), squeeze=False)
    for ax, ((lb, mb), (la, ma)) in zip(axes[:, 0], pairs, strict=True):
        rb, _ = prep.balance_residual(mb)
        ax.plot(w, rb[::step], ".", ms=2.5, alpha=0.5, color="tab:red", label=f"before ({lb})")
        if ma is not mb:
            ra, _ = prep.balance_residual(ma)
            ax.plot(w, ra[::step], ".", ms=2.5, alpha=0.5, color="tab:blue", label=f"after ({la})")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel(f"velocity w [{prep.units['v']}]")
        ax.set_ylabel(f"F_in - F_model [{prep.units['F']}]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8, markerscale=3)
    title = "Torque-balance residual against speed"
    if step > 1:
        title += f" (1 in {step} of {prep.data.n} decimated samples shown)"
    set_title(axes[0, 0], title)
    return fig


def plot_residual_vs_speed(diagnosis: Diagnosis, prep: Prepared, path: Path) -> Path:
    """Write :func:`residual_figure` as PNG at ``path``.

    Parameters
    ----------
    diagnosis : Diagnosis
        The doctor's result.
    prep : Prepared
        The record, prepared.
    path : Path
        The PNG file to write.
    """
    return save(residual_figure(diagnosis, prep), path)


def simulation_figure(diagnosis: Diagnosis, prep: Prepared) -> Figure:
    """Measured velocity [v] and the free-run simulation of the initial and final models.

    Records longer than 2 :data:`MAX_BUCKETS` samples are drawn as the minimum
    and maximum of each run of samples (:func:`envelope`), and the title says so.

    Parameters
    ----------
    diagnosis : Diagnosis
        The doctor's result: its initial and final models.
    prep : Prepared
        The record, prepared (kinematics and units).
    """
    kin = prep.kin
    t = np.arange(kin.n) * kin.dt
    fig, (ax, ax_e) = subplots(2, 1, figsize=(10, 6), sharex=True)
    tt, ww, size = envelope(t, kin.w)
    ax.plot(tt, ww, lw=1.0, color="k", label="measured")
    for label, model in (
        (diagnosis.models[0], diagnosis.models[-1]) if diagnosis.steps else diagnosis.models[:1]
    ):
        sim = prep.simulate(model)
        ax.plot(*envelope(t, sim)[:2], lw=0.8, label=f"free run, {label}")
        ax_e.plot(*envelope(t, kin.w - sim)[:2], lw=0.8, label=f"measured - free run, {label}")
    title = "Simulation against measurement"
    if size > 1:
        title += f" (minimum and maximum of every {size} samples shown)"
    set_title(ax, title)
    ax.set_ylabel(f"velocity [{prep.units['v']}]")
    ax_e.set_ylabel(f"measured - simulated [{prep.units['v']}]")
    ax_e.set_xlabel("time [s]")
    for a in (ax, ax_e):
        a.grid(alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    return fig


def plot_simulation(diagnosis: Diagnosis, prep: Prepared, path: Path) -> Path:
    """Write :func:`simulation_figure` as PNG at ``path``.

    Parameters
    ----------
    diagnosis : Diagnosis
        The doctor's result.
    prep : Prepared
        The record, prepared.
    path : Path
        The PNG file to write.
    """
    return save(simulation_figure(diagnosis, prep), path)


def write_figures(diagnosis: Diagnosis, prep: Prepared, out_dir: Path, prefix: str = "doctor_") -> list[Path]:
    """Write ``{prefix}residual_vs_speed.png`` and ``{prefix}simulation.png`` in ``out_dir``.

    Parameters
    ----------
    diagnosis : Diagnosis
        The doctor's result.
    prep : Prepared
        The record, prepared.
    out_dir : Path
        The folder to write in.
    prefix : str
        The start of each file's name (``doctor_2_`` for a pool's second record).
    """
    return [
        plot_residual_vs_speed(diagnosis, prep, out_dir / f"{prefix}residual_vs_speed.png"),
        plot_simulation(diagnosis, prep, out_dir / f"{prefix}simulation.png"),
    ]


__all__ = [
    "envelope",
    "plot_residual_vs_speed",
    "plot_simulation",
    "residual_figure",
    "simulation_figure",
    "write_figures",
]
