"""Run one task per record on a Dask cluster, writing each result as it completes.

The work is ``dask.distributed``'s: :func:`fleet_client` starts a
:class:`~dask.distributed.LocalCluster` (one single-threaded worker process per
core, so compiled code and the GIL do not serialise the records) or connects to a
running scheduler; :func:`run_fleet` submits one task per record not yet in the
results and stores each finished row at once (:class:`~motorid.fleet.results.ResultsStore`).

What survives what:

- a record that fails (a bad file, a diverging filter) is a row with its error;
  the task catches it, so the others go on;
- a worker process that dies: the scheduler reruns its tasks on the others (and a
  LocalCluster's nanny restarts it); a task that kills workers again and again
  ends as a failed row naming the lost worker;
- a task that runs longer than ``task_timeout`` (a frozen worker, a record that
  never ends): its row says it timed out, the scheduler forgets its worker, and the
  run goes on with the other workers;
- the run itself stopped (Ctrl-C, killed): every row stored before is on disk; a
  rerun skips the records in the results (``retry_failed`` also reruns the
  failed ones).

The LocalCluster listens on 127.0.0.1 at a random port, without TLS (Dask's TLS
needs the ``cryptography`` package and certificates): any process of the machine
can reach it while it runs, as it can reach any local service. A running
scheduler given with ``scheduler`` runs whatever its clients submit: it must be
one you trust, on a network you trust.

Worker processes are started by spawning Python, which imports the main script
again: a script that calls :func:`run` must do so under
``if __name__ == "__main__":``, and is told so in one line when it does not.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import re
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motorid.errors import DataError, OutputError
from motorid.fleet.jobs import DRIVE_KEY_PREFIX, Job, RecordOptions, per_drive_command
from motorid.fleet.results import ResultsStore
from motorid.io.records import read_record
from motorid.io.records.options import COMMAND_MAX_SAMPLES
from motorid.progress import progress_bar

logger = logging.getLogger(__name__)

#: A task: (record path, what the file-name pattern gave) -> the record's row.
Task = Callable[[str, dict[str, Any]], dict[str, Any]]

#: Longest a task may run on its worker before its row says it timed out [s] (``task_timeout``).
TASK_TIMEOUT = 600.0
#: What a script that runs a fleet needs, in the errors that say so.
MAIN_GUARD = 'if __name__ == "__main__":'


def _importing_the_script_in_a_worker() -> bool:
    """True while a spawned worker process imports the main script again (as ``__mp_main__``)."""
    import multiprocessing

    main = sys.modules.get("__main__")
    return multiprocessing.parent_process() is not None and getattr(main, "__name__", "") == "__mp_main__"


def _script_without_main_guard() -> str | None:
    """The main script's path when it has no ``if __name__ == "__main__":`` (workers would run it again)."""
    path = getattr(sys.modules.get("__main__"), "__file__", None)
    if not path:
        return None
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    return None if re.search(r"""if\s+__name__\s*==\s*['"]__main__['"]""", text) else path


