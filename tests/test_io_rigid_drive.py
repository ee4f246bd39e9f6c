"""A rigid drive (the doctor's improved model) hosted as a rig: in a simulated DAQ, and behind
Modbus by a real ``motorid rig serve --model`` process, against ``drive.simulate`` of the same inputs."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from io_fixtures import free_port, start_rig_process

from motorid.io import ModbusDAQ, RigServer, SimulatedDAQ, run_online
from motorid.testing import every_input_memory_drive

DRIVE = every_input_memory_drive()  # rating: its saturation


def quarter_volts(n: int, seed: int) -> np.ndarray:
    """Levels held 10 samples, multiples of 0.25 V within ±6 V: exact in float32, inside the rating."""
    rng = np.random.default_rng(seed)
    return np.repeat(rng.integers(-24, 25, size=-(-n // 10)) * 0.25, 10)[:n]


def test_a_simulated_daq_hosts_a_rigid_drive():
    u = quarter_volts(300, seed=1)
    with SimulatedDAQ(DRIVE, seed=5, u_max=8.0) as daq:
        y = []
        for v in u:
            daq.write(v)
            y.append(daq.read().y)
    # the DAQ steps the drive's own simulation: the record to the last bit
    np.testing.assert_array_equal(y, DRIVE.simulate(u)["y"].to_numpy())


@pytest.fixture
def served_drive(tmp_path):
    """A real ``motorid rig serve --model drive.json`` process on a free port of 127.0.0.1."""
    DRIVE.save(tmp_path / "drive.json")
    port = free_port()
    proc = start_rig_process(port, "--model", str(tmp_path / "drive.json"), "--watchdog-periods", "0")
    try:
        yield port
    finally:
        proc.terminate()
        assert proc.wait(30) == 0
        assert f"rigid drive of {tmp_path / 'drive.json'}" in proc.stderr.read()


def test_rig_serve_hosts_the_rigid_drive_of_a_model_file(served_drive, tmp_path):
    u = quarter_volts(200, seed=2)
    daq = ModbusDAQ("127.0.0.1", served_drive, dt=DRIVE.dt, timeout=2.0)
    record = run_online(daq, None, u, None, progress=False)
    np.testing.assert_array_equal(record["u"], u)
    # the command register is float32 (quarter volts pass it exactly) and so is the speed register:
    # the served speed is the drive's record rounded once to float32, so the comparison is exact
    expected = DRIVE.simulate(u)["y"].to_numpy().astype(np.float32)
    np.testing.assert_array_equal(record["y"], expected)

    # motorid run against the same server (lock-step, it goes on from the state the run above left)
    out = tmp_path / "run.csv"
    done = subprocess.run(
        [sys.executable, "-m", "motorid.cli", "run", "--daq", f"modbus://127.0.0.1:{served_drive}",
         "--estimator", "arx-rls", "--dt", str(DRIVE.dt), "--duration", "1", "--out", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    run = pd.read_csv(out, comment="#")
    # closing the first DAQ commanded 0 V for one sample; the rig applies float32 commands
    continued = np.concatenate([u, [0.0], np.float32(run["u"].to_numpy())])
    expected = DRIVE.simulate(continued)["y"].to_numpy()[u.size + 1 :].astype(np.float32)
    np.testing.assert_array_equal(run["y"], expected)  # the CSV holds repr(float): exact
    assert np.ptp(run["y"]) > 1.0  # on a drive that moves [rad/s]


def test_rig_serve_takes_the_rating_of_a_rigid_drive(tmp_path, monkeypatch, capsys):
    from motorid.cli import main

    served = []
    port = str(free_port())  # the server is not started, but its address is checked free
    monkeypatch.setattr(RigServer, "serve_forever", lambda self, on_listening=None: served.append(self))
    DRIVE.save(tmp_path / "drive.json")
    assert main(["rig", "serve", "--model", str(tmp_path / "drive.json"), "--port", port]) == 0
    assert served[-1].u_max == DRIVE.params["saturation"]
    unbounded = DRIVE.with_effects(
        ("coulomb_friction", "viscous_friction"),
        {k: DRIVE.params[k] for k in ("inertia", "input_gain", "coulomb", "viscous")},
    )
    unbounded.save(tmp_path / "unbounded.json")
    assert main(["rig", "serve", "--model", str(tmp_path / "unbounded.json"), "--port", port]) == 2
    err = capsys.readouterr().err
    assert f"--model {tmp_path / 'unbounded.json'}: the rigid drive has no input saturation" in err
    assert "--u-max" in err
    assert main(["rig", "serve", "--model", str(tmp_path / "unbounded.json"), "--u-max", "5"]) == 0
    assert served[-1].u_max == 5.0 and served[-1].plant.drive == unbounded
