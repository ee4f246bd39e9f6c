"""The online identification loop: excite the rig, feed every estimator, record as it goes."""

from __future__ import annotations

import copy
import csv
import gc
import io
import logging
import math
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from motorid.errors import OutputError
from motorid.io.records import attrs_line
from motorid.outputs import create_in_place, disk_full
from motorid.progress import progress_bar

from .base import DAQ, Sample

logger = logging.getLogger(__name__)

__all__ = ["KEEP_WITH_FILE", "OnlineEstimator", "RunRecorder", "run_online"]

KEEP_WITH_FILE = 10_000
"""Rows :func:`run_online` keeps in memory by default when it writes a file (the file holds them all)."""

Excitation = Sequence[float] | np.ndarray | Callable[[float], float]


class OnlineEstimator(Protocol):
    """What the loop needs from an estimator (every ``motorid.estimators`` one fits)."""

    params: Mapping[str, Any]

    def predict(self, u: float) -> Any:
        """Time update with this sample's input [V]; return the predicted output [rad/s]."""
        ...

    def update(self, y: float) -> None:
        """Measurement update with the measured output [rad/s]."""
        ...


def flatten_params(prefix: str, params: Mapping[str, Any]) -> dict[str, float]:
    """Flatten an estimator's ``params`` to columns.

    Scalars become ``prefix.name``; arrays become ``prefix.name1``,
    ``prefix.name2``, ... (1-based, in C order), so ``{"a": [0.9, -0.1]}``
    gives ``hammerstein-rls.a1`` and ``hammerstein-rls.a2``. Entries that are
    not numbers (e.g. the names of a basis) are left out.
    """
    out: dict[str, float] = {}
    for name, value in params.items():
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):  # labels such as basis names are not recorded
            continue
        if arr.ndim == 0:
            out[f"{prefix}.{name}"] = float(arr)
        else:
            for i, v in enumerate(arr.ravel(), start=1):
                out[f"{prefix}.{name}{i}"] = float(v)
    return out


def name_estimators(estimators: Mapping[str, Any] | Iterable[Any] | None) -> dict[str, Any]:
    """Give each estimator a column prefix.

    A mapping keeps its keys. For a sequence, the prefix is the estimator's
    ``name`` attribute when it has one, else its class name in lower case;
    repeats get ``-2``, ``-3``, ...
    """
    if estimators is None:
        return {}
    if isinstance(estimators, Mapping):
        named = dict(estimators)
    else:
        named = {}
        for est in estimators:
            base = str(getattr(est, "name", None) or type(est).__name__.lower())
            name, i = base, 1
            while name in named:
                i += 1
                name = f"{base}-{i}"
            named[name] = est
    for name, est in named.items():
        for attr in ("predict", "update"):
            if not callable(getattr(est, attr, None)):
                raise TypeError(f"run_online: estimator {name!r} has no {attr}() method")
        if "," in name or "\n" in name:
            raise ValueError(f"run_online: estimator name {name!r} must not hold ',' or a newline")
    return named


