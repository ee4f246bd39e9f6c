"""The doctor's first stage: records made ready to fit and judge.

:func:`prepare` checks one record and computes what every later stage reads of it
(:class:`Prepared`: its kinematics, the torque-balance data, the features a region is located
on, its rests and the free-run start); :func:`pool_records` prepares the records of one drive at
one timing (:class:`Pool`: fitted and judged as one model), and :func:`held_out` the rows and
samples a candidate is checked on.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from motorid.diagnose.artefacts import clean_output, refuse_pulsed
from motorid.diagnose.kinematics import (
    CUTOFF_PER_BAND,
    Kinematics,
    NoiseBand,
    kinematics,
    noise_bands,
    noise_left,
    quantisation_step,
)
from motorid.diagnose.locate import Region, feature, features
from motorid.diagnose.measures import (
    Gap,
    balance_residual,
    free_run_error,
    gaps,
    gaps_and_weights,
    holdout_rows,
    one_step_noise,
    rms,
)
from motorid.diagnose.model import BalanceData, PooledBalance, fit_model, stacked
from motorid.diagnose.rests import Rests, first_moving, rests
from motorid.drive.rigid import RigidDrive, check_sample_time
from motorid.errors import DataError
from motorid.units import UNNAMED_OUTPUT, input_unit_name, rate
from motorid.validation import check_signals

logger = logging.getLogger(__name__)

#: A rest's breakaway is read where the input's force rose into the first sample the shaft moved
#: in by at most this share of its value there (the force through the model's delay and lag: a
#: dead zone's or a backlash's zero is the drive's friction, not the input's step): the drive broke
#: away between the last sample at rest and that one. A larger step brackets the breakaway and
#: does not read it (held levels: a bank's stair, logged 24.4
#: samples late, stepped past its 5 breakaways from levels 0.4-1.4 times the force that moved it
#: below, each read at the level it rested at, 0.4-2.8 times the planted excess low; a wheel
#: motor's duty, a median 11 % in one sample against a kinetic level of 1.5-3.9 %).
BRACKET_SHARE = 0.25

#: The speed bands the noise floor is reported in, as shares of the largest |w|: near rest
#: (where static friction and Stribeck act), low, middle and high speed.
SPEED_BANDS = (0.0, 0.1, 0.3, 0.6, 1.0)
#: A velocity record sampled slower than this share of the fitted time constant τ = J / B has its
#: noise measured by the model's one-step prediction too (:func:`one_step_noise_pool`): there the
#: speed's part near the Nyquist frequency, where the noise is otherwise measured, holds signal.
#: On 50 of the bank's benches (:mod:`motorid.diagnose.bench`, ``python -m
#: motorid.diagnose.calibration --noise --seeds 5 --first 0``) that part measured a median 0.95
#: [0.91, 1.38] of the true noise at dt <= 0.25 τ, and 7.8 [1.1, 25] times it from 0.45 τ, where
#: the base model's one-step prediction measured 1.42 [0.95, 5.7] times it (the larger ones where
#: the base misses the planted effect: the search is run again on the model it finds).
ONE_STEP_SAMPLE_SHARE = 0.25
#: ... and the one-step figure replaces the other where it is below this share of it: both are the
#: noise and something more (the signal near Nyquist, what the model misses), so the smaller one
#: is the better bound, taken where it is clearly smaller.
ONE_STEP_BELOW = 0.8


@dataclass
class Prepared:
    """One record made ready: kinematics, balance data, features and the free-run start, and a
    note for each logging artefact left out (:mod:`.artefacts`).

    The features are kept on the decimated samples only (``feats_dec``); a
    region's full-rate mask is computed when asked for (:meth:`region_mask`). Every
    model's gaps (:func:`~motorid.diagnose.measures.gaps`) are kept: the workflow asks for some
    more than once.

    Attributes
    ----------
    kin : Kinematics
        The filtered, differentiated and decimated record (:mod:`.kinematics`).
    data : BalanceData
        The torque-balance rows on the decimated samples (:mod:`.model`).
    feats_dec : dict
        Feature name -> its value on each decimated sample (:func:`~motorid.diagnose.locate.features`).
    timing : str
        ``hold`` or ``sampled`` (:func:`prepare`).
    units : dict
        Units of velocity ``v``, force ``F``, input ``u`` and time ``s``.
    notes : list of str
        One line per logging artefact left out (:mod:`.artefacts`).
    quantisation : float or None
        The output's quantisation step [its unit], when it shows.
    input_quantisation : float or None
        The input's quantisation step [its unit] (an integer PWM duty), when it shows.
    rests : Rests or None
        The record's rests (:func:`rests_of`).
    """

    kin: Kinematics
    data: BalanceData
    feats_dec: dict[str, np.ndarray]
    timing: str
    units: dict[str, str]
    notes: list[str] = field(default_factory=list)
    quantisation: float | None = None
    input_quantisation: float | None = None
    rests: Rests | None = None
    _masks: dict[Region, np.ndarray] = field(default_factory=dict, repr=False)
    _gaps: dict[tuple, tuple[dict[str, float], dict[str, float]]] = field(default_factory=dict, repr=False)
    _moves: dict[tuple, np.ndarray] = field(default_factory=dict, repr=False)

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

    def free_run_start(self, model: RigidDrive) -> int:
        """The first sample ``model`` runs free from: the settled span's start (at least 1: the
        free run starts from the measured speed before it) and, with an input delay τ_d, no
        earlier than the first sample whose delayed input is the record's, ``ceil(τ_d / dt)``.
        What came before the record is not known, and a delay line filled with its first input
        drives the model that long before the drive moved: a chirp from rest logged 147 ms late at
        1 ms had its true model 56 noise floors from the record, 1.1 now.

        Parameters
        ----------
        model : RigidDrive
            The model run free.
        """
        delay = float(model.params.get("input_delay", 0.0)) / self.kin.dt
        return max(self.start, 1, math.ceil(delay - 1e-9))

    def simulate(self, model: RigidDrive) -> np.ndarray:
        """Free-run velocity at every sample, NaN before :meth:`free_run_start`.

        Parameters
        ----------
        model : RigidDrive
            The model run free on the record's input, from the measured speed.
        """
        i0 = self.free_run_start(model)
        out = np.full(self.kin.n, np.nan)
        w0, q0 = float(self.kin.w[i0 - 1]), float(self.kin.q[i0 - 1])  # the position for a ripple
        out[i0:] = model.free_run(self.kin.u, w0=w0, start=i0, q0=q0, position=self.kin.q)
        return out

    def first_moving(self, model: RigidDrive, rests: Rests, force: np.ndarray) -> np.ndarray | None:
        """The first sample each of ``rests`` moves in, read on the measured speed
        (:func:`~motorid.diagnose.rests.first_moving`) with ``model``'s inertia and viscous
        friction and the input ``force`` [F] it gives (``model.input_force``); None for a position
        record, whose speed is only known filtered, or a model without a positive inertia.

        Parameters
        ----------
        model : RigidDrive
            The drive's model.
        rests : Rests
            Rests of this record.
        force : ndarray
            ``model.input_force`` of the record's input [F].
        """
        kin = self.kin
        inertia = float(model.inertia)
        if kin.output_kind != "velocity" or not inertia > 0.0:
            return None
        viscous = max(float(model.params.get("viscous", 0.0)), 0.0)
        # a step asks twice of one model; the arrays' digests keep a long record's key small
        key = (inertia, viscous, *(hashlib.blake2b(np.ascontiguousarray(x).data, digest_size=16).digest()
                                   for x in (rests.stop, force)))  # fmt: skip
        if key not in self._moves:
            y = kin.balance_w + 0.5 * kin.dt * kin.balance_a  # the measured speed at each sample's end
            self._moves[key] = first_moving(y, rests, force, inertia, viscous, kin.filter_period)
        return self._moves[key]

    def balance_residual(self, model: RigidDrive) -> tuple[np.ndarray, np.ndarray]:
        """:func:`~motorid.diagnose.measures.balance_residual` of this record's decimated samples."""
        return balance_residual(model, self.data)

    def with_noise(self, scale: float) -> Prepared:
        """This record with its measured noise (:attr:`Kinematics.hf
        <motorid.diagnose.kinematics.Kinematics.hf>` and the noise floor) scaled by ``scale``, and
        what rests on it made again: the balance's noise band and compensation, the features,
        the rests."""
        kin = dataclasses.replace(self.kin, hf=self.kin.hf * scale, noise=self.kin.noise * scale)
        return _made_ready(kin, self.data.input_gain, self.timing, self.units, list(self.notes),
                           self.quantisation, self.input_quantisation)  # fmt: skip


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

    Parameters
    ----------
    record : DataFrame
        The record, in motorid's columns.
    dt : float, optional
        Sample time [s]; default ``attrs["dt"]`` or the median step of the ``t`` column.
    input, output : str
        The input and output columns.
    output_kind : {"velocity", "position"}
        What the output is (a position is differentiated).
    input_gain : float, optional
        Force per input unit g [N/V or N m/V], > 0; None (not known) fits with g = 1: the forces
        are then in the input's unit (see :func:`_units`).
    timing : {"hold", "sampled"}
        ``hold``: ``y[k]`` is measured at the end of the interval over which ``u[k]`` is held
        (motorid records); ``sampled``: ``y[k]`` is measured when ``u[k]`` is computed and
        ``u[k]`` then held (a sampled controller, EMPS). The second is brought to the first by
        pairing ``u[k]`` with ``y[k+1]``.
    band : float, optional
        Useful band [Hz] (:mod:`.kinematics`).

    Returns
    -------
    Prepared
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
    if output_kind == "velocity":
        refuse_pulsed(u, y, dt)
    if timing == "sampled":
        u, y = u[:-1], y[1:]
    kin = kinematics(u, y, dt, output_kind, band)  # type: ignore[arg-type]
    if kin.decimated_index.size < 30:
        raise DataError(
            f"the record is too short: {len(record)} samples give {kin.decimated_index.size} decimated "
            f"samples after the filter edges (at least 30 needed; decimation factor {kin.factor})"
        )
    return _made_ready(
        kin, float(input_gain), timing, units, notes, quantisation_step(y), quantisation_step(u)
    )


