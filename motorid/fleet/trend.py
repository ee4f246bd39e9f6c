"""Friction trends over a fleet: each drive's friction against record time, and the drives to look at.

From a results table (:func:`motorid.fleet.results.load_results`) of ``motorid fleet
doctor`` (the final model's parameters ``model.params.*`` and the effects it named)
with their standard errors ``model.params_std.*``, or ``motorid fleet identify`` with a
friction filter (``params.coulomb``, ``params.coulomb_std``, ...).

A drive is flagged when, over its last ``window_days`` days of records,

    rise = (f(t_end) - f(t_start)) / f(t_start) > threshold

for its Coulomb or viscous friction, with f the least-squares straight line through
the parameter against time (robust to the record-to-record scatter, which is a few
per cent), t_start and t_end the first and last record time in the window; or when an
effect appeared: from some record on (not the drive's first), the doctor names it on at
least half of the records, at least 3 of them, having named it on fewer than half of
the records before (a single record's false alarm does not flag a drive; the day is
reported).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from motorid.errors import DataError
from motorid.fleet.jobs import DRIVE_KEY_PREFIX

if TYPE_CHECKING:
    from matplotlib.figure import Figure

logger = logging.getLogger(__name__)

#: Parameters of a doctor's model that are not friction or an effect (not trended).
_NOT_TRENDED = ("inertia", "input_gain")
#: The parameters whose rise flags a drive.
RISING = ("coulomb", "viscous")


def friction_trends(results: pd.DataFrame) -> pd.DataFrame:
    """The friction parameters of every successful record, one row per record and parameter.

    Parameters
    ----------
    results : pandas.DataFrame
        A fleet run's results (:func:`~motorid.fleet.results.load_results`), one row per record.

    Returns
    -------
    pandas.DataFrame
        Columns ``drive``, ``time``, ``record``, ``parameter``, ``value``, ``std`` (NaN when
        the results carry no uncertainty), ``unit`` (the parameter's unit from the results'
        ``units.params.*``; None when they do not say), sorted by drive, parameter and time.

    Raises
    ------
    DataError
        When no successful record has a time, the results hold no friction parameter, or they
        are of a run per drive (one model per drive has no trend over time).
    """
    if results["record"].astype(str).str.startswith(DRIVE_KEY_PREFIX).any():
        raise DataError(
            "the results are of a run per drive (per_drive=True): one model per drive, so no friction against "
            "time; trends need a run per record (a doctor run without per_drive=True)"
        )
    ok = results[(results["status"] == "ok") & results["time"].notna()] if "time" in results else results[:0]
    if ok.empty:
        raise DataError(
            "no successful record with a time in the results: give the records a time "
            "(attrs 'time', or pattern=... with {date:...}) and rerun"
        )
    frames = []
    # (prefix of a parameter's column, prefix and suffix of its standard error's column)
    for prefix, std_prefix, std_suffix in (
        ("model.params.", "model.params_std.", ""),
        ("params.", "params.", "_std"),
    ):
        names = [
            c[len(prefix) :]
            for c in ok.columns
            if c.startswith(prefix)
            and not c.endswith("_std")
            and "[" not in c
            and c[len(prefix) :] not in _NOT_TRENDED
        ]
        for name in names:
            values = pd.to_numeric(ok[prefix + name], errors="coerce")
            std_col = std_prefix + name + std_suffix
            std = pd.to_numeric(ok[std_col], errors="coerce") if std_col in ok else np.nan
            unit_col = "units.params." + name
            unit = ok[unit_col].where(ok[unit_col].notna(), None) if unit_col in ok else None
            frame = pd.DataFrame(
                {"drive": ok["drive"], "time": ok["time"], "record": ok["record"], "parameter": name,
                 "value": values, "std": std, "unit": unit}
            )  # fmt: skip
            frames.append(frame[frame["value"].notna()])
    if not frames:
        raise DataError(
            "the results hold no friction parameter (run motorid fleet doctor, or identify with a friction filter)"
        )
    trends = pd.concat(frames, ignore_index=True)
    return trends.sort_values(["drive", "parameter", "time"], ignore_index=True)


def relative_rise(time: pd.Series, value: pd.Series) -> float:
    """(f(t_end) - f(t_start)) / f(t_start) for the least-squares line f through ``value`` against ``time``.

    NaN with fewer than 3 records or a line that is not positive at t_start.

    Parameters
    ----------
    time : pandas.Series
        The records' times (datetimes or ISO 8601 text); the line is fitted against days.
    value : pandas.Series
        The parameter's value in each record (any unit: the rise is a share).
    """
    if len(value) < 3:
        return float("nan")
    days = (pd.to_datetime(time) - pd.to_datetime(time).min()).dt.total_seconds().to_numpy() / 86400.0
    slope, intercept = np.polyfit(days, value.to_numpy(dtype=float), 1)
    start = intercept + slope * days.min()
    end = intercept + slope * days.max()
    return float((end - start) / start) if start > 0 else float("nan")


def flag_drives(
    trends: pd.DataFrame, results: pd.DataFrame, threshold: float = 0.2, window_days: float = 30.0
) -> pd.DataFrame:
    """Per drive: the rise of Coulomb and viscous friction over its last ``window_days`` days, effects
    that appeared, and whether it is flagged (see the module docstring).

    Returns
    -------
    pandas.DataFrame
        One row per drive, flagged ones first: ``drive``, ``records``, ``coulomb_rise`` and
        ``viscous_rise`` (shares, NaN when not estimated), ``appeared`` (``effect from
        YYYY-MM-DD``, comma-separated), ``flagged`` (bool), ``reason``.

    Parameters
    ----------
    trends : pandas.DataFrame
        :func:`friction_trends` of the results.
    results : pandas.DataFrame
        The run's results (the effects each record named, for ``appeared``).
    threshold : float
        A rise (share, > 0) over the window above which a drive is flagged, e.g. 0.2 for 20 %.
    window_days : float
        The window [days], > 0, ending at each drive's last record.

    Raises
    ------
    ValueError
        For a threshold or window that is not > 0.
    """
    if not threshold > 0:
        raise ValueError(f"threshold must be > 0, got {threshold!r}")
    if not window_days > 0:
        raise ValueError(f"window_days must be > 0, got {window_days!r}")
    ok = results[(results["status"] == "ok") & results["time"].notna()].sort_values("time")
    rows = []
    for drive, own in trends.groupby("drive", sort=True):
        end = own["time"].max()
        recent = own[own["time"] >= end - pd.Timedelta(days=window_days)]
        row: dict = {"drive": drive, "records": int(own["record"].nunique())}
        reasons = []
        for name in RISING:
            series = recent[recent["parameter"] == name]
            rise = relative_rise(series["time"], series["value"])
            row[f"{name}_rise"] = rise
            if rise > threshold:
                reasons.append(f"{name} +{rise:.0%}")
        appeared = _appeared(ok[ok["drive"] == drive]) if "named" in ok else {}
        row["appeared"] = ", ".join(f"{effect} from {when:%Y-%m-%d}" for effect, when in appeared.items())
        reasons += [f"{effect} appeared on {when:%Y-%m-%d}" for effect, when in appeared.items()]
        row["flagged"] = bool(reasons)
        row["reason"] = "; ".join(reasons)
        rows.append(row)
    table = pd.DataFrame(
        rows, columns=["drive", "records", "coulomb_rise", "viscous_rise", "appeared", "flagged", "reason"]
    )
    return table.sort_values(["flagged", "drive"], ascending=[False, True], ignore_index=True)


def _appeared(records: pd.DataFrame, min_records: int = 3) -> dict[str, pd.Timestamp]:
    """Per effect, the time of the first record from which the doctor names it on at least half of the
    drive's records (at least ``min_records`` of them), having named it on fewer than half before."""
    named = [set(filter(None, str(v).split(","))) if isinstance(v, str) else set() for v in records["named"]]
    times = list(records["time"])
    out = {}
    for effect in sorted(set().union(*named)):
        hits = np.array([effect in n for n in named])
        for i in np.flatnonzero(hits):
            after, before = hits[i:], hits[:i]
            if i > 0 and len(after) >= min_records and after.mean() >= 0.5 and before.mean() < 0.5:
                out[effect] = times[i]
                break
    return out


