"""The model on new data: drive models and identified estimators simulated on a record's own input.

Each model runs free (from rest, on the recorded input alone, never on the measured
output) and is scored against the measurement, as MATLAB's ``compare`` does::

    FIT = 100 (1 - ||y - y_sim|| / ||y - mean(y)||)   [%]
    RMSE = sqrt(mean((y - y_sim)^2))                  [output unit]
    low-speed RMSE: the same over the samples with |y| < threshold

(:mod:`motorid.validation`'s metrics), after the first ``skip`` samples (the start
from rest). On a record of positions the low-speed band is judged on the speed derived from
them (central differences, ``numpy.gradient``). The models it takes are those of a model
file (:func:`motorid.load_model`):

- a two-mass rig (``two-mass-rig``): simulated with its sensors noise free, so the
  prediction is its tacho and A/D reading of the load speed [rad/s];
- a rigid drive (``rigid-drive``, the doctor's model): its free run [its velocity unit], or on
  a record of positions (output in rad or m) its position from rest, placed at the first
  measured position, integrated inside the same free run (:meth:`~motorid.drive.RigidDrive.motion`);
- an identified estimator (``estimator``): its ``simulate(u)``, the identified model
  frozen as saved.

A drive model is physical (continuous time): it runs at the record's sample time
whatever ``dt`` its file holds, and says so. An estimator is a discrete-time model:
a friction filter whose rig's ``dt`` is not the record's is refused (an ARX or
Hammerstein model file does not know its sample time; it is taken as the record's).

Timing: a physical model (a drive model, a friction filter) gives the output at the
end of the sample over which ``u[k]`` is held (the ``"hold"`` timing of
:data:`motorid.io.records.TIMINGS`). On a ``"sampled"`` record (``y[k]`` read before
``u[k]`` is applied) its output for ``u[k]`` is compared with ``y[k+1]``, as the doctor
pairs them, and ``y[0]``, read before any input, with the rest it starts from
(:func:`free_run_on_record`). An ARX or Hammerstein model learnt the pairing of the
record it was identified on, as it was given, and runs on the input as given.

Units: a model works in motorid's units (V in, rad/s out for a two-mass rig and the
friction filters on it). A record whose input is PWM duty in % (no supply voltage
to make it volts) is refused for those models; a rigid drive's input gain is per
input unit, so it takes the duty as it was fitted on (:func:`input_unit_note`).
The scores are in the record's output unit, as read (``attrs["units"]["y"]``, or
"output units" for a record that names none).
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import TwoMassRig
from motorid.errors import DataError
from motorid.estimators.base import Estimator, first_bad_index
from motorid.io.records import record_timing
from motorid.validation import MIN_SCORED_SAMPLES, free_run_divergence, low_speed_mask, score

if TYPE_CHECKING:
    from matplotlib.figure import Figure

logger = logging.getLogger(__name__)

__all__ = [
    "MIN_SCORED_SAMPLES",
    "POSITION_UNITS",
    "BlockFreeRun",
    "Comparison",
    "ModelOnRecord",
    "check_output_unit",
    "compare_blocks",
    "compare_models",
    "free_run_on_record",
    "holds_input",
    "input_unit_note",
    "model_kind",
    "runs_in_blocks",
    "simulate_model",
]


#: The low-speed panel of ``compare.png`` spans ± this many times the low-speed band.
LOW_SPEED_AXIS = 2.0


def model_kind(model: Any) -> str:
    """What ``model`` is, in words: ``two-mass rig``, ``rigid drive`` or ``estimator NAME``.

    Parameters
    ----------
    model : Any
        A drive model or an estimator.
    """
    if isinstance(model, TwoMassRig):
        return "two-mass rig"
    if isinstance(model, RigidDrive):
        return "rigid drive"
    if isinstance(model, Estimator):
        return f"estimator {model.name}"
    raise DataError(
        f"a {type(model).__name__} is not a model: give a two-mass rig, a rigid drive or an estimator"
    )


def _takes_volts(model: Any) -> bool:
    """True for a model whose input is the amplifier's command in volts (a two-mass rig, or a
    friction filter on one); a rigid drive's input gain is per input unit of its record."""
    if isinstance(model, TwoMassRig):
        return True
    rig = getattr(model, "rig", False)
    if rig is False:  # an ARX or Hammerstein model: its input unit is its record's
        return False
    return not isinstance(rig, RigidDrive)  # None: the paper's rig


def input_unit_note(model: Any, units: Mapping[str, str] | None, name: str = "model") -> str | None:
    """Check the record's input unit against what ``model`` takes; a sentence for the user, or None.

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or Estimator
    units : mapping, optional
        The record's ``attrs["units"]`` after reading (``u`` in V when it was converted).
    name : str
        The model's name in the messages (its file).

    Returns
    -------
    str or None
        What is assumed, when the record leaves it open (no input unit named; a duty
        in % through a rigid drive's input gain).

    Raises
    ------
    DataError
        For an input in % duty to a model whose input is volts (a two-mass rig, a friction
        filter on one): duty is not volts, and only the supply voltage makes it so.
    """
    unit = (units or {}).get("u")
    if _takes_volts(model):
        if unit is None:
            return f"{name}: the record names no input unit; its input is taken as volts, the model's unit"
        if unit != "V":
            how = (
                " (PWM duty): give the supply voltage (supply_voltage=...) to make it volts"
                if unit == "%"
                else ""
            )
            raise DataError(
                f"{name}: the model's input is the amplifier's command in V, the record's is in {unit}{how}"
            )
        return None
    if unit == "%":
        how = (
            "goes through the model's input gain, per input unit as it was fitted"
            if isinstance(model, RigidDrive) or isinstance(getattr(model, "rig", None), RigidDrive)
            else "is used as it is, in the unit the model was identified in"
        )
        return f"{name}: the input in % duty {how}: the model must have been fitted on duty too"
    return None


