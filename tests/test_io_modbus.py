"""Modbus: our rig server and ModbusDAQ, against each other and against pyModbusTCP.

Every server here is real and listens on 127.0.0.1; nothing of the network is
mocked. No assertion is about elapsed time: waits poll with a generous limit.
"""

from __future__ import annotations

import math
import signal
import socket
from collections.abc import Callable, Iterator

import numpy as np
import pandas as pd
import pytest
from io_fixtures import (
    FirstOrderPlant,
    PlcDataHandler,
    free_port,
    make_plant,
    pty_pair,
    pymodbustcp_server,
    start_rig_process,
    wait_for,
)
from pyModbusTCP.client import ModbusClient
from pyModbusTCP.utils import decode_ieee, encode_ieee, long_list_to_word, word_list_to_long

from motorid import estimators
from motorid.errors import DAQConnectionError, DAQError, DAQValueError, RigFaultError
from motorid.io import (
    STATUS_BITS,
    ModbusDAQ,
    RegisterMap,
    RigServer,
    SimulatedDAQ,
    rig_map_toml,
    run_online,
)


# -- fixtures ---------------------------------------------------------------------------------
@pytest.fixture
def rig_factory() -> Iterator[Callable[..., RigServer]]:
    """Start rig servers on 127.0.0.1 (free port unless given); stop them all after the test.

    The watchdog is relaxed to 100 sample periods so a busy machine does not
    trip it; the watchdog test asks for the real setting.
    """
    servers: list[RigServer] = []

    def start(plant: object | None = None, **kw: object) -> RigServer:
        kw.setdefault("port", 0)
        kw.setdefault("seed", 7)
        kw.setdefault("watchdog_periods", 100.0)
        server = RigServer(FirstOrderPlant() if plant is None else plant, **kw)  # type: ignore[arg-type]
        servers.append(server)
        return server.start()

    yield start
    for server in servers:
        server.stop()


@pytest.fixture
def rig_server(rig_factory: Callable[..., RigServer]) -> RigServer:
    """One rig server (first-order plant, lock-step, seed 7) on 127.0.0.1."""
    return rig_factory()


def daq_for(server: RigServer, **kw: object) -> ModbusDAQ:
    """A ModbusDAQ for a rig server, with a timeout generous enough for a busy machine."""
    kw.setdefault("timeout", 2.0)
    return ModbusDAQ("127.0.0.1", server.port, dt=server.dt, register_map=server.register_map, **kw)  # type: ignore[arg-type]


