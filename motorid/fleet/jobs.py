"""What a fleet run does to its records, as typed options: how each record is read, and the job.

- :class:`ReadOptions`: how a record is read (columns, units, sample time, span), the
  command line's record options by their names;
- :class:`DoctorJob`: ``motorid doctor`` on a record, or on all records of one drive as one
  model (:func:`motorid.diagnose.diagnose`);
- :class:`IdentifyJob`: ``motorid identify`` on a record (:class:`motorid.app.IdentifyOptions`,
  the application layer's options of identify, under the fleet's name for a job);
- :class:`RecordTask` and :class:`DriveTask`: the work one Dask task does, one record or one
  drive's records, returning the rows of the results table. Every error of a record is caught
  and becomes a row with ``status = "failed"`` and ``error``, so one bad record does not stop
  the others; its warnings (a filter that diverged) are the row's ``warnings``.

All are frozen dataclasses of plain values: they pickle, and they travel to the workers as they are.
"""

from __future__ import annotations

import os
import socket
import time
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import pandas as pd

from motorid.app.identify import IdentifyOptions
from motorid.errors import DataError

if TYPE_CHECKING:
    from motorid.diagnose.results import Diagnosis


@dataclass(frozen=True)
class ReadOptions:
    """How each record of a run is read: :func:`motorid.records.read_record`'s options, then the
    span ``start <= t <= stop`` [s] (:func:`motorid.records.trim_record`).

    The names are the command line's record options (``--time``, ``--input-unit``,
    ``--start`` ...).

    Attributes
    ----------
    time : str, optional
        Name of the time column (default ``t``; none needed when ``dt`` is known).
    input, output : str
        Names of the columns that become ``u`` and ``y`` (default ``u``, ``y``).
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of the time column (default: the record's ``attrs["units"]["t"]``, else seconds).
    dt : float, optional
        Sample time [s]; a time column that says otherwise is refused.
    resample : bool
        Put a record with gaps on the uniform grid instead of refusing it.
    sep : str, optional
        Separator of a CSV record (one character); default: detected from its first lines.
    decimal : {".", ","}, optional
        Decimal mark of a CSV record; default: detected from its first lines.
    input_unit, output_unit : str, optional
        Units of the input and output columns, converted to motorid's as they are read
        (:data:`motorid.units.INPUT_UNITS`, :data:`motorid.units.OUTPUT_UNITS`).
    input_full_scale : float, optional
        The count of full duty, for ``input_unit="counts"`` (255 for an 8-bit PWM).
    supply_voltage : float, optional
        Supply voltage [V] of a PWM drive: a duty in % (or counts) becomes volts.
    max_samples : int
        Most rows read: :meth:`read` refuses a longer record, :meth:`read_segment` takes its
        first ``max_samples`` rows.
    start, stop : float, optional
        The span kept, ``start <= t <= stop`` [s], ``t`` from 0 at the first sample; None
        leaves that end as it is.
    """

    time: str | None = None
    input: str = "u"
    output: str = "y"
    time_unit: str | None = None
    dt: float | None = None
    resample: bool = False
    sep: str | None = None
    decimal: str | None = None
    input_unit: str | None = None
    input_full_scale: float | None = None
    output_unit: str | None = None
    supply_voltage: float | None = None
    max_samples: int = 2_000_000
    start: float | None = None
    stop: float | None = None

    def __post_init__(self) -> None:
        for key in ("start", "stop"):
            value = getattr(self, key)
            if value is not None and not (isinstance(value, int | float) and 0.0 <= value < float("inf")):
                raise DataError(f"--{key} must be a time >= 0 [s], got {value!r}")
        if self.start is not None and self.stop is not None and self.stop <= self.start:
            raise DataError(f"--stop {self.stop:g} must be after --start {self.start:g} [s]")

    def _options(self) -> dict[str, Any]:
        """The options :func:`motorid.records.read_record` and :func:`motorid.record_chunks.iter_record` take."""
        return {k: v for k, v in asdict(self).items() if k not in ("max_samples", "start", "stop")}

    def read(self, path: str | os.PathLike[str], min_samples: int = 20) -> pd.DataFrame:
        """The record ``path`` with columns ``t`` [s], ``u``, ``y``, trimmed to the span."""
        from motorid.records import read_record, trim_record

        record = read_record(
            path,
            min_samples=min_samples,
            max_samples=self.max_samples,
            other_columns=False,
            **self._options(),
        )
        return trim_record(record, self.start, self.stop, path, min_samples=min_samples)

    def read_segment(self, path: str | os.PathLike[str], min_samples: int = 20) -> tuple[pd.DataFrame, bool]:
        """As :meth:`read`, but a record longer than ``max_samples`` gives its first ``max_samples``
        rows (a segment, as ``motorid doctor`` reads it: :func:`motorid.record_chunks.read_head`);
        and whether it is a segment."""
        from motorid.record_chunks import read_head
        from motorid.records import trim_record

        record, segment = read_head(path, self.max_samples, min_samples, **self._options())
        return trim_record(record, self.start, self.stop, path, min_samples=min_samples), segment


