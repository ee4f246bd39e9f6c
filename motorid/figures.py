"""PNG figures of an identification run, laid out like the paper's Figs. 8-15.

Every function takes plain arrays (time [s], input, output, estimate histories)
and the units they are in (``units``, a record's ``attrs["units"]``; motorid's
own V and rad/s by default): a speed in rad/s is shown in rpm as the paper does,
any other unit as it is, and a quantity whose unit the record does not name is
labelled "input units" or "output units" (:mod:`motorid.units`). ``*_figure``
builds a figure, ``plot_*`` writes it as one PNG file.

Titles that would not fit the figure's width are wrapped (:func:`set_title`).
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from motorid.units import MOTORID_RECORD_UNITS, input_unit_name, shown_output

DPI = 110
#: Room an axes title leaves on the figure's width for the axis labels at its left [in].
_AXES_TITLE_MARGIN = 1.2
#: Room a figure title leaves on the figure's width [in].
_FIGURE_TITLE_MARGIN = 0.3


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


def set_title(target: Axes | Figure, text: str, **kwargs: Any) -> None:
    """Title an axes (or a figure: its ``suptitle``), wrapped into lines that fit the figure's width.

    The width of each line is measured with the font the title is drawn in, so a
    long title (a model's name with a note) breaks between words instead of
    running past the figure's edge; ``kwargs`` go to ``set_title``/``suptitle``
    (``fontsize`` among them). An axes title may take the figure's width less
    the room of the axis labels at its left: the figures here have one column.
    """
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.font_manager import FontProperties

    is_figure = isinstance(target, Figure)
    fig = target if is_figure else target.figure
    size = kwargs.get("fontsize", "figure.titlesize" if is_figure else "axes.titlesize")
    font = FontProperties(size=_rc_size(size))
    margin = _FIGURE_TITLE_MARGIN if is_figure else _AXES_TITLE_MARGIN
    room = (fig.get_figwidth() - margin) * fig.dpi
    renderer = RendererAgg(1, 1, fig.dpi)

    def fits(line: str) -> bool:
        return renderer.get_text_width_height_descent(line, font, ismath=False)[0] <= room

    width = len(text)
    lines = [text]
    while width > 10 and not all(fits(line) for line in lines):
        width -= 2
        lines = textwrap.wrap(text, width, break_long_words=False)
    wrapped = "\n".join(lines)
    if is_figure:
        target.suptitle(wrapped, **kwargs)
    else:
        target.set_title(wrapped, **kwargs)


def _rc_size(size: Any) -> Any:
    """A font size, or the size an rcParams key such as ``axes.titlesize`` holds."""
    import matplotlib as mpl

    return mpl.rcParams[size] if isinstance(size, str) and size in mpl.rcParams else size


def save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as PNG at :data:`DPI`, whole (:func:`motorid.outputs.write_file`), creating the
    folder; returns the path."""
    from motorid.outputs import write_file

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_file(
        path, lambda fh: fig.savefig(fh, dpi=DPI, format="png"), overwrite=True, binary=True, sync=False
    )


def input_label(units: Mapping[str, str]) -> str:
    """The axis label of the input ``u``: the armature voltage in V, else the input in its unit."""
    unit = units.get("u")
    return "armature voltage u [V]" if unit == "V" else f"input u [{input_unit_name(unit)}]"


def input_response_figure(
    t: np.ndarray, u: np.ndarray, y: np.ndarray, units: Mapping[str, str] = MOTORID_RECORD_UNITS
) -> Figure:
    """Fig. 8: the test signal (upper) and the measured output (lower), in ``units``."""
    shown = shown_output(units.get("y"))
    fig, (ax_u, ax_y) = subplots(2, 1, figsize=(9, 5), sharex=True)
    ax_u.plot(t, u, lw=0.8, color="tab:orange")
    ax_u.set_ylabel(input_label(units))
    set_title(ax_u, "Input signal and system response")
    ax_y.plot(t, y * shown.factor, lw=0.8)
    ax_y.set_ylabel(f"measured {shown.quantity} y [{shown.unit}]")
    ax_y.set_xlabel("time t [s]")
    for ax in (ax_u, ax_y):
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="k", lw=0.5)
    return fig


def plot_input_response(
    t: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    path: str | Path,
    units: Mapping[str, str] = MOTORID_RECORD_UNITS,
) -> Path:
    """Write :func:`input_response_figure` (Fig. 8) as PNG at ``path``."""
    return save(input_response_figure(t, u, y, units), path)