class RunRecorder:
    """Append-only CSV recording of an online run, readable at every moment, in bounded memory.

    The file is created with the first row (the parameter columns are known
    only once the estimators have produced them), so a run that never takes a
    sample leaves an existing file as it was and creates none. Rows are
    written to the operating system every ``flush_every`` rows, so a crash or
    Ctrl-C loses at most the rows since the last flush (none with the
    default 1). Only the last ``keep`` rows stay in memory: a run of days
    holds its memory flat, and the file holds every row. The file always ends
    on a whole row: when the disk is full, what part of a row reached it is cut
    off again and :class:`~motorid.errors.OutputError` says how many rows the
    file holds (a file left with no whole line is removed).

    Parameters
    ----------
    path : path or None
        CSV file to write; None keeps the rows in memory only.
    flush_every : int
        Flush after this many rows.
    overwrite : bool
        Replace an existing ``path``; without it an existing file is refused
        here, before the run starts.
    keep : int or None
        Rows kept in memory for :meth:`frame`; None keeps all of them.
    preamble : sequence of str
        Lines written before the header, each whole (a record's attribute line,
        :data:`motorid.io.records.ATTRS_MARKER`), so the file says its sample time and units.

    Attributes
    ----------
    count : int
        Rows recorded.
    on_disk : int
        Rows in the file (not counting the header): ``count`` after each flush.
    created : bool
        True once this recorder has created (or, with ``overwrite``, replaced) the file.
    largest_interval : float
        Longest time between the starts of two successive samples of the loop that fed it [s]
        (:func:`sample_loop`; NaN before two samples).
    largest_interval_sample : int
        The sample that started that late (-1 before two samples).

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    """

    def __init__(
        self,
        path: str | Path | None,
        flush_every: int = 1,
        *,
        overwrite: bool = False,
        keep: int | None = None,
        preamble: Sequence[str] = (),
    ) -> None:
        if flush_every < 1:
            raise ValueError(f"flush_every must be >= 1, got {flush_every!r}")
        if keep is not None and (not isinstance(keep, int) or keep < 0):
            raise ValueError(f"keep must be None or an integer >= 0, got {keep!r}")
        self.path = None if path is None else Path(path)
        self.flush_every = int(flush_every)
        self.overwrite = bool(overwrite)
        self.rows: deque[dict[str, float | int]] = deque(maxlen=keep)
        self.count = 0
        self.on_disk = 0
        self.created = False
        self.largest_interval = math.nan
        self.largest_interval_sample = -1
        self.columns: list[str] | None = None
        if any("\n" in line or "\r" in line for line in preamble):
            raise ValueError("preamble: each line must be one line, without line breaks")
        self.preamble = tuple(preamble)
        self._fd: int | None = None
        self._size = 0  # bytes in the file, ending on a whole line
        self._pending: list[bytes] = []  # lines formatted, not yet written
        self._line = io.StringIO()
        self._writer = csv.writer(self._line, lineterminator="\n")
        if self.path is not None:
            if self.path.is_dir():
                raise IsADirectoryError(f"run_online: out {self.path} is a folder, expected a file name")
            if self.path.exists() and not self.overwrite:
                raise FileExistsError(
                    f"run_online: out {self.path} exists; pass overwrite=True to replace it, "
                    "or choose another name"
                )

    def _csv_line(self, values: list[str]) -> bytes:
        self._line.seek(0)
        self._line.truncate()
        self._writer.writerow(values)
        return self._line.getvalue().encode("utf-8")

    def append(self, row: dict[str, float | int]) -> None:
        """Record one row (written every ``flush_every`` rows).

        Raises
        ------
        motorid.errors.OutputError
            The disk is full (or the file cannot be written): the message names
            the file and the rows it holds, ending on a whole row.
        """
        if self.columns is None:
            self.columns = list(row)
            if self.path is not None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self._fd = self._open_alone()
                self.created = True
                self._pending.extend(line.encode("utf-8") + b"\n" for line in self.preamble)
                self._pending.append(self._csv_line(self.columns))
        self.rows.append(row)
        self.count += 1
        if self._fd is not None:
            self._pending.append(self._csv_line([_format(row.get(c, math.nan)) for c in self.columns]))
            if self.count % self.flush_every == 0:
                self.flush()

    def _open_alone(self) -> int:
        """Create the file for this recorder alone (:func:`motorid.outputs.create_in_place`): a new file
        takes the name, replacing what is there with ``overwrite`` (a link is replaced, never written
        through), and stays locked until :meth:`close`, so no two runs write one file."""
        return create_in_place(self.path, overwrite=self.overwrite)

    def flush(self) -> None:
        """Write the rows not yet written; on an error, cut the file back to its last whole row."""
        if self._fd is None or not self._pending:
            return
        lines, self._pending = self._pending, []
        data = b"".join(lines)
        written = 0
        try:
            while written < len(data):
                written += os.write(self._fd, data[written:])
        except OSError as exc:
            self._cut_to_whole_line(lines, written, exc)
        self._size += written
        self.on_disk = self.count

    def _cut_to_whole_line(self, lines: list[bytes], written: int, exc: OSError) -> None:
        whole_bytes = whole_lines = 0
        for line in lines:
            if whole_bytes + len(line) > written:
                break
            whole_bytes += len(line)
            whole_lines += 1
        # the preamble and the header, where this batch holds them
        header_lines = 1 + len(self.preamble) if self._size == 0 else 0
        rows = self.on_disk + max(whole_lines - header_lines, 0)
        size = self._size + whole_bytes
        fd, self._fd = self._fd, None
        try:
            os.ftruncate(fd, size)
        finally:
            os.close(fd)
        reason = (
            f"the disk is full ({exc.strerror})" if disk_full(exc) else f"cannot write: {exc.strerror or exc}"
        )
        if size == 0:
            self.path.unlink(missing_ok=True)
            kept = "no whole line reached it, and the file was removed"
        else:
            kept = f"the file holds the first {rows} of {self.count} samples, ending on a whole row"
        self.on_disk = rows
        self._size = size
        raise OutputError(f"{self.path}: {reason}: {kept}") from None

    def close(self) -> None:
        """Write what is left and close the file; the recording stays readable.

        Raises
        ------
        motorid.errors.OutputError
            As :meth:`append` (the file is closed either way).
        """
        if self._fd is None:
            return
        try:
            self.flush()
        finally:
            if self._fd is not None:
                os.close(self._fd)
                self._fd = None

    def frame(
        self,
        dt: float,
        columns: Sequence[str] = ("t", "seq", "u", "y", "clamped"),
        units: Mapping[str, str] | None = None,
        timing: str = "hold",
    ) -> pd.DataFrame:
        """The rows kept in memory as a DataFrame.

        ``attrs`` holds ``dt`` [s], ``units``, ``timing``, ``samples``, the
        number of rows recorded in all (more than the frame's length when
        ``keep`` bounded it; the file holds every row), and ``largest_interval``,
        the longest time between the starts of two samples [s] (:attr:`largest_interval`).

        Parameters
        ----------
        dt : float
            The run's sample time [s].
        columns : sequence of str
            The columns of a run that recorded no row (else those of its rows).
        units : mapping, optional
            Column -> unit; default ``t`` in s, ``u`` in V, ``y`` in rad/s.
        timing : str
            A keyword of :data:`motorid.io.records.TIMINGS`: ``"hold"`` (``y`` measured at
            the end of the sample) or ``"sampled"`` (at its start).
        """
        df = pd.DataFrame(list(self.rows), columns=self.columns or list(columns))
        df.attrs["dt"] = dt
        df.attrs["units"] = dict(units) if units is not None else {"t": "s", "u": "V", "y": "rad/s"}
        df.attrs["timing"] = timing
        df.attrs["samples"] = self.count
        df.attrs["largest_interval"] = self.largest_interval
        return df