#: Output units that are a position, not a velocity (:data:`motorid.units.OUTPUT_UNITS`, once converted).
POSITION_UNITS = ("rad", "m")


def check_output_unit(
    model: Any, units: Mapping[str, str] | None, name: str = "model", position_run: bool = False
) -> None:
    """Refuse a record whose output the model does not give: a drive model gives a velocity
    (a two-mass rig, and a friction filter on one, in rad/s); an ARX or Hammerstein model gives
    the output it was identified on, whatever its unit. With ``position_run`` (where the caller
    runs a rigid drive in position, :func:`compare_models`) a rigid drive takes a position too.

    Parameters
    ----------
    model : Any
        A drive model or an estimator.
    units : mapping or None
        The record's ``attrs["units"]``.
    name : str
        What the model is called in the message (its file's name).
    position_run : bool
        The caller runs a rigid drive in position (a record of positions).

    Raises
    ------
    DataError
        For a position output (rad, m) to a drive model or friction filter (but a rigid drive
        with ``position_run``), or an output named in another unit than rad/s to a model in rad/s.
    """
    unit = (units or {}).get("y")
    if unit is None or not (isinstance(model, TwoMassRig | RigidDrive) or holds_input(model)):
        return
    if unit in POSITION_UNITS and position_run and isinstance(model, RigidDrive):
        return
    if unit in POSITION_UNITS:
        raise DataError(
            f"{name}: the record's output is a position in {unit}; the model gives a velocity: "
            "compare it on a velocity record"
        )
    if _takes_volts(model) and unit != "rad/s":
        raise DataError(f"{name}: the model's output is the load speed in rad/s, the record's is in {unit}")


def simulate_model(model: Any, u: np.ndarray, dt: float, name: str = "model") -> np.ndarray:
    """The free-run output of ``model`` for the input ``u`` held over samples of ``dt`` [s].

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or Estimator
        As :func:`motorid.load_model` returns it (see the module notes for each kind).
    u : ndarray, shape (N,)
        Input, in the model's unit.
    dt : float
        Sample time of the record [s].
    name : str
        The model's name in the messages.

    Returns
    -------
    ndarray, shape (N,)
        ``y_sim[k]``, the output at the end of sample k; NaN or inf once a model diverges.

    Raises
    ------
    DataError
        For a friction filter whose sample time is not ``dt``.
    """
    if isinstance(model, TwoMassRig):
        quiet = dataclasses.replace(model.tacho, noise_std=0.0)
        return model.replace(dt=dt, tacho=quiet).simulate(u, seed=0)["y"].to_numpy()
    if isinstance(model, RigidDrive):
        return model.replace(dt=dt).free_run(u)
    if isinstance(model, Estimator):
        own = getattr(model, "dt", None)
        if own is not None and not math.isclose(float(own), dt, rel_tol=1e-6):
            raise DataError(
                f"{name}: the {model.name} runs at dt = {float(own):g} s, the record at dt = {dt:g} s; "
                "a filter is a discrete-time model of its own sample time"
            )
        with np.errstate(over="ignore", invalid="ignore"):
            return np.asarray(model.simulate(u), dtype=float)
    raise DataError(f"{name}: {model_kind(model)}")


def holds_input(model: Any) -> bool:
    """True for a physical model, whose output is at the end of the sample its input is held
    over (a drive model, or an estimator that starts from one: a friction filter).

    Parameters
    ----------
    model : Any
        A drive model or an estimator.
    """
    return isinstance(model, TwoMassRig | RigidDrive) or (
        isinstance(model, Estimator) and hasattr(type(model), "from_rig")
    )


def free_run_on_record(
    model: Any,
    u: np.ndarray,
    dt: float,
    timing: str,
    name: str = "model",
    start_position: float | None = None,
) -> np.ndarray:
    """:func:`simulate_model` on a record's input, paired with the record's outputs by its ``timing``.

    ``y_sim[k]`` is the model's output for ``y[k]``. With ``timing="sampled"`` a physical
    model (:func:`holds_input`) runs on ``u[:-1]`` and its outputs are those of ``y[1:]``;
    ``y_sim[0]`` is 0, the rest it starts from.

    Parameters
    ----------
    model : Any
        A drive model or an estimator.
    u : ndarray
        The record's input [V or the record's unit].
    dt : float
        Sample time [s].
    timing : str
        The record's timing keyword (``"hold"`` or ``"sampled"``).
    name : str
        What the model is called in a message.
    start_position : float, optional
        A rigid drive on a record of positions: its position instead, from rest, placed so that
        its first position is ``start_position`` (the first measured one) [rad or m].
    """
    if start_position is not None and isinstance(model, RigidDrive):
        drive = model.replace(dt=dt)
        if timing == "sampled":
            return np.concatenate([[start_position], drive.motion(u[:-1], q0=start_position)[1]])
        position = drive.motion(u)[1]
        return position + (start_position - position[0])
    if timing == "sampled" and holds_input(model):
        return np.concatenate([[0.0], simulate_model(model, u[:-1], dt, name)])
    return simulate_model(model, u, dt, name)


