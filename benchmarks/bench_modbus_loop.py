"""A Modbus sample loop that keeps time: the largest jitter with and without the collector's measures,
and the loop time's 99th percentile with 20 other clients reading the rig.

The rig server (lock-step, the paper's rig) runs in its own process, as a PLC would. Each sample
writes the command and heartbeat, reads the sample, updates an ARX-RLS estimator and keeps the row
in a bounded deque, as ``motorid run`` does. The process holds what ``motorid control`` holds (the
command line, the doctor, pandas and SciPy imported: about 180,000 objects, whose full collection
takes 0.1-0.3 s on a busy machine) and ``--heap`` more objects.

- Jitter: the largest sample time minus the median, over ``--samples`` samples, and the longest
  garbage collection that ran inside a sample, with :class:`motorid.io.online.CollectorBetweenSamples`
  (the heap frozen, collection only between samples) against Python's default collector.
- Load: the loop time's 99th percentile while 20 pyModbusTCP clients in another process read the
  rig, 1000 reads/s together (``--rate``; 0 for as fast as it answers), against the same loop alone.
- Real time: ``run_online`` with an ARX-RLS estimator on a real-time rig server (its own process,
  the default real-time watchdog of ``motorid rig serve --realtime``, 2 s, and the client's default
  wait for an answer, 2 s) for ``--realtime-seconds`` (400 s by default; 0 to skip): whether it
  ends without a watchdog fault, and its largest time between two samples.

Usage::

    python benchmarks/bench_modbus_loop.py [--samples 10000] [--heap 0] [--clients 20] [--rate 1000]
                                           [--realtime-seconds 400]
"""

from __future__ import annotations

import argparse
import contextlib
import math
import multiprocessing as mp
import sys
import threading
import time
from collections import deque

import numpy as np
from _table import Row, print_rows

TITLE = "Modbus TCP sample loop on 127.0.0.1: garbage collection and 20 other clients"


def serve(queue: mp.Queue, stop: mp.Event, realtime: bool = False) -> None:  # type: ignore[type-arg]
    """Child process: a rig server on 127.0.0.1, free port, until ``stop``: lock-step without a
    watchdog, or real-time with the default real-time watchdog of ``motorid rig serve`` (2 s)."""
    from motorid.drive import paper_rig
    from motorid.io import RigServer
    from motorid.io.rig_server import REALTIME_WATCHDOG

    plant = paper_rig()
    watchdog = REALTIME_WATCHDOG / plant.simulation().dt if realtime else None
    server = RigServer(plant, port=0, seed=1, lockstep=not realtime, watchdog_periods=watchdog).start()
    queue.put(server.port)
    stop.wait()
    server.stop()


def readers(port: int, clients: int, rate: float, ready: mp.Event, stop: mp.Event, counts: mp.Queue) -> None:  # type: ignore[type-arg]
    """Child process: ``clients`` pyModbusTCP clients, one thread each, reading the rig at ``rate``
    reads/s together (0: as fast as it answers) until ``stop``."""
    from pyModbusTCP.client import ModbusClient

    done = [0] * clients

    def read(i: int) -> None:
        client = ModbusClient("127.0.0.1", port, timeout=2.0, auto_open=True)
        period = clients / rate if rate > 0 else 0.0
        due = time.monotonic()
        while not stop.is_set():
            if client.read_holding_registers(0, 8) is not None:
                done[i] += 1
            due += period
            time.sleep(max(0.0, due - time.monotonic()))
        client.close()

    threads = [threading.Thread(target=read, args=(i,), daemon=True) for i in range(clients)]
    for t in threads:
        t.start()
    ready.set()
    for t in threads:
        t.join()
    counts.put(sum(done))


def loop_times(port: int, n: int, collector: contextlib.AbstractContextManager) -> tuple[np.ndarray, float]:
    """Seconds each of ``n`` samples took (write, read, estimator update, row kept), and the longest
    garbage collection that ran inside one [s]."""
    import gc

    from motorid.estimators import create
    from motorid.io import ModbusDAQ

    inside = False
    started = longest = 0.0

    def watch(phase: str, info: dict) -> None:
        nonlocal started, longest
        if not inside:
            return
        if phase == "start":
            started = time.perf_counter()
        else:
            longest = max(longest, time.perf_counter() - started)

    est = create("arx-rls", na=2, nb=2, lam=0.99)
    u = np.random.default_rng(0).uniform(-6, 6, n)
    rows: deque[dict[str, object]] = deque(maxlen=10_000)
    times = np.empty(n)
    with ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=2.0) as daq:
        for _ in range(50):  # warm up (connection, compiled estimator code)
            daq.write(0.0)
            daq.read()
        gc.callbacks.append(watch)
        try:
            with collector as c:
                for k in range(n):
                    inside = True
                    t0 = time.perf_counter()
                    daq.write(float(u[k]))
                    s = daq.read()
                    est.predict(s.u)
                    est.update(s.y)
                    rows.append({"t": s.t, "y": s.y, "x": est.x.tolist(), "P": est.P.diagonal().tolist()})
                    times[k] = time.perf_counter() - t0
                    inside = False
                    if c is not None:
                        c.between_samples()
        finally:
            gc.callbacks.remove(watch)
    return times, longest


