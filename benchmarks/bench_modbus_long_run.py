"""A long run over Modbus on a loaded machine: ``motorid run`` against ``motorid rig serve --realtime``.

Three kinds of process, each started as a user would start it, on 127.0.0.1:

- the rig: ``motorid rig serve --realtime --port P --plant-seed 1`` (the paper's rig, 40 ms samples,
  the default real-time watchdog: 2 s, 50 periods, without the owner's heartbeat zero the voltage
  and latch a fault; ``--watchdog-periods`` for another);
- the load: ``--load`` processes ``python -c 'while 1: pass'``, each keeping a core busy, killed
  afterwards (7 on a 2-core machine: load average about 7 on top of whatever else runs);
- the client: ``motorid run --daq modbus://127.0.0.1:P --estimator arx-rls --signal steps --dt 0.04
  --duration S --json`` (its default wait for an answer, 2 s; ``--timeout`` for another).

Reported: whether the run ended (exit 0) or stopped and why (its one line), the largest time
between two samples the run reports (``largest_interval``) and its jitter (that minus ``dt``),
and the rig's samples the client never read (the gaps in the recorded sequence counter), with the
load average before and after. A watchdog trip during the run stops it (``run stopped: the rig ...
reports fault watchdog``): the run's line says whether the watchdog held. Not a test: a figure of the machine it
runs on.

Usage::

    python benchmarks/bench_modbus_long_run.py [--seconds 400] [--load 7] [--dt 0.04] [--watchdog-periods N]
                                               [--timeout S]
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from _table import Row, print_rows

TITLE = "motorid run over Modbus TCP against motorid rig serve --realtime, on a loaded machine"


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_rig(port: int, log: Path, watchdog_periods: float | None) -> subprocess.Popen:
    """``motorid rig serve --realtime`` on 127.0.0.1:``port`` (its stderr to ``log``), returned once it listens."""
    argv = [sys.executable, "-m", "motorid.cli", "rig", "serve", "--realtime", "--port", str(port),
            "--plant-seed", "1",
            *(["--watchdog-periods", f"{watchdog_periods:g}"] if watchdog_periods is not None else [])]  # fmt: skip
    with open(log, "w") as stderr:
        proc = subprocess.Popen(argv, stderr=stderr, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"the rig server exited: {log.read_text()}")
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return proc
        time.sleep(0.05)
    proc.kill()
    raise RuntimeError("the rig server did not listen within 120 s")


def measure(
    seconds: float = 400.0,
    load: int = 7,
    dt: float = 0.04,
    watchdog_periods: float | None = None,
    timeout: float | None = None,
) -> list[Row]:
    """Run ``motorid run`` for ``seconds`` at ``dt`` with ``load`` busy processes against a rig whose
    watchdog trips after ``watchdog_periods`` sample periods without a heartbeat (None: the rig's
    default, 2 s), waiting ``timeout`` [s] for each answer (None: run's default, 2 s); its figures as rows."""
    port = free_port()
    tmp = tempfile.TemporaryDirectory()
    rig = start_rig(port, Path(tmp.name) / "rig.log", watchdog_periods)
    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(load)]
    out = Path(tmp.name) / "run.csv"
    argv = [sys.executable, "-m", "motorid.cli", "run", "--daq", f"modbus://127.0.0.1:{port}",
            "--estimator", "arx-rls", "--signal", "steps", "--dt", str(dt), "--duration", str(seconds),
            "--out", str(out), "--quiet", "--json", *(["--timeout", f"{timeout:g}"] if timeout else [])]  # fmt: skip
    try:
        load_before = os.getloadavg()[0]
        started = time.perf_counter()
        run = subprocess.run(argv, capture_output=True, text=True, timeout=seconds * 3 + 300)
        elapsed = time.perf_counter() - started
        load_after = os.getloadavg()[0]
        rows = pd.read_csv(out, comment="#") if out.exists() else pd.DataFrame({"seq": []})
    finally:
        for proc in busy:
            proc.kill()
        for proc in busy:
            proc.wait(30)
        rig.terminate()
        try:
            rig.wait(30)
        except subprocess.TimeoutExpired:
            rig.kill()
            rig.wait()
        tmp.cleanup()
    seq = rows["seq"].to_numpy()
    missed = int(np.sum(np.diff(seq) - 1)) if seq.size > 1 else 0
    if run.returncode == 0:
        report = json.loads(run.stdout)
        largest = float(report["largest_interval"])
        what = f"ended, {report['samples']} samples in {elapsed:.0f} s"
    else:
        largest = float("nan")
        why = (run.stderr.strip().splitlines() or ["no message"])[-1]
        what = f"STOPPED after {seq.size} samples (exit {run.returncode}: {why[:100]})"
    waits = f", timeout {timeout:g} s" if timeout else ", default timeout"
    watchdog = (
        f"watchdog {watchdog_periods:g} periods" if watchdog_periods is not None else "default watchdog"
    )
    setting = f"{seconds:g} s at {dt * 1e3:g} ms, {watchdog}{waits}, {load} busy processes (load average {load_before:.1f} -> {load_after:.1f})"
    return [
        Row(f"{setting}: {what}; largest time between two samples", largest * 1e3, None, "ms", "", False),
        Row("jitter: largest time between two samples - dt", (largest - dt) * 1e3, None, "ms", "", False),
        Row("samples of the rig the client did not read", missed, None, "samples", "", False),
    ]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=400.0, help="length of the run [s] (default: 400)")
    parser.add_argument("--load", type=int, default=7, help="busy processes beside the run (default: 7)")
    parser.add_argument("--dt", type=float, default=0.04, help="sample time [s] (default: 0.04)")
    parser.add_argument("--watchdog-periods", type=float, help="the rig's watchdog (default: the rig's, 2 s)")
    parser.add_argument("--timeout", type=float, help="motorid run --timeout [s] (default: run's, 2 s)")
    args = parser.parse_args(argv)
    print_rows(measure(args.seconds, args.load, args.dt, args.watchdog_periods, args.timeout), TITLE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
