"""``motorid control``: the speed loop closed on the simulated rig and over Modbus against a real
``motorid rig serve`` process, with the controller designed on the doctor's model."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import interrupt_when_written, run
from io_fixtures import free_port, start_rig_process

from motorid.diagnose import diagnose
from motorid.drive import Amplifier, Friction, paper_rig
from motorid.signals import two_sine_signal

PLANT_SEED = "3"


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """plant.json: the paper's rig with a wider dead zone and more motor friction (at its 40 ms);
    drive.json: what the doctor makes of a 120 s record of it (no input gain: forces in V)."""
    root = tmp_path_factory.mktemp("control")
    friction = (Friction(("coulomb_friction",), {"coulomb": 6e-3}, side="motor"),
                Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="load"))  # fmt: skip
    rig = paper_rig(friction=friction, amplifier=Amplifier(dead_zone=0.8, v_max=12.0))
    rig.save(root / "plant.json")
    _, u = two_sine_signal(duration=120.0, dt=rig.dt, seed=0)
    diagnose(rig.simulate(u, seed=1)).model.save(root / "drive.json")
    return root


def control(capsys, files: Path, *options: str) -> dict:
    code, out, err = run(capsys, "control", "--design", str(files / "drive.json"), "--json", *options)
    assert code == 0, err
    return out


def test_compensation_from_the_doctors_model_cuts_the_low_speed_error_on_the_simulated_rig(
    capsys, files, tmp_path
):
    plant = ("--model", str(files / "plant.json"), "--plant-seed", PLANT_SEED)
    with_comp = control(capsys, files, *plant, "--out", str(tmp_path / "run.csv"))
    without = control(capsys, files, *plant, "--no-compensation")
    assert with_comp["compensation"] == "reference" and without["compensation"] is None
    assert with_comp["pi"] == without["pi"]  # the same PI, designed on the model
    assert with_comp["low_speed_rms_error"] < 0.5 * without["low_speed_rms_error"]
    assert with_comp["largest_stuck_after_reversal"] < 0.5 * without["largest_stuck_after_reversal"]
    record = pd.read_csv(tmp_path / "run.csv", comment="#")
    assert list(record.columns) == ["t", "reference", "u", "y", "clamped"]
    assert len(record) == with_comp["samples"] == 300  # 12 s at the rig's 40 ms
    # the built-in reference reverses through zero: a triangle of ±40 rad/s over 4 s
    assert record["reference"].max() == pytest.approx(40.0) and with_comp["reversals"] == 5
    e = record["reference"] - record["y"]
    assert with_comp["rms_error"] == pytest.approx(float(np.sqrt(np.mean(e**2))))


def test_a_reference_file_and_the_measured_speed_source(capsys, files, tmp_path):
    t = np.arange(0, 6.01, 0.1)
    pd.DataFrame({"t": t, "r": 30.0 * np.sin(2 * np.pi * t / 3.0)}).to_csv(tmp_path / "ref.csv", index=False)
    out = control(capsys, files, "--model", str(files / "plant.json"), "--reference", str(tmp_path / "ref.csv"),
                  "--source", "measured", "--speed-band", "2", "--out", str(tmp_path / "run.csv"))  # fmt: skip
    assert out["compensation"] == "measured" and out["samples"] == 150  # the file's 6 s at 40 ms
    record = pd.read_csv(tmp_path / "run.csv", comment="#")
    # the reference is the file's, interpolated at the loop's samples
    np.testing.assert_allclose(
        record["reference"], np.interp(record["t"], t, 30.0 * np.sin(2 * np.pi * t / 3.0))
    )
    # measured-speed compensation cancels the viscous term in the loop: the PI is designed without it
    assert out["pi"]["tracking_time"] == pytest.approx(4.0 / out["pi"]["bandwidth"])


def test_the_loop_over_modbus_against_rig_serve_gives_the_simulated_figures(capsys, files, tmp_path):
    port = free_port()
    # a register map of the rig's (float32 in CDAB word order): server and client read it from --map
    code, toml, err = run(capsys, "rig", "map", "--word-order", "CDAB")
    assert code == 0, err
    (tmp_path / "cdab.toml").write_text(toml)
    # the watchdog stays armed (25 periods, 1 s: a loaded test machine may pause longer than 3);
    # every command the loop writes feeds it
    proc = start_rig_process(port, "--model", str(files / "plant.json"), "--plant-seed", PLANT_SEED,
                             "--watchdog-periods", "25", "--map", str(tmp_path / "cdab.toml"))  # fmt: skip
    try:
        over_modbus = control(capsys, files, "--daq", f"modbus://127.0.0.1:{port}", "--dt", "0.04",
                              "--timeout", "2", "--map", str(tmp_path / "cdab.toml"),
                              "--out", str(tmp_path / "modbus.csv"))  # fmt: skip
    finally:
        proc.terminate()
        assert proc.wait(30) == 0
    simulated = control(capsys, files, "--model", str(files / "plant.json"), "--plant-seed", PLANT_SEED,
                        "--out", str(tmp_path / "sim.csv"))  # fmt: skip
    modbus, sim = (
        pd.read_csv(tmp_path / "modbus.csv", comment="#"),
        pd.read_csv(tmp_path / "sim.csv", comment="#"),
    )
    assert len(modbus) == len(sim)
    # the registers are float32: the speed and the command are rounded to 24 bits each sample (6e-8
    # relative) and the loop carries the rounding on; the drive's sticking can turn a rounding into a
    # sample's difference of timing, so the figures agree to 1 %, the records to 0.5 rad/s
    for key in ("rms_error", "low_speed_rms_error"):
        assert over_modbus[key] == pytest.approx(simulated[key], rel=0.01), key
    assert over_modbus["largest_stuck_after_reversal"] == pytest.approx(simulated["largest_stuck_after_reversal"],
                                                                       abs=0.04 + 1e-9)  # fmt: skip
    assert np.max(np.abs(modbus["y"] - sim["y"])) < 0.5
    assert modbus["u"].iloc[0] == pytest.approx(sim["u"].iloc[0], rel=1e-6)


def _digests(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in folder.iterdir() if p.is_file()}


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--design", "{plant}"], "--design"),
        (["--design", "{drive}", "--daq", "modbus://127.0.0.1:1", "--model", "{plant}"], "--model applies to --daq sim"),
        (["--design", "{drive}", "--daq", "modbus://127.0.0.1:1", "--dead-zone", "1"], "--dead-zone applies to --daq sim"),
        (["--design", "{drive}", "--model", "{plant}", "--coulomb-motor", "0.01"], "cannot be combined with --model"),
        (["--design", "{drive}", "--reference", "{bad_ref}"], "no column 'r'"),
        (["--design", "{drive}", "--reference", "{nan_ref}"], "column 'r' row 2"),
        (["--design", "{drive}", "--reference", "{back_ref}", "--duration", "1"], "must increase, row 2"),
        (["--design", "{drive}", "--reference", "{nan_ref}".replace("nan", "ok"), "--duration", "60"], "longer than"),
        (["--design", "{drive}", "--out", "{existing}"], "exists"),
        (["--design", "{drive}", "--no-compensation", "--source", "measured"], "--no-compensation"),
        (["--design", "{drive}", "--bandwidth", "-1"], "--bandwidth"),
        (["--design", "{drive}", "--daq", "modbus://127.0.0.1:{closed}", "--timeout", "0.2"], "cannot connect"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line_exit_2_and_nothing_changes(capsys, files, tmp_path, argv, words):
    pd.DataFrame({"t": [0, 1, 2], "x": [0, 1, 2]}).to_csv(tmp_path / "bad_ref.csv", index=False)
    pd.DataFrame({"t": [0.0, 1, 2, 3], "r": [0, 1, "x", 2]}).to_csv(tmp_path / "nan_ref.csv", index=False)
    pd.DataFrame({"t": [0.0, 1, 2, 3], "r": [0, 1, 2, 3]}).to_csv(tmp_path / "ok_ref.csv", index=False)
    pd.DataFrame({"t": [0.0, 1, 0.5], "r": [0, 1, 2]}).to_csv(tmp_path / "back_ref.csv", index=False)
    (tmp_path / "existing.csv").write_text("keep me\n")
    names = {"plant": files / "plant.json", "drive": files / "drive.json", "closed": str(free_port()),
             **{n: tmp_path / f"{n}.csv" for n in ("bad_ref", "nan_ref", "ok_ref", "back_ref", "existing")}}  # fmt: skip
    before = _digests(tmp_path)
    args = [a.format(**names) for a in argv]
    code, _, err = run(capsys, "control", *args)
    assert code == 2, err
    errors = [line for line in err.splitlines() if line.startswith("motorid control: error:")]
    assert len(errors) == 1 and words in errors[0] and "Traceback" not in err, err
    assert _digests(tmp_path) == before


def test_ctrl_c_stops_the_loop_with_zero_volts_at_the_rig_and_whole_rows_on_disk(files, tmp_path):
    """A real ``motorid control`` process on a real rig server, stopped by a real SIGINT."""
    import sys

    from pymodbus.client import ModbusTcpClient

    from motorid.io import RegisterMap

    port = free_port()
    server = start_rig_process(port, "--model", str(files / "plant.json"), "--watchdog-periods", "25")
    out = tmp_path / "run.csv"
    try:
        argv = [sys.executable, "-m", "motorid.cli", "control", "--design", str(files / "drive.json"),
                "--daq", f"modbus://127.0.0.1:{port}", "--dt", "0.04", "--timeout", "2", "--duration", "100000",
                "--out", str(out)]  # fmt: skip
        interrupt_when_written(argv, out, 5_000, 2_500_000)
        # the rig's voltage command register holds 0 V: the loop's last word to the rig
        command = RegisterMap.default()["voltage_command"]
        client = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
        assert client.connect()
        try:
            words = client.read_holding_registers(command.address, count=command.count).registers
        finally:
            client.close()
        assert command.decode(words) == 0.0
    finally:
        server.terminate()
        server.wait(30)


def test_the_built_in_sine_reference_bandwidth_and_low_speed_band(capsys, files, tmp_path):
    out = control(capsys, files, "--model", str(files / "plant.json"), "--shape", "sine", "--amplitude", "20",
                  "--period", "2", "--duration", "4", "--bandwidth", "8", "--low-speed-rpm", "60",
                  "--out", str(tmp_path / "run.csv"))  # fmt: skip
    record = pd.read_csv(tmp_path / "run.csv", comment="#")
    assert out["samples"] == 100  # 4 s at 40 ms
    np.testing.assert_allclose(record["reference"], 20.0 * np.sin(2 * np.pi * record["t"] / 2.0), atol=1e-9)
    assert out["pi"]["bandwidth"] == 8.0 and out["reversals"] == 3
    band = 60.0 * 2 * np.pi / 60.0
    assert out["low_speed_band"] == pytest.approx(band)
    assert out["low_speed_samples"] == int((record["reference"].abs() < band).sum())


def test_the_rig_options_make_the_simulated_plant_as_motorid_simulate_does(capsys, files, tmp_path):
    code, _, err = run(capsys, "simulate", "--save-model", str(tmp_path / "rig.json"), "--dead-zone", "1.1",
                       "--coulomb-motor", "0.008", "--stribeck", "0.002", "0.1")  # fmt: skip
    assert code == 0, err
    options = ("--dead-zone", "1.1", "--coulomb-motor", "0.008", "--stribeck", "0.002", "0.1")
    by_options = control(capsys, files, *options, "--out", str(tmp_path / "a.csv"))
    by_file = control(capsys, files, "--model", str(tmp_path / "rig.json"), "--out", str(tmp_path / "b.csv"))
    timing = ("out", "largest_interval")  # the file names differ; the loop's timing is the machine's
    assert {k: v for k, v in by_options.items() if k not in timing} == {
        k: v for k, v in by_file.items() if k not in timing
    }
    # and it is not the default rig: a wider dead zone and more friction stick longer without compensation
    default = control(capsys, files, "--no-compensation")
    wider = control(capsys, files, *options, "--no-compensation")
    assert wider["largest_stuck_after_reversal"] > default["largest_stuck_after_reversal"]