def realtime_run(seconds: float) -> tuple[bool, float, str]:
    """``run_online`` for ``seconds`` on a real-time rig with the default watchdog and wait for an
    answer: (ended without a fault, largest time between two samples [s], what stopped it)."""
    import tempfile

    from motorid.errors import DAQError
    from motorid.estimators import create
    from motorid.io import ModbusDAQ, run_online
    from motorid.signals import steps

    ctx = mp.get_context("spawn")
    queue, stop = ctx.Queue(), ctx.Event()
    server = ctx.Process(target=serve, args=(queue, stop, True), daemon=True)
    server.start()
    try:
        port = queue.get(timeout=60)
        _, u = steps(seconds, 0.04, seed=0)
        with tempfile.TemporaryDirectory() as tmp:
            daq = ModbusDAQ("127.0.0.1", port, dt=0.04)
            try:
                record = run_online(
                    daq, {"arx-rls": create("arx-rls", na=2, nb=2)}, u, None, out=f"{tmp}/run.csv"
                )
            except DAQError as exc:
                return False, math.nan, str(exc)
        return True, float(record.attrs["largest_interval"]), "ended"
    finally:
        stop.set()
        server.join(10)


def measure(
    samples: int = 10_000,
    heap: int = 0,
    clients: int = 20,
    rate: float = 1000.0,
    realtime_seconds: float = 400.0,
) -> list[Row]:
    import motorid.cli.control
    import motorid.diagnose

    held = (motorid.cli.control, motorid.diagnose)  # what motorid control holds
    from motorid.io.online import CollectorBetweenSamples

    live = [[i] for i in range(heap)]  # a long session's objects, all tracked by the collector
    ctx = mp.get_context("spawn")
    queue, stop = ctx.Queue(), ctx.Event()
    server = ctx.Process(target=serve, args=(queue, stop), daemon=True)
    server.start()
    try:
        port = queue.get(timeout=60)
        plain, plain_gc = loop_times(port, samples, contextlib.nullcontext())
        kept, kept_gc = loop_times(port, samples, CollectorBetweenSamples())
        ready, stop_readers, counts = ctx.Event(), ctx.Event(), ctx.Queue()
        load = ctx.Process(
            target=readers, args=(port, clients, rate, ready, stop_readers, counts), daemon=True
        )
        load.start()
        ready.wait(60)
        started = time.perf_counter()
        loaded, _ = loop_times(port, samples, CollectorBetweenSamples())
        elapsed = time.perf_counter() - started
        stop_readers.set()
        reads = counts.get(timeout=60)
        load.join(30)
    finally:
        stop.set()
        server.join(10)
    del live, held

    def jitter(t: np.ndarray) -> float:
        return float(t.max() - np.median(t)) * 1e3

    peer = "Python's default collector"
    alone = "the same loop, no other client"
    timed = []
    if realtime_seconds > 0:
        ok, largest, why = realtime_run(realtime_seconds)
        timed = [
            Row(f"{realtime_seconds:g} s real-time run at 40 ms, default watchdog (2 s): "
                + ("ended, largest interval" if ok else f"STOPPED ({why[:60]})"),
                largest * 1e3, None, "ms", "", False),
        ]  # fmt: skip
    return [
        *timed,
        Row("largest jitter (max - median)", jitter(kept), jitter(plain), "ms", peer, False),
        Row("largest sample time", float(kept.max()) * 1e3, float(plain.max()) * 1e3, "ms", peer, False),
        Row("longest collection inside a sample", kept_gc * 1e3, plain_gc * 1e3, "ms", peer, False),
        Row(f"loop time p99, {clients} clients reading ({reads / elapsed:.0f} reads/s)",
            float(np.percentile(loaded, 99)) * 1e3, float(np.percentile(kept, 99)) * 1e3, "ms", alone, False),
        Row(f"largest sample time, {clients} clients reading", float(loaded.max()) * 1e3,
            float(kept.max()) * 1e3, "ms", alone, False),
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=10_000, help="samples per measurement")
    parser.add_argument(
        "--heap", type=int, default=0, help="live objects the process holds besides its imports"
    )
    parser.add_argument("--clients", type=int, default=20, help="other clients reading the rig")
    parser.add_argument("--rate", type=float, default=1000.0, help="their reads/s together (0: unthrottled)")
    parser.add_argument("--realtime-seconds", type=float, default=400.0, help="real-time run [s] (0: skip)")
    args = parser.parse_args(argv)
    rows = measure(args.samples, args.heap, args.clients, args.rate, args.realtime_seconds)
    print_rows(rows, f"{TITLE}; {args.samples} samples each, {args.heap} more live objects")
    return 0


if __name__ == "__main__":
    sys.exit(main())