def quarter_volts(n: int, seed: int = 0, amplitude: float = 6.0) -> np.ndarray:
    """Random steps in multiples of 0.25 V: exact in float32, so Modbus carries them unchanged."""
    rng = np.random.default_rng(seed)
    levels = np.round(rng.uniform(-amplitude, amplitude, n // 5 + 1) * 4) / 4
    return np.repeat(levels, 5)[:n]


class GlitchPlant(FirstOrderPlant):
    """A first-order plant whose measurement becomes ``value`` from sample ``at`` on."""

    def __init__(self, at: int, value: float) -> None:
        super().__init__()
        self.at, self.value = at, value

    def reset(self, seed: int | None = None) -> None:
        super().reset(seed)
        self.k = 0

    def step(self, u: float) -> float:
        y = super().step(u)
        self.k += 1
        return self.value if self.k >= self.at else y


# -- the fixture and the basic exchange -----------------------------------------------------
def test_rig_server_fixture_serves_then_stops(rig_server):
    assert rig_server.running and rig_server.host == "127.0.0.1"
    with daq_for(rig_server) as daq:
        daq.write(2.0)
        s = daq.read()
        assert (s.seq, s.u, s.status) == (1, 2.0, 0)
        assert rig_server.voltage == 2.0 and rig_server.seq == 1
    assert rig_server.voltage == 0.0  # close() commands 0 V
    rig_server.stop()
    assert not rig_server.running
    with pytest.raises(DAQConnectionError, match="cannot connect"):
        daq_for(rig_server).open()


def test_rig_map_toml_describes_the_served_map(rig_factory, tmp_path):
    path = tmp_path / "map.toml"
    path.write_text(rig_map_toml(word_order="CDAB"))
    server = rig_factory(register_map=path)
    assert server.register_map == RegisterMap.default("CDAB")


# -- interoperability with pyModbusTCP, both directions ----------------------------------------
@pytest.mark.parametrize("word_order", ["ABCD", "CDAB"])
def test_pymodbustcp_client_drives_our_rig_server(rig_factory, word_order):
    server = rig_factory(word_order=word_order)
    m = server.register_map
    big = word_order == "ABCD"
    client = ModbusClient("127.0.0.1", server.port, unit_id=1, timeout=5.0, auto_open=True)
    try:
        for k, volts in enumerate([2.5, -7.25, 1.0e-3], start=1):
            words = long_list_to_word([encode_ieee(volts)], big_endian=big)
            assert client.write_multiple_registers(m["voltage_command"].address, [*words, k])
            assert server.voltage == pytest.approx(volts, rel=1e-7)
            regs = client.read_holding_registers(m["status"].address, 4)
            assert regs is not None, client.last_error_as_txt
            status, seq, speed = regs[0], regs[1], decode_ieee(word_list_to_long(regs[2:], big)[0])
            assert (status, seq) == (0, k)
            assert speed == np.float32(server.speed)
        # the rig refuses writes to its measurements
        assert not client.write_single_register(m["sequence"].address, 99)
    finally:
        client.close()


@pytest.mark.parametrize("word_order", ["ABCD", "CDAB"])
def test_modbus_daq_drives_a_pymodbustcp_server(word_order):
    m = RegisterMap.default(word_order)
    plc_plant, ref_plant = FirstOrderPlant(), FirstOrderPlant()
    plc_plant.reset(seed=2)
    u = quarter_volts(40, seed=1)
    with pymodbustcp_server(PlcDataHandler.build(plc_plant, m)) as (server, port):
        daq = ModbusDAQ("127.0.0.1", port, register_map=m, dt=0.04, timeout=2.0)
        df = run_online(daq, None, u, None, progress=False)
        # what we wrote, decoded by pyModbusTCP's own helpers
        words = server.data_bank.get_holding_registers(0, 3)
        assert decode_ieee(word_list_to_long(words[:2], word_order == "ABCD")[0]) == 0.0
        assert words[2] == 41  # heartbeat: 40 samples + the closing 0 V command
    ref = run_online(SimulatedDAQ(ref_plant, seed=2), None, u, None, progress=False)
    np.testing.assert_array_equal(df["u"], u)
    np.testing.assert_array_equal(df["y"], ref["y"].astype(np.float32))
    np.testing.assert_array_equal(df["seq"], np.arange(1, 41))


# -- faults ------------------------------------------------------------------------------------------
def test_server_killed_mid_run(rig_factory, tmp_path):
    server = rig_factory()
    out = tmp_path / "killed.csv"

    def excitation(t):
        if round(t / server.dt) == 20:
            server.stop()  # the rig goes away between sample 19 and the command of sample 20
        return 3.0

    with pytest.raises(DAQConnectionError, match="link lost") as info:
        run_online(daq_for(server), None, excitation, 2.0, out=out, progress=False)
    assert any("stopped after 20 of 50 samples" in n for n in info.value.__notes__)
    df = pd.read_csv(out, comment="#")
    assert len(df) == 20 and (df["u"] == 3.0).all() and np.isfinite(df["y"]).all()
    np.testing.assert_array_equal(df["seq"], np.arange(1, 21))


def test_failure_with_link_up_commands_zero_volts(rig_factory, tmp_path):
    server = rig_factory(plant=GlitchPlant(at=15, value=math.nan))
    out = tmp_path / "nan.csv"
    with pytest.raises(RigFaultError, match="plant"):
        run_online(daq_for(server), None, np.full(50, 4.0), None, out=out, progress=False)
    assert server.voltage == 0.0
    df = pd.read_csv(out, comment="#")
    assert len(df) == 14 and np.isfinite(df["y"]).all()


def test_client_reconnects_after_server_restart(rig_factory):
    port = free_port()
    first = rig_factory(port=port)
    daq = daq_for(first).open()
    daq.write(1.0)
    assert daq.read().seq == 1
    first.stop()
    with pytest.raises(DAQConnectionError):
        daq.read()
    with pytest.raises(DAQConnectionError):  # still down: each call tries, fails fast
        daq.write(1.0)
    second = rig_factory(port=port)
    daq.write(2.0)  # reconnects
    s = daq.read()
    assert daq.reconnect_count == 1
    assert s.seq == 2 and s.u == 2.0 and second.voltage == 2.0
    daq.close()


def test_no_answer_raises_connection_error():
    with socket.socket() as silent:  # accepts connections, never answers
        silent.bind(("127.0.0.1", 0))
        silent.listen(1)
        daq = ModbusDAQ("127.0.0.1", silent.getsockname()[1], dt=0.04, timeout=0.2)
        with pytest.raises(DAQConnectionError, match=r"no answer within 0\.2 s"):
            daq.open()


def test_watchdog_zeroes_voltage_and_raises_fault_bit(rig_factory):
    server = rig_factory(watchdog_periods=3.0, lockstep=False)  # real time: the watchdog counts the clock
    m = server.register_map
    daq = daq_for(server).open()
    daq.write(5.0)
    assert daq.read().u == 5.0
    # stop sending heartbeats: the rig must take the voltage away by itself
    wait_for(lambda: server.status & STATUS_BITS["watchdog"], what="the watchdog to trip")
    assert server.voltage == 0.0 and server.watchdog_trips == 1
    client = ModbusClient("127.0.0.1", server.port, timeout=5.0)
    regs = client.read_holding_registers(0, 4)
    client.close()
    assert decode_ieee(word_list_to_long(regs[:2])[0]) == 0.0
    assert regs[m["status"].address] & STATUS_BITS["watchdog"]
    with pytest.raises(RigFaultError, match="watchdog") as info:
        daq.read()
    assert info.value.status & STATUS_BITS["watchdog"]
    daq.reset_faults()
    daq.write(0.0)
    assert daq.read().status == 0
    daq.close()


@pytest.mark.parametrize(("value", "message"), [(math.nan, "nan"), (1.0e6, "valid range")])
def test_invalid_speed_from_a_plc_is_a_clear_error(tmp_path, value, message):
    m = RegisterMap.default()
    plant = GlitchPlant(at=10, value=value)
    plant.reset(seed=0)
    out = tmp_path / "bad.csv"
    with pymodbustcp_server(PlcDataHandler.build(plant, m)) as (server, port):
        daq = ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=2.0)
        with pytest.raises(DAQValueError, match=message):
            run_online(daq, None, np.full(30, 1.0), None, out=out, progress=False)
        words = server.data_bank.get_holding_registers(0, 2)
        assert decode_ieee(word_list_to_long(words)[0]) == 0.0  # 0 V commanded on the way out
    df = pd.read_csv(out, comment="#")
    assert len(df) == 9 and np.isfinite(df["y"]).all() and (df["y"].abs() < 1e3).all()


def test_scaled_integer_speed_out_of_range_is_flagged(rig_factory):
    regs = dict(RegisterMap.default().registers)
    from dataclasses import replace

    regs["speed"] = replace(regs["speed"], type="int16", scale=0.001, min=-30.0, max=30.0)
    server = rig_factory(register_map=RegisterMap(regs))
    with daq_for(server) as daq:
        daq.write(1.0)
        assert daq.read().y == pytest.approx(server.speed, abs=1e-3)
        with pytest.raises(RigFaultError, match="plant"):  # 12 V -> 120 rad/s: cannot fit
            for _ in range(100):
                daq.write(12.0)
                daq.read()


# -- same identification through the simulated DAQ and through Modbus --------------------------------
def test_same_estimates_simulated_and_modbus(rig_factory, tmp_path):
    u = quarter_volts(200, seed=3)

    def run(daq):
        ests = {"arx-rls": estimators.create("arx-rls", na=2, nb=2, lam=0.99)}
        return run_online(daq, ests, u, None, progress=False)

    sim = run(SimulatedDAQ(make_plant(), seed=11))
    server = rig_factory(plant=make_plant(), seed=11)
    mb = run(daq_for(server))
    # the rig applies exactly the same commands; speed is carried as float32
    np.testing.assert_array_equal(mb["u"], sim["u"])
    np.testing.assert_array_equal(mb["y"], sim["y"].astype(np.float32))
    params = [c for c in sim.columns if c.startswith("arx-rls.")]
    assert len(params) >= 5
    np.testing.assert_allclose(mb[params].iloc[-1], sim[params].iloc[-1], rtol=1e-3, atol=1e-6)
    # exactly the estimates of the simulated record with its speed quantised to float32
    ref = estimators.create("arx-rls", na=2, nb=2, lam=0.99)
    ref.batch_filter(sim["u"].to_numpy(), sim["y"].to_numpy().astype(np.float32).astype(float))
    estimates = [c for c in params if c != "arx-rls.y_hat"]
    np.testing.assert_allclose(mb[estimates].iloc[-1].to_numpy(), ref.x, rtol=1e-12, atol=0)


# -- Modbus RTU over a serial line (a socat pseudo-terminal pair) ----------------------------------------
def test_rtu_over_a_serial_line():
    pytest.importorskip("serial", reason="pyserial not installed: pymodbus needs it for RTU")
    u = quarter_volts(30, seed=5)
    with pty_pair() as (rig_end, client_end):
        server = RigServer(FirstOrderPlant(), serial_port=rig_end, seed=4, watchdog_periods=None).start()
        try:
            daq = ModbusDAQ(serial_port=client_end, baudrate=115200, dt=0.04, timeout=2.0)
            assert "RTU" in daq.endpoint
            df = run_online(daq, None, u, None, progress=False)
        finally:
            server.stop()
    ref = run_online(SimulatedDAQ(FirstOrderPlant(), seed=4), None, u, None, progress=False)
    np.testing.assert_array_equal(df["y"], ref["y"].astype(np.float32))


def test_from_url():
    daq = ModbusDAQ.from_url("modbus://127.0.0.1:5020?word_order=CDAB&timeout=0.1")
    assert (daq.host, daq.port, daq.timeout) == ("127.0.0.1", 5020, 0.1)
    assert daq.register_map == RegisterMap.default("CDAB")
    rtu = ModbusDAQ.from_url("modbus-rtu:///dev/ttyUSB0?baudrate=9600")
    assert (rtu.serial_port, rtu.serial_settings["baudrate"]) == ("/dev/ttyUSB0", 9600)
    with pytest.raises(ValueError, match="scheme"):
        ModbusDAQ.from_url("http://x")


def test_realtime_rig_paces_the_client(rig_factory):
    server = rig_factory(plant=FirstOrderPlant(dt=0.01), lockstep=False)
    df = run_online(daq_for(server), None, np.full(15, 2.0), None, progress=False)
    assert len(df) == 15
    assert (np.diff(df["seq"]) >= 1).all()  # never the same sample twice
    assert df["y"].iloc[-1] > 0


def test_stale_lockstep_read_is_a_clear_error(rig_server):
    with daq_for(rig_server, timeout=0.1) as daq:
        daq.write(1.0)
        daq.read()
        with pytest.raises(DAQError, match="no new sample"):
            daq.read()  # nothing written: a lock-step rig does not advance


def test_daq_from_url(rig_server):
    from motorid.io import daq_from_url

    assert isinstance(daq_from_url("sim", plant=FirstOrderPlant(), seed=1), SimulatedDAQ)
    daq = daq_from_url(rig_server.url, dt=rig_server.dt, timeout=2.0)
    assert isinstance(daq, ModbusDAQ)
    with daq:
        daq.write(1.0)
        assert daq.read().seq == 1
    # the library names its argument (url=...), never the command line's --daq
    with pytest.raises(ValueError, match=r"^url='tcp://x': expected 'sim'"):
        daq_from_url("tcp://x")
    with pytest.raises(ValueError, match=r"^url='modbus://127\.0\.0\.1:5020': plant, seed and realtime"):
        daq_from_url("modbus://127.0.0.1:5020", seed=3)
    with pytest.raises(ValueError, match=r"^url='sim': register_map and timeout apply to a Modbus DAQ only"):
        daq_from_url("sim", timeout=1.0)


# -- a rig server in its own process: killed for real, stopped by SIGTERM ------------------------------
def test_rig_process_killed_mid_run_and_sigterm(tmp_path):
    port = free_port()
    proc = start_rig_process(port, "--plant-seed", "1", "--watchdog-periods", "0")
    out = tmp_path / "sigkill.csv"

    def excitation(t):
        if round(t / 0.04) == 20:
            proc.kill()
            proc.wait(30)
        return 2.0

    try:
        daq = ModbusDAQ("127.0.0.1", port, dt=0.04, timeout=2.0)
        with pytest.raises(DAQConnectionError):
            run_online(daq, None, excitation, 2.0, out=out, progress=False)
    finally:
        proc.kill()
        proc.wait(30)
    assert len(pd.read_csv(out, comment="#")) == 20

    proc = start_rig_process(port, "--plant-seed", "1", "--watchdog-periods", "0")
    proc.send_signal(signal.SIGTERM)
    code = proc.wait(30)
    err = proc.stderr.read()
    assert code == 0, err
    assert "stopped" in err