@dataclass(frozen=True)
class DoctorJob:
    """``motorid doctor``'s options (:func:`motorid.diagnose.diagnose`'s arguments by the same names).

    Attributes
    ----------
    output_kind : {"velocity", "position"}
        What the output column is; a position is differentiated to a velocity.
    input_gain : float, optional
        Force or torque per input unit [N/V or N m/V], > 0; None: the forces come out per
        input unit.
    base : tuple of str, optional
        Effects already in the model (:func:`motorid.drive.effects.names`); None: the
        doctor's default base, or the effects of ``model``.
    candidates : tuple of str, optional
        Effects to try; None (or empty): every effect not in the base.
    holdout : float
        Share of the record held out for the held-out check, in (0, 0.9).
    max_steps : int
        Most effects added, >= 0.
    timing : {"hold", "sampled", "auto"}, optional
        Input/output timing; None: the record's ``attrs["timing"]``, else ``"hold"``.
    structure : bool
        Choose the input delay and lag from the record first; False is ``--no-structure``
        (the base as given).
    model : Path, optional
        A drive model file to start from, a rigid drive (``motorid doctor --save-model`` writes
        one) or a two-mass rig (``motorid simulate --save-model``); its effects are the base, so
        ``base`` stays None.
    """

    output_kind: Literal["velocity", "position"] = "velocity"
    input_gain: float | None = None
    base: tuple[str, ...] | None = None
    candidates: tuple[str, ...] | None = None
    holdout: float = 0.3
    max_steps: int = 3
    timing: Literal["hold", "sampled", "auto"] | None = None
    structure: bool = True
    model: Path | None = None

    command = "doctor"

    def __post_init__(self) -> None:
        from motorid.drive.effects import names as effect_names

        for key in ("base", "candidates"):
            names = getattr(self, key)
            if names is None:
                continue
            if isinstance(names, str):
                raise DataError(f"{key} must be a sequence of effect names, got the text {names!r}")
            object.__setattr__(self, key, tuple(names))
            for name in names:
                if name not in effect_names():
                    raise DataError(
                        f"{key}: unknown effect {name!r}; known effects: {', '.join(effect_names())}"
                    )
        if self.model is not None and self.base is not None:
            raise DataError("base cannot be combined with model: the model's effects are the base")

    def diagnose(
        self, records: pd.DataFrame | Sequence[pd.DataFrame], labels: list[str] | None = None,
        progress: bool = False,
    ) -> Diagnosis:  # fmt: skip
        """The doctor on a record with columns ``t``, ``u``, ``y``, or on several records of one
        drive fitted as one model (``labels`` name them)."""
        from motorid.diagnose import diagnose

        return diagnose(
            records, input="u", output="y", output_kind=self.output_kind, input_gain=self.input_gain,
            base=None if self.base is None else list(self.base),
            candidates=None if not self.candidates else list(self.candidates), holdout=self.holdout,
            max_steps=self.max_steps, progress=progress, timing=self.timing, model=self.start_model(),
            structure=self.structure, labels=labels,
        )  # fmt: skip

    def start_model(self) -> Any:
        """The drive model of the ``model`` file (None without one): a rigid drive, or a two-mass
        rig that has a rigid equivalent; DataError for another model or a rig without one."""
        if self.model is None:
            return None
        from motorid.drive import RigidDrive, TwoMassRig
        from motorid.estimators import load_model

        model = load_model(self.model)
        if not isinstance(model, RigidDrive | TwoMassRig):
            raise DataError(
                f"--model {self.model}: holds a {type(model).__name__}; the doctor starts from a drive model "
                "(a rigid drive motorid doctor --save-model wrote, or a two-mass rig motorid simulate "
                "--save-model wrote)"
            )
        if isinstance(model, TwoMassRig):
            try:
                model.rigid_equivalent()  # the doctor searches on it
            except ValueError as exc:
                raise DataError(f"--model {self.model}: {exc}") from None
        return model

    def row(self, records: list[pd.DataFrame], labels: list[str], figures: Path | None) -> dict[str, Any]:
        """The ``--json`` payload of the doctor on ``records`` (with ``named``, ``figures``)."""
        diagnosis = self.diagnose(records[0] if len(records) == 1 else records, labels=labels)
        written = diagnosis.write_figures(figures) if figures is not None else []
        return {
            **diagnosis.to_dict(),
            "named": ",".join(diagnosis.named),
            "figures": [str(f) for f in written],
        }


#: ``motorid identify``'s options, the job of a fleet's identify run: the application layer's
#: :class:`motorid.app.IdentifyOptions`, whose ``row`` is the single command's computation.
IdentifyJob = IdentifyOptions

Job = DoctorJob | IdentifyJob


