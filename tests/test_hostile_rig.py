"""The rig server against odd frames and two clients: a fixed register image, one owner, one watchdog rule.

Real servers on 127.0.0.1 (a ``RigServer`` thread, or a ``motorid rig serve --realtime`` process)
and a client we did not write (pyModbusTCP). No assertion is about speed: waits poll with a
generous limit.
"""

from __future__ import annotations

import logging
import socket
import struct
import subprocess
import sys
import threading
import time

import pytest
from io_fixtures import free_port, start_rig_process, wait_for
from pyModbusTCP.client import ModbusClient
from pyModbusTCP.utils import decode_ieee, encode_ieee, long_list_to_word, word_list_to_long

from motorid.drive import paper_rig
from motorid.errors import RigBusyError
from motorid.io import STATUS_BITS, ModbusDAQ, RegisterMap, RigServer, run_online

MAP = RegisterMap.default()
SPAN = MAP.span  # (first address, registers)
BUSY, ILLEGAL_FUNCTION, ILLEGAL_ADDRESS, NO_TARGET = 6, 1, 2, 11


def client_for(port: int, unit_id: int = 1) -> ModbusClient:
    return ModbusClient("127.0.0.1", port, unit_id=unit_id, timeout=5.0, auto_open=True)


def image(client: ModbusClient) -> list[int]:
    """Every register of the map, read in one request."""
    words = client.read_holding_registers(*SPAN)
    assert words is not None, client.last_error_as_txt
    return words


def applied_volts(client: ModbusClient) -> float:
    """The voltage the rig applies (its voltage register reads back the applied command) [V]."""
    words = client.read_holding_registers(MAP["voltage_command"].address, 2)
    assert words is not None, client.last_error_as_txt
    return decode_ieee(word_list_to_long(words)[0])


def register(client: ModbusClient, name: str) -> int:
    words = client.read_holding_registers(MAP[name].address, 1)
    assert words is not None, client.last_error_as_txt
    return words[0]


def command(client: ModbusClient, volts: float, heartbeat: int | None = None) -> bool:
    """Write a voltage command (and a heartbeat in the same request when given)."""
    words = long_list_to_word([encode_ieee(volts)])
    return client.write_multiple_registers(
        MAP["voltage_command"].address, words + ([] if heartbeat is None else [heartbeat])
    )


def heartbeat(client: ModbusClient, value: int) -> bool:
    return client.write_single_register(MAP["heartbeat"].address, value & 0xFFFF)


def raw_request(port: int, unit: int, pdu: bytes) -> bytes:
    """One Modbus TCP frame (MBAP header + ``pdu``) sent on a fresh socket; the answer's PDU."""
    with socket.create_connection(("127.0.0.1", port), timeout=5.0) as s:
        s.sendall(struct.pack(">HHHB", 7, 0, len(pdu) + 1, unit) + pdu)
        header = s.recv(7)
        length = struct.unpack(">H", header[4:6])[0]
        body = b""
        while len(body) < length - 1:
            body += s.recv(length - 1 - len(body))
        return body


@pytest.fixture
def rig():
    with RigServer(paper_rig(), port=0, seed=1, watchdog_periods=None) as server:
        yield server


# -- a fixed register image ------------------------------------------------------------------------
def test_write_multiple_coils_is_refused_and_changes_nothing(rig):
    client = client_for(rig.port)
    try:
        assert command(client, 1.5, heartbeat=1)
        before = image(client)
        for _ in range(200):
            assert client.write_multiple_coils(0, [True] * 960) is False
            assert client.last_except == ILLEGAL_FUNCTION
        assert image(client) == before
        assert len(rig._words) == SPAN[1]
        assert applied_volts(client) == pytest.approx(1.5)
    finally:
        client.close()


@pytest.mark.parametrize(
    ("pdu", "expected"),
    [
        (struct.pack(">BHH", 1, 0, 16), ILLEGAL_FUNCTION),  # read coils
        (struct.pack(">BHH", 2, 0, 16), ILLEGAL_FUNCTION),  # read discrete inputs
        (struct.pack(">BHH", 4, 0, 2), ILLEGAL_FUNCTION),  # read input registers
        (struct.pack(">BHH", 5, 0, 0xFF00), ILLEGAL_FUNCTION),  # write single coil
        (struct.pack(">BHHH", 22, 0, 0x0000, 0xFFFF), ILLEGAL_FUNCTION),  # mask write register
        (struct.pack(">BHH", 8, 1, 0), ILLEGAL_FUNCTION),  # diagnostics: restart communications
        (struct.pack(">BHH", 8, 4, 0), ILLEGAL_FUNCTION),  # diagnostics: force listen-only mode
        (struct.pack(">BH", 24, 0), ILLEGAL_FUNCTION),  # read FIFO queue
        (bytes([43, 14, 1, 0]), ILLEGAL_FUNCTION),  # read device identification
        (bytes([17]), ILLEGAL_FUNCTION),  # report server id
        (struct.pack(">BHHBHH", 16, 100, 2, 4, 1, 2), ILLEGAL_ADDRESS),  # write outside the map
        (struct.pack(">BHH", 6, MAP["sequence"].address, 9), ILLEGAL_ADDRESS),  # a read-only register
        (struct.pack(">BHH", 3, 0, 20), ILLEGAL_ADDRESS),  # read past the map
    ],
)
def test_other_function_codes_and_addresses_answer_an_exception_and_change_nothing(rig, pdu, expected):
    client = client_for(rig.port)
    try:
        assert command(client, 2.0, heartbeat=1)
        before = image(client)
        answer = raw_request(rig.port, 1, pdu)
        assert answer == bytes([pdu[0] | 0x80, expected])
        assert image(client) == before
        assert len(rig._words) == SPAN[1]
        assert client.write_single_register(MAP["heartbeat"].address, 2)  # still served as before
    finally:
        client.close()