@dataclass(frozen=True)
class ModelOnRecord:
    """One model's free run on a record and its scores.

    Attributes
    ----------
    name : str
        The model's label (its file).
    kind : str
        :func:`model_kind`.
    y_sim : ndarray
        Free-run output on the scored record's samples (see :class:`Comparison`).
    fit_percent, rmse, low_speed_rmse, mse, low_speed_mse : float
        Scores after ``skip`` [%, output unit, output unit, unit², unit²]; NaN when the free
        run stops being finite (``low_speed_*`` also when no sample is that slow).
    n_low_speed : int
        Samples in the low-speed band after ``skip``.
    diverges_from : int or None
        First sample where the free run diverges: not finite, or beyond ten times the largest
        measured ``|y|`` (:func:`motorid.validation.free_run_divergence`).
    notes : tuple of str
        What was assumed (a sample time, an input unit).
    """

    name: str
    kind: str
    y_sim: np.ndarray
    fit_percent: float
    rmse: float
    low_speed_rmse: float
    mse: float
    low_speed_mse: float
    n_low_speed: int
    diverges_from: int | None
    notes: tuple[str, ...] = ()

    def scores(self) -> dict[str, Any]:
        """The row of the table: every score, the divergence and the notes."""
        return {
            "kind": self.kind,
            "fit_percent": self.fit_percent,
            "rmse": self.rmse,
            "low_speed_rmse": self.low_speed_rmse,
            "mse": self.mse,
            "low_speed_mse": self.low_speed_mse,
            "n_low_speed": self.n_low_speed,
            "diverges_from_sample": self.diverges_from,
            "notes": list(self.notes),
        }


