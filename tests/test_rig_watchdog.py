"""The rig server's watchdog: a client that never heart-beats gets 0 V.

In real time the watchdog counts the clock from the first command; in lock-step, where the plant
waits for its client, it counts commands without a heartbeat and never the clock. A real ``motorid
rig serve`` process on 127.0.0.1 and a client we did not write (pyModbusTCP). No assertion is about
speed: waits poll with a generous limit, and the pauses are lower bounds.
"""

from __future__ import annotations

import time

from io_fixtures import SlowUpdatesARX, free_port, start_rig_process, wait_for
from pyModbusTCP.client import ModbusClient
from pyModbusTCP.utils import decode_ieee, encode_ieee, long_list_to_word, word_list_to_long

from motorid.io import STATUS_BITS, ModbusDAQ, RegisterMap, run_online

MAP = RegisterMap.default()


def applied_volts(client: ModbusClient) -> float:
    """The voltage the rig applies (its voltage register reads back the applied command) [V]."""
    words = client.read_holding_registers(MAP["voltage_command"].address, 2)
    assert words is not None, client.last_error_as_txt
    return decode_ieee(word_list_to_long(words)[0])


def status(client: ModbusClient) -> int:
    words = client.read_holding_registers(MAP["status"].address, 1)
    assert words is not None, client.last_error_as_txt
    return words[0]


def command(client: ModbusClient, volts: float) -> None:
    """Write a voltage command only: no heartbeat."""
    assert client.write_multiple_registers(
        MAP["voltage_command"].address, long_list_to_word([encode_ieee(volts)])
    ), client.last_error_as_txt


def test_a_command_without_heartbeat_is_zeroed_also_after_a_cleared_fault():
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1", "--watchdog-periods", "3")
    client = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    try:
        command(client, 10.0)
        # the rig takes the voltage away by itself (40 ms periods: 0.12 s; the bound is for a busy machine)
        wait_for(lambda: applied_volts(client) == 0.0, timeout=20, what="the watchdog to zero a 10 V command")
        assert status(client) & STATUS_BITS["watchdog"]

        assert client.write_single_register(MAP["status"].address, 0)  # acknowledge the fault
        assert not status(client) & STATUS_BITS["watchdog"]
        command(client, 9.0)
        wait_for(
            lambda: applied_volts(client) == 0.0 and status(client) & STATUS_BITS["watchdog"],
            timeout=20,
            what="the watchdog to zero a 9 V command after the fault was cleared",
        )
    finally:
        client.close()
        proc.kill()
        proc.wait(30)
    assert "watchdog fault latched" in proc.stderr.read()


def test_motorid_run_heartbeats_from_its_first_command(tmp_path):
    """The package's own client keeps a real-time rig's watchdog fed the whole run."""
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1", "--watchdog-periods", "25")
    try:
        daq = ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=2.0)
        record = run_online(daq, None, [2.0] * 50, None, out=tmp_path / "run.csv", progress=False)
    finally:
        proc.kill()
        proc.wait(30)
    assert record.attrs["samples"] == 50
    assert record["u"].eq(2.0).all()


# -- lock-step: the plant waits for the client, so the watchdog counts commands, never the clock -------------
def heartbeat_and_command(client: ModbusClient, volts: float) -> None:
    """One sample of a lock-step client: the command and the next heartbeat in one request."""
    beat = (client.read_holding_registers(MAP["heartbeat"].address, 1)[0] + 1) & 0xFFFF
    words = [*long_list_to_word([encode_ieee(volts)]), beat]
    assert client.write_multiple_registers(MAP["voltage_command"].address, words), client.last_error_as_txt


def sequence(client: ModbusClient) -> int:
    words = client.read_holding_registers(MAP["sequence"].address, 1)
    assert words is not None, client.last_error_as_txt
    return words[0]


def test_a_lock_step_client_that_pauses_keeps_its_command_and_its_rig():
    """A pause of 25 sample periods (a busy machine, an estimator's slow step) is no fault: the plant
    stood still the whole time, and the next sample carries on from where it stopped."""
    port = free_port()
    proc = start_rig_process(port, "--plant-seed", "1")  # lock-step, the default watchdog: 3
    client = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    other = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    try:
        heartbeat_and_command(client, 4.0)
        assert sequence(client) == 1
        time.sleep(1.0)  # 25 periods of 40 ms
        assert status(client) == 0 and applied_volts(client) == 4.0 and sequence(client) == 1
        assert not other.write_single_register(MAP["status"].address, 0)  # still the paused client's rig
        heartbeat_and_command(client, 5.0)
        assert (status(client), applied_volts(client), sequence(client)) == (0, 5.0, 2)
    finally:
        client.close()
        other.close()
        proc.kill()
        proc.wait(30)
    assert "watchdog" not in proc.stderr.read()


def test_lock_step_commands_without_a_heartbeat_trip_the_watchdog_after_the_periods():
    """Re-writing the command is not a heartbeat: 3 commands in a row without one are held (a client
    whose map splits command and heartbeat writes the command first), the 4th trips the watchdog."""
    port = free_port()
    proc = start_rig_process(port, "--plant-seed", "1")
    client = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    other = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    try:
        heartbeat_and_command(client, 6.0)
        for volts in (6.0, 6.5, 7.0):
            command(client, volts)
            assert (status(client), applied_volts(client)) == (0, volts)
        command(client, 7.5)
        assert status(client) & STATUS_BITS["watchdog"] and applied_volts(client) == 0.0
        assert sequence(client) == 1  # no command without a heartbeat moved the plant
        assert other.write_single_register(MAP["status"].address, 0)  # the rig let its owner go
        heartbeat_and_command(other, 1.0)
        assert (status(other), applied_volts(other), sequence(other)) == (0, 1.0, 2)
    finally:
        client.close()
        other.close()
        proc.kill()
        proc.wait(30)
    assert "4 commands in a row without a heartbeat" in proc.stderr.read()