def low_speed_window(y: np.ndarray, width: int, threshold: float, skip: int = 0) -> slice:
    """The stretch of ``width`` samples after ``skip`` with the most samples below
    ``threshold`` in |y| (ties: the earliest), for a close look at low speed."""
    slow = (np.abs(y) < threshold).astype(float)
    if len(y) - skip <= width:
        return slice(skip, len(y))
    counts = np.convolve(slow[skip:], np.ones(width), mode="valid")
    start = skip + int(np.argmax(counts))
    return slice(start, start + width)


def low_speed_figure(
    t: np.ndarray,
    y: np.ndarray,
    predictions: Mapping[str, np.ndarray],
    window: slice,
    title: str = "Measured and identified output at low speed",
    units: Mapping[str, str] = MOTORID_RECORD_UNITS,
) -> Figure:
    """Figs. 9-11: measured (solid) and identified (dashed) output in a low-speed
    window, one panel per model, in ``units``."""
    shown = shown_output(units.get("y"))
    fig, axes = subplots(len(predictions), 1, figsize=(9, 2.6 * len(predictions)), sharex=True)
    for ax, (label, y_hat) in zip(np.atleast_1d(axes), predictions.items(), strict=True):
        ax.plot(t[window], y[window] * shown.factor, "k-", lw=1.2, label="measured")
        ax.plot(t[window], y_hat[window] * shown.factor, "--", lw=1.2, color="tab:red", label=label)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(f"{shown.quantity} [{shown.unit}]")
        set_title(ax, label)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    np.atleast_1d(axes)[-1].set_xlabel("time t [s]")
    set_title(fig, title)
    return fig


def plot_low_speed(
    t: np.ndarray,
    y: np.ndarray,
    predictions: Mapping[str, np.ndarray],
    window: slice,
    path: str | Path,
    title: str = "Measured and identified output at low speed",
    units: Mapping[str, str] = MOTORID_RECORD_UNITS,
) -> Path:
    """Write :func:`low_speed_figure` (Figs. 9-11) as PNG at ``path``."""
    return save(low_speed_figure(t, y, predictions, window, title, units), path)


def identification_error_figure(
    t: np.ndarray,
    y: np.ndarray,
    predictions: Mapping[str, np.ndarray],
    units: Mapping[str, str] = MOTORID_RECORD_UNITS,
) -> Figure:
    """Fig. 12: the identification error y - y_hat, one panel per model, on one
    common scale, in ``units``.

    The scale is ±1.2 times the largest 99.5th percentile of |y - y_hat|, so a
    few samples of a panel may lie outside it: that panel's title then says
    the axis is clipped and how many samples it leaves out.
    """
    shown = shown_output(units.get("y"))
    errors = {label: (y - y_hat) * shown.factor for label, y_hat in predictions.items()}
    limit = max(float(np.percentile(np.abs(e), 99.5)) for e in errors.values()) * 1.2
    fig, axes = subplots(len(errors), 1, figsize=(9, 2.4 * len(errors)), sharex=True)
    for ax, (label, err) in zip(np.atleast_1d(axes), errors.items(), strict=True):
        ax.plot(t, err, lw=0.6)
        ax.set_ylim(-limit, limit)
        ax.set_ylabel(f"y - y_hat [{shown.unit}]")
        outside = int(np.count_nonzero(np.abs(err) > limit))
        note = f" (y clipped to ±{limit:.3g} {shown.unit}; {outside} samples outside)" if outside else ""
        set_title(ax, f"identification error, {label}{note}")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[-1].set_xlabel("time t [s]")
    return fig


def plot_identification_error(
    t: np.ndarray,
    y: np.ndarray,
    predictions: Mapping[str, np.ndarray],
    path: str | Path,
    units: Mapping[str, str] = MOTORID_RECORD_UNITS,
) -> Path:
    """Write :func:`identification_error_figure` (Fig. 12) as PNG at ``path``."""
    return save(identification_error_figure(t, y, predictions, units), path)


def estimates_figure(
    t: np.ndarray, groups: Sequence[tuple[str, Mapping[str, np.ndarray]]], title: str
) -> Figure:
    """Figs. 13-15: parameter estimates converging, one panel per group
    (e.g. coefficients of A, of B, of the nonlinearity).

    Each group is ``(axis label with its unit, {name: estimate per sample})``.
    """
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
    set_title(fig, title)
    return fig


def plot_estimates(
    t: np.ndarray,
    groups: Sequence[tuple[str, Mapping[str, np.ndarray]]],
    path: str | Path,
    title: str,
) -> Path:
    """Write :func:`estimates_figure` (Figs. 13-15) as PNG at ``path``."""
    return save(estimates_figure(t, groups, title), path)
