"""What a fleet run does to its records, as typed options: how each record is read, and the job.

- :class:`RecordOptions`: how a record is read (columns, units, sample time, span), the
  command line's record options by their names (:class:`motorid.io.records.RecordOptions`);
- :class:`DoctorJob`: ``motorid doctor`` on a record, or on all records of one drive as one
  model (:class:`motorid.app.DoctorOptions`, the application layer's options of the doctor);
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
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motorid.app.doctor import DoctorOptions
from motorid.app.identify import IdentifyOptions
from motorid.errors import DataError
from motorid.io.records import RecordOptions, read_head, read_record

#: ``motorid doctor``'s options, the job of a fleet's doctor run: the application layer's
#: :class:`motorid.app.DoctorOptions`, whose ``row`` is the single command's computation.
DoctorJob = DoctorOptions

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
    read : RecordOptions
        How the record is read (the doctor reads a longer record's first ``max_samples`` rows).
    figures : Path, optional
        The run folder, the figures written under ``<drive>/<record>/``; None: no figures.
    """

    job: Job
    read: RecordOptions
    figures: Path | None

    def __call__(self, path: str, given: dict[str, Any]) -> dict[str, Any]:
        from motorid.fleet.sources import identity

        drive, when = identity(path, {}, given)
        row: dict[str, Any] = {"record": path, "drive": drive, "time": when, "command": self.job.command}
        with _row_of(row):
            doctor = isinstance(self.job, DoctorJob)
            # as the single command reads it: the doctor a longer record's first max_samples samples
            record, segment = (
                read_head(path, self.read, min_samples=20, speed=True)
                if doctor
                else (read_record(path, self.read, min_samples=20, other_columns=False, speed=True), False)
            )
            drive, when = identity(path, record.attrs, given)
            row.update(drive=drive, time=when)
            payload = self.job.row([record], [path], _figure_folder(self.figures, drive, Path(path).stem))
            row.update(_flat({**payload, "segment": segment} if doctor else payload))
        return row


#: The ``record`` key of a drive's row in a per-drive run: this prefix and the drive id.
DRIVE_KEY_PREFIX = "drive:"


def per_drive_command(job: DoctorJob) -> str:
    """The ``command`` the rows of a per-drive run say: the job's, on each drive's records as one
    model (``"doctor per drive"``).

    Parameters
    ----------
    job : DoctorJob
        The doctor a per-drive run runs on each drive.
    """
    return f"{job.command} per drive"


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
    read : RecordOptions
        How each record is read (a longer record's first ``max_samples`` rows).
    figures : Path, optional
        The run folder, the drive's figures written under ``<drive>/``; None: no figures.
    """

    job: DoctorJob
    read: RecordOptions
    figures: Path | None

    def __call__(self, drive: str, paths: list[str], times: list[str | None]) -> list[dict[str, Any]]:
        command = per_drive_command(self.job)
        row: dict[str, Any] = {"record": DRIVE_KEY_PREFIX + drive, "drive": drive, "time": None,
                               "command": command, "records": ",".join(paths)}  # fmt: skip
        rows = [
            {"record": p, "drive": drive, "time": t, "command": command}
            for p, t in zip(paths, times, strict=True)
        ]
        with _row_of(row):
            read = [read_head(p, self.read, min_samples=20, speed=True) for p in paths]
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


__all__ = [
    "DRIVE_KEY_PREFIX",
    "DoctorJob",
    "DriveTask",
    "IdentifyJob",
    "Job",
    "RecordOptions",
    "RecordTask",
    "per_drive_command",
]
