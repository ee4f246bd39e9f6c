"""The DAQ contract, the simulated DAQ, the register map and the online loop (no network)."""

from __future__ import annotations

import logging
import math
import signal
import threading

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st
from io_fixtures import FirstOrderPlant

from motorid import drive
from motorid.errors import DAQError
from motorid.io import Register, RegisterMap, SimulatedDAQ, rig_map_toml, run_online


class Recorder:
    """A minimal estimator: predicts the last output, records what it saw."""

    name = "echo"

    def __init__(self) -> None:
        self.u: list[float] = []
        self.y: list[float] = []
        self.last = 0.0

    def predict(self, u: float) -> float:
        self.u.append(u)
        return self.last

    def update(self, y: float) -> None:
        self.y.append(y)
        self.last = y

    @property
    def params(self) -> dict[str, object]:
        return {"gain": 2.0, "a": np.array([self.last, -self.last]), "basis": ("u", "u^3"), "s": np.eye(2)}


# -- SimulatedDAQ ------------------------------------------------------------------------
def test_simulated_daq_steps_the_plant_once_per_write():
    plant, ref = FirstOrderPlant(), FirstOrderPlant()
    ref.reset(seed=3)
    with SimulatedDAQ(plant, seed=3) as daq:
        assert daq.dt == plant.dt
        first = daq.read()
        assert (first.seq, first.t, first.y) == (0, 0.0, 0.0)
        for k, u in enumerate([1.0, -2.0, 0.5], start=1):
            daq.write(u)
            s = daq.read()
            assert s.seq == k
            assert s.t == pytest.approx(k * plant.dt)
            assert s.u == u
            assert s.y == ref.step(u)
    assert not daq.is_open


def test_simulated_daq_dt_multiple_of_plant_dt():
    with SimulatedDAQ(FirstOrderPlant(dt=0.01), dt=0.03, seed=0) as daq:
        assert daq.dt == pytest.approx(0.03)
        daq.write(1.0)
        assert daq.read().t == pytest.approx(0.03)
    with pytest.raises(ValueError, match="whole multiple"):
        SimulatedDAQ(FirstOrderPlant(dt=0.01), dt=0.025)


def test_simulated_daq_realtime_runs():
    with SimulatedDAQ(FirstOrderPlant(dt=0.002), realtime=True, seed=0) as daq:
        for _ in range(5):
            daq.write(1.0)
        assert daq.read().seq == 5


def test_clamp_is_reported_never_silent(caplog):
    daq = SimulatedDAQ(FirstOrderPlant(), seed=0, u_max=12.0).open()
    with caplog.at_level(logging.WARNING, logger="motorid.io"):
        assert daq.write(20.0) == 12.0
        s = daq.read()
        assert s.clamped and s.u == 12.0
        assert daq.write(-30.0) == -12.0
        assert daq.write(5.0) == 5.0
        assert not daq.read().clamped
    assert daq.clamp_count == 2
    assert any("clamped" in r.message for r in caplog.records)
    with pytest.raises(ValueError, match="finite"):
        daq.write(float("nan"))
    daq.close()
    with pytest.raises(DAQError, match="not open"):
        daq.write(1.0)


# -- register map ---------------------------------------------------------------------------
@given(st.floats(width=32, allow_nan=False), st.sampled_from(["ABCD", "CDAB"]))
def test_float32_register_round_trip(value, order):
    reg = Register("speed", 5, "float32", word_order=order)
    words = reg.encode(value)
    assert len(words) == 2 and all(0 <= w <= 0xFFFF for w in words)
    assert reg.decode(words) == value


def test_word_orders_are_swapped_words():
    abcd = Register("speed", 0, "float32", word_order="ABCD").encode(1.5)
    cdab = Register("speed", 0, "float32", word_order="CDAB").encode(1.5)
    assert abcd == [0x3FC0, 0x0000] and cdab == [0x0000, 0x3FC0]


@given(st.integers(-32768, 32767))
def test_scaled_int16_round_trip(raw):
    reg = Register("speed", 5, "int16", scale=0.01)
    value = raw * 0.01
    assert reg.encode(value) == [raw & 0xFFFF]
    assert reg.decode(reg.encode(value)) == pytest.approx(value)