@dataclass
class Comparison:
    """Models on one record: the record's samples (``t`` [s], ``u``, ``y``) and each model's
    run, ``y_sim[k]`` its output for ``y[k]`` (:func:`free_run_on_record`).

    Attributes
    ----------
    t : ndarray
        Sample times [s].
    u, y : ndarray
        The record's input and measured output, in the record's units.
    dt : float
        Sample time [s].
    timing : str
        The record's timing keyword (``"hold"`` or ``"sampled"``).
    skip : int
        Samples at the start left out of the scores (the start from rest).
    low_speed_threshold : float
        The low-speed band is ``|y| <`` this [output unit].
    output_unit : str
        The unit of ``y``.
    models : list of ModelOnRecord
        Each model's free run on the record.
    speed : ndarray or None
        On a record of positions, the speed derived from them, which the low-speed band is
        judged on (then ``|speed| <`` the threshold).
    samples : int or None
        Samples in the record; None: ``y.size`` (``t``, ``u``, ``y`` and each ``y_sim`` are the
        record's). A record compared in blocks (:func:`compare_blocks`) gives its count here, and
        in ``t`` ... ``y_sim`` a bounded view of it, which ``windows`` cuts into the figure's panels.
    windows : dict of str to slice or None, optional
        The figure's panels (title -> the view's samples drawn; None: nothing to draw), for a
        view; None: :meth:`figure` chooses them on the whole record.
    """

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    dt: float
    timing: str
    skip: int
    low_speed_threshold: float
    output_unit: str
    models: list[ModelOnRecord] = field(default_factory=list)
    speed: np.ndarray | None = None
    samples: int | None = None
    windows: dict[str, slice | None] | None = None

    def table(self) -> pd.DataFrame:
        """One row per model: FIT [%], RMSE and low-speed RMSE [output unit], samples in the band."""
        rows = {m.name: m.scores() for m in self.models}
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "model"
        return df[["kind", "fit_percent", "rmse", "low_speed_rmse", "n_low_speed"]]

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (no arrays)."""
        samples = int(self.y.size if self.samples is None else self.samples)
        return {
            "samples": samples,
            "scored_samples": samples - self.skip,
            "dt": self.dt,
            "timing": self.timing,
            "skip": self.skip,
            "output_unit": self.output_unit,
            "low_speed_threshold": self.low_speed_threshold,
            "models": {m.name: m.scores() for m in self.models},
        }

    def figure(self, input_unit: str = "input units") -> Figure:
        """Measured against each model over the record, at low speed and at a reversal.

        Three panels share the legend's colours: the whole record; the window of
        :func:`motorid.figures.low_speed_window` (most samples below the band); the
        reversal of the measured output with the longest stay inside half the band
        (where stiction and Stribeck friction show), or a note when it never reverses.
        Each panel's output axis spans the measurement's range in it, widened by half that
        range on either side (the low-speed panel of a speed record: ±:data:`LOW_SPEED_AXIS`
        times the band, its edges dotted, so a drive stuck near rest shows): a model far off
        leaves the panel rather than squash the measurement; a diverged model is drawn until it
        diverges. A comparison made in blocks
        draws its bounded view (``windows``, :func:`compare_blocks`).

        Parameters
        ----------
        input_unit : str
            The record's input unit, for the title.
        """
        from motorid.figures import low_speed_window, subplots

        unit = self.output_unit
        n = self.y.size
        width = int(min(max(round(5.0 / self.dt), 10), max(n // 4, 10)))
        band, band_name = (self.y, f"|y| < {self.low_speed_threshold:.3g} {unit}")
        if self.speed is not None:
            band, band_name = self.speed, f"|dy/dt| < {self.low_speed_threshold:.3g} {unit}/s"
        windows = self.windows or {
            "whole record": slice(0, n),
            f"low speed ({band_name})": low_speed_window(band, width, self.low_speed_threshold, self.skip),
            "a reversal of the measured output": reversal_window(
                band, width, self.low_speed_threshold, self.skip
            ),
        }
        fig, axes = subplots(len(windows), 1, figsize=(9, 8.5))
        for ax, (title, window) in zip(axes, windows.items(), strict=True):
            if window is None:
                ax.text(0.5, 0.5, "the measured output never reverses", ha="center", va="center",
                        transform=ax.transAxes)  # fmt: skip
            else:
                y = self.y[window]
                ax.plot(self.t[window], y, "k-", lw=1.2, label="measured")
                for m in self.models:
                    score = "diverges" if m.diverges_from is not None else f"FIT {m.fit_percent:.1f} %"
                    y_sim = np.where(np.isfinite(m.y_sim[window]), m.y_sim[window], np.nan)
                    ax.plot(self.t[window], y_sim, "--", lw=1.1, label=f"{m.name} ({score})")
                ax.axhline(0.0, color="k", lw=0.5)
                if title.startswith("low speed") and self.speed is None:  # the band's own axis
                    limit = LOW_SPEED_AXIS * self.low_speed_threshold
                    for level in (-self.low_speed_threshold, self.low_speed_threshold):
                        ax.axhline(level, color="0.5", lw=0.6, ls=":")
                    ax.set_ylim(-limit, limit)
                else:
                    pad = 0.5 * max(float(np.ptp(y)), 1e-12)
                    ax.set_ylim(float(y.min()) - pad, float(y.max()) + pad)
                ax.legend(loc="upper right", fontsize=7)
            ax.set_title(title, fontsize=10)
            ax.set_xlabel("time t [s]")
            ax.set_ylabel(f"output y [{unit}]")
            ax.grid(alpha=0.3)
        fig.suptitle(f"Measured and simulated (free run from rest on the recorded input, in {input_unit})")
        return fig

    def write_figure(self, path: str | Path, input_unit: str = "input units") -> Path:
        """:meth:`figure` as a PNG file at ``path``."""
        from motorid.figures import save

        return save(self.figure(input_unit), path)


def reversal_window(y: np.ndarray, width: int, threshold: float, skip: int = 0) -> slice | None:
    """``width`` samples centred on the reversal of ``y`` (after ``skip``) that stays longest
    inside ``|y| < threshold / 2``; None when ``y`` never passes from one side of that band
    to the other."""
    h = 0.5 * threshold
    side = np.where(y > h, 1, np.where(y < -h, -1, 0))
    outside = np.flatnonzero(side[skip:] != 0) + skip
    if outside.size < 2:
        return None
    flips = np.flatnonzero(np.diff(side[outside]) != 0)
    if flips.size == 0:
        return None
    dwell = outside[flips + 1] - outside[flips]
    c = int(flips[np.argmax(dwell)])
    centre = (int(outside[c]) + int(outside[c + 1])) // 2
    start = min(max(centre - width // 2, 0), max(y.size - width, 0))
    return slice(start, start + width)


def _samples(record: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, str]:
    """``t``, ``u``, ``y`` of a record, its ``dt`` and its timing."""
    if not isinstance(record, pd.DataFrame):
        raise DataError(f"record must be a pandas DataFrame, got {type(record).__name__}")
    for column in ("u", "y"):
        if column not in record.columns:
            raise DataError(f"the record has no column {column!r}; columns are {list(record.columns)}")
    dt = record.attrs.get("dt")
    if dt is None:
        raise DataError("the record has no attrs['dt']: read it with motorid.io.records.read_record")
    dt = float(dt)
    u = record["u"].to_numpy(dtype=float)
    y = record["y"].to_numpy(dtype=float)
    t = record["t"].to_numpy(dtype=float) if "t" in record.columns else np.arange(y.size) * dt
    return t, u, y, dt, record_timing(record.attrs)


def compare_models(
    record: pd.DataFrame,
    models: Mapping[str, Any],
    low_speed_threshold: float,
    skip: int = 0,
    input_scales: Mapping[str, tuple[float, str | None]] | None = None,
) -> Comparison:
    """Simulate each model free on the record's input and score it against the measured output.

    Parameters
    ----------
    record : DataFrame
        Columns ``u`` and ``y`` (``t`` optional), ``attrs["dt"]`` [s]; ``attrs["units"]``
        and ``attrs["timing"]`` when known (see the module notes).
    models : mapping of str to model
        Label -> a model as :func:`motorid.load_model` returns it.
    low_speed_threshold : float
        |y| below this is low speed [output unit].
    skip : int
        Leading samples left out of the scores: the models start from rest.
    input_scales : mapping of str to (float, str or None), optional
        Label -> the factor that puts the record's input in the unit the model's card says it
        was fitted on, and a note when it converts (:func:`motorid.app.model_cards.input_scale`:
        % duty <-> V). A label in it was checked against its card, so the assumptions of
        :func:`input_unit_note` are not made; one not in it runs on the input as read.

    Returns
    -------
    Comparison

    Raises
    ------
    DataError
        No model; a model that is not a drive model or an estimator; an input unit the
        model does not take (:func:`input_unit_note`); a friction filter of another sample
        time; fewer than :data:`MIN_SCORED_SAMPLES` samples after ``skip``; a constant output.
    """
    if not models:
        raise DataError("no model to compare: give at least one")
    t, u, y, dt, timing = _samples(record)
    if not isinstance(skip, int) or skip < 0:
        raise DataError(f"skip must be an integer >= 0, got {skip!r}")
    if y.size - skip < MIN_SCORED_SAMPLES:
        raise DataError(
            f"the record has {y.size} samples; "
            f"after the {skip} skipped at the start {max(y.size - skip, 0)} are left to score, "
            f"at least {MIN_SCORED_SAMPLES} are needed"
        )
    units = record.attrs.get("units") or {}
    unit = units.get("y") or "output units"
    kinds = {name: model_kind(model) for name, model in models.items()}
    for name, model in models.items():
        check_output_unit(model, units, name, position_run=True)
    notes_of = card_checked_notes(models, units, input_scales)
    positions = units.get("y") in POSITION_UNITS
    speed = np.gradient(y, dt) if positions else None
    band = y if speed is None else speed
    low_speed_mask(band, low_speed_threshold)  # a bad threshold is refused before any simulation
    comparison = Comparison(t, u, y, dt, timing, skip, float(low_speed_threshold), unit, speed=speed)
    largest = float(np.max(np.abs(y)))
    for name, model in models.items():
        notes = [note for note in (notes_of[name],) if note]
        own_dt = getattr(model, "dt", None)
        if isinstance(model, TwoMassRig | RigidDrive) and not math.isclose(own_dt, dt, rel_tol=1e-6):
            notes.append(f"{name}: simulated at the record's dt = {dt:g} s (its file says {own_dt:g} s)")
        scale = (input_scales or {}).get(name, (1.0, None))[0]
        y_sim = free_run_on_record(model, u * scale, dt, timing, name, float(y[0]) if positions else None)
        diverges = free_run_divergence(y_sim, largest)
        if first_bad_index(y_sim) is not None:  # a bounded run is scored, also one beyond the bound
            nan = math.nan
            scores = {
                "fit_percent": nan,
                "rmse": nan,
                "low_speed_rmse": nan,
                "mse": nan,
                "low_speed_mse": nan,
            }
            n_low = int(low_speed_mask(band[skip:], low_speed_threshold).sum())
        else:
            s = score(y[skip:], y_sim[skip:], low_speed_threshold, band[skip:])
            scores = {"fit_percent": s.fit_percent, "rmse": s.rmse, "low_speed_rmse": math.sqrt(s.low_speed_mse),
                      "mse": s.mse, "low_speed_mse": s.low_speed_mse}  # fmt: skip
            n_low = s.n_low_speed
        for note in notes:
            logger.info(note)
        comparison.models.append(
            ModelOnRecord(
                name,
                kinds[name],
                y_sim,
                n_low_speed=n_low,
                diverges_from=diverges,
                notes=tuple(notes),
                **scores,
            )
        )
    return comparison


def card_checked_notes(
    models: Mapping[str, Any],
    units: Mapping[str, str] | None,
    input_scales: Mapping[str, tuple[float, str | None]] | None,
) -> dict[str, str | None]:
    """Each model's note on its input: the conversion its card asked for (``input_scales``), or
    for a model without a checked card what :func:`input_unit_note` assumes."""
    checked = input_scales or {}
    return {
        name: checked[name][1] if name in checked else input_unit_note(model, units, name)
        for name, model in models.items()
    }


def runs_in_blocks(model: Any) -> bool:
    """Whether ``model``'s free run continues from one block of the input to the next
    (:class:`BlockFreeRun`): a two-mass rig, a rigid drive, an ARX or Hammerstein model. A
    friction filter's free run takes the record whole.

    Parameters
    ----------
    model : Any
        A drive model or an estimator.
    """
    from motorid.estimators.rls import LaggedRegressionRLS

    return isinstance(model, TwoMassRig | RigidDrive | LaggedRegressionRLS)


class BlockFreeRun:
    """:func:`free_run_on_record` over a record given in consecutive blocks: calling it on the
    blocks' inputs gives, block by block, the whole record's ``y_sim`` to the last bit.

    Each model carries its own state from block to block: a two-mass rig its running
    simulation (:meth:`motorid.drive.two_mass.RigSimulation.run`, sensors noise free), a rigid drive
    its input path and speed (:meth:`motorid.drive.rigid.RigidSimulation.run`), an ARX or
    Hammerstein model its past outputs and basis values (:class:`motorid.estimators.rls.FreeRun`).
    On a ``"sampled"`` record a physical model's output for ``u[k]`` is that of ``y[k+1]``: each
    block's last output is carried to the next, and the first is the rest it starts from.

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or LaggedRegressionRLS
        As :func:`motorid.load_model` returns it (:func:`runs_in_blocks`).
    dt : float
        Sample time of the record [s].
    timing : str
        The record's timing keyword (``"hold"`` or ``"sampled"``).
    name : str
        The model's name in the messages.

    Raises
    ------
    DataError
        For a friction filter, whose free run takes the record whole.
    """

    def __init__(self, model: Any, dt: float, timing: str, name: str = "model"):
        from motorid.estimators.rls import FreeRun

        if isinstance(model, TwoMassRig):
            quiet = dataclasses.replace(model.tacho, noise_std=0.0)
            self._run = model.replace(dt=dt, tacho=quiet).simulation(seed=0).run
        elif isinstance(model, RigidDrive):
            self._run = model.replace(dt=dt).simulation().run
        elif runs_in_blocks(model):
            self._run = FreeRun(model)
        else:
            raise DataError(
                f"{name}: the free run of a {model_kind(model)} takes the record whole, not in blocks"
            )
        self._shift = timing == "sampled" and holds_input(model)
        self._carry = 0.0

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """``y_sim`` for the next block of the record, whose input is ``u``."""
        with np.errstate(over="ignore", invalid="ignore"):
            y = np.asarray(self._run(u), dtype=float)
        if not self._shift or not y.size:
            return y
        paired = np.concatenate([[self._carry], y[:-1]])
        self._carry = float(y[-1])
        return paired


class _View:
    """The bounded view of a record compared in blocks, for :meth:`Comparison.figure`: rows of
    ``series`` (``t``, ``u``, ``y``, each model's ``y_sim``) in

    - an envelope: the minimum and maximum of runs of ``size`` samples, ``size`` doubling
      (neighbouring runs merged) whenever there would be more than
      :data:`motorid.diagnose.figures.MAX_BUCKETS` runs, so that there are at most that many;
    - the ``width`` samples after ``skip`` with the most samples in the low-speed band (ties:
      the earliest), as :func:`motorid.figures.low_speed_window` chooses them;
    - ``width`` samples centred on the reversal of ``y`` that stays longest inside half the
      band, as :func:`reversal_window` chooses it among the reversals whose stay is at most
      ``width`` samples (a longer one is not held: its middle has gone by when it ends).

    It holds the last ``2 width`` samples, whatever the record's length.
    """

    def __init__(self, width: int, threshold: float, skip: int):
        from motorid.diagnose.figures import MAX_BUCKETS

        self.width, self.threshold, self.skip = width, threshold, skip
        self.buckets = MAX_BUCKETS
        self.size = 1
        self.lo: np.ndarray | None = None
        self.hi: np.ndarray | None = None
        self.tail: np.ndarray | None = None  # the last 2 width samples of the series
        self.seen = 0
        self.next_start = skip  # the first start of a low-speed window not yet counted
        self.low: np.ndarray | None = None
        self.low_count = -1
        self.last_outside: tuple[int, int] | None = (
            None  # (row, side) of the last sample out of half the band
        )
        self.dwell = 0
        self.reversal_start: int | None = None
        self.reversal: np.ndarray | None = None

    def add(self, series: np.ndarray) -> None:
        """The next block: ``series`` of shape (rows of series, samples), row 2 the measured ``y``."""
        series = np.where(np.isfinite(series), series, np.nan)
        self._envelope(series)
        start = self.seen if self.tail is None else self.seen - self.tail.shape[1]
        ext = series if self.tail is None else np.concatenate([self.tail, series], axis=1)
        self.seen += series.shape[1]
        self._low_speed(ext, start)
        self._reversal(series[2], ext, start)
        self.tail = ext[:, -2 * self.width :].copy()

    def _envelope(self, series: np.ndarray) -> None:
        ids = (self.seen + np.arange(series.shape[1])) // self.size
        if not ids.size:
            return
        starts = np.concatenate([[0], np.flatnonzero(np.diff(ids)) + 1])
        lo, hi = np.fmin.reduceat(series, starts, axis=1), np.fmax.reduceat(series, starts, axis=1)
        if self.lo is None:
            self.lo, self.hi = lo, hi
        else:
            if ids[0] == self.lo.shape[1] - 1:  # the block continues the last run
                self.lo[:, -1], self.hi[:, -1] = (
                    np.fmin(self.lo[:, -1], lo[:, 0]),
                    np.fmax(self.hi[:, -1], hi[:, 0]),
                )
                lo, hi = lo[:, 1:], hi[:, 1:]
            self.lo, self.hi = np.concatenate([self.lo, lo], axis=1), np.concatenate([self.hi, hi], axis=1)
        while self.lo.shape[1] > self.buckets:
            if self.lo.shape[1] % 2:
                pad = np.full((self.lo.shape[0], 1), np.nan)
                self.lo, self.hi = (
                    np.concatenate([self.lo, pad], axis=1),
                    np.concatenate([self.hi, pad], axis=1),
                )
            self.lo = np.fmin(self.lo[:, 0::2], self.lo[:, 1::2])
            self.hi = np.fmax(self.hi[:, 0::2], self.hi[:, 1::2])
            self.size *= 2

    def _low_speed(self, ext: np.ndarray, start: int) -> None:
        last = self.seen - self.width  # the last window start whose samples are all in
        if last < self.next_start:
            return
        slow = np.concatenate([[0], np.cumsum(np.abs(ext[2]) < self.threshold)])
        first = self.next_start - start
        counts = slow[first + self.width : last - start + self.width + 1] - slow[first : last - start + 1]
        best = int(np.argmax(counts))
        if counts[best] > self.low_count:
            self.low_count = int(counts[best])
            self.low = ext[:, first + best : first + best + self.width].copy()
        self.next_start = last + 1

    def _reversal(self, y: np.ndarray, ext: np.ndarray, start: int) -> None:
        h = 0.5 * self.threshold
        first_row = self.seen - y.size
        side = np.where(y > h, 1, np.where(y < -h, -1, 0))
        outside = np.flatnonzero(side != 0) + first_row
        outside = outside[outside >= self.skip]
        sides = side[outside - first_row]
        if self.last_outside is not None:
            outside = np.concatenate([[self.last_outside[0]], outside])
            sides = np.concatenate([[self.last_outside[1]], sides])
        if outside.size:
            flips = np.flatnonzero(np.diff(sides) != 0)
            dwell = outside[flips + 1] - outside[flips]
            held = flips[dwell <= self.width]
            if held.size:
                c = int(held[np.argmax(outside[held + 1] - outside[held])])
                if outside[c + 1] - outside[c] > self.dwell:
                    self.dwell = int(outside[c + 1] - outside[c])
                    centre = (int(outside[c]) + int(outside[c + 1])) // 2
                    self.reversal_start, self.reversal = max(centre - self.width // 2, 0), None
            self.last_outside = (int(outside[-1]), int(sides[-1]))
        s = self.reversal_start
        if s is not None and self.reversal is None and s + self.width <= self.seen:
            self.reversal = ext[:, s - start : s - start + self.width].copy()

    def finish(self) -> tuple[np.ndarray, dict[str, slice | None], int]:
        """The view's series, the panels' slices of them, and the envelope's run length."""
        assert self.lo is not None and self.tail is not None
        tail_start = self.seen - self.tail.shape[1]
        if self.low is None:  # fewer than width samples after skip: all of them
            self.low = self.tail[:, max(self.skip - tail_start, 0) :]
        if self.reversal_start is not None and self.reversal is None:  # its window runs past the end
            s = max(self.seen - self.width, 0)
            self.reversal = self.tail[:, s - tail_start :]
        if self.size == 1:
            whole = self.lo
        else:
            whole = np.stack([self.lo, self.hi], axis=2).reshape(self.lo.shape[0], -1)
            whole[0] = np.repeat(self.lo[0], 2)  # each run drawn at its first time
        parts = [whole, self.low] + ([self.reversal] if self.reversal is not None else [])
        edges = np.cumsum([0] + [p.shape[1] for p in parts])
        windows = [slice(int(a), int(b)) for a, b in itertools.pairwise(edges)]
        return (
            np.concatenate(parts, axis=1),
            {
                "whole": windows[0],
                "low": windows[1],
                "reversal": windows[2] if self.reversal is not None else None,
            },
            self.size,
        )


def compare_blocks(
    blocks: Iterable[pd.DataFrame],
    models: Mapping[str, Any],
    low_speed_threshold: float,
    skip: int = 0,
    largest_output: float | None = None,
    input_scales: Mapping[str, tuple[float, str | None]] | None = None,
) -> Comparison:
    """:func:`compare_models` on a record given in consecutive blocks, in memory that does not grow
    with its length.

    Each model's free run continues from block to block (:class:`BlockFreeRun`: the whole
    record's ``y_sim``, to the last bit), and is scored with running sums
    (:class:`motorid.validation.RunningScore`): FIT %, RMSE and low-speed RMSE equal
    :func:`compare_models`'s up to the rounding of those sums (a relative difference of about
    1e-12 on a million samples). The figure is drawn from a bounded view of the record
    (:class:`_View`: the minimum and maximum of runs of samples over the whole record, and the
    low-speed and reversal windows, chosen as :func:`compare_models` chooses them; a reversal
    whose stay in the band is longer than the window is not one of them).

    Parameters
    ----------
    blocks : iterable of DataFrame
        The record's consecutive blocks (:func:`motorid.io.records.iter_record`): columns
        ``t`` [s], ``u``, ``y``, the first block's ``attrs`` (``dt``, ``units``, ``timing``)
        those of the record. A velocity record: the band of a record of positions is judged
        on their speed, which takes the record whole.
    models : mapping of str to model
        Label -> a model whose free run runs in blocks (:func:`runs_in_blocks`).
    low_speed_threshold : float
        |y| below this is low speed [output unit].
    skip : int
        Leading samples left out of the scores: the models start from rest.
    largest_output : float, optional
        The record's largest ``|y|`` [output unit], the bound beyond which a free run has
        diverged (:func:`motorid.validation.free_run_divergence`), as :func:`compare_models`
        judges it; None: the largest ``|y|`` of the blocks read so far (known before the record
        ends, so a run may be said to diverge earlier than on the whole record).
    input_scales : mapping of str to float, optional
        As :func:`compare_models`'s.

    Returns
    -------
    Comparison
        With ``samples`` the record's length and a bounded view in its arrays.

    Raises
    ------
    DataError
        As :func:`compare_models`; a friction filter, or a record of positions.
    """
    from motorid.validation import RunningScore

    if not models:
        raise DataError("no model to compare: give at least one")
    if not isinstance(skip, int) or skip < 0:
        raise DataError(f"skip must be an integer >= 0, got {skip!r}")
    low_speed_mask(np.zeros(0), low_speed_threshold)  # a bad threshold is refused before any simulation
    names = list(models)
    runs: list[BlockFreeRun] = []
    scores = [RunningScore(low_speed_threshold) for _ in names]
    diverged: list[int | None] = [None] * len(names)
    finite = [True] * len(names)
    scales = [(input_scales or {}).get(name, (1.0, None))[0] for name in names]
    seen = 0.0  # the largest |y| so far, the bound without largest_output
    n_low = 0
    view: _View | None = None
    start = 0
    attrs: dict[str, Any] = {}
    for block in blocks:
        if view is None:
            attrs = dict(block.attrs)
            dt = float(attrs["dt"])
            timing = record_timing(attrs)
            units = attrs.get("units") or {}
            if units.get("y") in POSITION_UNITS:
                raise DataError(
                    f"the record's output is a position in {units['y']}: it is compared whole, "
                    "on the speed derived from it"
                )
            for name, model in models.items():
                model_kind(model)
                check_output_unit(model, units, name)
            notes_of = card_checked_notes(models, units, input_scales)
            runs = [BlockFreeRun(model, dt, timing, name) for name, model in models.items()]
            view = _View(max(round(5.0 / dt), 10), float(low_speed_threshold), skip)
        u, y = block["u"].to_numpy(dtype=float), block["y"].to_numpy(dtype=float)
        scored = slice(max(0, skip - start), None)
        n_low += int(np.count_nonzero(np.abs(y[scored]) < low_speed_threshold))
        simulated = []
        if y.size:
            seen = max(seen, float(np.max(np.abs(y))))
        bound = seen if largest_output is None else float(largest_output)
        for i, run in enumerate(runs):
            if not finite[i]:
                simulated.append(np.full(y.size, np.nan))
                continue
            y_sim = run(u * scales[i])
            if diverged[i] is None:
                diverged[i] = free_run_divergence(y_sim, bound, start)
            finite[i] = first_bad_index(y_sim) is None
            if finite[i]:  # a bounded run is scored, also one beyond the bound
                scores[i].add(y[scored], y_sim[scored])
            simulated.append(y_sim)
        view.add(np.vstack([block["t"].to_numpy(dtype=float), u, y, *simulated]))
        start += y.size
    if view is None or start - skip < MIN_SCORED_SAMPLES:
        raise DataError(
            f"the record has {start} samples; after the {skip} skipped at the start {max(start - skip, 0)} "
            f"are left to score, at least {MIN_SCORED_SAMPLES} are needed"
        )
    series, panels, size = view.finish()
    unit = (attrs.get("units") or {}).get("y") or "output units"
    band = f"|y| < {low_speed_threshold:.3g} {unit}"
    windows = {
        "whole record" + (f" (minimum and maximum of every {size} samples)" if size > 1 else ""): panels[
            "whole"
        ],
        f"low speed ({band})": panels["low"],
        "a reversal of the measured output": panels["reversal"],
    }
    comparison = Comparison(
        series[0], series[1], series[2], dt, timing, skip, float(low_speed_threshold), unit,
        samples=start, windows=windows,
    )  # fmt: skip
    for i, (name, model) in enumerate(models.items()):
        notes = [note for note in (notes_of[name],) if note]
        own_dt = getattr(model, "dt", None)
        if isinstance(model, TwoMassRig | RigidDrive) and not math.isclose(own_dt, dt, rel_tol=1e-6):
            notes.append(f"{name}: simulated at the record's dt = {dt:g} s (its file says {own_dt:g} s)")
        for note in notes:
            logger.info(note)
        if not finite[i]:
            nan = math.nan
            values = {
                "fit_percent": nan,
                "rmse": nan,
                "low_speed_rmse": nan,
                "mse": nan,
                "low_speed_mse": nan,
            }
            low = n_low
        else:
            s = scores[i].result()
            values = {"fit_percent": s.fit_percent, "rmse": s.rmse, "low_speed_rmse": math.sqrt(s.low_speed_mse),
                      "mse": s.mse, "low_speed_mse": s.low_speed_mse}  # fmt: skip
            low = s.n_low_speed
        comparison.models.append(
            ModelOnRecord(
                name,
                model_kind(model),
                series[3 + i],
                n_low_speed=low,
                diverges_from=diverged[i],
                notes=tuple(notes),
                **values,
            )
        )
    return comparison
