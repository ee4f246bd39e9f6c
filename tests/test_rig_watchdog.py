"""The rig server's watchdog from the first command: a client that never heart-beats gets 0 V.

A real ``motorid rig serve --realtime`` process on 127.0.0.1 and a client we did not
write (pyModbusTCP). No assertion is about speed: waits poll with a generous limit.
"""

from __future__ import annotations

from io_fixtures import free_port, start_rig_process, wait_for
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
