"""PNG figures of a diagnosis: residual against speed before and after each step, and
the free-run simulation of each model against the measurement."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from motorid.figures import save, subplots

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from motorid.diagnose.workflow import Diagnosis, Prepared


def residual_figure(diagnosis: Diagnosis, prep: Prepared) -> Figure:
    """Torque-balance residual [F] against velocity [v]: one panel per step (before, after).

    The axes name the units of ``prep.units``: ``F`` is N or N m with a known
    input gain, else the input's unit (the model's forces per input unit).
    """
    from motorid.diagnose.workflow import balance_residual

    w = prep.data.w
    models = diagnosis.models
    pairs = list(itertools.pairwise(models)) or [(models[0], models[0])]
    fig, axes = subplots(len(pairs), 1, figsize=(8, 3.2 * len(pairs)), squeeze=False)
    for ax, ((lb, mb), (la, ma)) in zip(axes[:, 0], pairs, strict=True):
        rb, _ = balance_residual(mb, prep.data)
        ax.plot(w, rb, ".", ms=2.5, alpha=0.5, color="tab:red", label=f"before ({lb})")
        if ma is not mb:
            ra, _ = balance_residual(ma, prep.data)
            ax.plot(w, ra, ".", ms=2.5, alpha=0.5, color="tab:blue", label=f"after ({la})")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel(f"velocity w [{prep.units['v']}]")
        ax.set_ylabel(f"F_in - F_model [{prep.units['F']}]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8, markerscale=3)
    axes[0, 0].set_title("Torque-balance residual against speed")
    return fig


def plot_residual_vs_speed(diagnosis: Diagnosis, prep: Prepared, path: Path) -> Path:
    """Write :func:`residual_figure` as PNG at ``path``."""
    return save(residual_figure(diagnosis, prep), path)


def plot_simulation(diagnosis: Diagnosis, prep: Prepared, path: Path) -> Path:
    """Measured velocity and the free-run simulation of the initial and final models."""
    kin = prep.kin
    t = np.arange(kin.n) * kin.dt
    fig, (ax, ax_e) = subplots(2, 1, figsize=(10, 6), sharex=True)
    ax.plot(t, kin.w, lw=1.0, color="k", label="measured")
    err_axes = []
    for label, model in (
        (diagnosis.models[0], diagnosis.models[-1]) if diagnosis.steps else diagnosis.models[:1]
    ):
        sim = prep.simulate(model)
        ax.plot(t, sim, lw=0.8, label=f"free run, {label}")
        err_axes.append(ax_e.plot(t, kin.w - sim, lw=0.8, label=label))
    ax.set_ylabel(f"velocity [{prep.units['v']}]")
    ax.set_title("Simulation against measurement")
    ax_e.set_ylabel(f"measured - simulated [{prep.units['v']}]")
    ax_e.set_xlabel("time [s]")
    for a in (ax, ax_e):
        a.grid(alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    return save(fig, path)


def write_figures(diagnosis: Diagnosis, prep: Prepared, out_dir: Path) -> list[Path]:
    """Write ``doctor_residual_vs_speed.png`` and ``doctor_simulation.png`` in ``out_dir``."""
    return [
        plot_residual_vs_speed(diagnosis, prep, out_dir / "doctor_residual_vs_speed.png"),
        plot_simulation(diagnosis, prep, out_dir / "doctor_simulation.png"),
    ]


__all__ = ["plot_residual_vs_speed", "plot_simulation", "residual_figure", "write_figures"]