@dataclass(frozen=True)
class RecordTask:
    """One record's work in a worker: read it, run the job, return its row (picklable).

    Attributes
    ----------
    job : DoctorJob or IdentifyJob
        What is computed on the record.
    read : ReadOptions
        How the record is read (the doctor reads a longer record's first ``max_samples`` rows).
    figures : Path, optional
        The run folder, the figures written under ``<drive>/<record>/``; None: no figures.
    """

    job: Job
    read: ReadOptions
    figures: Path | None

    def __call__(self, path: str, given: dict[str, Any]) -> dict[str, Any]:
        from motorid.fleet.sources import identity

        drive, when = identity(path, {}, given)
        row: dict[str, Any] = {"record": path, "drive": drive, "time": when, "command": self.job.command}
        with _row_of(row):
            doctor = isinstance(self.job, DoctorJob)
            # as the single command reads it: the doctor a longer record's first max_samples samples
            record, segment = self.read.read_segment(path) if doctor else (self.read.read(path), False)
            drive, when = identity(path, record.attrs, given)
            row.update(drive=drive, time=when)
            payload = self.job.row([record], [path], _figure_folder(self.figures, drive, Path(path).stem))
            row.update(_flat({**payload, "segment": segment} if doctor else payload))
        return row


#: The ``record`` key of a drive's row in a per-drive run: this prefix and the drive id.
DRIVE_KEY_PREFIX = "drive:"


@dataclass(frozen=True)
class DriveTask:
    """One drive's work in a worker: read its records, run the doctor on them as one model.

    Returns the drive's row (``record`` = ``drive:<id>``, ``records`` its record paths, the
    joint ``--json`` output flattened) and one row per record (its path, drive, time and its
    gaps from the joint run: ``samples``, ``noise_floor``, ``initial_gap.*``, ``final_gap.*``,
    ``final_gap_noise_floors``). A record that cannot be read fails the drive's rows.

    Attributes
    ----------
    job : DoctorJob
        The doctor, run on all the drive's records as one model.
    read : ReadOptions
        How each record is read (a longer record's first ``max_samples`` rows).
    figures : Path, optional
        The run folder, the drive's figures written under ``<drive>/``; None: no figures.
    """

    job: DoctorJob
    read: ReadOptions
    figures: Path | None

    def __call__(self, drive: str, paths: list[str], times: list[str | None]) -> list[dict[str, Any]]:
        command = f"{self.job.command} --per-drive"
        row: dict[str, Any] = {"record": DRIVE_KEY_PREFIX + drive, "drive": drive, "time": None,
                               "command": command, "records": ",".join(paths)}  # fmt: skip
        rows = [
            {"record": p, "drive": drive, "time": t, "command": command}
            for p, t in zip(paths, times, strict=True)
        ]
        with _row_of(row):
            read = [self.read.read_segment(p) for p in paths]
            records = [record for record, _ in read]
            payload = self.job.row(records, list(paths), _figure_folder(self.figures, drive, None))
            payload["segment"] = any(segment for _, segment in read)
            row.update(_flat(payload))
            # one record: its gaps are the run's own
            per_record = payload.get("records") or [
                {"samples": len(records[0]), "noise_floor": payload["noise_floor"],
                 "initial_gap": payload["initial_gap"], "final_gap": payload["final_gap"]}
            ]  # fmt: skip
            for record_row, gaps in zip(rows, per_record, strict=True):
                record_row.update(_flat({k: v for k, v in gaps.items() if k != "record"}))
                record_row.update(named=row.get("named"))
        for record_row in rows:
            for key in ("status", "error", "warnings", "run_time_s", "worker"):
                record_row[key] = row[key]
        return [row, *rows]


def _figure_folder(figures: Path | None, drive: str, record: str | None) -> Path | None:
    """``figures/<drive>[/<record>]``, made: names from data are file names, never paths."""
    from motorid.outputs import safe_file_name

    if figures is None:
        return None
    folder = figures / safe_file_name(drive)
    if record is not None:
        folder = folder / safe_file_name(record)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _flat(payload: dict[str, Any]) -> dict[str, Any]:
    from motorid.fleet.results import flatten
    from motorid.outputs import jsonable

    return flatten(jsonable(payload))


@contextmanager
def _row_of(row: dict[str, Any]) -> Iterator[None]:
    """Fill ``row``'s ``status``, ``error``, ``warnings``, ``run_time_s`` and ``worker`` from the work in the block."""
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:  # a worker's warnings go in the row, not stderr
        warnings.simplefilter("always")
        try:
            yield
            row.update(status="ok", error=None)
        except Exception as exc:  # the record's failure, whatever it is, is its row
            message = str(exc) if isinstance(exc, DataError) else f"{type(exc).__name__}: {exc}"
            row.update(status="failed", error=message)
    # a ResourceWarning comes from the garbage collector, at any time: not this record's
    messages = [str(w.message) for w in caught if not issubclass(w.category, ResourceWarning)]
    row["warnings"] = "; ".join(dict.fromkeys(messages)) or None
    row["run_time_s"] = time.perf_counter() - start
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"


__all__ = ["DRIVE_KEY_PREFIX", "DoctorJob", "DriveTask", "IdentifyJob", "Job", "ReadOptions", "RecordTask"]