def warm_up(estimators: Mapping[str, OnlineEstimator]) -> None:
    """Run one ``predict(0); update(0)`` on a copy of each estimator, before the rig is opened.

    The first call of a compiled estimator compiles it (0.1-0.2 s), longer
    than a rig server's watchdog allows between samples (3 periods of 40 ms);
    done here, on a copy, it costs nothing during the run and leaves the
    estimators untouched. An estimator that cannot be copied is not warmed
    (logged at debug level).
    """
    for name, est in estimators.items():
        try:
            twin = copy.deepcopy(est)
            twin.predict(0.0)
            twin.update(0.0)
        except Exception as exc:  # a plugin that cannot be copied or run on zeros: warm-up is optional
            logger.debug("estimator %r not warmed up before the run: %s: %s", name, type(exc).__name__, exc)


def _format(value: float) -> str:
    if isinstance(value, int):
        return str(value)
    return repr(float(value))


def _command_for(excitation: Excitation, k: int, t: float) -> float:
    if callable(excitation):
        u = float(excitation(t))
    else:
        u = float(excitation[k])
    if not math.isfinite(u):
        raise ValueError(f"run_online: excitation gave {u!r} V at sample {k} (t = {t:.6g} s)")
    return u


class StopRequest:
    """Ctrl-C (SIGINT) and SIGTERM as a request to stop between two samples.

    Inside :meth:`installed` the first signal only sets :attr:`signal_name`;
    the loop checks :meth:`check` once per sample and stops there, so the
    rig is commanded to 0 V and the CSV ends on a whole row that the stop
    message counts exactly. A second signal raises KeyboardInterrupt at once
    (a rig that no longer answers). Outside the main thread signals cannot be
    caught, and nothing is installed.
    """

    def __init__(self) -> None:
        self.signal_name: str | None = None

    def _handle(self, signum: int, frame: object) -> None:
        if self.signal_name is not None:
            raise KeyboardInterrupt(f"{signal.Signals(signum).name} received twice")
        self.signal_name = signal.Signals(signum).name

    def check(self) -> None:
        """Raise KeyboardInterrupt if a stop was requested."""
        if self.signal_name is not None:
            raise KeyboardInterrupt(f"{self.signal_name} received")

    @contextmanager
    def installed(self) -> Any:
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous = {s: signal.signal(s, self._handle) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            yield self
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)


