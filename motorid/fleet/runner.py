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
- the run itself stopped (Ctrl-C, killed): every row stored before is on disk; a
  rerun skips the records in the results (``retry_failed`` also reruns the
  failed ones).
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motorid.errors import OutputError
from motorid.fleet.results import ResultsStore
from motorid.progress import progress_bar

logger = logging.getLogger(__name__)

#: A task: (record path, what the file-name pattern gave) -> the record's row.
Task = Callable[[str, dict[str, Any]], dict[str, Any]]


@contextlib.contextmanager
def fleet_client(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A ``dask.distributed.Client``: on ``scheduler`` (``tcp://HOST:8786``) or a LocalCluster.

    The LocalCluster has ``workers`` processes (default: the machine's cores), one thread
    each, and no dashboard; it is closed on exit, as is the client.
    """
    # the cluster's own log (start and stop, a worker lost and its tasks rerun) at the level the caller
    # gave the "distributed" logger (motorid's command line: critical only, all with -v); dask resets
    # the levels on import and as it starts, so they are set again once it runs
    level = logging.getLogger("distributed").getEffectiveLevel()
    from dask.distributed import Client, LocalCluster

    def keep_level() -> None:
        for name in list(logging.root.manager.loggerDict):
            if name.startswith("distributed."):
                logging.getLogger(name).setLevel(logging.NOTSET)
        logging.getLogger("distributed").setLevel(level)

    keep_level()
    if scheduler is not None:
        with Client(scheduler) as client:
            keep_level()
            yield client
        return
    n = workers or os.cpu_count() or 1
    with (
        LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # the scheduler's HTTP endpoints on a free loopback port: its default, 8787, is taken by
            # a second fleet run and would warn
            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
            silence_logs=level,
        ) as cluster,
        Client(cluster) as client,
    ):
        keep_level()
        yield client


def pending_records(
    paths: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str] | ResultsStore,
    retry_failed: bool = False,
) -> list[str]:
    """The absolute paths of ``paths`` that have no row in ``out``'s results (with ``retry_failed``,
    no successful row): what a run has to do."""
    store = out if isinstance(out, ResultsStore) else ResultsStore(out)
    previous = store.rows()
    kept = previous if not retry_failed else previous[previous["status"] == "ok"]
    finished = set(kept["record"])
    return [path for path in map(os.path.abspath, paths) if path not in finished]


@dataclass
class FleetRun:
    """Counts of a run: records found, skipped (already in the results), done, failed; wall time [s]."""

    records: int
    skipped: int
    done: int
    failed: int
    seconds: float


def run_fleet(
    paths: Sequence[str | os.PathLike[str]],
    task: Task,
    out: str | os.PathLike[str],
    client: Any,
    given: dict[str, dict[str, Any]] | None = None,
    retry_failed: bool = False,
    progress: bool = False,
    csv_every: float = 5.0,
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
    """
    from dask.distributed import as_completed

    start = time.perf_counter()
    store = ResultsStore(out)
    records = [os.path.abspath(p) for p in paths]
    todo = pending_records(records, store, retry_failed)
    given = given or {}
    run = FleetRun(records=len(records), skipped=len(records) - len(todo), done=0, failed=0, seconds=0.0)
    logger.info("%d records, %d already in %s, %d to run", run.records, run.skipped, out, len(todo))
    bar = progress_bar(show=progress, total=len(todo), desc="fleet", unit="record")
    bar.set_postfix(done=0, failed=0)
    futures = client.map(task, todo, [given.get(p, {}) for p in todo], pure=False)
    path_of = {future.key: path for future, path in zip(futures, todo, strict=True)}
    last_csv = time.monotonic()
    try:
        for batch in as_completed(futures, with_results=True, raise_errors=False).batches():
            rows = []
            for future, result in batch:
                if (
                    future.status == "error"
                ):  # not the record's own error (the task catches that): a lost worker
                    exc = future.exception()
                    path = path_of[future.key]
                    drive = given.get(path, {}).get("drive", Path(path).stem)
                    when = given.get(path, {}).get("time")
                    result = {"record": path, "drive": drive, "time": when.isoformat() if when else None,
                              "status": "failed", "error": f"{type(exc).__name__}: {exc}"}  # fmt: skip
                rows.append(result)
                future.release()
            with _saying_what_is_kept(run, store):
                store.append(rows)
            failed = sum(row["status"] != "ok" for row in rows)
            run.done += len(rows) - failed
            run.failed += failed
            bar.update(len(rows))
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
    run.seconds = time.perf_counter() - start
    return run


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


__all__ = ["FleetRun", "Task", "fleet_client", "pending_records", "run_fleet"]