def _made_ready(
    kin: Kinematics,
    input_gain: float,
    timing: str,
    units: dict[str, str],
    notes: list[str],
    step: float | None,
    input_step: float | None,
) -> Prepared:
    """A :class:`Prepared` record of kinematics ``kin``: its balance data, features and rests."""
    data = BalanceData(kin, input_gain)
    feats = features(kin.w, kin.a, kin.u, kin.dt, data.w_threshold, at=data.idx)
    return Prepared(kin, data, feats, timing, units, notes, step, input_step, rests_of(kin, step))


def rests_of(kin: Kinematics, step: float | None) -> Rests:
    """The rests of a record (:func:`~motorid.diagnose.rests.rests`), at rest below the larger of
    the output's quantisation ``step`` and three noise floors of its band nearest rest
    (:data:`SPEED_BANDS`).

    Parameters
    ----------
    kin : Kinematics
        The record's kinematics.
    step : float or None
        The output's quantisation step [its unit], when it shows.
    """
    speed = np.abs(kin.w[kin.valid])
    floor = 0.0
    if speed.size:
        near = noise_bands(speed, kin.hf[kin.valid], np.asarray(SPEED_BANDS[:2]) * float(np.max(speed)),
                           kin.band, kin.dt)[0].noise_floor  # fmt: skip
        floor = near if math.isfinite(near) else kin.noise
    w_rest = max(step or 0.0, 3.0 * floor, 1e-12)
    return rests(kin.u, kin.w, kin.dt, w_rest, kin.valid, settle=kin.filter_period)


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

    Attributes
    ----------
    parts : list of Prepared
        The records, prepared (at one sample time, decimation and units).
    labels : list of str
        A name for each record.
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

    def gaps(self, model: RigidDrive, region: Region | None) -> Gap:
        """The pooled :func:`~motorid.diagnose.measures.gaps` (see the class notes)."""
        if len(self.parts) == 1:
            return gaps(model, self.parts[0], region)
        pairs = [gaps_and_weights(model, p, region) for p in self.parts]
        out = {}
        for key in ("overall", "region", "force_error_percent"):
            # a gap is an RMS over n samples, the force error a norm ratio: pool the squares
            power = 2 if key == "force_error_percent" else 1
            terms = [(getattr(g, key), w[key] ** power) for g, w in pairs]
            terms = [(g, wt) for g, wt in terms if wt > 0 and math.isfinite(g)]
            total = sum(wt for _, wt in terms)
            out[key] = math.sqrt(sum(g * g * wt for g, wt in terms) / total) if total > 0 else float("nan")
        return Gap(**out)

    def record_gaps(self, model: RigidDrive, region: Region | None) -> list[Gap]:
        """:func:`~motorid.diagnose.measures.gaps` of each record."""
        return [gaps(model, p, region) for p in self.parts]

    def balance_residual(self, model: RigidDrive) -> tuple[np.ndarray, np.ndarray]:
        """:func:`~motorid.diagnose.measures.balance_residual` of each record, stacked as the pooled
        rows are."""
        if len(self.parts) == 1:
            return balance_residual(model, self.parts[0].data)
        pairs = [balance_residual(model, p.data) for p in self.parts]
        return np.concatenate([r for r, _ in pairs]), np.concatenate([f for _, f in pairs])

    def free_run_error(self, model: RigidDrive, samples: list[np.ndarray] | None = None) -> np.ndarray:
        """:func:`~motorid.diagnose.measures.free_run_error` of each record (on its full-rate
        ``samples``), stacked."""
        errors = [free_run_error(p, model) for p in self.parts]
        if samples is not None:
            errors = [e[m] for e, m in zip(errors, samples, strict=True)]
        return stacked(errors)

    def noise_bands(self) -> list[NoiseBand]:
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
        floor = bands[-1 if acts == "speed" else 0].noise_floor
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
            return self.rest_folds(1)[0]
        return [self.acting_rows(p.kin.w, acts) for p in self.parts]

    def acting_rows(self, w: np.ndarray, acts: str) -> np.ndarray:
        """Where speeds ``w`` [v] lie in the band an effect acts in: below the first edge of
        :data:`SPEED_BANDS` (of the largest |w| over the records) for ``rest``, above the last
        inner edge for ``speed``.

        Parameters
        ----------
        w : ndarray
            Speeds [v] (a record's samples, or the balance's rows).
        acts : str
            ``rest`` or ``speed``.
        """
        if acts not in ("rest", "speed"):
            raise ValueError(f"acts must be 'rest' or 'speed' for a speed band, got {acts!r}")
        top = max(float(np.max(np.abs(p.kin.w[p.kin.valid]), initial=0.0)) for p in self.parts)
        if acts == "rest":
            return np.abs(w) < SPEED_BANDS[1] * top
        return np.abs(w) >= SPEED_BANDS[-2] * top

    def rest_folds(self, folds: int) -> list[list[np.ndarray]]:
        """The rests of the records, in time order, dealt into ``folds`` folds (the j-th rest into
        fold j mod ``folds``; fewer folds where there are fewer rests, one of no sample without rests): each
        fold's full-rate samples, per record, of its rests and, after each, as long again (the
        breakaway and the speed it picks up)."""
        spans = [
            (k, a, b)
            for k, p in enumerate(self.parts)
            for a, b in zip(p.rests.start, p.rests.stop, strict=True)
        ]
        out = []
        for j in range(min(folds, len(spans)) if spans else 1):
            masks = [np.zeros(p.kin.n, dtype=bool) for p in self.parts]
            for k, a, b in spans[j::folds]:
                masks[k][a : b + 1 + (b - a + 1)] = True
            out.append(masks)
        return out

    def acting_gap(self, model: RigidDrive, acts: str) -> float:
        """RMS free-run gap [v] over the samples where an effect acts (:meth:`acting_samples`)."""
        return rms(self.free_run_error(model, self.acting_samples(acts)))

    def breakaway_excess(
        self, model: RigidDrive, samples: list[np.ndarray] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The force at breakaway above ``model``'s kinetic level at 0± [F], at each rest of each
        record (:attr:`Prepared.rests`; those that break away in the full-rate ``samples``):
        ``F_b - T(0+)`` breaking away forwards, ``T(0-) - F_b`` backwards, with ``F_b`` the force
        of the input at breakaway (:meth:`RigidDrive.input_force
        <motorid.drive.rigid.RigidDrive.input_force>`: through the model's dead zone, delay and
        lag) and ``T(0±)`` the model's friction (and offset) at ±0, with a position ripple's torque
        where the drive rests; and the force's rate there [F/s], in the direction of the motion
        (central differences). The drive rests to the sample before the first it moves in, read
        on the measured speed (:meth:`Prepared.first_moving`; a position record's: the filtered
        speed's reading, :attr:`Rests.stop <motorid.diagnose.rests.Rests.stop>`). NaN where the
        input's force (through the model's delay and lag, before a dead zone) stepped into the
        first moving sample by more than :data:`BRACKET_SHARE` of its value there: the breakaway
        lies somewhere in that step."""
        eps = max(1e-9, 1e-6 * self.data.scale["w_max"])
        t_pos, t_neg = model.without(*model.position_effects).friction(np.array([eps, -eps]))
        # the input's force through the model's delay and lag, before a dead zone or a backlash's dwell
        # takes the drive's own friction out of it (the model itself where it has neither)
        path = model.without("input_dead_zone", "backlash")
        out, rates = [], []
        for k, p in enumerate(self.parts):
            r = p.rests if samples is None else p.rests.within(samples[k])
            f_in = model.input_force(p.kin.u)  # through the model's input path (dead zone, lag...)
            drive = f_in if path is model else path.input_force(p.kin.u)
            moves = p.first_moving(model, r, f_in)
            last = r.stop if moves is None else moves - 1  # the last sample at rest
            force = r.direction * f_in[last]  # in the direction of the motion
            ripple = model.position_torque(p.kin.q[last])  # where the drive rests
            excess = np.where(r.direction > 0, force - (t_pos + ripple), force + (t_neg + ripple))
            if moves is not None:  # a step of the input past the breakaway brackets it: no reading
                stepped = r.direction * (drive[moves] - drive[moves - 1])
                excess = np.where(stepped > BRACKET_SHARE * r.direction * drive[moves], np.nan, excess)
            out.append(excess)
            rates.append(r.direction * np.gradient(f_in, p.kin.dt)[last])
        return stacked(out), stacked(rates)

    @property
    def input_quantisation(self) -> float:
        """The largest quantisation step of the records' inputs [input unit], 0 where none shows."""
        return max((p.input_quantisation or 0.0 for p in self.parts), default=0.0)

    @property
    def quantisation(self) -> float | None:
        """The output's quantisation step [its unit] when every record shows the same one (1 %)."""
        steps = [p.quantisation for p in self.parts]
        if any(q is None for q in steps) or max(steps) > 1.01 * min(steps):  # type: ignore[type-var]
            return None
        return steps[0]

    def holdout_rows(self, fraction: float) -> np.ndarray:
        """Each record's held-out decimated rows (:func:`~motorid.diagnose.measures.holdout_rows`),
        stacked."""
        return stacked([holdout_rows(p.data.n, fraction) for p in self.parts])

    def holdout_samples(self, fraction: float) -> list[np.ndarray]:
        """Each record's held-out full-rate samples: the same blocks as :meth:`holdout_rows`."""
        return [holdout_rows(p.kin.n, fraction) for p in self.parts]


def normalised_records(
    records: Sequence[pd.DataFrame],
    labels: Sequence[str],
    columns: dict[str, str | None],
    reading: dict[str, object],
) -> list[pd.DataFrame]:
    """Each record brought to motorid's columns and units (:func:`motorid.io.records.normalise_record`).

    Parameters
    ----------
    records : sequence of DataFrame
        The records as the user holds them.
    labels : sequence of str
        A name for each record, put before an error's text when there are several.
    columns : dict
        ``time``, ``input`` and ``output``: the columns to read (``time`` None: ``t``).
    reading : dict
        The rest of :func:`~motorid.io.records.normalise_record`'s options (``dt``, units...).

    Returns
    -------
    list of DataFrame
        Columns ``t`` (when given), ``u``, ``y``: only the columns the doctor reads are brought
        over (a simulated record's true states stay behind).
    """
    from motorid.io.records import normalise_record

    time = columns["time"]

    def normalised(r: pd.DataFrame, label: str) -> pd.DataFrame:
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

    return [normalised(r, label) for r, label in zip(records, labels, strict=True)]


def common_timing(records: Sequence[pd.DataFrame], labels: Sequence[str]) -> str:
    """The timing the records say (:func:`motorid.io.records.record_timing`), one for all of them.

    Parameters
    ----------
    records : sequence of DataFrame
        Normalised records (their ``attrs`` read).
    labels : sequence of str
        Their names, for the error when they differ.

    Returns
    -------
    str
        ``hold`` or ``sampled``.
    """
    from motorid.io.records import record_timing

    own = [record_timing(getattr(r, "attrs", {})) for r in records]
    if len(set(own)) > 1:
        raise DataError(
            f"the records say different timings ({', '.join(f'{x}: {t}' for x, t in zip(labels, own, strict=True))}): "
            "pass timing= for all of them"
        )
    return own[0]


def pool_records(
    records: list[pd.DataFrame],
    labels: Sequence[str],
    timing: str,
    options: dict[str, object],
    base: tuple[str, ...],
    stribeck_shape: str,
) -> Pool:
    """The records of one drive prepared (:func:`prepare`) and pooled (:class:`Pool`).

    Parameters
    ----------
    records : list of DataFrame
        Normalised records (:func:`normalised_records`); emptied once prepared (each part holds
        what it needs).
    labels : list of str
        A name for each record.
    timing : {"hold", "sampled", "auto"}
        Input/output timing (:func:`prepare`); ``auto`` prepares both and keeps the one whose
        ``base`` model fits the torque balance better, relative to the commanded input's energy
        on the moving samples.
    options : dict
        :func:`prepare`'s other options (``dt``, ``input``, ``output``, ``output_kind``,
        ``input_gain``, ``band``).
    base : tuple of str
        The base effects, fitted for ``auto``.
    stribeck_shape : str
        Their Stribeck shape.

    Returns
    -------
    Pool
    """

    def pooled(timing: str) -> Pool:
        parts = []
        for label, r in zip(labels, records, strict=True):
            try:
                parts.append(prepare(r, timing=timing, **options))  # type: ignore[arg-type]
            except DataError as exc:
                raise DataError(f"{label}: {exc}" if len(records) > 1 else str(exc)) from None
        return Pool(parts, list(labels))

    if timing == "auto":
        pools = [pooled(t) for t in ("hold", "sampled")]
        scores = []
        for p in pools:
            fit = fit_model(p.data, base, stribeck_shape=stribeck_shape)
            commanded = sum(
                float(np.sum(q.data.kin.decimate(q.data.kin.u)[q.data.moving] ** 2)) for q in p.parts
            )
            scores.append(fit.rss / max(commanded, 1e-300))
        pool = pools[int(np.argmin(scores))]
        pools.clear()  # the other timing's arrays go now
    else:
        pool = pooled(timing)
    records.clear()  # the normalised copies go: each part holds what it needs
    return pool


@dataclass
class HeldOut:
    """What a candidate is checked on: the held-out blocks of the pool, or a second record.

    Attributes
    ----------
    train : ndarray of bool
        The pool's decimated rows a held-out check fits on.
    rows : ndarray of bool
        The held-out decimated rows (moving samples only) it is scored on: the pool's, or
        ``other``'s.
    samples : list of ndarray or None
        The same blocks at full rate, per record (static friction fitted on the free run is held
        out on them where the records have no rests); None with a second record.
    other : Prepared or None
        The second record, when one is given.
    """

    train: np.ndarray
    rows: np.ndarray
    samples: list[np.ndarray] | None
    other: Prepared | None

    def speeds(self, pool: Pool) -> np.ndarray:
        """The speed [v] of each held-out row (the decimated speed of the pool or of ``other``).

        Parameters
        ----------
        pool : Pool
            The records fitted.
        """
        return (pool.data if self.other is None else self.other.data).w[self.rows]

    def balance_residual(self, pool: Pool, model: RigidDrive) -> np.ndarray:
        """``model``'s :func:`~motorid.diagnose.measures.balance_residual` on the held-out rows.

        Parameters
        ----------
        pool : Pool
            The records fitted.
        model : RigidDrive
            A model fitted on :attr:`train`.
        """
        if self.other is not None:
            r, _ = balance_residual(model, self.other.data)
        else:
            r, _ = pool.balance_residual(model)
        return r[self.rows]


def sampled_slowly(pool: Pool, model: RigidDrive) -> bool:
    """Whether the records of ``pool`` are sampled slower than :data:`ONE_STEP_SAMPLE_SHARE` of the
    time constant J / B of ``model`` (inertia and viscous friction both positive)."""
    inertia, viscous = float(model.inertia), float(model.params.get("viscous", 0.0))
    return inertia > 0.0 and viscous > 0.0 and viscous * pool.dt / inertia > ONE_STEP_SAMPLE_SHARE


def one_step_noise_pool(pool: Pool, models: Sequence[RigidDrive]) -> Pool:
    """The pool with each velocity record's noise measured by the one-step prediction
    (:func:`~motorid.diagnose.measures.one_step_noise`) of the closest of ``models`` where the record
    is sampled slower than :data:`ONE_STEP_SAMPLE_SHARE` of the first model's time constant
    τ = J / B (:func:`sampled_slowly`) and that figure is below :data:`ONE_STEP_BELOW` of the one
    measured on the speed's part near the Nyquist frequency
    (:func:`~motorid.diagnose.kinematics.filtered_noise`): the record's measured noise is scaled by
    their ratio (:meth:`Prepared.with_noise`), and the record says so in a note. Each figure holds
    the noise and something more (the signal near Nyquist, what a model misses); the smallest is
    the closest. ``pool`` itself where nothing changes.

    Parameters
    ----------
    pool : Pool
        The records of the drive.
    models : sequence of RigidDrive
        The fitted models (with their delay and lag, where taken): the model found first, then
        others fitted to the same records (the candidates it was judged against).
    """
    if not models or not sampled_slowly(pool, models[0]):
        return pool
    model = models[0]
    inertia, viscous = float(model.inertia), float(model.params["viscous"])
    parts, changed = [], False
    for part in pool.parts:
        kin = part.kin
        sigma_hf = kin.noise / noise_left(CUTOFF_PER_BAND * kin.band, kin.dt)
        sigma = min(one_step_noise(m, part.data) for m in models)
        if not (sigma_hf > 0.0 and math.isfinite(sigma) and sigma < ONE_STEP_BELOW * sigma_hf):
            parts.append(part)
            continue
        changed = True
        part = part.with_noise(sigma / sigma_hf)
        part.notes.append(
            f"the noise measured by the model's one-step prediction, {sigma:.3g} {pool.units['v']} per "
            f"sample: the speed's part near the Nyquist frequency ({sigma_hf:.3g} {pool.units['v']}) holds "
            f"signal at a sample time of {viscous * pool.dt / inertia:.2g} of the time constant J/B"
        )
        parts.append(part)
    return Pool(parts, pool.labels) if changed else pool


def held_out(pool: Pool, holdout: float | pd.DataFrame, options: dict[str, object]) -> HeldOut:
    """The held-out check's rows: ``round(10 holdout)`` of 10 interleaved blocks of each record
    (:func:`~motorid.diagnose.measures.holdout_rows`), or every row of the pool against a second,
    normalised record.

    Parameters
    ----------
    pool : Pool
        The records fitted.
    holdout : float or DataFrame
        Share held out, in (0, 0.9), or the second record (prepared at the pool's timing).
    options : dict
        :func:`prepare`'s options for the second record (``timing`` is the pool's).

    Returns
    -------
    HeldOut
    """
    data = pool.data
    if isinstance(holdout, pd.DataFrame):
        other = prepare(holdout, **options, timing=pool.parts[0].timing)  # type: ignore[arg-type]
        return HeldOut(np.ones(data.n, dtype=bool), other.data.moving, None, other)
    held = pool.holdout_rows(float(holdout))
    return HeldOut(~held, held & data.moving, pool.holdout_samples(float(holdout)), None)


__all__ = [
    "SPEED_BANDS",
    "HeldOut",
    "Pool",
    "Prepared",
    "common_timing",
    "held_out",
    "normalised_records",
    "pool_records",
    "prepare",
    "rests_of",
]