def test_an_unknown_unit_id_is_answered_without_a_traceback(rig, caplog):
    caplog.set_level(logging.DEBUG)
    stranger = client_for(rig.port, unit_id=7)
    try:
        for _ in range(50):
            assert stranger.read_holding_registers(0, 2) is None
            assert stranger.last_except == NO_TARGET
        assert raw_request(rig.port, 0, struct.pack(">BHH", 3, 0, 2)) == bytes([0x83, NO_TARGET])
    finally:
        stranger.close()
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
    assert "Traceback" not in caplog.text
    assert "request for device id 7 refused" in caplog.text
    assert image(client_for(rig.port)) is not None  # the rig's own id is served


# -- one owner ----------------------------------------------------------------------------------------
class Owner(threading.Thread):
    """A pyModbusTCP client that commands ``volts`` with a heartbeat every 20 ms until stopped."""

    def __init__(self, port: int, volts: float) -> None:
        super().__init__(daemon=True)
        self.client = client_for(port)
        self.volts = volts
        self.halt = threading.Event()
        self.beats = 0
        self.failures: list[str] = []

    def run(self) -> None:
        k = register(self.client, "heartbeat")
        while not self.halt.is_set():
            k += 1
            if not command(self.client, self.volts, heartbeat=k & 0xFFFF):
                self.failures.append(self.client.last_error_as_txt)
            self.beats += 1
            time.sleep(0.02)

    def stop(self, disconnect: bool = True) -> None:
        self.halt.set()
        self.join(30)
        if disconnect:
            self.client.close()


def test_a_second_client_is_refused_and_counted_while_the_first_owns_the_rig():
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1")
    owner = Owner(port, 2.0)
    other = client_for(port)
    try:
        owner.start()
        wait_for(
            lambda: owner.beats > 3 and applied_volts(other) == pytest.approx(2.0), what="the owner's 2 V"
        )
        for k in range(5):
            assert command(other, -6.0, heartbeat=1000 + k) is False
            assert other.last_except == BUSY
        assert other.write_single_register(MAP["status"].address, 0) is False  # no acknowledgement either
        assert other.last_except == BUSY
        assert register(other, "refused_writes") == 6
        assert applied_volts(other) == pytest.approx(2.0)
        assert not owner.failures
    finally:
        owner.stop()
        other.close()
        proc.kill()
        proc.wait(30)


def test_a_rig_freed_by_its_owner_disconnecting_goes_to_0_V_and_takes_the_next_client():
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1")
    owner = Owner(port, 3.0)
    other = client_for(port)
    try:
        owner.start()
        wait_for(lambda: applied_volts(other) == pytest.approx(3.0), what="the owner's 3 V")
        owner.stop(disconnect=True)
        wait_for(lambda: applied_volts(other) == 0.0, what="0 V once the owner left")
        wait_for(lambda: register(other, "status") & STATUS_BITS["watchdog"], what="the watchdog's fault")
        assert other.write_single_register(MAP["status"].address, 0)  # the rig is free: acknowledged
        assert command(other, 1.0, heartbeat=register(other, "heartbeat") + 1)
        assert applied_volts(other) == pytest.approx(1.0)
    finally:
        other.close()
        proc.kill()
        proc.wait(30)


def test_motorid_run_on_a_rig_another_client_owns_stops_with_one_clear_line(tmp_path, capsys):
    from cli_fixtures import run

    with RigServer(paper_rig(), port=0, seed=1, lockstep=False) as server:
        owner = Owner(server.port, 1.0)
        owner.start()
        try:
            wait_for(lambda: owner.beats > 3, what="the first client to own the rig")
            out = tmp_path / "run.csv"
            argv = ("run", "--daq", server.url, "--estimator", "arx-rls", "--duration", "1", "--out", str(out),
                    "--timeout", "2")  # fmt: skip
            code, _, err = run(capsys, *argv)
        finally:
            owner.stop()
    assert code == 2
    last = err.strip().splitlines()[-1].split("\r")[-1]
    assert last.startswith(
        f"motorid run: error: run stopped: the rig at {server.url} is owned by another client"
    )
    assert "start motorid run again" in last and "reset_faults" not in err
    assert not out.exists() or len(out.read_text().splitlines()) <= 2  # the attribute line and the header


