"""Find the missing effect: where a model and a measurement disagree, which effect is
missing, and how much better the model is once it is added.

The workflow (:func:`diagnose`):

0. **Structure**: choose the input delay and lag of the drive from the record
   (:func:`choose_structure`), held fixed in every later fit.
1. **Fit** the current rigid model (inertia, input gain, the ``base`` effects) to
   the torque balance of the record (:mod:`.model`), simulate it free-run on the
   measured input and compare with the measured velocity. Gaps: the RMS of
   ``w_meas - w_sim`` overall and in the located region [v], and the force
   error ``100 ||F_in - F_model|| / ||F_in||`` [%] on the decimated samples
   (the EMPS figure of merit). The measured velocity is the zero-phase
   low-passed one (for position records: the velocity derived from position).
2. **Locate** where the torque-balance residual concentrates (:mod:`.locate`).
3. **Name**: fit each candidate effect added to the current model and rank by
   the evidence

       ΔBIC = N_eff ln(RSS_0 / RSS_1) - Δk ln N_eff,
       N_eff = N (1 - ρ) / (1 + ρ)

   on the decimated moving samples (N of them, RSS the residual sum of squares
   without and with the candidate, Δk the parameters it adds, ρ the lag-one
   autocorrelation of the candidate's residual, so coloured residuals count
   as fewer independent samples). Candidates with ΔBIC above ``threshold``
   pass. Static friction acts on a resting drive only, which the balance of the
   moving samples cannot see: its level is fitted to the free run
   (:func:`fit_static_friction`), and its ΔBIC, held-out error and gap are those of
   the free-run output (RSS of measured minus free-run velocity, the held-out
   blocks at full rate). Candidates that explain the torque balance alike (each removes at
   least 80 % of what the best removes, as Coulomb friction and an input dead
   zone do) are re-simulated free-run and the smallest output gap decides.
4. **Add** a passing candidate only if (a) fitted on the training blocks it
   lowers the torque-balance RMS error on held-out blocks (or on a second
   record) by at least ``min_holdout_gain`` and (b) refitted on everything, its
   free-run output gap is at least ``min_gap_shrink`` smaller and (c) for a
   second or later step, the gap shrinks by more than ``noise_shrink`` times
   the record's noise floor σ_w (below); then refit and repeat until no
   candidate passes, all are in the model or ``max_steps`` is reached.
   :attr:`Diagnosis.stop_reason` says which, and how far the final gap is from
   the noise floor.

   **Lookalikes**: effects that are forms of one physics
   (:meth:`Effect.physics <motorid.drive.effects.base.Effect.physics>`: Coulomb
   friction, an input dead zone and, in a model without either, a Stribeck decay
   are kinetic friction; beside a kinetic level, Stribeck and static friction are
   breakaway friction) fit alike when both pass the evidence threshold and their
   free-run gaps lie within ``noise_shrink`` noise floors of each other: the data
   cannot tell them apart (a drive that never reverses while moving is held back
   alike by Coulomb friction and a dead zone). **The rule**: of effects that fit
   alike, the first in the library's order
   (:func:`motorid.drive.effects.names`: ``coulomb_friction``,
   ``stribeck_friction``, ..., ``input_dead_zone``, ..., ``static_friction``) is
   named, whichever the evidence ranked first, so one physics gets one name on
   every record of a motor; the step reports the others beside it with their
   levels and free-run gaps (:class:`Lookalike`). It prefers the effect the
   balance of the moving drive measures (a Coulomb or Stribeck level, with a
   standard error) over one that only a dead zone's input path or the free run
   at rest sees.
5. **Show**: the gaps before and after each step (:meth:`Diagnosis.table`) and
   figures (:meth:`Diagnosis.write_figures`).

The noise floor σ_w [v] is the standard deviation of the measurement noise left
on the low-passed measured velocity the free run is compared with
(:attr:`Kinematics.noise <motorid.diagnose.kinematics.Kinematics.noise>`, from
the high-frequency part of the measured output): a model that reproduces the
drive exactly still leaves a free-run gap of about σ_w. A second effect must
therefore shrink the gap by a clear share of σ_w, not only pass the held-out
blocks (an effect that moves a gap of 1.5 σ_w by 0.05 σ_w fits noise); a gap
already within ``noise_shrink`` σ_w of the floor ends the search. A final gap
above ``missing_factor`` σ_w says that something is still missing, and where
the torque-balance residual of the final model concentrates.

**Where an effect acts.** An encoder's speed noise grows with speed, so one record-wide σ_w is
too high near rest and too low at speed. An effect that acts in one place
(:attr:`Effect.acts <motorid.drive.effects.base.Effect.acts>`) is judged there: its free-run gap
where it acts (static friction: the rests and breakaways; Stribeck friction: below a tenth of the
largest speed; quadratic drag: above 0.6 of it) must shrink by ``min_gap_shrink`` and by more than
``noise_shrink`` times the noise floor of that speed band (:meth:`Pool.band_floor`), and a search
whose gap is already at the record-wide floor still tries them.

**Static friction** is measured where it shows: at the rests of the record
(:mod:`.rests`: each rest's length and the input it breaks away at). The force at breakaway
above the model's kinetic level, fitted against the input's rate there (:class:`Breakaway`: a
lag between input and force raises the input at breakaway as the input rises faster, stiction
does not), is its level ΔF_s; its ΔBIC is that of the rests (:func:`breakaway_evidence`), its
held-out check the rests of the held-out blocks (:func:`breakaway_holdout`). A record with fewer
than :data:`MIN_RESTS` rests fits it to the free run instead (:func:`fit_static_friction`).

A model given with a friction effect of its own (``model=``) stands where a step would have put
it: what comes next is judged by the rules of a second step, so a run from a saved model with
Coulomb friction names what a run from the default base names after Coulomb friction.

The default ``threshold`` was calibrated on records with no hidden effect, and
``noise_shrink`` and ``missing_factor`` on records with one, also with an encoder's speed; see
:mod:`motorid.diagnose.calibration` for the measured false-alarm rates.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from motorid.diagnose.artefacts import clean_output
from motorid.diagnose.kinematics import Kinematics, kinematics, noise_bands, quantisation_step
from motorid.diagnose.locate import Region, feature, features, locate
from motorid.diagnose.model import (
    BalanceData,
    FitResult,
    PooledBalance,
    fit_model,
    model_balance,
    model_key,
    stacked,
)
from motorid.diagnose.rests import Rests, rests
from motorid.drive.effects import effect_order, param_unit
from motorid.drive.effects import get as get_effect
from motorid.drive.effects import names as effect_names
from motorid.drive.rigid import RigidDrive, check_sample_time
from motorid.errors import DataError
from motorid.records import record_timing
from motorid.units import UNNAMED_OUTPUT, input_unit_name, rate
from motorid.validation import check_signals

logger = logging.getLogger(__name__)

#: Default evidence threshold on ΔBIC: above the 99th percentile (6.7) of the best candidate's
#: ΔBIC on 200 no-effect records, where the workflow named nothing (:mod:`.calibration`).
DEFAULT_THRESHOLD = 10.0
#: Share of the best candidate's RSS reduction above which two candidates are "alike".
ALIKE = 0.8
DEFAULT_BASE = ("viscous_friction", "offset")
#: Share of the input force below which the inertia is not determined by a record: the kit
#: motor's 0.5 Hz sines put 4.6 % of it into acceleration, its 1 Hz sines 9.5 %, its chirps 20 %
#: and their joint run 15 % (``scripts/realmotors_doctor.py``); the sines' inertias differ from
#: the chirps' by 3-10 %, many times their standard errors. 12 % lies a quarter away from both.
INERTIA_SHARE_LIMIT = 0.12
#: Relative standard error above which a parameter is not determined by a record.
RELATIVE_STD_LIMIT = 0.5
#: Smallest free-run gap shrink of a second or later step, in noise floors σ_w: a second effect
#: was named on 1 of 900 one-effect records with it, on 14 without (:mod:`.calibration`).
NOISE_SHRINK = 0.5
#: The speed bands the noise floor is reported in, as shares of the largest |w|: near rest
#: (where static friction and Stribeck act), low, middle and high speed.
SPEED_BANDS = (0.0, 0.1, 0.3, 0.6, 1.0)
#: A final gap above this many noise floors says an effect is still missing, within it "at the
#: noise floor": above the largest final gap (3.18) of 899 models that found their one planted
#: effect, and above the 99th percentile (3.04) of 191 on an encoder's speed (quantised, noise
#: growing with speed) (:mod:`.calibration`).
MISSING_FACTOR = 3.5


# --------------------------------------------------------------------------- prepared record
@dataclass
class Prepared:
    """One record made ready: kinematics, balance data, features and the free-run start, and a
    note for each logging artefact left out (:mod:`.artefacts`).

    The features are kept on the decimated samples only (``feats_dec``); a
    region's full-rate mask is computed when asked for (:meth:`region_mask`). Every
    model's gaps (:func:`gaps`) are kept: the workflow asks for some more than once.
    """

    kin: Kinematics
    data: BalanceData
    feats_dec: dict[str, np.ndarray]
    timing: str
    units: dict[str, str]
    notes: list[str] = field(default_factory=list)
    quantisation: float | None = None
    rests: Rests | None = None
    _masks: dict[Region, np.ndarray] = field(default_factory=dict, repr=False)
    _gaps: dict[tuple, tuple[dict[str, float], dict[str, float]]] = field(default_factory=dict, repr=False)

    def region_mask(self, region: Region) -> np.ndarray:
        """Full-rate samples inside ``region`` (cached per region)."""
        if region not in self._masks:
            kin = self.kin
            x = feature(region.feature, kin.w, kin.a, kin.u, kin.dt, self.data.w_threshold)
            self._masks[region] = region.mask({region.feature: x})
        return self._masks[region]

    @property
    def start(self) -> int:
        valid = np.flatnonzero(self.kin.valid)
        return int(valid[0]) if valid.size else 1

    def simulate(self, model: RigidDrive) -> np.ndarray:
        """Free-run velocity at every sample (NaN before the settled span)."""
        i0 = max(self.start, 1)
        out = np.full(self.kin.n, np.nan)
        out[i0:] = model.free_run(self.kin.u, w0=float(self.kin.w[i0 - 1]), start=i0)
        return out

    def balance_residual(self, model: RigidDrive) -> tuple[np.ndarray, np.ndarray]:
        """:func:`balance_residual` of this record's decimated samples."""
        return balance_residual(model, self.data)


def _column(record: pd.DataFrame, name: str, role: str) -> np.ndarray:
    if not isinstance(name, str) or name not in record.columns:
        raise DataError(f"{role} column {name!r} is not in the record; columns are {list(record.columns)}")
    values = pd.to_numeric(record[name], errors="coerce").to_numpy(dtype=float)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        raise DataError(f"column {name!r} is not finite at sample {k}: {record[name].iloc[k]!r}")
    return values


def _sample_time(record: pd.DataFrame, dt: float | None) -> float:
    if dt is None:
        dt = record.attrs.get("dt")
    if dt is None and "t" in record.columns:
        t = pd.to_numeric(record["t"], errors="coerce").to_numpy(dtype=float)
        if t.size >= 2 and np.all(np.isfinite(t)):
            dt = float(np.median(np.diff(t)))
    if dt is None:
        raise DataError("dt is not given and the record has neither attrs['dt'] nor a 't' column")
    try:
        return check_sample_time(dt)
    except ValueError as exc:
        raise DataError(str(exc)) from None


