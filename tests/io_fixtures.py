"""Shared pieces of the io tests: a small test plant, free ports, a third-party
(pyModbusTCP) PLC stand-in, a serial line made by socat."""

from __future__ import annotations

import contextlib
import math
import shutil
import socket
import subprocess
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from motorid.io import RegisterMap


class FirstOrderPlant:
    """A first-order speed response with measurement noise (stand-in for the rig).

    ``omega[k+1] = a omega[k] + (1 - a) K u[k]``, ``a = exp(-dt / tau)``, measured
    with Gaussian noise of standard deviation ``noise`` [rad/s].
    """

    def __init__(self, dt: float = 0.04, tau: float = 0.3, gain: float = 10.0, noise: float = 0.01) -> None:
        self.dt, self.tau, self.gain, self.noise = dt, tau, gain, noise
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self.omega = 0.0

    def step(self, u: float) -> float:
        a = math.exp(-self.dt / self.tau)
        self.omega = a * self.omega + (1.0 - a) * self.gain * u
        return self.omega + self.noise * self.rng.standard_normal()

    @property
    def state(self) -> dict[str, float]:
        return {"omega": self.omega}


def make_plant() -> object:
    """The paper's rig when motorid.drive provides it, else the first-order stand-in."""
    try:
        from motorid.drive import paper_rig
    except ImportError:
        return FirstOrderPlant()
    return paper_rig()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(condition: Callable[[], bool], timeout: float = 20.0, what: str = "") -> None:
    """Poll ``condition`` until true; fail the test (not a timing check) after ``timeout``."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"gave up waiting for {what or condition} after {timeout} s")
        time.sleep(0.005)


def start_rig_process(port: int, *options: str) -> subprocess.Popen:
    """A real ``python -m motorid.cli -v rig serve --port PORT OPTIONS...`` process, returned once
    it listens on 127.0.0.1:PORT (its stderr piped; the test fails if it exits first)."""
    import sys

    argv = ["-m", "motorid.cli", "-v", "rig", "serve", "--port", str(port), *options]
    proc = subprocess.Popen([sys.executable, *argv], stderr=subprocess.PIPE, text=True)

    def listening() -> bool:
        if proc.poll() is not None:
            pytest.fail(f"rig server process exited: {proc.stderr.read()}")
        with socket.socket() as s:
            return s.connect_ex(("127.0.0.1", port)) == 0

    wait_for(listening, timeout=60, what="the rig server process to listen")
    return proc


class PlcDataHandler:
    """Factory of a pyModbusTCP data handler that acts as a small lock-step PLC.

    Written only against pyModbusTCP's public API: a write that changes the
    heartbeat steps the plant with the voltage in the registers and publishes
    speed and sequence, as our rig server does, so ModbusDAQ can run against an
    implementation we did not write.
    """

    @staticmethod
    def build(plant: FirstOrderPlant, register_map: RegisterMap) -> object:
        from pyModbusTCP.server import DataHandler

        m = register_map

        class _Handler(DataHandler):
            heartbeat: int | None = None
            seq = 0

            def write_h_regs(self, address, words_l, srv_info):
                result = super().write_h_regs(address, words_l, srv_info)
                hb = m["heartbeat"]
                if address <= hb.address < address + len(words_l):
                    beat = words_l[hb.address - address]
                    if beat != self.heartbeat:
                        self.heartbeat = beat
                        vr = m["voltage_command"]
                        words = self.data_bank.get_holding_registers(vr.address, vr.count)
                        y = plant.step(vr.decode(words))
                        self.seq += 1
                        bank = self.data_bank
                        bank.set_holding_registers(m["speed"].address, m["speed"].encode(y))
                        bank.set_holding_registers(m["sequence"].address, [self.seq & 0xFFFF])
                return result

        return _Handler()


@contextlib.contextmanager
def pymodbustcp_server(data_hdl: object | None = None) -> Iterator[tuple[object, int]]:
    """A pyModbusTCP ModbusServer on 127.0.0.1 (free port), stopped afterwards."""
    from pyModbusTCP.server import ModbusServer

    for _ in range(5):  # the free port may be taken between probe and bind
        port = free_port()
        server = ModbusServer("127.0.0.1", port, no_block=True, data_hdl=data_hdl)
        try:
            server.start()
            break
        except ModbusServer.NetworkError:
            continue
    else:
        pytest.fail("could not start a pyModbusTCP server on 127.0.0.1")
    try:
        yield server, port
    finally:
        server.stop()


@contextlib.contextmanager
def pty_pair() -> Iterator[tuple[str, str]]:
    """Two linked pseudo-terminals made by socat; skips the test when socat is absent."""
    socat = shutil.which("socat")
    if socat is None:
        pytest.skip("socat is not installed (apt-get install socat): no serial line for RTU")
    proc = subprocess.Popen(
        [socat, "-d", "-d", "pty,raw,echo=0", "pty,raw,echo=0"],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        ptys: list[str] = []
        assert proc.stderr is not None
        while len(ptys) < 2:
            line = proc.stderr.readline()
            if not line:
                pytest.fail(f"socat exited early (code {proc.poll()})")
            if "PTY is" in line:
                ptys.append(line.strip().split("PTY is ")[-1])
        yield ptys[0], ptys[1]
    finally:
        proc.terminate()
        proc.wait(10)


class SlowUpdatesARX:
    """An ARX-RLS estimator (na = nb = 2) whose updates numbered ``late(n)`` (from 1) take
    ``seconds`` longer: an estimator that misses a real-time loop's period now and then."""

    def __init__(self, seconds: float, late: Callable[[int], bool]) -> None:
        from motorid.estimators import create

        self.inner = create("arx-rls", na=2, nb=2)
        self.seconds, self.late = seconds, late
        self.updates = 0
        self.params = self.inner.params

    def predict(self, u: float) -> float:
        return self.inner.predict(u)

    def update(self, y: float) -> None:
        self.updates += 1
        if self.late(self.updates):
            time.sleep(self.seconds)
        self.inner.update(y)
        self.params = self.inner.params