def samples_for(duration: float | None, dt: float, series: object, who: str, what: str) -> int:
    """The samples a run of ``duration`` [s] at ``dt`` [s] takes; without a duration, the length of
    ``series`` (the excitation or reference of ``who``, called ``what`` in the errors).

    Parameters
    ----------
    duration : float or None
        Length of the run [s], > 0 and at least one sample; None: the whole ``series``.
    dt : float
        Sample time [s].
    series : array or callable
        Per-sample values, or a function of time (then ``duration`` is required).
    who : str
        The run's name in the errors (``run_online``).
    what : str
        The series' name in the errors (``excitation``).

    Raises
    ------
    ValueError
        Naming ``who`` and what is wrong with the duration.
    """
    if duration is None:
        if callable(series):
            raise ValueError(f"{who}: duration is required with a callable {what}")
        return len(series)  # type: ignore[arg-type]
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"{who}: duration must be a positive time [s], got {duration!r}")
    n = round(duration / dt)
    if n < 1:
        raise ValueError(f"{who}: duration {duration!r} s is shorter than one sample ({dt!r} s)")
    return n


class CollectorBetweenSamples:
    """Python's garbage collector kept out of a sample loop: frozen, off, and run in small steps between samples.

    On entry everything alive (modules, the model, the estimators) is collected once and frozen
    (:func:`gc.freeze`: never scanned again), and automatic collection is turned off, so no
    collection of the whole heap (165-320 ms with motorid's imports loaded on a busy machine, longer
    than a rig's watchdog of 3 periods of 40 ms) can start inside a sample. :meth:`between_samples`,
    called once a sample is recorded, collects the youngest generation when it holds more than
    :data:`YOUNG_LIMIT` objects and the objects made since entry every :data:`FULL_EVERY` samples
    (both scan only what the loop made: well under a millisecond). On exit the frozen objects are
    released and automatic collection is as it was.
    """

    #: Objects in the youngest generation that start a collection of it between two samples.
    YOUNG_LIMIT = 700
    #: Samples between two collections of everything made since the loop started.
    FULL_EVERY = 1000

    def __init__(self) -> None:
        self._was_enabled = gc.isenabled()
        self._samples = 0

    def __enter__(self) -> CollectorBetweenSamples:
        gc.collect()
        gc.freeze()
        gc.disable()
        return self

    def between_samples(self) -> None:
        """One small step of collection, where the loop has finished a sample."""
        self._samples += 1
        if self._samples % self.FULL_EVERY == 0:
            gc.collect()
        elif gc.get_count()[0] > self.YOUNG_LIMIT:
            gc.collect(0)

    def __exit__(self, *exc_info: object) -> None:
        gc.unfreeze()
        if self._was_enabled:
            gc.enable()


