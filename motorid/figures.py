"""PNG figures of an identification run, laid out like the paper's Figs. 8-15.

Every function takes plain arrays (time [s], input [V], speeds [rad/s], estimate
histories), shows speeds in rpm as the paper does, and writes one PNG file.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from motorid.validation import RPM_PER_RAD_S

DPI = 110


def subplots(
    nrows: int, ncols: int = 1, *, figsize: tuple[float, float], **kwargs: Any
) -> tuple[Figure, Any]:
    """A figure with constrained layout and its axes, outside pyplot.

    The figure belongs to no pyplot backend, so writing PNG files neither changes
    the backend of the caller (a notebook keeps its inline figures) nor leaves
    figures open; ``kwargs`` go to :meth:`matplotlib.figure.Figure.subplots`.
    """
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, ncols, **kwargs)


def save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as PNG at :data:`DPI`, whole (:func:`motorid.outputs.write_file`), creating the
    folder; returns the path."""
    from motorid.outputs import write_file

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_file(
        path, lambda fh: fig.savefig(fh, dpi=DPI, format="png"), overwrite=True, binary=True, sync=False
    )


def plot_input_response(t: np.ndarray, u: np.ndarray, y: np.ndarray, path: str | Path) -> Path:
    """Fig. 8: the test signal [V] (upper) and the measured speed [rpm] (lower)."""
    fig, (ax_u, ax_y) = subplots(2, 1, figsize=(9, 5), sharex=True)
    ax_u.plot(t, u, lw=0.8, color="tab:orange")
    ax_u.set_ylabel("armature voltage u [V]")
    ax_u.set_title("Input signal and system response")
    ax_y.plot(t, y * RPM_PER_RAD_S, lw=0.8)
    ax_y.set_ylabel("load speed y [rpm]")
    ax_y.set_xlabel("time t [s]")
    for ax in (ax_u, ax_y):
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="k", lw=0.5)
    return save(fig, path)


def low_speed_window(y: np.ndarray, width: int, threshold: float, skip: int = 0) -> slice:
    """The stretch of ``width`` samples after ``skip`` with the most samples below
    ``threshold`` in |y| (ties: the earliest), for a close look at low speed."""
    slow = (np.abs(y) < threshold).astype(float)
    if len(y) - skip <= width:
        return slice(skip, len(y))
    counts = np.convolve(slow[skip:], np.ones(width), mode="valid")
    start = skip + int(np.argmax(counts))
    return slice(start, start + width)


def plot_low_speed(
    t: np.ndarray,
    y: np.ndarray,
    predictions: Mapping[str, np.ndarray],
    window: slice,
    path: str | Path,
    title: str = "Measured and identified output at low speed",
) -> Path:
    """Figs. 9-11: measured (solid) and identified (dashed) output [rpm] in a
    low-speed window, one panel per model."""
    fig, axes = subplots(len(predictions), 1, figsize=(9, 2.6 * len(predictions)), sharex=True)
    for ax, (label, y_hat) in zip(np.atleast_1d(axes), predictions.items(), strict=True):
        ax.plot(t[window], y[window] * RPM_PER_RAD_S, "k-", lw=1.2, label="measured")
        ax.plot(t[window], y_hat[window] * RPM_PER_RAD_S, "--", lw=1.2, color="tab:red", label=label)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel("speed [rpm]")
        ax.set_title(label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    np.atleast_1d(axes)[-1].set_xlabel("time t [s]")
    fig.suptitle(title)
    return save(fig, path)


def identification_error_figure(
    t: np.ndarray, y: np.ndarray, predictions: Mapping[str, np.ndarray]
) -> Figure:
    """Fig. 12: the identification error y - y_hat [rpm], one panel per model, on
    one common scale.

    The scale is ±1.2 times the largest 99.5th percentile of |y - y_hat|, so a
    few samples of a panel may lie outside it: that panel's title then says
    the axis is clipped and how many samples it leaves out.
    """
    errors = {label: (y - y_hat) * RPM_PER_RAD_S for label, y_hat in predictions.items()}
    limit = max(float(np.percentile(np.abs(e), 99.5)) for e in errors.values()) * 1.2
    fig, axes = subplots(len(errors), 1, figsize=(9, 2.4 * len(errors)), sharex=True)
    for ax, (label, err) in zip(np.atleast_1d(axes), errors.items(), strict=True):
        ax.plot(t, err, lw=0.6)
        ax.set_ylim(-limit, limit)
        ax.set_ylabel("error [rpm]")
        outside = int(np.count_nonzero(np.abs(err) > limit))
        note = f" (y clipped to ±{limit:.3g} rpm; {outside} samples outside)" if outside else ""
        ax.set_title(f"identification error, {label}{note}")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[-1].set_xlabel("time t [s]")
    return fig


def plot_identification_error(
    t: np.ndarray, y: np.ndarray, predictions: Mapping[str, np.ndarray], path: str | Path
) -> Path:
    """Write :func:`identification_error_figure` (Fig. 12) as PNG at ``path``."""
    return save(identification_error_figure(t, y, predictions), path)


def plot_estimates(
    t: np.ndarray,
    groups: Sequence[tuple[str, Mapping[str, np.ndarray]]],
    path: str | Path,
    title: str,
) -> Path:
    """Figs. 13-15: parameter estimates converging, one panel per group
    (e.g. coefficients of A, of B, of the nonlinearity)."""
    fig, axes = subplots(len(groups), 1, figsize=(9, 2.6 * len(groups)), sharex=True)
    for ax, (ylabel, series) in zip(np.atleast_1d(axes), groups, strict=True):
        for name, values in series.items():
            ax.plot(t, values, lw=1.0, label=name)
        # scale to the settled estimates: the first tenth of the record is the start-up swing
        settled = np.concatenate([np.asarray(v, dtype=float)[len(v) // 10 :] for v in series.values()])
        settled = settled[np.isfinite(settled)]
        if settled.size:
            lo, hi = float(settled.min()), float(settled.max())
            pad = 0.15 * (hi - lo) + 1e-12
            ax.set_ylim(lo - pad, hi + pad)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8, ncol=min(len(series), 5))
    np.atleast_1d(axes)[-1].set_xlabel("time t [s]")
    fig.suptitle(title)
    return save(fig, path)