def parameter_label(name: str, units: pd.Series) -> str:
    """The axis label of a parameter: its name and the unit its records name, e.g. ``coulomb [N m]``.

    Records that name different units (drives set up differently) are listed; results that
    name none say so, rather than guess one.

    Parameters
    ----------
    name : str
        The parameter's name (``coulomb``).
    units : pandas.Series
        The unit each record gives it (text; empty or None where not said).
    """
    named = list(dict.fromkeys(u for u in units if isinstance(u, str) and u))
    return f"{name} [{', '.join(named) if named else 'unit not in the results'}]"


def trend_figure(drive: str, own: pd.DataFrame, reason: str = "", appeared: str = "") -> Figure:
    """One drive's friction parameters against record time: a panel per parameter, ±2σ bars
    when known, the day an effect appeared marked (and named in the legend); the title says
    why the drive is flagged.

    Parameters
    ----------
    drive : str
        The drive's name.
    own : pandas.DataFrame
        The drive's rows of :func:`friction_trends`.
    reason, appeared : str
        The drive's ``reason`` and ``appeared`` of :func:`flag_drives`.
    """
    import matplotlib.dates as mdates

    from motorid.figures import set_title, subplots

    names = list(dict.fromkeys(own["parameter"]))
    fig, axes = subplots(len(names), 1, figsize=(7, 1.9 * len(names) + 1.0), sharex=True, squeeze=False)
    days = [item.rsplit(" from ", 1) for item in filter(None, appeared.split(", "))]  # (effect, day)
    for ax, name in zip(axes[:, 0], names, strict=True):
        series = own[own["parameter"] == name]
        known = series["std"].notna().any()
        ax.errorbar(series["time"], series["value"], yerr=2 * series["std"] if known else None, fmt="o-", ms=3,
                    lw=1, capsize=2, label="estimate per record" + (" ±2σ" if known else ""))  # fmt: skip
        ax.set_ylabel(parameter_label(name, series["unit"]))
        ax.grid(alpha=0.3)
        for effect, day in days:
            ax.axvline(pd.Timestamp(day), color="tab:red", ls="--", lw=1, label=f"{effect} appeared")
        ax.legend(loc="best", fontsize=7)
    shown = drive if str(drive).isprintable() else repr(drive)  # a control character from data, escaped
    shown = shown if len(shown) <= 80 else shown[:77] + "..."  # an id from data of any length
    set_title(axes[0, 0], f"{shown}: " + (f"flagged ({reason})" if reason else "not flagged"), fontsize=10)
    axis = axes[-1, 0].xaxis
    locator = mdates.AutoDateLocator()
    axis.set_major_locator(locator)
    axis.set_major_formatter(mdates.ConciseDateFormatter(locator))
    axes[-1, 0].set_xlabel("record time [date]")
    return fig