def sample_loop(
    daq: DAQ,
    n: int,
    sample: Callable[[int], dict[str, float | int]],
    recorder: RunRecorder,
    who: str,
    progress: bool = False,
    then: Callable[[int], None] | None = None,
) -> None:
    """Open ``daq``, take ``n`` samples recording the row ``sample(k)`` returns for each, and close
    the DAQ (which commands 0 V), whatever happens: the one loop of every run on a rig.

    ``sample(k)`` does the sample's reads and writes. Ctrl-C or SIGTERM stops the loop between two
    samples (:class:`StopRequest`). Python's garbage collector runs only between samples, in small
    steps (:class:`CollectorBetweenSamples`), and the longest time between the starts of two samples
    is kept in ``recorder.largest_interval`` [s] (``largest_interval_sample``: where). When anything stops it early, the DAQ is closed, the recording
    closed on a whole row, and a note on the exception says how many samples were taken and what
    is on disk (``{who} stopped after 11 of 50 samples (11 rows in run.csv)``), then it is re-raised.

    Parameters
    ----------
    daq : DAQ
        The rig (not yet open).
    n : int
        Samples to take.
    sample : callable
        ``k -> row``: sample ``k``'s reads and writes, and its row (column -> value).
    recorder : RunRecorder
        Where the rows go; closed on return.
    who : str
        The run's name in the note (``run_online``).
    progress : bool
        A progress bar on stderr (:func:`motorid.progress.progress_bar`).
    then : callable, optional
        ``k -> None``: what follows once sample ``k``'s row is recorded (the next command of an
        open loop, so a failure computing it keeps the row it follows).
    """
    bar = progress_bar(show=progress, total=n, unit="sample", desc=who)
    try:
        with StopRequest().installed() as stop, CollectorBetweenSamples() as collector:
            daq.open()
            previous = math.nan
            for k in range(n):
                stop.check()
                started = time.perf_counter()
                if started - previous > recorder.largest_interval or k == 1:
                    recorder.largest_interval, recorder.largest_interval_sample = started - previous, k
                previous = started
                recorder.append(sample(k))
                bar.update()
                if then is not None:
                    then(k)
                collector.between_samples()
    except BaseException as exc:
        bar.close()
        try:
            daq.close()  # commands 0 V where it can
        finally:
            kept = _close_recording(recorder, exc)
        msg = f"{who} stopped after {recorder.count} of {n} samples ({kept})"
        reason = str(exc) or ("interrupted" if isinstance(exc, KeyboardInterrupt) else "no message")
        logger.info("%s: %s: %s", msg, type(exc).__name__, reason)  # the note on exc tells the caller
        exc.add_note(msg)
        raise
    bar.close()
    try:
        daq.close()  # commands 0 V where it can
    finally:
        recorder.close()