def test_the_client_refused_raises_rig_busy_error():
    with RigServer(paper_rig(), port=0, seed=1) as server:
        owner = client_for(server.port)
        try:
            assert command(owner, 0.5, heartbeat=1)
            daq = ModbusDAQ("127.0.0.1", server.port, dt=server.dt, timeout=2.0, clear_faults_on_open=False)
            daq.open()
            try:
                with pytest.raises(RigBusyError, match="another client owns it"):
                    daq.write(1.0)
            finally:
                daq.close()
            assert server.refused_writes == 2  # the command, and the 0 V of the close
        finally:
            owner.close()


# -- one watchdog rule --------------------------------------------------------------------------------
def test_rewriting_a_command_is_not_a_heartbeat():
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1", "--watchdog-periods", "3")
    client = client_for(port)
    try:
        speeds_at_6_v = 0
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline:  # 6 V every 60 ms and never a heartbeat
            assert command(client, 6.0)
            speeds_at_6_v += applied_volts(client) == pytest.approx(6.0)
            time.sleep(0.06)
        assert register(client, "status") & STATUS_BITS["watchdog"]
        assert applied_volts(client) == 0.0
        assert speeds_at_6_v < 25  # the first reads of 3 s; the watchdog needs 3 periods of 40 ms
    finally:
        client.close()
        proc.kill()
        proc.wait(30)


def test_another_clients_heartbeat_does_not_keep_a_command():
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1")
    commander, beater = client_for(port), client_for(port)
    try:
        assert command(
            commander, 6.0, heartbeat=register(commander, "heartbeat") + 1
        )  # one heartbeat, then none
        k = 5000
        tripped = False
        deadline = time.monotonic() + 20
        while not tripped and time.monotonic() < deadline:
            k += 1
            if heartbeat(beater, k):  # taken only once the watchdog let the silent commander's rig go
                tripped = True
                break
            assert beater.last_except == BUSY
            time.sleep(0.02)
        assert register(beater, "status") & STATUS_BITS["watchdog"]
        assert tripped, "the watchdog never tripped while another client heart-beat"
        assert applied_volts(commander) == 0.0
    finally:
        commander.close()
        beater.close()
        proc.kill()
        proc.wait(30)


def test_a_heartbeat_after_the_commanding_client_left_does_not_hold_its_command():
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1")
    commander, beater = client_for(port), client_for(port)
    try:
        assert command(commander, 6.0, heartbeat=register(commander, "heartbeat") + 1)
        commander.close()  # leaves with 6 V commanded
        k = 7000
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:
            k += 1
            heartbeat(beater, k)  # refused while the commander owns the rig, the new owner's afterwards
            time.sleep(0.02)
        assert applied_volts(beater) == 0.0
    finally:
        beater.close()
        proc.kill()
        proc.wait(30)


# -- the heartbeat counts on from the rig's ----------------------------------------------------------------
@pytest.mark.parametrize("last", [1, 0xFFFF])
def test_a_run_starts_whatever_heartbeat_the_rig_last_saw(tmp_path, last):
    with RigServer(paper_rig(), port=0, seed=1) as server:
        earlier = client_for(server.port)
        assert heartbeat(earlier, last)  # a client before ours left the rig at this heartbeat
        earlier.close()
        wait_for(lambda: server._owner is None, what="the earlier client to let the rig go")
        daq = ModbusDAQ("127.0.0.1", server.port, dt=server.dt, timeout=2.0)
        record = run_online(daq, None, [1.0] * 20, None, out=tmp_path / "run.csv")
    assert record.attrs["samples"] == 20
    assert record["seq"].tolist() == list(range(1, 21))


def test_a_second_controller_on_a_lock_step_rig_is_refused_while_motorid_run_owns_it(tmp_path):
    """The case of the review: a second client writing -6 V and heartbeats during a run was obeyed."""
    port = free_port()
    proc = start_rig_process(port, "--plant-seed", "1")  # lock-step
    out = tmp_path / "run.csv"
    argv = [sys.executable, "-m", "motorid.cli", "run", "--daq", f"modbus://127.0.0.1:{port}", "--estimator",
            "arx-rls", "--signal", "steps", "--duration", "8", "--out", str(out), "--timeout", "2", "--quiet"]  # fmt: skip
    runner = subprocess.Popen(argv, cwd=tmp_path, stderr=subprocess.PIPE, text=True)
    intruder = client_for(port)
    refused = 0
    try:
        wait_for(lambda: out.exists() and out.stat().st_size > 200, timeout=120, what="the run's first rows")
        k = 40000
        while runner.poll() is None:
            k += 1
            if command(intruder, -6.0, heartbeat=k & 0xFFFF) is False:
                assert intruder.last_except == BUSY
                refused += 1
            time.sleep(0.005)
        err = runner.stderr.read()
    finally:
        intruder.close()
        runner.kill()
        proc.kill()
        proc.wait(30)
    assert runner.returncode == 0, err
    assert refused > 10
    assert "not read" not in err and "too slow" not in err
    import pandas as pd

    table = pd.read_csv(out, comment="#")
    assert len(table) == 200 and (table["u"] != -6.0).all()
    assert table["seq"].tolist() == list(range(1, 201))  # every sample the run's own: none skipped