def _units(
    record: pd.DataFrame, input: str, output: str, output_kind: str, gain_given: bool
) -> dict[str, str]:
    """Concrete units of velocity ``v``, force ``F``, input ``u`` and time ``s`` for a record.

    The force unit is N (linear drive: velocity in m/s) or N m when the input
    gain is given; without it the model's forces are per input unit, so ``F``
    is the input's unit (``attrs["units"][input]``, else ``"input units"``). A
    velocity whose unit the record does not name is in ``"output units"`` (per
    second for a position): no unit is invented (:mod:`motorid.units`).
    """
    known = record.attrs.get("units") or {}
    unit = known.get(output)
    v = rate(unit) if output_kind == "position" else unit or UNNAMED_OUTPUT
    u = input_unit_name(known.get(input))
    if gain_given:
        force = "N" if v.startswith("m/") else "N m"
    else:
        force = u
    return {"v": v, "u": u, "s": "s", "F": force}


def prepare(
    record: pd.DataFrame,
    dt: float | None = None,
    input: str = "u",
    output: str = "y",
    output_kind: str = "velocity",
    input_gain: float | None = None,
    timing: str = "hold",
    band: float | None = None,
) -> Prepared:
    """Check a record and compute its kinematics and balance data.

    ``input_gain`` None (not known) fits with g = 1: the forces are then in
    the input's unit (see :func:`_units`).

    ``timing="hold"``: ``y[k]`` is measured at the end of the interval over which
    ``u[k]`` is held (motorid records); ``"sampled"``: ``y[k]`` is measured when
    ``u[k]`` is computed and ``u[k]`` then held (a sampled controller, EMPS). The
    second is brought to the first by pairing ``u[k]`` with ``y[k+1]``.
    """
    if not isinstance(record, pd.DataFrame):
        raise DataError(f"record must be a pandas DataFrame, got {type(record).__name__}")
    if output_kind not in ("velocity", "position"):
        raise DataError(f"output_kind must be 'velocity' or 'position', got {output_kind!r}")
    if timing not in ("hold", "sampled"):
        raise DataError(f"timing must be 'hold', 'sampled' or 'auto', got {timing!r}")
    gain_given = input_gain is not None
    if input_gain is None:
        input_gain = 1.0
    if isinstance(input_gain, bool) or not isinstance(input_gain, int | float | np.number):
        raise DataError(f"input_gain must be a number or None, got {input_gain!r}")
    if not math.isfinite(input_gain) or input_gain <= 0:
        raise DataError(f"input_gain must be finite and > 0, got {input_gain!r}")
    dt = _sample_time(record, dt)
    if "t" in (input, output) or input == output:
        raise DataError(
            f"input {input!r} and output {output!r} must be two columns other than the time column 't'"
        )
    u = _column(record, input, "input")
    y = _column(record, output, "output")
    check_signals({input: u, output: y})
    units = _units(record, input, output, output_kind, gain_given)
    y_unit = units["v"] if output_kind == "velocity" else (record.attrs.get("units") or {}).get(output, "")
    u, y, notes = clean_output(u, y, dt, (units["u"], y_unit), start=output_kind == "velocity")
    for note in notes:
        logger.info("%s", note)
    if timing == "sampled":
        u, y = u[:-1], y[1:]
    kin = kinematics(u, y, dt, output_kind, band)  # type: ignore[arg-type]
    if kin.decimated_index.size < 30:
        raise DataError(
            f"the record is too short: {len(record)} samples give {kin.decimated_index.size} decimated "
            f"samples after the filter edges (at least 30 needed; decimation factor {kin.factor})"
        )
    data = BalanceData(kin, float(input_gain))
    feats = features(kin.w, kin.a, kin.u, dt, data.w_threshold, at=data.idx)
    step = quantisation_step(y)
    return Prepared(kin, data, feats, timing, units, notes, step, rests_of(kin, step))


def rests_of(kin: Kinematics, step: float | None) -> Rests:
    """The rests of a record (:func:`~motorid.diagnose.rests.rests`), at rest below the larger of
    the output's quantisation ``step`` and three noise floors of its band nearest rest
    (:data:`SPEED_BANDS`)."""
    speed = np.abs(kin.w[kin.valid])
    floor = 0.0
    if speed.size:
        near = noise_bands(speed, kin.hf[kin.valid], np.asarray(SPEED_BANDS[:2]) * float(np.max(speed)),
                           kin.band, kin.dt)[0]["noise_floor"]  # fmt: skip
        floor = near if math.isfinite(near) else kin.noise
    w_rest = max(step or 0.0, 3.0 * floor, 1e-12)
    return rests(kin.u, kin.w, kin.dt, w_rest, kin.valid)


# --------------------------------------------------------------------------- measures
def balance_residual(model: RigidDrive, data: BalanceData) -> tuple[np.ndarray, np.ndarray]:
    """Force residual ``F_in - F_model`` on the decimated samples, and the commanded force ``g u``.

    On samples near rest (not moving) static friction holds whatever force lies
    between the model's friction levels at 0- and 0+ (widened by its static friction
    ``ΔF_s``): there the model force is ``J a + clip(F_in - J a, T(0-) - ΔF_s, T(0+) + ΔF_s)``.
    """
    f_in, f_model = model_balance(model, data)
    f_meas = data.decimated("F|", data.balance_force(data.input_gain * data.kin.u))
    eps = max(1e-9, 1e-6 * data.scale["w_max"])
    t_pos, t_neg = model.friction(np.array([eps, -eps]))
    excess = model.params.get("breakaway_excess", 0.0)  # static friction widens the band at rest
    lo, hi = min(t_pos, t_neg) - excess, max(t_pos, t_neg) + excess
    rest = ~data.moving
    ja = model.params["inertia"] * data.a[rest]
    f_model = f_model.copy()
    f_model[rest] = ja + np.clip(f_in[rest] - ja, lo, hi)
    return f_in - f_model, f_meas


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


def gaps(model: RigidDrive, prep: Prepared, region: Region | None) -> dict[str, float]:
    """Output gap overall and in ``region`` [v] (free run) and force error [%]."""
    return dict(_gaps_and_weights(model, prep, region)[0])


def _gaps_and_weights(
    model: RigidDrive, prep: Prepared, region: Region | None
) -> tuple[dict[str, float], dict[str, float]]:
    """:func:`gaps` and what a pool weighs them by: the samples each RMS is over (``overall``,
    ``region``) and the norm of the commanded force (``force_error_percent``)."""
    key = (model_key(model), region)
    if key not in prep._gaps:
        w_sim = prep.simulate(model)
        err = prep.kin.w - w_sim
        valid = prep.kin.valid & np.isfinite(w_sim)
        in_region = valid & prep.region_mask(region) if region is not None else np.zeros_like(valid)
        r, f_in = balance_residual(model, prep.data)
        f_norm = float(np.linalg.norm(f_in))
        prep._gaps[key] = (
            {
                "overall": _rms(err[valid]),
                "region": _rms(err[in_region]) if region is not None else float("nan"),
                "force_error_percent": 100.0 * float(np.linalg.norm(r) / max(f_norm, 1e-300)),
            },
            {"overall": int(valid.sum()), "region": int(in_region.sum()), "force_error_percent": f_norm},
        )
    return prep._gaps[key]


def free_run_error(prep: Prepared, model: RigidDrive) -> np.ndarray:
    """Measured minus free-run velocity [v] at every sample (NaN outside the settled span)."""
    err = prep.kin.w - prep.simulate(model)
    err[~prep.kin.valid] = np.nan
    return err