def plot_trends(trends: pd.DataFrame, flags: pd.DataFrame, out: str | os.PathLike[str]) -> list[Path]:
    """One PNG per drive, ``<drive>.png`` (:func:`trend_figure`). The paths.

    Parameters
    ----------
    trends : pandas.DataFrame
        :func:`friction_trends` of the results.
    flags : pandas.DataFrame
        :func:`flag_drives` of them (the reason and the effects that appeared go in the titles).
    out : str or PathLike
        The folder the figures are written to (made when missing); a drive's name is made safe
        as a file name (:func:`motorid.outputs.safe_file_name`).
    """
    from motorid.figures import save
    from motorid.outputs import safe_file_name

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    reasons = dict(zip(flags["drive"], flags["reason"], strict=True))
    appeared = dict(zip(flags["drive"], flags["appeared"], strict=True))
    return [
        save(
            trend_figure(drive, own, reasons.get(drive, ""), str(appeared.get(drive, "") or "")),
            folder / f"{safe_file_name(drive)}.png",  # a drive id from data is never a path
        )
        for drive, own in trends.groupby("drive", sort=True)
    ]


__all__ = [
    "RISING",
    "flag_drives",
    "friction_trends",
    "parameter_label",
    "plot_trends",
    "relative_rise",
    "trend_figure",
]