@contextlib.contextmanager
def fleet_client(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A ``dask.distributed.Client``: on ``scheduler`` (``tcp://HOST:8786``) or a LocalCluster.

    The LocalCluster has ``workers`` processes (default: the machine's cores), one thread
    each, and no dashboard; it is closed on exit, as is the client.

    Parameters
    ----------
    scheduler : str, optional
        The address of a running scheduler; None starts a LocalCluster.
    workers : int, optional
        Worker processes of the LocalCluster (default: the machine's cores).
    """
    # the cluster's own log (start and stop, a worker lost and its tasks rerun) at the level the caller
    # gave the "distributed" logger (motorid's command line: critical only, all with -v); dask resets
    # the levels on import and as it starts, so they are set again once it runs
    level = logging.getLogger("distributed").getEffectiveLevel()
    import dask
    from dask.distributed import Client, LocalCluster

    def keep_level() -> None:
        for name in list(logging.root.manager.loggerDict):
            if name.startswith("distributed."):
                logging.getLogger(name).setLevel(logging.NOTSET)
        logging.getLogger("distributed").setLevel(level)

    keep_level()
    if scheduler is not None:
        try:
            client = Client(scheduler)
        except OSError as exc:  # refused, timed out, no such host
            raise DataError(f"cannot reach the scheduler at {scheduler}: {exc}") from None
        with client:
            keep_level()
            yield client
        return
    n = workers or os.cpu_count() or 1
    try:
        # one task on a worker at a time (no queue behind it): a task the scheduler sees on a
        # worker is the one running there, which is what the task timeout measures
        with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",  # loopback only, at a random port
                scheduler_port=0,
                dashboard_address=None,
                # the scheduler's HTTP endpoints on a free loopback port: its default, 8787, is taken by
                # a second fleet run and would warn
                scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                silence_logs=level,
            )
    except RuntimeError as exc:  # "Nanny failed to start."
        script = _script_without_main_guard()
        if script is None:
            raise
        raise DataError(
            f"the Dask worker processes did not start: each imports {script} again, which runs the fleet "
            f"at import; put the code that runs it under {MAIN_GUARD}"
        ) from exc
    with cluster, Client(cluster) as client:
        keep_level()
        yield client


def pending_records(
    paths: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str] | ResultsStore,
    retry_failed: bool = False,
) -> list[str]:
    """The absolute paths of ``paths`` that have no row in ``out``'s results (with ``retry_failed``,
    no successful row): what a run has to do.

    Parameters
    ----------
    paths : sequence of path
        The run's record files.
    out : path or ResultsStore
        The run folder, or its open store.
    retry_failed : bool
        Count a record whose row is a failure as still to do.
    """
    store = out if isinstance(out, ResultsStore) else ResultsStore(out)
    previous = store.rows()
    kept = previous if not retry_failed else previous[previous["status"] == "ok"]
    finished = set(kept["record"])
    return [path for path in map(os.path.abspath, paths) if path not in finished]


@dataclass
class FleetRun:
    """Counts of a run: records found, skipped (already in the results), done, failed; wall time [s].

    In a run per drive (:func:`run_fleet_per_drive`), ``drives`` is the number of drives and
    ``skipped``, ``done`` and ``failed`` count drives (a record that cannot be read is a failed
    drive of its own).

    Attributes
    ----------
    records : int
        Records found.
    skipped : int
        Already in the results (records, or drives in a run per drive).
    done : int
        Computed in this run.
    failed : int
        Whose row is a failure.
    seconds : float
        Wall time of the run [s].
    drives : int, optional
        Drives, in a run per drive; None otherwise.
    """

    records: int
    skipped: int
    done: int
    failed: int
    seconds: float
    drives: int | None = None


def run_fleet(
    paths: Sequence[str | os.PathLike[str]],
    task: Task,
    out: str | os.PathLike[str],
    client: Any,
    given: dict[str, dict[str, Any]] | None = None,
    retry_failed: bool = False,
    progress: bool = False,
    csv_every: float = 5.0,
    task_timeout: float = TASK_TIMEOUT,
) -> FleetRun:
    """Run ``task`` on every record of ``paths`` not yet in ``out``'s results; store each row.

    Parameters
    ----------
    paths : sequence of path
        The records; a record's key in the results is its path as given, made absolute.
    task : callable
        ``task(path, given) -> row`` (picklable: it runs in the workers); it catches the
        record's own errors and returns them as a row with ``status = "failed"``.
    out : path
        The run folder (:mod:`motorid.fleet.results`).
    client : dask.distributed.Client
    given : dict, optional
        Per absolute path, what a file-name pattern gave (``drive``, ``time``).
    retry_failed : bool
        Rerun the records whose row says failed (default: skip every record in the results).
    progress : bool
        A progress bar on stderr with the counts of done and failed records
        (:func:`motorid.progress.progress_bar`).
    csv_every : float
        Seconds between rewrites of ``results.csv`` during the run [s].
    task_timeout : float
        Longest a record's task may run on its worker [s] (default :data:`TASK_TIMEOUT`); then
        its row is a failure saying so and the run goes on without that worker.
    """
    start = time.perf_counter()
    store = ResultsStore(out)
    records = [os.path.abspath(p) for p in paths]
    todo = pending_records(records, store, retry_failed)
    given = given or {}
    run = FleetRun(records=len(records), skipped=len(records) - len(todo), done=0, failed=0, seconds=0.0)
    logger.info("%d records, %d already in %s, %d to run", run.records, run.skipped, out, len(todo))
    futures = client.map(task, todo, [given.get(p, {}) for p in todo], pure=False)

    def lost(path: str, exc: BaseException) -> list[dict[str, Any]]:
        drive = given.get(path, {}).get("drive", Path(path).stem)
        when = given.get(path, {}).get("time")
        return [{"record": path, "drive": drive, "time": when.isoformat() if when else None,
                 "status": "failed", "error": f"{type(exc).__name__}: {exc}"}]  # fmt: skip

    _store_as_completed(
        dict(zip(futures, todo, strict=True)),
        lost,
        store,
        run,
        progress,
        csv_every,
        "record",
        client,
        task_timeout,
    )
    run.seconds = time.perf_counter() - start
    return run


def _store_as_completed(
    futures: dict[Any, Any],
    lost: Callable[[Any, BaseException], list[dict[str, Any]]],
    store: ResultsStore,
    run: FleetRun,
    progress: bool,
    csv_every: float,
    unit: str,
    client: Any,
    task_timeout: float,
) -> None:
    """Store the row (or the list of rows) of each future of ``futures`` (future -> its key) as it
    completes, counting it in ``run``; a future whose worker was lost, or that ran longer than
    ``task_timeout`` [s] on its worker (:class:`_TaskClock`), is ``lost(key, exc)``'s rows.
    A task is done when its first row says ok."""
    from dask.distributed import as_completed, wait

    if not (task_timeout > 0):
        raise DataError(f"task_timeout must be a positive time [s], got {task_timeout!r}")
    bar = progress_bar(show=progress, total=len(futures), desc="fleet", unit=unit)
    bar.set_postfix(done=0, failed=0)
    key_of = {future.key: key for future, key in futures.items()}
    clock = _TaskClock(client, {future.key: future for future in futures}, task_timeout)
    last_csv = time.monotonic()
    try:
        pending = as_completed(list(futures), with_results=True, raise_errors=False)
        remaining = set(futures)
        while not pending.is_empty():
            batch = pending.next_batch(block=False)
            if not batch:
                clock.check()
                running = [future for future in remaining if future.key not in clock.timed_out]
                if not running:  # only cancelled ones left, on their way out of as_completed
                    time.sleep(0.05)
                    continue
                with contextlib.suppress(TimeoutError):  # until one completes, or the clock's next look
                    wait(running, timeout=clock.EVERY, return_when="FIRST_COMPLETED")
                continue
            remaining.difference_update(future for future, _ in batch)
            rows = []
            failed = 0
            for future, result in batch:
                if future.key in clock.timed_out:
                    result = lost(key_of[future.key], TimeoutError(clock.timed_out[future.key]))
                elif (
                    future.status == "error"
                ):  # not the record's own error (the task catches that): a lost worker
                    result = lost(key_of[future.key], future.exception())
                task_rows = result if isinstance(result, list) else [result]
                failed += task_rows[0]["status"] != "ok"
                rows += task_rows
                future.release()
            with _saying_what_is_kept(run, store):
                store.append(rows)
            run.done += len(batch) - failed
            run.failed += failed
            bar.update(len(batch))
            bar.set_postfix(done=run.done, failed=run.failed)
            if time.monotonic() - last_csv > csv_every:
                with _saying_what_is_kept(run, store):
                    store.write_csv()
                last_csv = time.monotonic()
    except BaseException:
        bar.close()
        try:
            store.write_csv(reread=True)
        except OutputError as exc:  # the error already on its way says what matters
            logger.info("%s", exc)
        raise
    bar.close()
    with _saying_what_is_kept(run, store):
        store.write_csv(reread=True)
    store.compact()


class _TaskClock:
    """The time each task has been running on a worker, from the scheduler's view; a task past the
    timeout is cancelled (its row says so) and its worker removed from the scheduler, so the tasks
    queued behind it run elsewhere (a frozen worker answers nothing and would hold them)."""

    #: Seconds between two looks at the scheduler.
    EVERY = 1.0

    def __init__(self, client: Any, futures: dict[str, Any], timeout: float) -> None:
        self.client = client
        self.futures = futures
        self.timeout = float(timeout)
        self.first_seen: dict[str, float] = {}
        self.timed_out: dict[str, str] = {}  # key -> what happened
        self._last = -math.inf

    def check(self) -> None:
        now = time.monotonic()
        if now - self._last < self.EVERY:
            return
        self._last = now
        stuck: set[str] = set()
        for worker, keys in self.client.processing().items():
            for key in keys:
                key = key if isinstance(key, str) else str(key)
                if key not in self.futures or key in self.timed_out:
                    continue
                started = self.first_seen.setdefault(key, now)
                if now - started > self.timeout:
                    self.timed_out[key] = f"the task ran longer than {self.timeout:g} s on worker {worker}"
                    logger.warning("%s: %s; the run goes on without that worker", key, self.timed_out[key])
                    self.futures[key].cancel()
                    stuck.add(worker)
        for worker in stuck:
            self.client.run_on_scheduler(_forget_worker, address=worker)


async def _forget_worker(dask_scheduler: Any, address: str) -> None:
    """Scheduler side: remove the worker at ``address`` (its other tasks are rescheduled)."""
    await dask_scheduler.remove_worker(address=address, stimulus_id="motorid-task-timeout", close=False)


def pending_drives(
    groups: Mapping[str, Sequence[str]],
    out: str | os.PathLike[str] | ResultsStore,
    retry_failed: bool = False,
) -> list[str]:
    """The drives of ``groups`` without a row in ``out``'s results for exactly their records now.

    A drive that gained or lost a record since its row was written is run again.

    Parameters
    ----------
    groups : mapping of str to sequence of str
        Drive -> its records' absolute paths, in the order of its row's ``records``.
    out : path or ResultsStore
        The run folder, or its results.
    retry_failed : bool
        Run again a drive whose row says failed (default: a drive with any row for these
        records is done).
    """
    store = out if isinstance(out, ResultsStore) else ResultsStore(out)
    previous = store.rows()
    if retry_failed:
        previous = previous[previous["status"] == "ok"]
    done = dict(zip(previous["record"], previous.get("records", [None] * len(previous)), strict=True))
    return [
        drive
        for drive, paths in groups.items()
        if done.get(DRIVE_KEY_PREFIX + drive, "\0") != ",".join(paths)
    ]


def record_identity(path: str, read: Any, given: dict[str, Any]) -> tuple[str, str | None, str | None]:
    """The drive and time of a record (:func:`motorid.fleet.sources.identity`), and the error when
    it cannot be read (None when it can).

    Parameters
    ----------
    path : str
        The record file.
    read : RecordOptions
        How it is read (:class:`~motorid.io.records.RecordOptions`): its attrs may name the drive
        and time.
    given : dict
        What a file-name pattern gave for it (``drive``, ``time``), which comes first.
    """
    from motorid.fleet.sources import identity

    try:
        drive, when = identity(
            path, read_record(path, read, min_samples=20, other_columns=False, speed=True).attrs, given
        )
        return drive, when, None
    except Exception as exc:  # the record's failure is its row
        drive, when = identity(path, {}, given)
        return drive, when, str(exc) if isinstance(exc, DataError) else f"{type(exc).__name__}: {exc}"


def group_by_drive(
    paths: Sequence[str | os.PathLike[str]],
    read: Any,
    client: Any,
    given: dict[str, dict[str, Any]] | None = None,
    known: Mapping[str, tuple[str, str | None]] | None = None,
) -> tuple[dict[str, list[tuple[str, str | None]]], list[dict[str, Any]]]:
    """The records of ``paths`` per drive, and a failed row for each record that cannot be read.

    A record's drive is what a file-name pattern gave, else its attrs ``drive``
    (:data:`motorid.io.records.DRIVE_ATTR`), else its file's stem: a record without a drive id is
    a drive of its own. The records whose drive the pattern gave or ``known`` holds are not
    read; the others are read on the cluster, one task each. Each drive's records are sorted
    by time, then path.

    Parameters
    ----------
    paths : sequence of path
        The records; made absolute.
    read : RecordOptions
        How a record is read to find its drive and time (:func:`record_identity`).
    client : dask.distributed.Client
        Where the records are read; unused (None will do) when none needs reading.
    given : dict, optional
        Per absolute path, what a file-name pattern gave (``drive``, ``time``).
    known : mapping, optional
        Absolute path -> (drive, time) from the results of a run before
        (:func:`known_identities`).
    """
    from motorid.fleet.sources import identity

    given = given or {}
    known = known or {}
    records = [os.path.abspath(p) for p in paths]
    found: dict[str, tuple[str, str | None]] = {}
    to_read = []
    for path in records:
        if path in known:
            found[path] = known[path]
        elif "drive" in given.get(path, {}):
            found[path] = identity(path, {}, given.get(path, {}))
        else:
            to_read.append(path)
    unread = []
    if to_read:
        futures = client.map(record_identity, to_read, [read] * len(to_read), [given.get(p, {}) for p in to_read],
                             pure=False)  # fmt: skip
        for path, (drive, when, error) in zip(to_read, client.gather(futures), strict=True):
            if error is None:
                found[path] = (drive, when)
            else:
                unread.append(
                    {"record": path, "drive": drive, "time": when, "status": "failed", "error": error}
                )
    groups: dict[str, list[tuple[str, str | None]]] = {}
    for path in records:
        if path in found:
            drive, when = found[path]
            groups.setdefault(drive, []).append((path, when))
    for members in groups.values():
        members.sort(key=lambda member: (member[1] or "", member[0]))
    return groups, unread


def known_identities(store: ResultsStore, command: str) -> dict[str, tuple[str, str | None]]:
    """Record path -> (drive, time) of the records a per-drive run has done: a rerun need not
    read them again to group them.

    Parameters
    ----------
    store : ResultsStore
        The results of the run folder.
    command : str
        The rows' ``command``, e.g. ``"doctor per drive"`` (:func:`~motorid.fleet.jobs.per_drive_command`);
        only its successful rows count.
    """
    previous = store.rows()
    if not len(previous):
        return {}
    ok = previous[(previous["status"] == "ok") & (previous["command"] == command)]
    return {
        record: (drive, when if isinstance(when, str) else None)
        for record, drive, when in zip(ok["record"], ok["drive"], ok["time"], strict=True)
        if not str(record).startswith(DRIVE_KEY_PREFIX)
    }


def run_fleet_per_drive(
    paths: Sequence[str | os.PathLike[str]],
    task: Any,
    out: str | os.PathLike[str],
    client: Any,
    read: Any,
    given: dict[str, dict[str, Any]] | None = None,
    retry_failed: bool = False,
    progress: bool = False,
    csv_every: float = 5.0,
    task_timeout: float = TASK_TIMEOUT,
) -> FleetRun:
    """Run ``task`` once per drive on all its records; store each drive's rows.

    The records are grouped by :func:`group_by_drive` (the records already in the results
    are not read again for it); the drives whose row holds exactly their records now are
    skipped (:func:`pending_drives`); each drive's rows (its own and one per record) are
    stored together as the drive completes.

    Parameters
    ----------
    paths : sequence of path
        The records; a record's key in the results is its path made absolute.
    task : DriveTask
        ``task(drive, paths, times) -> rows`` (:class:`~motorid.fleet.jobs.DriveTask`), run in
        the workers.
    out : path
        The run folder (:mod:`motorid.fleet.results`).
    client : dask.distributed.Client
        Where the records are grouped and the drives run.
    read : RecordOptions
        How a record is read to find its drive (:func:`group_by_drive`).
    given : dict, optional
        Per absolute path, what a file-name pattern gave (``drive``, ``time``).
    retry_failed : bool
        Rerun the drives whose row says failed (default: skip every drive in the results).
    progress : bool
        A progress bar on stderr with the counts of done and failed drives
        (:func:`motorid.progress.progress_bar`).
    csv_every : float
        Time between rewrites of ``results.csv`` during the run [s].
    task_timeout : float
        Longest a drive's task may run on its worker [s] (:func:`run_fleet`).
    """
    start = time.perf_counter()
    store = ResultsStore(out)
    command = per_drive_command(task.job)
    known = known_identities(store, command)
    groups, unread = group_by_drive(paths, read, client, given, known)
    members = {drive: [path for path, _ in group] for drive, group in groups.items()}
    todo = pending_drives(members, store, retry_failed)
    run = FleetRun(records=len(paths), skipped=len(groups) - len(todo), done=0, failed=len(unread),
                   seconds=0.0, drives=len(groups) + len(unread))  # fmt: skip
    logger.info("%d records of %d drives, %d drives already in %s, %d to run", run.records, len(groups),
                run.skipped, out, len(todo))  # fmt: skip
    if unread:
        for row in unread:
            row["command"] = command
        with _saying_what_is_kept(run, store):
            store.append(unread)
    futures = client.map(task, todo, [members[d] for d in todo], [[w for _, w in groups[d]] for d in todo],
                         pure=False)  # fmt: skip

    def lost(drive: str, exc: BaseException) -> list[dict[str, Any]]:
        error = f"{type(exc).__name__}: {exc}"
        return [{"record": DRIVE_KEY_PREFIX + drive, "drive": drive, "command": command, "records": ",".join(members[drive]),
                 "status": "failed", "error": error}] + [
            {"record": path, "drive": drive, "time": when, "command": command, "status": "failed", "error": error}
            for path, when in groups[drive]
        ]  # fmt: skip

    _store_as_completed(
        dict(zip(futures, todo, strict=True)),
        lost,
        store,
        run,
        progress,
        csv_every,
        "drive",
        client,
        task_timeout,
    )
    run.seconds = time.perf_counter() - start
    return run


def run(
    records: Sequence[str | os.PathLike[str]] | str | os.PathLike[str],
    out: str | os.PathLike[str],
    job: Job,
    *,
    read: RecordOptions | None = None,
    per_drive: bool = False,
    pattern: str | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    figures: bool = True,
    retry_failed: bool = False,
    wait: bool = False,
    lock: bool = True,
    progress: bool = False,
    task_timeout: float = TASK_TIMEOUT,
    **record_fields: Any,
) -> FleetRun:
    """Run ``job`` on a fleet's records on Dask, the results in the folder ``out``: ``motorid fleet``
    from Python.

    Parameters
    ----------
    records : path or sequence of paths
        Record files, globs, folders or ``@list`` files (:func:`~motorid.fleet.sources.find_records`).
    out : path
        The run folder: ``results.parquet/``, ``results.csv`` (:mod:`motorid.fleet.results`) and,
        with ``figures``, the figures under ``<drive>/<record>/`` (per drive: ``<drive>/``).
    job : DoctorJob or IdentifyJob
        What is computed (:mod:`motorid.fleet.jobs`).
    read : RecordOptions, optional
        How each record is read (default: columns ``t``, ``u``, ``y``, the whole record, at most
        :data:`~motorid.io.records.options.COMMAND_MAX_SAMPLES` rows held whole, as the command line's
        ``--max-samples``).
    per_drive : bool
        The doctor once per drive on all its records as one model (:func:`run_fleet_per_drive`;
        a ``DoctorJob`` only): one row per drive, one per record with its gaps.
    pattern : str, optional
        Drive and time from the file name (:class:`~motorid.fleet.sources.FilenamePattern`).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://HOST:8786``) the tasks run on, when no
        ``client`` is given.
    workers : int, optional
        Processes of the LocalCluster started when neither ``client`` nor ``scheduler`` is
        given (default: the machine's cores; :func:`fleet_client`).
    client : dask.distributed.Client, optional
        A client the tasks run on, which comes first (and is not closed).
    figures : bool
        Write each record's (or drive's) figures into ``out``.
    retry_failed : bool
        Rerun the records (per drive: the drives) whose row says failed.
    wait : bool
        Wait for the folder's lock when another run holds it (default: refuse the run).
    lock : bool
        Take the folder's lock for the run (:class:`motorid.outputs.FolderLock`); False when the
        caller holds it.
    progress : bool
        A progress bar on stderr.
    task_timeout : float
        Longest a record's (per drive: a drive's) task may run on its worker [s] (default
        :data:`TASK_TIMEOUT`, 600 s): then its row is a failure saying so, the worker is dropped
        and the run goes on.
    **record_fields :
        Fields of :class:`~motorid.io.records.RecordOptions` given one by one (``input="pwm"``,
        ``input_unit="%"``), in place of those of ``read``.

    Call it from a script under ``if __name__ == "__main__":``: the LocalCluster's worker
    processes import the script again (a script without it is told so in one line).

    A run stopped and started again does only what is missing (a record, or per drive a
    drive, whose row is not in the results). One folder holds one kind of run: a per-drive run
    into a folder of per-record rows (or the other way round) is refused.
    """
    from motorid.fleet.jobs import DoctorJob, DriveTask, RecordOptions, RecordTask
    from motorid.fleet.sources import FilenamePattern, find_records
    from motorid.outputs import FolderLock

    if _importing_the_script_in_a_worker():
        raise RuntimeError(
            f"motorid.fleet.run called while a Dask worker process imports the main script: put the code "
            f"that runs the fleet under {MAIN_GUARD}"
        )
    if not (task_timeout > 0):
        raise DataError(f"task_timeout must be a positive time [s], got {task_timeout!r}")
    read = RecordOptions.of(read or RecordOptions(max_samples=COMMAND_MAX_SAMPLES), **record_fields)
    if per_drive and not isinstance(job, DoctorJob):
        raise DataError(f"per_drive: the doctor runs per drive (a DoctorJob), got a {type(job).__name__}")
    items = [records] if isinstance(records, str | os.PathLike) else list(records)
    paths = find_records([os.fspath(item) for item in items])
    given = {}
    if pattern:
        parse = FilenamePattern(pattern)
        given = {os.path.abspath(p): parse.parse(p) for p in paths}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    held = FolderLock(out, wait=wait).acquire() if lock else None
    try:
        store = ResultsStore(out)
        check_run_kind(store, per_drive)
        figure_folder = out.resolve() if figures else None
        if per_drive:
            task: Any = DriveTask(job, read, figure_folder)
        else:
            task = RecordTask(job, read, figure_folder)
        if not per_drive and not pending_records(paths, store, retry_failed):  # every record done: no cluster
            return FleetRun(records=len(paths), skipped=len(paths), done=0, failed=0, seconds=0.0)
        if per_drive:  # every record's drive known, every drive done: no cluster either
            known = known_identities(store, per_drive_command(job))
            if all(path in known or "drive" in given.get(path, {}) for path in map(os.path.abspath, paths)):
                groups, _ = group_by_drive(paths, read, None, given, known)
                members = {drive: [path for path, _ in group] for drive, group in groups.items()}
                if not pending_drives(members, store, retry_failed):
                    return FleetRun(records=len(paths), skipped=len(groups), done=0, failed=0, seconds=0.0,
                                    drives=len(groups))  # fmt: skip
        with contextlib.ExitStack() as stack:
            if client is None:
                client = stack.enter_context(fleet_client(scheduler, workers))
            if per_drive:
                return run_fleet_per_drive(paths, task, out, client, read, given=given, retry_failed=retry_failed,
                                           progress=progress, task_timeout=task_timeout)  # fmt: skip
            return run_fleet(
                paths, task, out, client, given=given, retry_failed=retry_failed, progress=progress,
                task_timeout=task_timeout,
            )  # fmt: skip
    finally:
        if held is not None:
            held.release()


def check_run_kind(out: str | os.PathLike[str] | ResultsStore, per_drive: bool) -> None:
    """Refuse (DataError) a per-drive run into a folder of per-record rows, and the other way round.

    Parameters
    ----------
    out : path or ResultsStore
        The run folder, or its results; an empty one takes either kind.
    per_drive : bool
        Whether the run is per drive (:func:`run_fleet_per_drive`).
    """
    store = out if isinstance(out, ResultsStore) else ResultsStore(out)
    rows = store.rows()
    if not len(rows):
        return
    per_drive_rows = rows["record"].astype(str).str.startswith(DRIVE_KEY_PREFIX).any()
    if per_drive_rows != per_drive:
        held, asked = ("per drive", "per record") if per_drive_rows else ("per record", "per drive")
        raise DataError(
            f"out={str(store.folder)!r}: holds the results of a run {held}; a run {asked} needs a folder of its own"
        )


@contextlib.contextmanager
def _saying_what_is_kept(run: FleetRun, store: ResultsStore) -> Iterator[None]:
    """Add to a write's OutputError (a full disk) the rows the run has stored."""
    try:
        yield
    except OutputError as exc:
        raise OutputError(
            f"{exc}; the {run.done + run.failed} rows of this run stored so far are in {store.parts}/ "
            "(a rerun once there is room does the rest)"
        ) from None


__all__ = [
    "TASK_TIMEOUT",
    "FleetRun",
    "Task",
    "check_run_kind",
    "fleet_client",
    "group_by_drive",
    "known_identities",
    "pending_drives",
    "pending_records",
    "record_identity",
    "run",
    "run_fleet",
    "run_fleet_per_drive",
]