def run_online(
    daq: DAQ,
    estimators: Mapping[str, OnlineEstimator] | Iterable[OnlineEstimator] | None,
    excitation: Excitation,
    duration: float | None,
    out: str | Path | None = None,
    progress: bool = False,
    *,
    flush_every: int = 1,
    overwrite: bool = False,
    keep: int | None = None,
) -> pd.DataFrame:
    """Run online identification on a DAQ: excite, measure, estimate, record.

    Each sample ``k`` the loop commands ``u_k`` (held for one sample), reads
    the speed ``y_k`` measured at the end of that sample, and feeds every
    estimator ``y_hat = est.predict(u_k); est.update(y_k)``. A row per
    sample is appended to ``out`` as it is taken.

    Parameters
    ----------
    daq : DAQ
        The rig (opened here if it is not open; always closed on return).
    estimators : mapping of name to estimator, or sequence of estimators
        Each has ``predict(u)``, ``update(y)`` and ``params``. The name is
        the column prefix (``hammerstein-rls.a1``).
    excitation : array of float or callable
        Input command [V] per sample, or a function of time ``t`` [s] (the
        start of the sample it is applied in) returning volts.
    duration : float or None
        Length of the run [s]; ``round(duration / daq.dt)`` samples. None
        with an array excitation runs the whole array.
    out : path, optional
        CSV file written row by row while the loop runs (created with the
        first sample). An existing file is refused before the DAQ is opened
        unless ``overwrite`` is true. Its first line is the record's attributes
        (:func:`motorid.io.records.attrs_line`: ``dt`` [s], ``units`` V and rad/s,
        ``timing`` ``"hold"``), so ``motorid doctor``, ``identify`` and ``compare``
        read it as it is, with no options.
    progress : bool
        Show a progress bar on stderr (:func:`motorid.progress.progress_bar`).
    flush_every : int
        Flush the CSV every this many samples (1: every sample).
    overwrite : bool
        Replace an existing ``out``. Even then the old file stays as it was
        until the first sample is taken.
    keep : int or None
        Rows kept in memory and returned. None: every row without ``out``,
        the last :data:`KEEP_WITH_FILE` rows with it (the file holds them
        all), so a run of days at 25 Hz holds its memory flat.

    Returns
    -------
    pandas.DataFrame
        Columns ``t`` [s], ``seq``, ``u`` [V] (command applied, after
        clamping), ``y`` [rad/s], ``clamped``,
        then for each estimator ``NAME.y_hat`` and its flattened ``params``
        after the update. Timing as in ``TwoMassRig.simulate``: ``u`` is held
        over ``[t, t + dt)`` and ``y`` is measured at ``t + dt`` (the sample's
        time stamp). ``attrs["dt"]``, ``attrs["units"]``,
        ``attrs["timing"]`` and ``attrs["samples"]`` (rows recorded in all)
        are set.

    Raises
    ------
    FileExistsError
        ``out`` exists and ``overwrite`` is false (before the DAQ is opened).
    DAQError
        The rig failed (lost link, invalid reading, fault). The loop stops,
        commands 0 V where it can, closes the DAQ, and re-raises; the CSV
        holds every sample taken before the failure (a note on the exception
        says how many and where).
    KeyboardInterrupt
        Ctrl-C or SIGTERM: the loop stops before the next sample, with the
        same clean-up (a second signal stops it at once).
    """
    named = name_estimators(estimators)
    dt = float(daq.dt)
    n = samples_for(duration, dt, excitation, "run_online", "excitation")
    if not callable(excitation):
        if np.ndim(excitation) != 1:
            raise ValueError(
                f"run_online: excitation must be 1-D volts per sample, got shape {np.shape(excitation)}"
            )
        if len(excitation) < n:
            raise ValueError(
                f"run_online: excitation has {len(excitation)} samples, the run "
                f"needs {n} ({duration} s at dt = {dt} s)"
            )

    if keep is None and out is not None:
        keep = KEEP_WITH_FILE
    units = {"t": "s", "u": "V", "y": "rad/s"}
    attrs = {"dt": dt, "units": units, "timing": "hold"}
    recorder = RunRecorder(
        out, flush_every=flush_every, overwrite=overwrite, keep=keep, preamble=[attrs_line(attrs)]
    )
    warm_up(named)

    def sample(k: int) -> dict[str, float | int]:
        if k == 0:
            daq.write(_command_for(excitation, 0, 0.0))
        taken: Sample = daq.read()
        row: dict[str, float | int] = {
            "t": taken.t - dt,
            "seq": taken.seq,
            "u": taken.u,
            "y": taken.y,
            "clamped": int(taken.clamped),
        }
        for name, est in named.items():
            y_hat = est.predict(taken.u)
            est.update(taken.y)
            row[f"{name}.y_hat"] = float(np.asarray(y_hat, dtype=float).ravel()[0])
            row.update(flatten_params(name, getattr(est, "params", {})))
        return row

    def next_command(k: int) -> None:
        if k + 1 < n:
            daq.write(_command_for(excitation, k + 1, (k + 1) * dt))

    sample_loop(daq, n, sample, recorder, "run_online", progress, then=next_command)
    return recorder.frame(dt, units=units, timing="hold")


def _close_recording(recorder: RunRecorder, exc: BaseException) -> str:
    """Close the recording of a run stopped by ``exc``; what is on disk now, for the note on ``exc``."""
    try:
        recorder.close()
    except OutputError as closing:  # a full disk at the last flush: the note says what the file holds
        logger.error("%s", closing)
        if closing is not exc:
            exc.add_note(str(closing))
    if recorder.path is None:
        return "kept in memory"
    if not recorder.created or not recorder.path.exists():
        return f"nothing written to {recorder.path}"
    return f"{recorder.on_disk} rows in {recorder.path}"