def test_a_lock_step_owner_that_disconnects_frees_the_rig_at_0_V_without_a_fault():
    port = free_port()
    proc = start_rig_process(port, "--plant-seed", "1")
    owner = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    other = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    try:
        heartbeat_and_command(owner, 3.0)
        owner.close()
        wait_for(lambda: applied_volts(other) == 0.0, what="0 V once the owner left")
        time.sleep(0.5)  # more than the periods: in lock-step nothing trips later
        assert status(other) == 0
        heartbeat_and_command(other, 2.0)
        assert applied_volts(other) == 2.0
    finally:
        other.close()
        proc.kill()
        proc.wait(30)


def test_a_slow_estimator_on_a_lock_step_rig_runs_to_the_end_with_the_default_watchdog(tmp_path):
    """The case of a notebook on a busy machine: the estimator's step outlasted 3 periods of wall time
    and the lock-step rig tripped. The rig waits for its client: the run ends with every sample its own."""
    from motorid.drive import paper_rig
    from motorid.io import RigServer

    with RigServer(paper_rig(), port=0, seed=1, watchdog_periods=3.0) as server:
        daq = ModbusDAQ("127.0.0.1", server.port, dt=server.dt, timeout=2.0)
        estimator = SlowUpdatesARX(0.5, lambda n: n in (10, 20))
        record = run_online(daq, {"arx": estimator}, [1.5] * 30, None, out=tmp_path / "run.csv")
        assert server.watchdog_trips == 0 and server.status == 0
    assert estimator.updates == 30
    assert record["seq"].tolist() == list(range(1, 31))
    assert record.attrs["largest_interval"] > 0.5  # the pauses happened, inside the run


# -- a loop that keeps time on a busy machine --------------------------------------------------------------
def paused_at(proc, sample: int, pause: float):
    """An excitation of 2 V that stops the rig server process (SIGSTOP) for ``pause`` [s] as sample
    ``sample``'s command is computed, as a busy machine's scheduler may leave it without a core."""
    import os
    import signal
    import threading

    def excitation(t: float) -> float:
        if round(t / 0.04) == sample:
            os.kill(proc.pid, signal.SIGSTOP)
            threading.Timer(pause, os.kill, (proc.pid, signal.SIGCONT)).start()
        return 2.0

    return excitation


def test_a_late_answer_is_waited_for_not_taken_for_a_lost_rig(tmp_path):
    """The rig server gets no core for 0.4 s (SIGSTOP): the client's read is answered late, and the run
    goes on with the default wait (2 s); a wait of 2.5 periods (0.1 s, the former default) stops it."""
    import pytest

    from motorid.errors import DAQConnectionError
    from motorid.io.modbus import LATE_ANSWER

    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1", "--watchdog-periods", "25")
    try:
        daq = ModbusDAQ("127.0.0.1", port, dt=0.04)
        assert daq.timeout == LATE_ANSWER == 2.0
        record = run_online(daq, None, paused_at(proc, 20, 0.4), 2.0, out=tmp_path / "late.csv")
        assert record.attrs["samples"] == 50 and record["u"].eq(2.0).all()
        assert record.attrs["largest_interval"] >= 0.4  # the pause happened inside the run
        assert record["seq"].diff().max() > 1  # the rig's clock caught up after the pause: samples unread

        hasty = ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=0.1)
        with pytest.raises(DAQConnectionError, match=r"no answer within 0\.1 s"):
            run_online(hasty, None, paused_at(proc, 20, 0.4), 2.0, out=tmp_path / "hasty.csv")
    finally:
        proc.kill()
        proc.wait(30)


def test_rig_serve_freezes_its_heap_while_it_serves():
    """The process that serves the rig keeps what start-up made out of the collector's scans while it
    serves (a full collection would hold every request behind it), and gives it back when it stops."""
    import subprocess
    import sys

    script = (
        "import gc, os, signal\n"
        "from motorid.io import RigServer\n"
        "server = RigServer(port=0)\n"
        "def listening():\n"
        "    print('serving', gc.get_freeze_count(), flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "server.serve_forever(on_listening=listening)\n"
        "print('stopped', gc.get_freeze_count())\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    serving, stopped = (line.split() for line in done.stdout.splitlines())
    assert serving[0] == "serving" and int(serving[1]) > 10_000  # modules, numpy, the plant, pymodbus
    assert stopped == ["stopped", "0"]


def test_rig_serve_realtime_watchdog_defaults_to_two_seconds_of_periods():
    """The served rig shares the computer's cores with its client: its default real-time watchdog is 2 s
    (50 periods of 40 ms), twice the 1.02 s a process went without a core at most at load 7 on 2 cores."""
    port = free_port()
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1")
    client = ModbusClient("127.0.0.1", port, timeout=5.0, auto_open=True)
    try:
        command(client, 5.0)
        wait_for(lambda: status(client) & STATUS_BITS["watchdog"], timeout=20, what="the watchdog to trip")
        assert applied_volts(client) == 0.0
    finally:
        client.close()
        proc.kill()
        proc.wait(30)
    assert "more than 50 sample periods (2 s)" in proc.stderr.read()