# --------------------------------------------------------------------------- records of one drive
@dataclass
class Pool:
    """The records of one drive, prepared, fitted and judged as one model.

    The parameters are shared; each record keeps its own kinematics, filter edges, moving
    samples and decimation, its own initial state (its free run starts from its own measured
    speed) and its own time origin (each record's free run is compared with that record only).
    The torque balance stacks the records' decimated rows (:class:`PooledBalance`), and every
    figure of merit is pooled over the samples it is an RMS of:

        gap = sqrt(Σ_i n_i gap_i² / Σ_i n_i),    σ_w = sqrt(Σ_i n_i σ_i² / Σ_i n_i),
        force error = 100 sqrt(Σ_i ||r_i||²) / sqrt(Σ_i ||F_in,i||²)

    (n_i the settled samples of record i). A pool of one record is that record: every figure
    is the record's own, computed as for it alone.
    """

    parts: list[Prepared]
    labels: list[str]
    data: BalanceData | PooledBalance = field(init=False)
    feats_dec: dict[str, np.ndarray] = field(init=False)
    noise: float = field(init=False)

    def __post_init__(self) -> None:
        first = self.parts[0]
        if len(self.parts) == 1:
            self.data, self.feats_dec, self.noise = first.data, first.feats_dec, first.kin.noise
            return
        for label, part in zip(self.labels[1:], self.parts[1:], strict=True):
            if abs(part.kin.dt - first.kin.dt) > 1e-6 * first.kin.dt or part.kin.factor != first.kin.factor:
                raise DataError(
                    f"{label}: sample time {part.kin.dt:.9g} s (decimation {part.kin.factor}) differs from "
                    f"{self.labels[0]}'s {first.kin.dt:.9g} s ({first.kin.factor}): the records of one drive "
                    "are pooled at one sample time (resample them first)"
                )
            if part.units != first.units:
                raise DataError(
                    f"{label}: units {part.units} differ from {self.labels[0]}'s {first.units}: the records "
                    "of one drive are pooled in the same units"
                )
        counts = [int(p.kin.valid.sum()) for p in self.parts]
        self.noise = math.sqrt(
            sum(n * p.kin.noise**2 for n, p in zip(counts, self.parts, strict=True)) / max(sum(counts), 1)
        )
        self.data = PooledBalance(tuple(p.data for p in self.parts), self.noise)
        self.feats_dec = {k: np.concatenate([p.feats_dec[k] for p in self.parts]) for k in first.feats_dec}

    @property
    def units(self) -> dict[str, str]:
        return self.parts[0].units

    @property
    def dt(self) -> float:
        return self.parts[0].kin.dt

    def gaps(self, model: RigidDrive, region: Region | None) -> dict[str, float]:
        """The pooled :func:`gaps` (see the class notes)."""
        if len(self.parts) == 1:
            return gaps(model, self.parts[0], region)
        pairs = [_gaps_and_weights(model, p, region) for p in self.parts]
        out = {}
        for key in ("overall", "region", "force_error_percent"):
            # a gap is an RMS over n samples, the force error a norm ratio: pool the squares
            power = 2 if key == "force_error_percent" else 1
            terms = [(g[key], w[key] ** power) for g, w in pairs]
            terms = [(g, wt) for g, wt in terms if wt > 0 and math.isfinite(g)]
            total = sum(wt for _, wt in terms)
            out[key] = math.sqrt(sum(g * g * wt for g, wt in terms) / total) if total > 0 else float("nan")
        return out

    def record_gaps(self, model: RigidDrive, region: Region | None) -> list[dict[str, float]]:
        """:func:`gaps` of each record."""
        return [gaps(model, p, region) for p in self.parts]

    def balance_residual(self, model: RigidDrive) -> tuple[np.ndarray, np.ndarray]:
        """:func:`balance_residual` of each record, stacked as the pooled rows are."""
        if len(self.parts) == 1:
            return balance_residual(model, self.parts[0].data)
        pairs = [balance_residual(model, p.data) for p in self.parts]
        return np.concatenate([r for r, _ in pairs]), np.concatenate([f for _, f in pairs])

    def free_run_error(self, model: RigidDrive, samples: list[np.ndarray] | None = None) -> np.ndarray:
        """:func:`free_run_error` of each record (on its full-rate ``samples``), stacked."""
        errors = [free_run_error(p, model) for p in self.parts]
        if samples is not None:
            errors = [e[m] for e, m in zip(errors, samples, strict=True)]
        return stacked(errors)

    def noise_bands(self) -> list[dict[str, float]]:
        """The noise floor per speed band (:func:`~motorid.diagnose.kinematics.noise_bands`) over
        the settled samples of every record, the bands :data:`SPEED_BANDS` of the largest |w|."""
        speed = stacked([np.abs(p.kin.w[p.kin.valid]) for p in self.parts])
        if speed.size == 0:
            return []
        hf = stacked([p.kin.hf[p.kin.valid] for p in self.parts])
        edges = np.asarray(SPEED_BANDS) * float(np.max(speed))
        kin = self.parts[0].kin
        return noise_bands(speed, hf, edges, kin.band, kin.dt)

    def band_floor(self, acts: str) -> float:
        """The noise floor [v] where an effect acts (:attr:`Effect.acts
        <motorid.drive.effects.base.Effect.acts>`): the band nearest rest for ``rest`` and ``rests``, the top band
        for ``speed`` (:meth:`noise_bands`), else the record-wide floor. A band of too few samples
        to measure falls back to the record-wide floor."""
        if not acts:
            return self.noise
        bands = self.noise_bands()
        if not bands:
            return self.noise
        floor = bands[-1 if acts == "speed" else 0]["noise_floor"]
        return floor if math.isfinite(floor) and floor > 0 else self.noise

    def acting_samples(self, acts: str) -> list[np.ndarray] | None:
        """Each record's full-rate samples where an effect acts: its rests and, after each, as long
        again (the breakaway and the speed it picks up: :attr:`Prepared.rests`) for ``rests``;
        speeds below the first edge of :data:`SPEED_BANDS` (of the largest |w| over the records)
        for ``rest``, above the last inner edge for ``speed``; None (every sample) for an effect
        that acts everywhere."""
        if not acts:
            return None
        if acts == "rests":
            out = []
            for p in self.parts:
                mask = np.zeros(p.kin.n, dtype=bool)
                for a, b in zip(p.rests.start, p.rests.stop, strict=True):
                    mask[a : b + 1 + (b - a + 1)] = True
                out.append(mask)
            return out
        top = max(float(np.max(np.abs(p.kin.w[p.kin.valid]), initial=0.0)) for p in self.parts)
        if acts == "rest":
            return [np.abs(p.kin.w) < SPEED_BANDS[1] * top for p in self.parts]
        return [np.abs(p.kin.w) >= SPEED_BANDS[-2] * top for p in self.parts]

    def acting_gap(self, model: RigidDrive, acts: str) -> float:
        """RMS free-run gap [v] over the samples where an effect acts (:meth:`acting_samples`)."""
        return _rms(self.free_run_error(model, self.acting_samples(acts)))

    def breakaway_excess(
        self, model: RigidDrive, samples: list[np.ndarray] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The force at breakaway above ``model``'s kinetic level at 0± [F], at each rest of each
        record (:attr:`Prepared.rests`; those that break away in the full-rate ``samples``):
        ``F_b - T(0+)`` breaking away forwards, ``T(0-) - F_b`` backwards, with ``F_b`` the force
        of the input at breakaway (:meth:`RigidDrive.input_force
        <motorid.drive.rigid.RigidDrive.input_force>`: through the model's dead zone, delay and
        lag) and ``T(0±)`` the model's friction (and offset) at ±0; and the force's rate there
        [F/s], in the direction of the motion (central differences)."""
        eps = max(1e-9, 1e-6 * self.data.scale["w_max"])
        t_pos, t_neg = model.friction(np.array([eps, -eps]))
        out, rates = [], []
        for k, p in enumerate(self.parts):
            r = p.rests if samples is None else p.rests.within(samples[k])
            f_in = model.input_force(p.kin.u)  # through the model's input path (dead zone, lag...)
            force = r.direction * f_in[r.stop]  # in the direction of the motion
            out.append(np.where(r.direction > 0, force - t_pos, force + t_neg))
            rates.append(r.direction * np.gradient(f_in, p.kin.dt)[r.stop])
        return stacked(out), stacked(rates)

    @property
    def quantisation(self) -> float | None:
        """The output's quantisation step [its unit] when every record shows the same one (1 %)."""
        steps = [p.quantisation for p in self.parts]
        if any(q is None for q in steps) or max(steps) > 1.01 * min(steps):  # type: ignore[type-var]
            return None
        return steps[0]

    def holdout_rows(self, fraction: float) -> np.ndarray:
        """Each record's held-out decimated rows (:func:`holdout_rows`), stacked."""
        return stacked([holdout_rows(p.data.n, fraction) for p in self.parts])

    def holdout_samples(self, fraction: float) -> list[np.ndarray]:
        """Each record's held-out full-rate samples: the same blocks as :meth:`holdout_rows`."""
        return [holdout_rows(p.kin.n, fraction) for p in self.parts]


#: Fewest rests a record (or pool) needs before its breakaway says anything.
MIN_RESTS = 5


@dataclass(frozen=True)
class Breakaway:
    """What the rests of a pool say of static friction, against a model's kinetic level.

    The force at breakaway above the kinetic level at 0±, ``e_i`` [F] at rest i
    (:meth:`Pool.breakaway_excess`), is fitted by least squares as a level and a lag::

        e_i = ΔF_s + τ g r_i

    with ``r_i`` the input's rate at breakaway [u/s] (:class:`~motorid.diagnose.rests.Rests`):
    a lag τ [s] between input and force (an armature's electrical time constant) raises the input
    a drive breaks away at in proportion to how fast the input rises, static friction ΔF_s does
    not. ΔF_s is the breakaway at an input that rises infinitely slowly; rests whose rates do not
    spread (a sine's reversals all alike) cannot tell it from a lag, and its standard error says so.

    Attributes
    ----------
    rests : int
        Rests counted.
    excess : float
        ΔF_s [F] (NaN for fewer than 3 rests, or rates that do not spread).
    standard_error : float
        Standard error of ΔF_s [F] from the fit's residual.
    lag : float
        τ [s].
    shown : bool
        The rests show breakaway above the kinetic level: at least :data:`MIN_RESTS` rests and
        ΔF_s above twice its standard error.
    """

    rests: int
    excess: float
    standard_error: float
    lag: float
    shown: bool

    def to_dict(self) -> dict[str, Any]:
        return {"rests": self.rests, "excess": self.excess, "standard_error": self.standard_error,
                "lag": self.lag, "shown": self.shown}  # fmt: skip


#: The rates at breakaway spread enough to tell a level from a lag when their standard deviation
#: is at least this share of their mean magnitude (a sine's reversals: 0.1-0.5 %; a chirp's: 40 %).
RATE_SPREAD = 0.2


def _breakaway_fit(excess: np.ndarray, rate: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares ``excess = ΔF_s + τ rate``: the coefficients, their covariance and the RSS.
    The covariance is inf where the rates do not spread by :data:`RATE_SPREAD` of their mean
    magnitude: reversals at one input rate cannot tell a level from a lag."""
    x = np.column_stack([np.ones(excess.size), rate])
    coef, *_ = np.linalg.lstsq(x, excess, rcond=None)
    resid = excess - x @ coef
    rss = float(resid @ resid)
    xtx = x.T @ x
    if not np.any(rate):  # every breakaway under a held input: no lag to tell, the level alone
        level = float(np.mean(excess))
        rss = float(np.sum((excess - level) ** 2))
        var = rss / max(excess.size - 1, 1) / excess.size
        return np.array([level, 0.0]), np.array([[var, 0.0], [0.0, 0.0]]), rss
    if float(np.std(rate)) < RATE_SPREAD * float(np.mean(np.abs(rate))) or np.linalg.cond(xtx) > 1e12:
        return coef, np.full((2, 2), np.inf), rss
    return coef, rss / max(excess.size - 2, 1) * np.linalg.inv(xtx), rss


def _typical(excess: np.ndarray, rate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rests that look like a breakaway: the input rising (or held) in the direction the
    drive then moves (a drive that leaves a rest while its input falls was not held by friction
    but crept off), and, of those, the ones whose breakaway lies within 3 robust standard
    deviations (1.4826 MAD) of the fit of :class:`Breakaway`, refitted until none is left out
    (at most 3 times: a rest the filtered speed left by noise would pull a least-squares level)."""
    keep = rate >= 0.0
    excess, rate = excess[keep], rate[keep]
    for _ in range(3):
        if excess.size < 3:
            break
        coef, *_ = _breakaway_fit(excess, rate)
        resid = excess - coef[0] - coef[1] * rate
        centre = float(np.median(resid))
        spread = 1.4826 * float(np.median(np.abs(resid - centre)))
        keep = np.abs(resid - centre) <= 3.0 * spread
        if spread <= 0 or keep.all():
            break
        excess, rate = excess[keep], rate[keep]
    return excess, rate


def breakaway(pool: Pool, model: RigidDrive, samples: list[np.ndarray] | None = None) -> Breakaway:
    """The breakaway the rests of ``pool`` show above ``model``'s kinetic level (see
    :class:`Breakaway`; the rests that break away in the full-rate ``samples``, the typical ones:
    :func:`_typical`)."""
    excess, rate = _typical(*pool.breakaway_excess(model, samples))
    n = int(excess.size)
    if n < 3:
        return Breakaway(n, math.nan, math.nan, math.nan, False)
    coef, cov, _ = _breakaway_fit(excess, rate)
    se = math.sqrt(cov[0, 0])
    if not math.isfinite(se):  # the rates cannot tell a level from a lag
        return Breakaway(n, math.nan, math.inf, math.nan, False)
    level = float(coef[0])
    return Breakaway(n, level, se, float(coef[1]), n >= MIN_RESTS and level > 2.0 * se)


def breakaway_evidence(excess: np.ndarray, rate: np.ndarray) -> dict[str, float]:
    """ΔBIC of static friction on the rests: the fit of :class:`Breakaway` against the lag alone
    (``e_i = τ g r_i``, no level above the kinetic one)::

        ΔBIC = n ln(RSS_lag / RSS_lag+level) - ln n

    (:func:`evidence` with the typical rests as its samples: one per reversal)."""
    excess, rate = _typical(excess, rate)
    n = int(excess.size)
    if n < 3:
        return {"delta_bic": -math.inf, "n": n, "n_eff": float(n), "rho": 0.0, "rss_ratio": 1.0}
    coef, _, rss1 = _breakaway_fit(excess, rate)
    slope = float(rate @ excess / (rate @ rate)) if float(rate @ rate) > 0 else 0.0
    resid0 = excess - slope * rate
    return evidence(float(resid0 @ resid0), rss1, n, 1, excess - coef[0] - coef[1] * rate)


def breakaway_holdout(
    train: Pool,
    train_samples: list[np.ndarray] | None,
    held: Pool,
    held_samples: list[np.ndarray] | None,
    model: RigidDrive,
) -> tuple[float, float]:
    """Held-out check of static friction on the rests: the fits of :class:`Breakaway` on the
    rests of ``train`` (in ``train_samples``), with and without the level ΔF_s, predict the
    breakaway of the rests of ``held`` (in ``held_samples``; those with the input rising) above
    ``model``'s kinetic level; the median absolute errors [F] without and with it (a median: a
    few held-out rests cannot be sifted for the typical ones; NaN without rests to fit or check)."""
    e_t, r_t = _typical(*train.breakaway_excess(model, train_samples))
    e_h, r_h = held.breakaway_excess(model, held_samples)
    e_h, r_h = e_h[r_h >= 0.0], r_h[r_h >= 0.0]
    if e_t.size < 3 or e_h.size == 0:
        return math.nan, math.nan
    coef, _, _ = _breakaway_fit(e_t, r_t)
    lag_only = float(r_t @ e_t / (r_t @ r_t)) if float(r_t @ r_t) > 0 else 0.0
    level = max(float(coef[0]), 0.0)
    return float(np.median(np.abs(e_h - lag_only * r_h))), float(
        np.median(np.abs(e_h - level - coef[1] * r_h))
    )


def fit_static_friction(pool: Pool, model: RigidDrive, samples: list[np.ndarray] | None) -> RigidDrive:
    """``model`` with ``static_friction`` and its ``breakaway_excess`` ΔF_s [F], from the full-rate
    ``samples`` of each record of ``pool`` (None: all).

    Static friction acts on a drive at rest only, so the balance of the moving samples cannot
    fit it. Where the records show at least :data:`MIN_RESTS` typical rests, they measure it: the
    force at breakaway above the model's kinetic level (:func:`breakaway`; 0 when they show
    none above it). With fewer, the free run fits it: the ΔF_s that minimises the free-run gap,
    from a grid of 17 values on [0, half the largest input force] and a bounded search between
    the best one's neighbours.
    """
    from scipy.optimize import minimize_scalar

    effects = tuple(dict.fromkeys((*model.effects, "static_friction")))

    def with_excess(excess: float) -> RigidDrive:
        return model.with_effects(effects, {**model.params, "breakaway_excess": float(excess)})

    found = breakaway(pool, model, samples)
    if found.rests >= MIN_RESTS:
        return with_excess(max(found.excess, 0.0) if math.isfinite(found.excess) else 0.0)
    top = 0.5 * pool.data.scale["u_max"] * abs(model.input_gain)

    def cost(excess: float) -> float:
        err = pool.free_run_error(with_excess(excess), samples)
        err = err[np.isfinite(err)]
        return float(np.mean(err**2)) if err.size else math.inf

    grid = np.linspace(0.0, top, 17)
    costs = [cost(e) for e in grid]
    i = int(np.argmin(costs))
    best = minimize_scalar(
        cost,
        bounds=(grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]),
        method="bounded",
        options={"xatol": 1e-4 * top, "maxiter": 500},
    )
    return with_excess(best.x if best.fun <= costs[i] else grid[i])


def _lag1(r: np.ndarray) -> float:
    r = r - r.mean()
    den = float(np.dot(r, r))
    return float(np.dot(r[1:], r[:-1]) / den) if den > 0 and r.size > 2 else 0.0


def evidence(rss0: float, rss1: float, n: int, dk: int, residual: np.ndarray) -> dict[str, float]:
    """ΔBIC on the effective sample size (see the module notes)."""
    rho = min(max(_lag1(residual), 0.0), 0.95)
    n_eff = max(n * (1.0 - rho) / (1.0 + rho), 2.0)
    ratio = rss0 / rss1 if rss1 > 0 else np.inf
    dbic = n_eff * math.log(ratio) - max(dk, 0) * math.log(n_eff) if np.isfinite(ratio) else np.inf
    return {
        "delta_bic": float(dbic),
        "n": int(n),
        "n_eff": float(n_eff),
        "rho": float(rho),
        "rss_ratio": float(ratio),
    }


def holdout_rows(n: int, fraction: float, blocks: int = 10) -> np.ndarray:
    """Held-out decimated rows: ``round(blocks * fraction)`` of ``blocks`` equal blocks, spread out."""
    m = min(max(round(blocks * fraction), 1), blocks - 1)
    chosen = np.unique(np.round(np.linspace(0, blocks - 1, m + 2)[1:-1]).astype(int))
    block = np.minimum((np.arange(n) * blocks) // max(n, 1), blocks - 1)
    return np.isin(block, chosen)


# --------------------------------------------------------------------------- results
@dataclass
class Structure:
    """The base structure chosen from the record before any other effect is judged.

    Attributes
    ----------
    effects : tuple of str
        The structure effects taken (``input_delay``, ``input_lag``; none for a drive
        that answers its input at once).
    params : dict
        Their parameters [s], held fixed in every later fit.
    probe : tuple of str
        The effects of the model the structures were compared in (the base and
        Coulomb friction: a missing friction level must not pass for a lag).
    gap_before, gap_after : float
        Free-run output gap [v] of the probe model without and with the structure.
    candidates : list of dict
        Each structure tried: ``effects``, ``params``, ``delta_bic`` (against the
        probe, or against the best single effect for the pair) and ``gap`` [v].
    reason : str
        Why this structure.
    """

    effects: tuple[str, ...] = ()
    params: dict[str, float] = field(default_factory=dict)
    probe: tuple[str, ...] = ()
    gap_before: float = float("nan")
    gap_after: float = float("nan")
    candidates: list[dict[str, Any]] = field(default_factory=list)
    reason: str = "not searched"

    def describe(self, dt: float) -> str:
        """One line for the report, e.g. ``input_delay = 0.012 s (1.20 samples)``."""
        if not self.effects:
            return "no input delay or lag"
        return ", ".join(f"{p} = {v:.4g} s ({v / dt:.2f} samples)" for p, v in self.params.items())

    def to_dict(self) -> dict[str, Any]:
        return {
            "effects": list(self.effects), "params": self.params, "probe": list(self.probe),
            "gap_before": self.gap_before, "gap_after": self.gap_after,
            "candidates": self.candidates, "reason": self.reason,
        }  # fmt: skip


@dataclass
class Lookalike:
    """Effects the data cannot tell apart: one physics, fitted alike by two or more effects.

    Attributes
    ----------
    physics : str
        What they are forms of (:meth:`Effect.physics <motorid.drive.effects.base.Effect.physics>`),
        e.g. ``kinetic friction``.
    named : str
        The effect the lookalike rule named (:func:`diagnose`, step 4).
    gaps : dict
        Effect -> free-run gap [v] of the model with it, the named one first.
    levels : dict
        Effect -> the size of the physics in that model [F] (:meth:`Effect.level <motorid.drive.effects.base.Effect.level>`).
    tolerance : float
        Two gaps closer than this [v] fit alike: ``noise_shrink`` noise floors.
    """

    physics: str
    named: str
    gaps: dict[str, float]
    levels: dict[str, float]
    tolerance: float

    def describe(self, units: dict[str, str]) -> str:
        """One line, e.g. ``kinetic friction 0.73 V: coulomb_friction and input_dead_zone fit alike
        (free-run gap 4.771 vs 4.802 rad/s, within 0.21 rad/s); named coulomb_friction by the
        lookalike rule (the first in the library's order)``."""
        names = list(self.gaps)
        figures = " vs ".join(f"{g:.4g}" for g in self.gaps.values())
        return (
            f"{self.physics} {self.levels[self.named]:.3g} {units['F']}: {' and '.join(names)} fit alike "
            f"(free-run gap {figures} {units['v']}, within {self.tolerance:.3g} {units['v']}); named "
            f"{self.named} by the lookalike rule (the first in the library's order)"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "physics": self.physics, "named": self.named, "effects": list(self.gaps),
            "free_run_gaps": self.gaps, "levels": self.levels, "tolerance": self.tolerance,
        }  # fmt: skip


@dataclass
class Step:
    """One accepted effect.

    Attributes
    ----------
    effect : str
        The effect's name.
    params : dict
        Its parameters (SI units) in the refitted model.
    region : Region
        Where the disagreement concentrated before it was added.
    gap_before, gap_after : dict
        ``overall`` and ``region`` output gap [v], ``force_error_percent`` [%].
    evidence : dict
        ΔBIC and its threshold, held-out errors [F], the candidate ranking.
    model : RigidDrive
        The refitted model after this step.
    record_gaps : list of dict
        Several records: each record's ``record`` label and overall ``gap_before`` and
        ``gap_after`` [v] (the step's gaps are the pooled ones); empty for one record.
    lookalike : Lookalike or None
        The effects that fit alike here, and which one the lookalike rule named.
    """

    effect: str
    params: dict[str, float]
    region: Region
    gap_before: dict[str, float]
    gap_after: dict[str, float]
    evidence: dict[str, Any]
    model: RigidDrive
    record_gaps: list[dict[str, Any]] = field(default_factory=list)
    lookalike: Lookalike | None = None

    def to_dict(self) -> dict[str, Any]:
        out = {
            "effect": self.effect,
            "params": self.params,
            "region": self.region.to_dict(),
            "gap_before": self.gap_before,
            "gap_after": self.gap_after,
            "evidence": self.evidence,
            "model_params": self.model.params,
        }
        if self.record_gaps:
            out["record_gaps"] = self.record_gaps
        if self.lookalike is not None:
            out["lookalike"] = self.lookalike.to_dict()
        return out


@dataclass
class Diagnosis:
    """What :func:`diagnose` found.

    Attributes
    ----------
    initial_gap, final_gap : dict
        ``overall`` output gap [v] (RMS of measured minus free-run velocity),
        ``region`` (the same in the first located region) and
        ``force_error_percent`` [%] (torque-balance error on the decimated samples).
    steps : list of Step
    stop_reason : str
        Why the search stopped, then the final gap against the noise floor: at it, or
        many times it ("something is still missing") and where it concentrates.
    noise_floor : float
        σ_w [v]: standard deviation of the noise on the measured velocity the free
        run is compared with, estimated from the record (see the module notes; several
        records: pooled over them, :class:`Pool`).
    final_region : Region
        Where the final model's torque-balance residual concentrates.
    model : RigidDrive
        The final fitted model (``model.params``: inertia, input_gain, viscous, ...),
        at the record's sample time; ``model.save(path)`` writes it as a model file.
    initial_model : RigidDrive
        The user's model as given (``diagnose(model=...)``), else the fitted base.
    region : Region
        The region located on the initial model's residual.
    units : dict
        Units of velocity (``v``), force (``F``) and input (``u``): ``F`` is
        N or N m with a known input gain, else the input's unit.
    settings : dict
        Options used (for :meth:`evaluate` on another record).
    rejected : list of dict
        Candidates that passed the evidence threshold but were not accepted, and why.
    refitted_model, refitted_gap : RigidDrive and dict, or None
        With a given model: its effects refitted to the record, and their gaps (the
        start of the first step).
    param_std : dict
        Standard error of each linear parameter of the final model (inertia and the
        effects' levels, in the units of ``param_units``), from the fit's residual
        (:func:`motorid.diagnose.model.linear_param_std`); shape parameters have none.
    param_share : dict
        Share of the input force each linear parameter's term carries
        (:func:`motorid.diagnose.model.force_shares`) [-].
    noise_bands : list of dict
        The noise floor per speed band (:meth:`Pool.noise_bands`): ``speed_from``, ``speed_to``
        [v], ``samples``, ``noise_floor`` [v]. An encoder's noise often grows with speed, where
        :attr:`noise_floor` is one figure over every speed.
    quantisation_step : float or None
        The step the output is quantised in [its unit] (an encoder's count per sample), when it
        shows (:func:`~motorid.diagnose.kinematics.quantisation_step`).
    rests : list of dict
        Per record (:func:`rest_summaries`): its ``record`` label, the ``count`` of its rests,
        their ``median_length`` [s], ``median_breakaway_input`` [u] (the input it breaks away
        at, in the direction it then moves: :mod:`.rests`) and ``median_input_rate`` [u/s] (how
        fast that input rises there), ``w_rest`` [v] (the speed below which
        it counts as at rest), the final model's ``kinetic_level`` at 0 [F] (mean of the two
        directions), ``breakaway_excess`` [F] (the force at breakaway above it at an input that
        rises infinitely slowly, and its ``breakaway_excess_std``) and ``breakaway_lag`` [s] (how
        much later the force follows the input: :class:`Breakaway`).
    notes : list of str
        One line per logging artefact left out of a record (a held start, drop-out spikes:
        :mod:`.artefacts`); with several records each begins with the record's label.
    records : list of dict
        Several records of one drive (:class:`Pool`): per record its ``record`` label,
        ``samples``, ``noise_floor`` [v], ``initial_gap`` and ``final_gap`` (as above, of that
        record alone) and ``final_gap_noise_floors``; the gaps above are the pooled ones.
        Empty for one record.
    """

    initial_gap: dict[str, float]
    final_gap: dict[str, float]
    steps: list[Step]
    stop_reason: str
    noise_floor: float
    final_region: Region
    model: RigidDrive
    initial_model: RigidDrive
    region: Region
    units: dict[str, str]
    settings: dict[str, Any]
    rejected: list[dict[str, Any]] = field(default_factory=list)
    refitted_model: RigidDrive | None = None
    refitted_gap: dict[str, float] | None = None
    param_std: dict[str, float] = field(default_factory=dict)
    param_share: dict[str, float] = field(default_factory=dict)
    structure: Structure = field(default_factory=Structure)
    structure_model: RigidDrive | None = None
    records: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    noise_bands: list[dict[str, float]] = field(default_factory=list)
    quantisation_step: float | None = None
    rests: list[dict[str, Any]] = field(default_factory=list)
    _pool: Pool | None = field(default=None, repr=False)

    @property
    def named(self) -> list[str]:
        """The effects added, in order."""
        return [s.effect for s in self.steps]

    @property
    def lookalikes(self) -> list[Lookalike]:
        """The steps' lookalikes: effects that fit alike and the one the rule named."""
        return [s.lookalike for s in self.steps if s.lookalike is not None]

    @property
    def undetermined(self) -> dict[str, str]:
        """The linear parameters the record(s) cannot determine, each with why.

        A parameter is not determined when its standard error exceeds
        :data:`RELATIVE_STD_LIMIT` of its value, and the inertia also when its term carries less
        than :data:`INERTIA_SHARE_LIMIT` of the input force (a slow sine spends its force on
        friction; the inertia then follows whatever the rigid model leaves unexplained, and
        records of other signals disagree with it by more than its standard error). The fitted
        value stays in :attr:`model` for the free run; the report does not present it as a
        finding. A dropped column (value and standard error 0) is not listed.
        """
        out = {}
        for name, std in self.param_std.items():
            value = self.model.params.get(name, math.nan)
            share = self.param_share.get(name, math.nan)
            if value == 0.0 and std == 0.0:
                continue
            if name == "inertia" and share < INERTIA_SHARE_LIMIT:
                out[name] = (
                    f"its term carries {100 * share:.1f} % of the input force, below {100 * INERTIA_SHARE_LIMIT:.0f} %"
                )
            elif not std <= RELATIVE_STD_LIMIT * abs(value):
                out[name] = (
                    f"standard error {std:.2g} is above {100 * RELATIVE_STD_LIMIT:.0f} % of {value:.3g}"
                )
        return out

    @property
    def param_units(self) -> dict[str, str]:
        """Concrete unit of each parameter of the final model, e.g. ``{"coulomb": "N m"}``."""
        return {name: param_unit(name, self.units) for name in self.model.params}

    @property
    def models(self) -> list[tuple[str, RigidDrive]]:
        """``(label, model)`` for the initial model and after each step."""
        out = [("initial", self.initial_model)]
        if self.refitted_model is not None:
            out.append(("refitted", self.refitted_model))
        if self.structure_model is not None:
            out.append(("+" + "+".join(self.structure.effects), self.structure_model))
        out += [(f"+{s.effect}", s.model) for s in self.steps]
        return out

    def to_dict(self) -> dict[str, Any]:
        """The JSON shape of ``motorid doctor --json``."""
        return {
            "initial_gap": self.initial_gap,
            "final_gap": self.final_gap,
            "steps": [s.to_dict() for s in self.steps],
            "stop_reason": self.stop_reason,
            "noise_floor": self.noise_floor,
            "noise_bands": self.noise_bands,
            "quantisation_step": self.quantisation_step,
            "at_noise_floor_factor": self.settings["missing_factor"],
            "rests": self.rests,
            "region": self.region.to_dict(),
            "final_region": self.final_region.to_dict(),
            "model": {
                "effects": list(self.model.effects),
                "params": self.model.params,
                "params_std": self.param_std,
                "params_share": self.param_share,
                "params_undetermined": self.undetermined,
            },
            "rejected": self.rejected,
            "units": {
                "gap": f"{self.units['v']} (RMS of measured minus free-run velocity"
                + (
                    "; velocity derived from position)" if self.settings["output_kind"] == "position" else ")"
                ),
                "force_error_percent": "%",
                "force": self.units["F"],
                "velocity": self.units["v"],
                "input": self.units["u"],
                "params": self.param_units,
            },
            "settings": self.settings,
            "initial_model": {
                "effects": list(self.initial_model.effects),
                "params": self.initial_model.params,
            },
            "refitted_gap": self.refitted_gap,
            "structure": self.structure.to_dict(),
            **({"records": self.records} if self.records else {}),
            **({"lookalikes": [x.to_dict() for x in self.lookalikes]} if self.lookalikes else {}),
            **({"notes": self.notes} if self.notes else {}),
        }

    def table(self) -> pd.DataFrame:
        """Gap before and after each step, overall and in the step's region."""
        rows = []
        for s in self.steps:
            rows.append(
                {
                    "effect": s.effect,
                    "region": s.region.description,
                    "gap_before": s.gap_before["overall"],
                    "gap_after": s.gap_after["overall"],
                    "region_gap_before": s.gap_before["region"],
                    "region_gap_after": s.gap_after["region"],
                    "force_error_before_percent": s.gap_before["force_error_percent"],
                    "force_error_after_percent": s.gap_after["force_error_percent"],
                    "delta_bic": s.evidence["delta_bic"],
                }
            )
        df = pd.DataFrame(rows, columns=[
            "effect", "region", "gap_before", "gap_after", "region_gap_before", "region_gap_after",
            "force_error_before_percent", "force_error_after_percent", "delta_bic",
        ])  # fmt: skip
        df.index = pd.RangeIndex(1, len(df) + 1, name="step")
        df.attrs["units"] = {"gap": self.units["v"], "force_error": "%"}
        return df

    def evaluate(self, record: pd.DataFrame, **overrides: Any) -> pd.DataFrame:
        """Gaps of the initial model and of the model after each step on another record.

        No refitting: the models found here are simulated on ``record``'s input
        and their torque balance evaluated on its data. Column names, output
        kind, input gain, timing and band, and the way the record is read (its
        columns and units, :func:`motorid.records.normalise_record`), are those of
        this diagnosis unless overridden (``input=``, ``output=``, ``dt=`` ...).

        Returns
        -------
        pandas.DataFrame
            One row per model (``initial``, ``+effect``...), columns ``overall``
            and ``region`` [v] (the region located on this record's initial
            residual) and ``force_error_percent`` [%].
        """
        from motorid.records import normalise_record

        reading = {"input": self.settings["input"], "output": self.settings["output"], "dt": None,
                   **self.settings.get("reading", {})}  # fmt: skip
        reading.update({k: v for k, v in overrides.items() if k in reading})
        record = normalise_record(record, **reading)
        keys = ("output_kind", "input_gain", "timing", "band")
        opts = {k: self.settings[k] for k in keys}
        opts.update({k: v for k, v in overrides.items() if k not in reading})
        prep = prepare(record, input="u", output="y", dt=reading["dt"], **opts)
        rows = {label: gaps(model, prep, self.region) for label, model in self.models}
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "model"
        df.attrs["units"] = {
            "overall": self.units["v"],
            "region": self.units["v"],
            "force_error_percent": "%",
        }
        return df

    def write_figures(self, out_dir: str | Path) -> list[Path]:
        """PNG figures: residual against speed before/after each step; simulation against measurement.

        Several records: one pair of figures per record, named with its number (``doctor_2_...``).
        """
        from motorid.diagnose.figures import write_figures

        if self._pool is None:
            raise ValueError("this diagnosis holds no record data to plot")
        parts = self._pool.parts
        if len(parts) == 1:
            return write_figures(self, parts[0], Path(out_dir))
        return [
            path
            for k, prep in enumerate(parts, 1)
            for path in write_figures(self, prep, Path(out_dir), prefix=f"doctor_{k}_")
        ]


# --------------------------------------------------------------------------- workflow
def _lookalike_rule(
    accepted: tuple[dict[str, Any], dict[str, float], dict[str, Any]],
    passing: list[dict[str, Any]],
    judge: Callable[[dict[str, Any]], tuple[bool, dict[str, float], dict[str, Any]]],
    pool: Pool,
    region: Region,
    tolerance: float,
    model: tuple[str, ...],
) -> tuple[tuple[dict[str, Any], dict[str, float], dict[str, Any]], Lookalike | None]:
    """The lookalike rule (step 4 of the module notes): among the accepted candidate and the
    passing candidates of the same physics (:meth:`Effect.physics
    <motorid.drive.effects.base.Effect.physics>` in the ``model`` they are added to) whose
    free-run gap lies within ``tolerance`` [v] of its own, the first in the library's order
    (:func:`motorid.drive.effects.names`) is named, when it passes :func:`diagnose`'s
    checks too. Returns the candidate accepted and the lookalike (None when nothing fits alike).
    """
    c, gap1, _ = accepted
    physics = get_effect(c["effect"]).physics(model)
    if not physics:
        return accepted, None
    alike = [(c, gap1)]
    for m in passing:
        if m is not c and get_effect(m["effect"]).physics(model) == physics:
            gap_m = pool.gaps(m["fit"].model, region)
            if abs(gap_m["overall"] - gap1["overall"]) <= tolerance:
                alike.append((m, gap_m))
    if len(alike) == 1:
        return accepted, None
    order = list(effect_names())
    preferred = min(alike, key=lambda item: order.index(item[0]["effect"]))[0]
    if preferred is not c:
        ok, gap_p, record_p = judge(preferred)
        if ok:
            accepted = (preferred, gap_p, record_p)
    named = accepted[0]
    alike.sort(key=lambda item: item[0] is not named)
    lookalike = Lookalike(
        physics=physics,
        named=named["effect"],
        gaps={m["effect"]: g["overall"] for m, g in alike},
        levels={m["effect"]: get_effect(m["effect"]).level(m["fit"].model.params) for m, _ in alike},
        tolerance=tolerance,
    )
    return accepted, lookalike


def record_summaries(
    pool: Pool, initial: RigidDrive, final: RigidDrive, region: Region
) -> list[dict[str, Any]]:
    """Each record's gaps of the ``initial`` and ``final`` models and its noise floor
    (:attr:`Diagnosis.records`); none for a pool of one record."""
    if len(pool.parts) == 1:
        return []
    out = []
    for label, prep, before, after in zip(
        pool.labels,
        pool.parts,
        pool.record_gaps(initial, region),
        pool.record_gaps(final, region),
        strict=True,
    ):
        floor = prep.kin.noise
        out.append({
            "record": label, "samples": prep.kin.n, "noise_floor": floor, "initial_gap": before,
            "final_gap": after, "final_gap_noise_floors": after["overall"] / floor if floor > 0 else math.inf,
        })  # fmt: skip
    return out


def rest_summaries(pool: Pool, model: RigidDrive) -> list[dict[str, Any]]:
    """Each record's rests (:meth:`Rests.summary <motorid.diagnose.rests.Rests.summary>`) and the
    breakaway they show above ``model``'s kinetic level (:func:`breakaway`) (:attr:`Diagnosis.rests`)."""
    eps = max(1e-9, 1e-6 * pool.data.scale["w_max"])
    t_pos, t_neg = model.friction(np.array([eps, -eps]))
    out = []
    for k, (label, prep) in enumerate(zip(pool.labels, pool.parts, strict=True)):
        only = [np.full(p.kin.n, j == k) for j, p in enumerate(pool.parts)]
        found = breakaway(pool, model, only)
        out.append({
            "record": label, **prep.rests.summary(), "kinetic_level": 0.5 * float(t_pos - t_neg),
            "breakaway_excess": found.excess, "breakaway_excess_std": found.standard_error,
            "breakaway_lag": found.lag,
        })  # fmt: skip
    return out


def _against_noise(
    gap: float, region_gap: float, region: Region, floor: float, missing_factor: float, unit: str
) -> str:
    """The final gap [unit] against the noise floor [unit], and where it concentrates when far above."""
    ratio = gap / floor if floor > 0 else (0.0 if gap == 0 else math.inf)
    text = f"final gap {gap:.4g} {unit} = {ratio:.1f} x the noise floor {floor:.3g} {unit}"
    if ratio <= missing_factor:
        return text + ": at the noise floor, nothing more to explain"
    return (
        f"{text}: something is still missing; the gap concentrates where {region.description} "
        f"(final gap there {region_gap:.4g} {unit})"
    )


#: The structures tried, each single effect first; the pair only when a single one passes.
STRUCTURES: tuple[tuple[str, ...], ...] = (("input_delay",), ("input_lag",), ("input_delay", "input_lag"))


def choose_structure(
    pool: Pool,
    base: tuple[str, ...],
    start: dict[str, float],
    stribeck_shape: str,
    threshold: float,
    min_gap_shrink: float,
    noise_shrink: float,
) -> Structure:
    """Choose the input delay and lag of the drive from its records, before friction is judged.

    The base and Coulomb friction (the probe) are fitted to the torque balance on the moving
    samples with each structure of :data:`STRUCTURES` added (the delay and the time constant
    by the bounded search of :func:`~motorid.diagnose.model.fit_model`). A structure is taken
    when its ΔBIC against the probe (for the pair: against the best single effect) exceeds
    ``threshold`` and its free-run output gap shrinks by more than ``min_gap_shrink`` of the
    probe's and by more than ``noise_shrink`` noise floors: the same rules as a step.
    """
    data = pool.data
    floor = pool.noise
    probe = effect_order((*base, "coulomb_friction"))
    fit_p = fit_model(data, probe, start=start, stribeck_shape=stribeck_shape)
    gap_p = pool.gaps(fit_p.model, None)["overall"]
    tried: list[dict[str, Any]] = []
    fits: dict[tuple[str, ...], FitResult] = {}

    def fit_pair(against: FitResult) -> FitResult:
        """The pair's fit: a delay and a lag trade along a valley (their sum is what the balance
        sees first), where a search one coordinate at a time stalls; so the delay is searched at
        each lag of a grid up to the single effect's total (a profile), then both refined."""
        names = STRUCTURES[-1]
        total = sum(against.model.params.get(p, 0.0) for p in ("input_delay", "lag_time_constant"))
        lo = get_effect("input_lag").bounds(data.scale)["lag_time_constant"][0]
        profile = [
            fit_model(data, (*probe, *names), start=against.model.params, stribeck_shape=stribeck_shape,
                      fixed={"lag_time_constant": lag})
            for lag in np.geomspace(lo, max(total, 2.0 * lo), 9)
        ]  # fmt: skip
        best = min(profile, key=lambda f: f.rss)
        fit = fit_model(data, (*probe, *names), start=best.model.params, stribeck_shape=stribeck_shape)
        return fit if fit.rss <= best.rss else best

    def try_structure(names: tuple[str, ...], against: FitResult) -> dict[str, Any]:
        if len(names) > 1:
            fit = fit_pair(against)
        else:
            fit = fit_model(data, (*probe, *names), start=against.model.params, stribeck_shape=stribeck_shape)
        ev = evidence(
            against.rss, fit.rss, fit.n_rows, fit.n_params - against.n_params, fit.residual[data.moving]
        )
        params = {p: fit.model.params[p] for n in names for p in get_effect(n).nonlinear}
        row = {"effects": list(names), "params": params, "delta_bic": ev["delta_bic"], "gap": math.nan}
        fits[names] = fit
        tried.append(row)
        return row

    singles = [try_structure(names, fit_p) for names in STRUCTURES if len(names) == 1]
    passing = sorted((r for r in singles if r["delta_bic"] > threshold), key=lambda r: -r["delta_bic"])
    # ΔBIC alone decides between the single effects: a delay and a lag of 1-2 samples fit alike,
    # and on 24 records with one planted the balance named the right one 23 times, the free-run
    # gap (biased towards the lag) only 18 times
    if passing:
        best_single = tuple(passing[0]["effects"])
        pair = try_structure(STRUCTURES[-1], fits[best_single])
        if pair["delta_bic"] > threshold:
            passing.insert(0, pair)
    reasons = []
    for row in passing:
        names = tuple(row["effects"])
        row["gap"] = gap1 = pool.gaps(fits[names].model, None)["overall"]
        shrink = (gap_p - gap1) / floor if floor > 0 else math.inf
        if gap1 < (1.0 - min_gap_shrink) * gap_p and shrink > noise_shrink:
            reason = (
                f"chosen from the moving samples: ΔBIC {row['delta_bic']:.1f} > {threshold:g}, free-run gap of "
                f"{' + '.join(probe)} {gap_p:.4g} -> {gap1:.4g} ({shrink:.1f} noise floors)"
            )
            return Structure(names, row["params"], probe, gap_p, gap1, tried, reason)
        reasons.append(
            f"{'+'.join(names)} (free-run gap {gap_p:.4g} -> {gap1:.4g}, {shrink:.2f} noise floors)"
        )
    if reasons:
        reason = (
            "no delay or lag: the structures that pass ΔBIC do not shrink the free-run gap: "
            + ", ".join(reasons)
        )
    else:
        best = max(tried, key=lambda r: r["delta_bic"])
        reason = (
            f"no delay or lag: the best, {'+'.join(best['effects'])}, has ΔBIC {best['delta_bic']:.1f} "
            f"<= {threshold:g}"
        )
    return Structure((), {}, probe, gap_p, gap_p, tried, reason)


def _names(value: Sequence[str] | str | None, what: str) -> tuple[str, ...]:
    if value is None:
        return ()
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip()]
    out = []
    for name in value:
        if name not in effect_names():
            raise DataError(f"{what}: unknown effect {name!r}; known effects: {', '.join(effect_names())}")
        out.append(name)
    return tuple(dict.fromkeys(out))


def diagnose(
    record: pd.DataFrame | Sequence[pd.DataFrame],
    dt: float | None = None,
    input: str = "u",
    output: str = "y",
    output_kind: Literal["velocity", "position"] = "velocity",
    input_gain: float | None = None,
    base: Sequence[str] | str | None = None,
    candidates: Sequence[str] | str | None = None,
    holdout: float | pd.DataFrame = 0.3,
    max_steps: int = 3,
    progress: bool = False,
    *,
    threshold: float = DEFAULT_THRESHOLD,
    min_holdout_gain: float = 0.01,
    min_gap_shrink: float = 0.01,
    noise_shrink: float = NOISE_SHRINK,
    missing_factor: float = MISSING_FACTOR,
    timing: Literal["hold", "sampled", "auto"] | None = None,
    band: float | None = None,
    model: RigidDrive | None = None,
    structure: bool = True,
    time: str | None = None,
    time_unit: str | None = None,
    input_unit: str | None = None,
    output_unit: str | None = None,
    supply_voltage: float | None = None,
    input_full_scale: float | None = None,
    resample: bool = False,
    labels: Sequence[str] | None = None,
) -> Diagnosis:
    """Find the effects missing from a rigid drive model of ``record`` (see the module notes).

    Parameters
    ----------
    record : pandas.DataFrame or sequence of DataFrame
        The measurement, as the user's own code holds it: the columns and units
        are named by the options below, the same as the command line's, and
        brought to motorid's by :func:`motorid.records.normalise_record`;
        ``attrs["dt"]`` is used when ``dt`` is None. Several records of one
        drive (at one sample time, read with the same options) are fitted as one model
        (:class:`Pool`): shared parameters, each record its own initial state and time origin;
        each candidate is judged on the pooled evidence, and :attr:`Diagnosis.records` holds
        the gaps of each record.
    dt : float, optional
        Sample time [s], > 0; default from ``attrs["dt"]`` or the time column.
    input, output : str
        Column names of the input (e.g. [V]) and the output, any text.
    output_kind : {"velocity", "position"}
        What the output is. Position records are differentiated (zero-phase
        low-pass and central differences); their output gap is then measured
        on the velocity derived from position, since a free-run position drifts.
    input_gain : float, optional
        Force or torque per input unit g [N/V or N m/V], > 0, so the model's
        parameters come out in N or N m. Without it (None) the fit takes g = 1
        and forces are per input unit: a Coulomb level of 0.8 is 0.8 V when the
        input is in V (the torque balance fixes them only up to this scale).
        :attr:`Diagnosis.units` states which.
    base : sequence of str or comma-separated str, optional
        Effects already in the model (inertia and input gain always are); default
        :data:`DEFAULT_BASE`, or the effects of ``model``.
    candidates : sequence of str, optional
        Effects to try; default every effect of the library not in ``base``.
    holdout : float or DataFrame
        Share of the record held out (in 10 interleaved blocks), in (0, 0.9),
        or a second record for the held-out check.
    max_steps : int
        Most effects added, >= 0.
    progress : bool
        Show a progress bar on stderr (:func:`motorid.progress.progress_bar`).
    threshold : float
        ΔBIC a candidate needs to pass.
    min_holdout_gain, min_gap_shrink : float
        Smallest relative improvement of the held-out torque-balance error and
        of the free-run output gap for a candidate to be accepted.
    noise_shrink : float
        Smallest free-run gap shrink of a second or later step, in noise floors, >= 0.
    missing_factor : float
        Final gap, in noise floors, above which :attr:`Diagnosis.stop_reason` says
        that something is still missing, > 0.
    timing : {"hold", "sampled", "auto"}, optional
        Input/output timing (:func:`prepare`); ``auto`` takes the one whose
        base model fits the torque balance better (a base model that lacks an
        effect can mislead it). By default the record's ``attrs["timing"]``
        (:func:`motorid.datasets.load_emps` sets ``"sampled"``: the controller
        reads the position, then holds its output), else ``"hold"``, the
        motorid convention of :mod:`motorid.drive`.
    band : float, optional
        Useful band [Hz] (:mod:`.kinematics`).
    model : RigidDrive, optional
        The user's own model of the drive. The initial gap is then this model, as
        given, against the measurement ("where does my simulation disagree"); the
        workflow refits its effects (every parameter free; its Stribeck shape kept),
        then names, adds and refits as without it. Its input gain is the force scale
        unless ``input_gain`` is given; its effects are the base (give no ``base``).
    structure : bool
        Choose the input delay and lag from the record before any other effect is
        judged (:func:`choose_structure`; skipped when the base already holds one);
        the chosen values are held in every later fit. False: the base as given.
    time, time_unit, input_unit, output_unit, supply_voltage, input_full_scale, resample
        The time column (default ``t``; none needed when ``dt`` is known) and the
        record's units, as :class:`motorid.records.RecordOptions` (``--time``,
        ``--time-unit``, ``--input-unit``, ... on the command line): e.g.
        ``diagnose(df, input="pwm", output="rpm", input_unit="%", output_unit="rpm")``.
    labels : sequence of str, optional
        A name for each record in the report (e.g. its file); default ``record 1``, ``record 2``...

    Returns
    -------
    Diagnosis
    """
    from motorid.progress import progress_bar
    from motorid.records import normalise_record

    columns = {"time": time, "input": input, "output": output}
    reading = {"dt": dt, "time_unit": time_unit, "input_unit": input_unit, "output_unit": output_unit,
               "supply_voltage": supply_voltage, "input_full_scale": input_full_scale, "resample": resample}  # fmt: skip
    if isinstance(holdout, pd.DataFrame):
        holdout = normalise_record(holdout, **columns, **reading)
    input, output = "u", "y"
    if model is not None and not isinstance(model, RigidDrive):
        raise DataError(f"model must be a RigidDrive, got {type(model).__name__}")
    if model is not None and base is not None:
        raise DataError("base: give either base effects or a model (its effects are the base), not both")
    if model is not None:
        base_names = model.effects
        if input_gain is None:
            input_gain = model.input_gain
    else:
        base_names = _names(DEFAULT_BASE if base is None else base, "base")
    stribeck_shape = "exponential" if model is None else model.stribeck_shape
    if candidates is None:
        cand_names = tuple(n for n in effect_names() if n not in base_names and not get_effect(n).structure)
    else:
        cand_names = tuple(n for n in _names(candidates, "candidates") if n not in base_names)
    if isinstance(max_steps, bool) or not isinstance(max_steps, int | np.integer) or max_steps < 0:
        raise DataError(f"max_steps must be an integer >= 0, got {max_steps!r}")
    if not isinstance(holdout, pd.DataFrame):
        if isinstance(holdout, bool) or not isinstance(holdout, int | float) or not 0.0 < holdout < 0.9:
            raise DataError(f"holdout must be a fraction in (0, 0.9) or a DataFrame, got {holdout!r}")
    records = [record] if isinstance(record, pd.DataFrame) else record
    if isinstance(records, str) or not isinstance(records, Sequence) or not records:
        raise DataError(
            f"record must be a pandas DataFrame or a non-empty sequence of them, got {type(record).__name__}"
        )
    labels = [f"record {k + 1}" for k in range(len(records))] if labels is None else [str(x) for x in labels]
    if len(labels) != len(records):
        raise DataError(f"labels: {len(labels)} labels for {len(records)} records")

    def normalised(r: pd.DataFrame, label: str) -> pd.DataFrame:
        # only the columns the doctor reads are brought over (a simulated record's true states stay behind)
        part = r
        if isinstance(r, pd.DataFrame):
            named = [c for c in (time or "t", columns["input"], columns["output"]) if c in r.columns]
            if len(named) == 3 or (len(named) == 2 and time is None):
                part = r[named]
                part.attrs = dict(r.attrs)
        try:
            return normalise_record(part, **columns, **reading)
        except DataError as exc:
            raise DataError(f"{label}: {exc}" if len(records) > 1 else str(exc)) from None

    records = [normalised(r, label) for r, label in zip(records, labels, strict=True)]
    if timing is None:
        own = [record_timing(getattr(r, "attrs", {})) for r in records]
        if len(set(own)) > 1:
            raise DataError(
                f"the records say different timings ({', '.join(f'{x}: {t}' for x, t in zip(labels, own, strict=True))}): "
                "pass timing= for all of them"
            )
        timing = own[0]
    if timing not in ("auto", "hold", "sampled"):
        raise DataError(f"timing must be 'auto', 'hold' or 'sampled', got {timing!r}")
    if not isinstance(structure, bool):
        raise DataError(f"structure must be True or False, got {structure!r}")
    if not math.isfinite(threshold):
        raise DataError(f"threshold must be finite, got {threshold!r}")
    if not (isinstance(noise_shrink, int | float) and math.isfinite(noise_shrink) and noise_shrink >= 0):
        raise DataError(f"noise_shrink must be a finite number >= 0 (noise floors), got {noise_shrink!r}")
    if not (isinstance(missing_factor, int | float) and math.isfinite(missing_factor) and missing_factor > 0):
        raise DataError(f"missing_factor must be a finite number > 0 (noise floors), got {missing_factor!r}")

    opts = {"dt": dt, "input": input, "output": output, "output_kind": output_kind,
            "input_gain": input_gain, "band": band}  # fmt: skip

    def pooled(timing: str) -> Pool:
        parts = []
        for label, r in zip(labels, records, strict=True):
            try:
                parts.append(prepare(r, timing=timing, **opts))
            except DataError as exc:
                raise DataError(f"{label}: {exc}" if len(records) > 1 else str(exc)) from None
        return Pool(parts, labels)

    if timing == "auto":
        pools = [pooled(t) for t in ("hold", "sampled")]
        scores = []
        for p in pools:
            fit = fit_model(p.data, base_names, stribeck_shape=stribeck_shape)
            commanded = sum(
                float(np.sum(q.data.kin.decimate(q.data.kin.u)[q.data.moving] ** 2)) for q in p.parts
            )
            scores.append(fit.rss / max(commanded, 1e-300))
        pool = pools[int(np.argmin(scores))]
        pools.clear()  # the other timing's arrays go now
    else:
        pool = pooled(timing)
    records.clear()  # the normalised copies go: each part holds what it needs
    data = pool.data
    first = pool.parts[0]
    settings = {**opts, "input": columns["input"], "output": columns["output"], "dt": first.kin.dt,
                "reading": {"time": time, **{k: v for k, v in reading.items() if k != "dt"}},
                "timing": first.timing, "band": first.kin.band,
                "base": list(base_names), "candidates": list(cand_names), "threshold": threshold,
                "noise_shrink": noise_shrink, "missing_factor": missing_factor,
                "holdout": "record" if isinstance(holdout, pd.DataFrame) else holdout,
                "max_steps": int(max_steps), "model": "given" if model is not None else "fitted",
                "stribeck_shape": stribeck_shape, "structure": structure}  # fmt: skip
    if len(labels) > 1:
        settings["records"] = list(labels)

    if isinstance(holdout, pd.DataFrame):
        other = prepare(holdout, **opts, timing=first.timing)
        train = np.ones(data.n, dtype=bool)
        held_rows = other.data.moving
    else:
        held = pool.holdout_rows(float(holdout))
        train, held_rows = ~held, held & data.moving
    # the same blocks at full rate, for static friction (held out on the rests in them)
    held_full = None if isinstance(holdout, pd.DataFrame) else pool.holdout_samples(float(holdout))

    fixed: dict[str, float] = {}  # the structure's delay and lag once chosen

    def held_error(effects: tuple[str, ...], start: dict[str, float] | None) -> float:
        """RMS torque-balance residual / J [v/s] on the held-out rows, fitted on the training rows."""
        fit = fit_model(data, effects, rows=train, start=start, stribeck_shape=stribeck_shape, fixed=fixed)
        inertia = fit.model.params["inertia"]
        if not inertia > 0:
            return math.inf
        if held_full is None:
            r, _ = balance_residual(fit.model, other.data)
        else:
            r, _ = pool.balance_residual(fit.model)
        return _rms(r[held_rows]) / inertia

    current = tuple(base_names)
    # stages: the initial fit, each step, the final gaps (after the checks: an error shows no bar)
    bar = progress_bar(show=progress, total=max_steps + 2, desc="doctor", unit="stage")
    bar.set_postfix_str(f"initial fit on {data.n} decimated samples")
    # a rest-only effect of the user's model (static friction) keeps its value: the balance cannot refit it
    kept = (
        {p: model.params[p] for n in current if get_effect(n).rest_only for p in get_effect(n).nonlinear}
        if model
        else {}
    )
    fit0 = fit_model(data, current, stribeck_shape=stribeck_shape, start=kept or None)
    # the user's model as given (at the record's sample time), else the fitted base
    initial_model = fit0.model if model is None else model.replace(dt=pool.dt)
    r0, _ = pool.balance_residual(initial_model)
    refitted_model = fit0.model
    first_region = locate(r0, pool.feats_dec, pool.units)
    steps: list[Step] = []
    rejected: list[dict[str, Any]] = []
    stop_reason = f"max_steps = {max_steps} reached"
    floor = pool.noise
    v = pool.units["v"]
    # a model given with a friction effect of its own stands where a step would have put it: the
    # same rules judge what comes next, so the names do not depend on where the search starts
    given = any(n not in DEFAULT_BASE and not get_effect(n).structure for n in base_names)
    chosen = Structure(
        reason="not searched: " + ("structure=False" if not structure else "the base holds it")
    )
    structure_model = None
    if structure and not any(get_effect(n).structure for n in current):
        bar.set_postfix_str("base structure")
        chosen = choose_structure(
            pool, current, fit0.model.params, stribeck_shape, threshold, min_gap_shrink, noise_shrink
        )
        if chosen.effects:
            fixed.update(chosen.params)
            fit0 = fit_model(
                data, (*current, *chosen.effects), start=fit0.model.params, stribeck_shape=stribeck_shape,
                fixed=fixed,
            )  # fmt: skip
            current = fit0.model.effects
            structure_model = fit0.model
        logger.info("structure: %s", chosen.reason)
    bar.update(1)
    for _ in range(max_steps):
        bar.set_postfix_str(f"step {len(steps) + 1}")
        remaining = [
            c for c in cand_names if c not in current and all(r in current for r in get_effect(c).requires)
        ]
        if not remaining:
            stop_reason = "every candidate effect is already in the model (or needs one that is not)"
            break
        r_cur, _ = pool.balance_residual(fit0.model)
        region = (
            first_region if not steps and not chosen.effects else locate(r_cur, pool.feats_dec, pool.units)
        )
        gap0 = pool.gaps(fit0.model, region)
        if (steps or given) and gap0["overall"] <= (1.0 + noise_shrink) * floor:
            # at the record-wide floor: only an effect judged where it acts, against the floor
            # there (near rest, where an encoder's noise is least), can still show
            remaining = [c for c in remaining if get_effect(c).acts]
        if (steps or given) and gap0["overall"] <= (1.0 + noise_shrink) * floor and not remaining:
            stop_reason = (
                f"the free-run gap {gap0['overall']:.4g} {v} is {gap0['overall'] / floor:.2f} x the noise "
                f"floor {floor:.4g} {v}: no further effect can shrink it by more than {noise_shrink:g} x the noise"
                " (and none acts where the noise is lower)"
            )
            break
        ranking = []
        for name in progress_bar(remaining, show=progress, desc="candidates", unit="effect", leave=False):
            if get_effect(name).rest_only:
                # static friction: measured by the rests (the input it takes to start the drive
                # again), the evidence theirs, judged on the free run at the rests in step 4; on
                # records with too few rests, fitted and judged on the whole free run
                found = breakaway(pool, fit0.model)
                fitted = fit_static_friction(pool, fit0.model, None)
                fit = FitResult(
                    fitted, fit0.rss, fit0.rss_force, fit0.n_rows, fit0.n_params + 1, fit0.residual
                )
                if found.rests < MIN_RESTS:
                    err0, err1 = pool.free_run_error(fit0.model), pool.free_run_error(fitted)
                    ok = np.isfinite(err0) & np.isfinite(err1)
                    ev = evidence(
                        float(np.sum(err0[ok] ** 2)), float(np.sum(err1[ok] ** 2)), int(ok.sum()), 1, err1[ok]
                    )
                    ev["measure"] = f"free run ({found.rests} rests, fewer than {MIN_RESTS})"
                    ranking.append({"effect": name, "fit": fit, "acts": "", **ev})
                    continue
                ev = breakaway_evidence(*pool.breakaway_excess(fit0.model))
                ev["measure"] = "rests"
                ev["breakaway"] = found.to_dict()
                if not found.shown:  # the rests do not show breakaway above the kinetic level
                    ev["delta_bic"] = -math.inf
                    if not math.isfinite(found.standard_error):
                        ev["note"] = (
                            f"{found.rests} rests, all at one input rate: a breakaway level and a lag "
                            "between input and force look alike there"
                        )
                    else:
                        ev["note"] = (
                            f"{found.rests} rests break away {found.excess:.3g} ± {found.standard_error:.2g} "
                            f"{pool.units['F']} above the kinetic level: not shown"
                        )
                ranking.append({"effect": name, "fit": fit, **ev})
                continue
            fit = fit_model(
                data, (*current, name), start=fit0.model.params, stribeck_shape=stribeck_shape, fixed=fixed
            )
            ev = evidence(
                fit0.rss, fit.rss, fit.n_rows, fit.n_params - fit0.n_params, fit.residual[data.moving]
            )
            negative = [p for p in get_effect(name).nonnegative if fit.model.params[p] < 0.0]
            if negative:  # fitted with the wrong sign: not this physical effect
                ev["delta_bic"] = -math.inf
                ev["note"] = f"{negative[0]} = {fit.model.params[negative[0]]:.4g} < 0 is not physical"
            ranking.append({"effect": name, "fit": fit, **ev})
        ranking.sort(key=lambda c: -c["delta_bic"])
        table = [{k: v for k, v in c.items() if k not in ("fit", "acts")} for c in ranking]
        passing = [c for c in ranking if c["delta_bic"] > threshold]
        if not passing:
            best = ranking[0]
            stop_reason = (
                f"no candidate passes the evidence threshold: the best, {best['effect']}, has "
                f"ΔBIC = {best['delta_bic']:.1f} <= {threshold:g}"
            )
            break
        # candidates alike in the torque balance: the free-run output gap decides
        best = passing[0]
        drop_best = fit0.rss - best["fit"].rss
        alike = [c for c in passing if fit0.rss - c["fit"].rss >= ALIKE * drop_best]
        for c in alike:
            c["free_run_gap"] = pool.gaps(c["fit"].model, region)["overall"]
        order = list(passing)
        if len(alike) > 1:
            pick = min(alike, key=lambda c: np.nan_to_num(c["free_run_gap"], nan=np.inf))
            if pick["free_run_gap"] < 0.98 * best["free_run_gap"]:
                order.remove(pick)
                order.insert(0, pick)
        base_held = held_error(current, fit0.model.params)

        def judge(
            c: dict[str, Any],
            fit0: FitResult = fit0,
            base_held: float = base_held,
            region: Region = region,
            gap0: dict[str, float] = gap0,
            current: tuple[str, ...] = current,
            v: str = v,
        ) -> tuple[bool, dict[str, float], dict[str, Any]]:
            """Whether candidate ``c`` improves held-out data and shrinks the free-run gap beyond the
            noise (against this step's model ``fit0``); its gaps; and its record (with the reason
            when it does not)."""  # fmt: skip
            name = c["effect"]
            acts = c.get("acts", get_effect(name).acts)
            if get_effect(name).rest_only and not acts:  # too few rests: held out on the free run
                trained = fit_static_friction(
                    pool, fit0.model, None if held_full is None else [~m for m in held_full]
                )
                if held_full is None:
                    base_held_c, cand_held = (
                        _rms(free_run_error(other, fit0.model)),
                        _rms(free_run_error(other, trained)),
                    )
                else:
                    base_held_c = _rms(pool.free_run_error(fit0.model, held_full))
                    cand_held = _rms(pool.free_run_error(trained, held_full))
            elif get_effect(name).rest_only:  # held out on the rests: ΔF_s and τ from the training rests
                if held_full is None:
                    base_held_c, cand_held = breakaway_holdout(
                        pool, None, Pool([other], ["held out"]), None, fit0.model
                    )
                else:
                    base_held_c, cand_held = breakaway_holdout(
                        pool, [~m for m in held_full], pool, held_full, fit0.model
                    )
            else:
                base_held_c = base_held
                cand_held = held_error((*current, name), c["fit"].model.params)
            gap1 = pool.gaps(c["fit"].model, region)
            ok_held = cand_held < (1.0 - min_holdout_gain) * base_held_c
            # judged where it acts: the gap there against the noise floor there
            where = {"rests": " at the rests", "rest": " near rest", "speed": " at speed"}.get(acts, "")
            if acts:
                before, after = pool.acting_gap(fit0.model, acts), pool.acting_gap(c["fit"].model, acts)
                ok_gap = after < (1.0 - min_gap_shrink) * before and gap1["overall"] <= gap0["overall"]
            else:
                before, after = gap0["overall"], gap1["overall"]
                ok_gap = after < (1.0 - min_gap_shrink) * before
            floor_c = pool.band_floor(acts)
            shrink = (before - after) / floor_c if floor_c > 0 else math.inf
            ok_noise = not (steps or given) or shrink > noise_shrink
            record_c = {
                "effect": name, "delta_bic": c["delta_bic"], "held_out_error_before": base_held_c,
                "held_out_error_after": cand_held, "gap_before": gap0["overall"], "gap_after": gap1["overall"],
                "gap_shrink_noise_floors": shrink,
            }  # fmt: skip
            if acts:
                record_c.update({"judged": where.strip(), "acting_gap_before": before,
                                 "acting_gap_after": after, "acting_noise_floor": floor_c})  # fmt: skip
            why = []
            if not ok_held:
                unit = v + "/s" if not get_effect(name).rest_only else pool.units["F"] if acts else v
                why.append(f"held-out error {cand_held:.4g} vs {base_held_c:.4g} {unit}")
            if not ok_gap:
                why.append(f"free-run gap{where} {after:.4g} vs {before:.4g} {v}")
            elif not ok_noise:
                why.append(
                    f"free-run gap{where} {after:.4g} vs {before:.4g} {v}, a shrink of {shrink:.2f} "
                    f"noise floors{where} ({floor_c:.3g} {v}), not above {noise_shrink:g}"
                )
            if why:
                record_c["reason"] = "; ".join(why)
            return not why, gap1, record_c

        accepted = None
        reasons = []
        for c in order:
            ok, gap1, record_c = judge(c)
            if ok:
                accepted = (c, gap1, record_c)
                break
            rejected.append({"step": len(steps) + 1, **record_c})
            reasons.append(f"{c['effect']} ({record_c['reason']})")
        if accepted is None:
            stop_reason = (
                "no candidate improves held-out data and shrinks the free-run gap beyond the noise: "
                + ", ".join(reasons)
            )
            break
        accepted, lookalike = _lookalike_rule(
            accepted, passing, judge, pool, region, noise_shrink * floor, current
        )
        c, gap1, record_c = accepted
        fit1: FitResult = c["fit"]
        eff = get_effect(c["effect"])
        params = {p: fit1.model.params[p] for p in (*eff.linear, *eff.nonlinear)}
        ev = {
            "delta_bic": c["delta_bic"], "threshold": threshold, "n": c["n"], "n_eff": c["n_eff"],
            "rss_ratio": c["rss_ratio"], "held_out_error_before": record_c["held_out_error_before"],
            "held_out_error_after": record_c["held_out_error_after"],
            "gap_shrink_noise_floors": record_c["gap_shrink_noise_floors"], "noise_floor": floor,
            "chosen_by": "free-run gap among alike candidates" if c is not passing[0] else "evidence",
            "ranking": table,
        }  # fmt: skip
        if lookalike is not None:
            ev["chosen_by"] = "the lookalike rule"
        before, after = pool.record_gaps(fit0.model, region), pool.record_gaps(fit1.model, region)
        per_record = [
            {"record": label, "gap_before": g0["overall"], "gap_after": g1["overall"]}
            for label, g0, g1 in zip(labels, before, after, strict=True)
        ]
        step = Step(c["effect"], params, region, gap0, gap1, ev, fit1.model, lookalike=lookalike)
        step.record_gaps = per_record if len(labels) > 1 else []
        steps.append(step)
        logger.info("added %s: %s", c["effect"], params)
        current = fit1.model.effects
        fit0 = fit1
        bar.update(1)
    bar.total = bar.n + 1  # a diagnosis that stops early skips the steps it did not take
    bar.set_postfix_str("final gaps")
    final_model = fit0.model
    initial_gap = pool.gaps(initial_model, first_region)
    refitted_gap = None if model is None else pool.gaps(refitted_model, first_region)
    if steps or chosen.effects:
        final_gap = pool.gaps(final_model, first_region)
    else:
        final_gap = dict(initial_gap if refitted_gap is None else refitted_gap)
    final_region = locate(pool.balance_residual(final_model)[0], pool.feats_dec, pool.units)
    stop_reason += "; " + _against_noise(
        final_gap["overall"], pool.gaps(final_model, final_region)["region"], final_region, floor,
        missing_factor, v,
    )  # fmt: skip
    bar.update(1)
    bar.close()
    return Diagnosis(
        initial_gap=initial_gap, final_gap=final_gap, steps=steps, stop_reason=stop_reason,
        noise_floor=floor, final_region=final_region,
        model=final_model, initial_model=initial_model, region=first_region, units=pool.units,
        settings=settings, rejected=rejected, refitted_model=None if model is None else refitted_model,
        refitted_gap=refitted_gap, param_std=fit0.param_std, param_share=fit0.param_share, structure=chosen, structure_model=structure_model,
        records=record_summaries(pool, initial_model, final_model, first_region), _pool=pool,
        noise_bands=pool.noise_bands(), quantisation_step=pool.quantisation,
        rests=rest_summaries(pool, final_model),
        notes=[
            f"{label}: {note}" if len(labels) > 1 else note
            for label, prep in zip(labels, pool.parts, strict=True)
            for note in prep.notes
        ],
    )  # fmt: skip


__all__ = [
    "DEFAULT_BASE",
    "DEFAULT_THRESHOLD",
    "STRUCTURES",
    "Diagnosis",
    "Lookalike",
    "Pool",
    "Prepared",
    "Step",
    "Structure",
    "choose_structure",
    "diagnose",
    "fit_static_friction",
    "free_run_error",
    "prepare",
]
