"""Closed-loop samples per second over loopback Modbus TCP.

Each loop iteration is one sample of online identification: write the
command (voltage + heartbeat), read the sample (status, sequence, speed),
and update an estimator. The rig server (lock-step, the paper's rig) runs in
a separate process, as a PLC would, so client and server do not share a
GIL. Rows: samples/s, the median and 99th percentile loop time, each beside
the same exchange made by a bare pyModbusTCP client (a peer implementation,
no estimator, no checks) on the same server; and the whole ``run_online``
loop with its CSV recording.

Usage::

    python benchmarks/bench_modbus.py [--samples 5000] [--estimator hammerstein-rls]

Target: >= 500 samples/s.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import sys
import time

import numpy as np
from _table import Row, print_rows

TARGET = 500.0
TITLE = "Closed-loop Modbus TCP on 127.0.0.1, rig server (lock-step) in its own process"


def serve(queue: mp.Queue, stop: mp.Event) -> None:  # type: ignore[type-arg]
    """Child process: a lock-step rig server on 127.0.0.1, free port, until ``stop``."""
    from motorid.io import RigServer

    try:
        from motorid.drive import paper_rig

        plant = paper_rig()
    except ImportError:  # the drive models not available: a first-order stand-in
        plant = None
    if plant is None:
        sys.path.insert(0, "tests")
        from io_fixtures import FirstOrderPlant

        plant = FirstOrderPlant()
    server = RigServer(plant, port=0, seed=1, watchdog_periods=None).start()
    queue.put(server.port)
    stop.wait()
    server.stop()


def bench_motorid(port: int, n: int, estimator: str) -> tuple[float, np.ndarray]:
    from motorid.estimators import create
    from motorid.io import ModbusDAQ

    kw = {"na": 2, "nb": 2, "lam": 0.99}
    if estimator == "hammerstein-rls":
        kw["degree"] = 3
    est = create(estimator, **kw)
    u = np.random.default_rng(0).uniform(-6, 6, n)
    loop = np.empty(n)
    with ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=1.0) as daq:
        for _ in range(50):  # warm up (connection, compiled estimator code)
            daq.write(0.0)
            daq.read()
        t_start = time.perf_counter()
        for k in range(n):
            t0 = time.perf_counter()
            daq.write(u[k])
            s = daq.read()
            est.predict(s.u)
            est.update(s.y)
            loop[k] = time.perf_counter() - t0
        total = time.perf_counter() - t_start
    return total, loop


def bench_run_online(port: int, n: int, estimator: str) -> float:
    """Whole online loop: run_online with CSV recording (flushed every sample)."""
    import tempfile

    from motorid.estimators import create
    from motorid.io import ModbusDAQ, run_online

    kw = {"na": 2, "nb": 2, "lam": 0.99}
    if estimator == "hammerstein-rls":
        kw["degree"] = 3
    u = np.random.default_rng(0).uniform(-6, 6, n)
    with tempfile.TemporaryDirectory() as tmp:
        daq = ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=1.0)
        t0 = time.perf_counter()
        run_online(daq, {estimator: create(estimator, **kw)}, u, None, out=f"{tmp}/run.csv", progress=False)
        return n / (time.perf_counter() - t0)


def bench_pymodbustcp(port: int, n: int) -> tuple[float, np.ndarray]:
    from pyModbusTCP.client import ModbusClient
    from pyModbusTCP.utils import decode_ieee, encode_ieee, long_list_to_word, word_list_to_long

    client = ModbusClient("127.0.0.1", port, timeout=1.0, auto_open=True)
    u = np.random.default_rng(0).uniform(-6, 6, n)
    loop = np.empty(n)
    hb = 0
    for _ in range(50):
        hb += 1
        client.write_multiple_registers(0, [*long_list_to_word([encode_ieee(0.0)]), hb])
        client.read_holding_registers(3, 4)
    t_start = time.perf_counter()
    for k in range(n):
        t0 = time.perf_counter()
        hb = (hb + 1) & 0xFFFF
        client.write_multiple_registers(0, [*long_list_to_word([encode_ieee(float(u[k]))]), hb])
        regs = client.read_holding_registers(3, 4)
        decode_ieee(word_list_to_long(regs[2:])[0])
        loop[k] = time.perf_counter() - t0
    total = time.perf_counter() - t_start
    client.close()
    return total, loop


def measure(samples: int = 5000, estimator: str = "hammerstein-rls") -> list[Row]:
    """Start the rig server process, measure ours and the peer on it, stop it."""
    ctx = mp.get_context("spawn")
    queue, stop = ctx.Queue(), ctx.Event()
    proc = ctx.Process(target=serve, args=(queue, stop), daemon=True)
    proc.start()
    try:
        port = queue.get(timeout=60)
        ours_total, ours_loop = bench_motorid(port, samples, estimator)
        online_rate = bench_run_online(port, samples, estimator)
        peer_total, peer_loop = bench_pymodbustcp(port, samples)
    finally:
        stop.set()
        proc.join(10)
    peer = "pyModbusTCP client, no estimator"
    return [
        Row(f"Modbus TCP loop + {estimator}", samples / ours_total, samples / peer_total, "samples/s", peer, True),
        Row("Modbus TCP loop time, median", float(np.median(ours_loop)) * 1e3,
            float(np.median(peer_loop)) * 1e3, "ms", peer, False),
        Row("Modbus TCP loop time, p99", float(np.percentile(ours_loop, 99)) * 1e3,
            float(np.percentile(peer_loop, 99)) * 1e3, "ms", peer, False),
        Row("run_online over Modbus, CSV flushed each sample", online_rate, None, "samples/s", "", True),
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=5000, help="samples per measurement")
    parser.add_argument("--estimator", default="hammerstein-rls", choices=["arx-rls", "hammerstein-rls"])
    args = parser.parse_args(argv)
    rows = measure(args.samples, args.estimator)
    print_rows(rows, f"{TITLE}; {args.samples} samples each")
    ours = rows[0].ours
    verdict = "meets" if ours >= TARGET else "MISSES"
    print(f"target >= {TARGET:.0f} samples/s: {verdict} ({ours:.0f} samples/s)")
    return 0 if ours >= TARGET else 1


if __name__ == "__main__":
    sys.exit(main())