def test_scaled_int16_out_of_range_is_a_clear_error():
    reg = Register("speed", 5, "int16", scale=0.1, unit="rad/s")
    with pytest.raises(ValueError, match=r"speed.*does not fit int16"):
        reg.encode(5000.0)


def test_register_check_rejects_nan_and_out_of_range():
    reg = Register("speed", 5, "float32", min=-100.0, max=100.0)
    assert reg.check(50.0) == 50.0
    for bad in (math.nan, 101.0, -math.inf):
        with pytest.raises(ValueError, match="'speed' at address 5"):
            reg.check(bad)


def test_map_toml_round_trip(tmp_path):
    text = rig_map_toml(word_order="CDAB")
    path = tmp_path / "map.toml"
    path.write_text(text)
    assert RegisterMap.from_toml(path) == RegisterMap.default("CDAB")


def test_map_toml_with_scaled_integer(tmp_path):
    path = tmp_path / "plc.toml"
    path.write_text(
        'device_id = 3\nword_order = "CDAB"\n[registers.speed]\naddress = 10\ntype = "int16"\nscale = 0.1\n'
    )
    m = RegisterMap.from_toml(path)
    assert m.device_id == 3
    assert (m["speed"].type, m["speed"].scale, m["speed"].address) == ("int16", 0.1, 10)
    assert m["voltage_command"].word_order == "CDAB"
    assert RegisterMap.from_toml_text(m.to_toml()) == m


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[registers.speed]\naddress = 3\n", "overlaps"),
        ("[registers.torque]\naddress = 30\n", "unknown register 'torque'"),
        ('[registers.speed]\naddress = 10\ntype = "int8"\n', r"registers.speed.*type"),
        ('word_order = "BADC"\n', "word_order"),
        ('[registers.heartbeat]\naddress = 9\ntype = "float32"\n', "heartbeat"),
        ("[registers.speed]\nadress = 10\n", "unknown field"),
    ],
)
def test_bad_map_gives_a_clear_error(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        RegisterMap.from_toml(path)


# -- online loop on the simulated DAQ -------------------------------------------------------------
def test_run_online_records_every_sample(tmp_path):
    out = tmp_path / "run.csv"
    est = Recorder()
    u = np.sin(np.arange(50) * 0.3) * 5
    df = run_online(SimulatedDAQ(FirstOrderPlant(), seed=1), [est], u, duration=2.0, out=out, progress=False)
    assert len(df) == 50
    np.testing.assert_array_equal(df["u"], u)
    np.testing.assert_allclose(df["t"], np.arange(50) * 0.04, atol=1e-12)
    assert list(df.columns[:5]) == ["t", "seq", "u", "y", "clamped"]
    assert {"echo.y_hat", "echo.gain", "echo.a1", "echo.a2", "echo.s4"} <= set(df.columns)
    assert not any(c.startswith("echo.basis") for c in df.columns)
    assert est.u == list(u) and est.y == list(df["y"])
    assert df.attrs["dt"] == 0.04 and df.attrs["units"]["y"] == "rad/s"
    on_disk = pd.read_csv(out, comment="#")
    pd.testing.assert_frame_equal(on_disk, df, check_dtype=False)


def test_run_online_same_as_offline_simulation():
    plant = FirstOrderPlant()
    plant.reset(seed=4)
    u = np.linspace(-3, 3, 40)
    y_offline = [plant.step(v) for v in u]
    df = run_online(SimulatedDAQ(FirstOrderPlant(), seed=4), None, u, None, progress=False)
    np.testing.assert_array_equal(df["y"], y_offline)


def test_run_online_callable_excitation_and_clamp():
    df = run_online(SimulatedDAQ(FirstOrderPlant(), seed=0), {}, lambda t: 100.0 * t, 1.0, progress=False)
    assert df["u"].max() == 12.0
    assert df["clamped"].sum() > 0


class CommandLog(SimulatedDAQ):
    """A simulated DAQ that remembers every command sent and whether it was closed."""

    def __init__(self, *a, **kw):
        super().__init__(*a, **kw)
        self.sent: list[float] = []
        self.closed = False

    def _write(self, u):
        self.sent.append(u)
        super()._write(u)

    def _close(self):
        self.closed = True


def test_run_online_failure_leaves_csv_and_commands_zero(tmp_path):
    out = tmp_path / "crash.csv"

    def excitation(t):
        if t > 0.42:  # raises when computing the command of sample 11
            raise RuntimeError("excitation generator failed")
        return 3.0

    daq = CommandLog(FirstOrderPlant(), seed=0)
    with pytest.raises(RuntimeError, match="generator failed") as info:
        run_online(daq, [Recorder()], excitation, 2.0, out=out, progress=False)
    assert any("stopped after 11 of 50 samples" in n for n in info.value.__notes__)
    assert daq.sent[-1] == 0.0 and daq.closed and not daq.is_open
    df = pd.read_csv(out, comment="#")
    assert len(df) == 11 and (df["u"] == 3.0).all()


def test_run_online_keyboard_interrupt_and_sigterm(tmp_path):
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals need the main thread")
    for how in ("ctrl-c", "sigterm"):
        out = tmp_path / f"{how}.csv"

        def excitation(t, how=how):
            if t > 0.22:  # sample 6
                if how == "ctrl-c":
                    raise KeyboardInterrupt
                signal.raise_signal(signal.SIGTERM)
            return 1.0

        daq = CommandLog(FirstOrderPlant(), seed=0)
        with pytest.raises(KeyboardInterrupt) as info:
            run_online(daq, [Recorder()], excitation, 2.0, out=out, progress=False)
        assert daq.sent[-1] == 0.0 and daq.closed
        assert len(pd.read_csv(out, comment="#")) == 6
        # the stop message counts exactly the rows on disk
        assert any("stopped after 6 of 50 samples" in n for n in info.value.__notes__)
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_run_online_stops_between_samples_on_a_real_sigint(tmp_path):
    """A real Ctrl-C (SIGINT) mid-loop: the file ends on a whole row, the message says how many."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals need the main thread")
    handler = signal.getsignal(signal.SIGINT)
    out = tmp_path / "sigint.csv"

    def excitation(t):
        if abs(t - 0.4) < 1e-9:  # while computing the command of sample 10
            signal.raise_signal(signal.SIGINT)
        return 1.0

    daq = CommandLog(FirstOrderPlant(), seed=0)
    with pytest.raises(KeyboardInterrupt, match="SIGINT") as info:
        run_online(daq, [Recorder()], excitation, 2.0, out=out, progress=False)
    rows = len(pd.read_csv(out, comment="#"))
    assert rows == 10
    assert any(f"stopped after {rows} of 50 samples" in n for n in info.value.__notes__)
    assert daq.sent[-1] == 0.0 and daq.closed
    assert signal.getsignal(signal.SIGINT) is handler


def test_run_online_never_truncates_an_existing_file(tmp_path):
    out = tmp_path / "old.csv"
    out.write_text("t,u,y\n0,1,2\n")
    daq = CommandLog(FirstOrderPlant(), seed=0)
    with pytest.raises(FileExistsError, match=r"old\.csv.*overwrite=True"):
        run_online(daq, None, np.ones(5), None, out=out, progress=False)
    assert daq.sent == [] and not daq.is_open  # refused before the rig was touched
    assert out.read_text() == "t,u,y\n0,1,2\n"

    class Unreachable(CommandLog):
        def _open(self):
            raise DAQError("cannot connect")

    # overwrite=True, but the run never takes a sample: the old file stays as it was
    with pytest.raises(DAQError):
        run_online(Unreachable(FirstOrderPlant(), seed=0), None, np.ones(5), None, out=out, overwrite=True,
                   progress=False)  # fmt: skip
    assert out.read_text() == "t,u,y\n0,1,2\n"
    new = tmp_path / "never.csv"
    with pytest.raises(DAQError):
        run_online(Unreachable(FirstOrderPlant(), seed=0), None, np.ones(5), None, out=new, progress=False)
    assert not new.exists()

    df = run_online(CommandLog(FirstOrderPlant(), seed=0), None, np.ones(5), None, out=out, overwrite=True,
                    progress=False)  # fmt: skip
    pd.testing.assert_frame_equal(pd.read_csv(out, comment="#"), df, check_dtype=False)


MEMORY_RUN = """
import resource, sys
import numpy as np
sys.path.insert(0, {tests!r})
from io_fixtures import FirstOrderPlant
from motorid.estimators import create
from motorid.io import SimulatedDAQ, run_online
n = int(sys.argv[1])
u = 6.0 * np.sin(0.05 * np.arange(n))
df = run_online(SimulatedDAQ(FirstOrderPlant(), seed=0), {{"arx": create("arx-rls", na=2, nb=2)}}, u, None,
                out=sys.argv[2], progress=False)
print(len(df), df.attrs["samples"], resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def test_a_long_online_run_holds_its_memory_flat(tmp_path):
    """200,000 samples (2.2 h at 25 Hz) peak at the memory of 20,000: the rows are on disk, not in memory.

    Each run is a fresh process and its peak resident set is what the
    operating system measured. With every row kept in memory the 180,000
    extra samples of this run cost 243 MB (measured: 289 -> 533 MB); bounded,
    2 MB. 32 MB allows the allocator's and the interpreter's own variation and
    is still 7 times below the unbounded growth.
    """
    import subprocess
    import sys
    from pathlib import Path

    script = MEMORY_RUN.format(tests=str(Path(__file__).parent))
    peaks = {}
    for n in (20_000, 200_000):
        out = tmp_path / f"run{n}.csv"
        done = subprocess.run([sys.executable, "-c", script, str(n), str(out)], capture_output=True,
                              text=True, timeout=600, check=True)  # fmt: skip
        kept, samples, peak_kb = map(int, done.stdout.split())
        assert samples == n and kept == 10_000  # KEEP_WITH_FILE rows in memory, the file holds all
        assert sum(1 for _ in out.open()) == n + 2  # the attribute line, the header, every sample
        peaks[n] = peak_kb
    assert peaks[200_000] - peaks[20_000] < 32 * 1024, peaks


def test_run_online_rejects_bad_arguments():
    daq = SimulatedDAQ(FirstOrderPlant(), seed=0)
    with pytest.raises(ValueError, match="excitation has 3 samples"):
        run_online(daq, [], [1.0, 2.0, 3.0], 1.0, progress=False)
    with pytest.raises(ValueError, match="duration"):
        run_online(daq, [], lambda t: 0.0, None, progress=False)
    with pytest.raises(TypeError, match=r"bad.*no predict"):
        run_online(daq, {"bad": object()}, [1.0], None, progress=False)
    with pytest.raises(ValueError, match="at sample 1"):
        run_online(daq, [], [1.0, float("nan")], None, progress=False)
    assert not daq.is_open


def test_online_record_matches_the_rigs_offline_simulation():
    u = np.repeat(np.linspace(-8.0, 8.0, 12), 10)
    offline = drive.paper_rig().simulate(u, seed=21)
    online = run_online(SimulatedDAQ(drive.paper_rig(), seed=21), None, u, None, progress=False)
    np.testing.assert_allclose(online["t"], offline["t"], atol=1e-12)
    np.testing.assert_array_equal(online["u"], offline["u"])
    np.testing.assert_allclose(online["y"], offline["y"], rtol=1e-12, atol=1e-12)


def test_a_drive_model_runs_in_a_simulation_of_each_daq():
    """A model is a description: each DAQ steps a simulation of its own, and the model stays as it was."""
    rig = drive.paper_rig()
    u = np.repeat([4.0, -4.0], 15)
    first = run_online(SimulatedDAQ(rig, seed=3), None, u, None, progress=False)
    second_daq = SimulatedDAQ(rig, seed=3)
    assert second_daq.plant is not SimulatedDAQ(rig, seed=3).plant
    second = run_online(second_daq, None, u, None, progress=False)
    np.testing.assert_array_equal(first["y"], second["y"])
    np.testing.assert_array_equal(first["y"], rig.simulate(u, seed=3)["y"])
    assert rig == drive.paper_rig()
