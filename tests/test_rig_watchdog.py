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
    proc = start_rig_process(port, "--realtime", "--plant-seed", "1")  # the default watchdog: 3 periods
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
