"""Records as loggers write them: the files real loggers write, read by every command and by Python.

Each file is made from one simulated drive with a planted Coulomb friction
(:func:`motorid.diagnose.synthetic.planted_record`, 10 ms samples), written as a
logger writes it: an Arduino's ``millis()`` log with duty in %, a spreadsheet's
``;``-separated export with decimal commas and names like ``Zeit [s]``, a
tab-separated log with time in µs since boot, seconds with 15 % jitter. Each
loads with the documented options, and the doctor finds the sample time and the
friction on it.
"""

from __future__ import annotations

import logging
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run

from motorid.diagnose import diagnose
from motorid.diagnose.synthetic import planted_record
from motorid.errors import DataError
from motorid.io.records import JITTER_LIMIT, normalise_record, read_record, write_record

RPM = 60.0 / (2.0 * math.pi)
SUPPLY = 24.0  # [V]: the planted drive's input, at most 6.4 V, is a duty of at most 27 %
DT = 0.01
COULOMB = 8e-3  # [N m], planted


@pytest.fixture(scope="module")
def planted():
    return planted_record("coulomb_friction", 7, sizes={"coulomb": COULOMB})


def _arduino(planted, path: Path, seed: int = 1) -> pd.DataFrame:
    """millis() since boot, one tick of jitter either way; duty in % of the supply; speed in rpm."""
    rec = planted.record
    rng = np.random.default_rng(seed)
    log = pd.DataFrame({
        "time_ms": 123_456 + 10 * np.arange(len(rec)) + rng.integers(-1, 2, len(rec)),
        "pwm": (rec["u"] / SUPPLY * 100).round(2),
        "rpm": (rec["y"] * RPM).round(3),
    })  # fmt: skip
    log.to_csv(path, index=False)
    return log


def _export(planted, path: Path) -> None:
    """A spreadsheet's export in much of Europe: ';' separated, decimal commas, names with units."""
    rec = planted.record
    pd.DataFrame({"Zeit [s]": rec["t"], "Spannung [V]": rec["u"], "Drehzahl [1/min]": rec["y"] * RPM}).to_csv(
        path, sep=";", decimal=",", index=False
    )


def _tab_us(planted, path: Path, seed: int = 2) -> None:
    """Tab separated, time in µs since boot (an integer clock started 5000 s earlier), ±200 µs jitter."""
    rec = planted.record
    rng = np.random.default_rng(seed)
    us = 5_000_000_123 + 10_000 * np.arange(len(rec)) + rng.integers(-200, 201, len(rec))
    pd.DataFrame({"t_us": us, "u": rec["u"], "w": rec["y"]}).to_csv(path, sep="\t", index=False)


def _jittered_seconds(planted, path: Path, seed: int = 3) -> np.ndarray:
    """Seconds whose steps jitter by up to 15 % of dt (each stamp off by up to 7.5 % of dt)."""
    rec = planted.record
    rng = np.random.default_rng(seed)
    t = rec["t"].to_numpy() + rng.uniform(-0.075, 0.075, len(rec)) * DT
    pd.DataFrame({"time": t, "volts": rec["u"], "speed": rec["y"]}).to_csv(path, index=False)
    return t


@pytest.fixture(scope="module")
def logs(tmp_path_factory, planted) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("loggers")
    paths = {name: folder / name for name in ("arduino.csv", "export.csv", "tab.tsv", "jitter.csv")}
    _arduino(planted, paths["arduino.csv"])
    _export(planted, paths["export.csv"])
    _tab_us(planted, paths["tab.tsv"])
    _jittered_seconds(planted, paths["jitter.csv"])
    return paths


# (file, the documented options, how many samples the 10 ms grid keeps)
LOGGER_OPTIONS = [
    ("arduino.csv", ["--time", "time_ms", "--time-unit", "ms", "--input", "pwm", "--input-unit", "%",
                     "--supply-voltage", str(SUPPLY), "--output", "rpm", "--output-unit", "rpm"]),
    ("export.csv", ["--time", "Zeit [s]", "--input", "Spannung [V]", "--output", "Drehzahl [1/min]",
                    "--output-unit", "rpm"]),
    ("tab.tsv", ["--time", "t_us", "--time-unit", "us", "--output", "w"]),
    ("jitter.csv", ["--time", "time", "--input", "volts", "--output", "speed"]),
]  # fmt: skip


@pytest.mark.parametrize(("name", "options"), LOGGER_OPTIONS, ids=[row[0] for row in LOGGER_OPTIONS])
def test_the_doctor_finds_the_sample_time_and_the_friction_in_a_loggers_file(
    capsys, caplog, logs, planted, name, options
):
    caplog.set_level(logging.WARNING, logger="motorid.io.records")
    code, out, err = run(capsys, "doctor", str(logs[name]), *options, "--input-gain", repr(planted.input_gain),
                         "--base", "viscous_friction,offset", "--max-steps", "1", "--json")  # fmt: skip
    assert code == 0, err
    # the median step of millis() is exactly 10 ticks; of µs stamps with ±200 µs jitter within 0.1 %
    assert out["settings"]["dt"] == pytest.approx(DT, rel=1e-3)
    assert [s["effect"] for s in out["steps"]] == ["coulomb_friction"]
    # 20 %: the stamps' jitter, taken out by resampling, blurs the planted level a little (15 % without)
    assert out["steps"][0]["params"]["coulomb"] == pytest.approx(COULOMB, rel=0.2)
    said = [r.getMessage() for r in caplog.records if "jitter" in r.getMessage()]
    if name == "export.csv":  # uniform stamps: nothing to say
        assert not said
    else:  # the jitter, said once, on one line
        assert len(said) == 1 and "\n" not in said[0] and "resampled to a uniform 10 ms grid" in said[0]


def test_the_command_states_the_jitter_once_on_stderr(logs):
    """A real run: the warning reaches stderr as one line (in-process tests see it through caplog)."""
    argv = [str(Path(sys.executable).with_name("motorid")), "identify", str(logs["arduino.csv"]),
            *LOGGER_OPTIONS[0][1], "--estimator", "arx-rls"]  # fmt: skip
    done = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if "jitter" in line]
    assert len(lines) == 1, done.stderr
    assert re.search(r"arduino.csv: time stamps jitter by up to 2 ms \(20 % of dt 10 ms\); resampled to a "
                     r"uniform 10 ms grid", lines[0]), lines[0]  # fmt: skip


@pytest.mark.parametrize("command", ["identify", "sweep", "doctor"])
def test_every_command_reads_columns_named_with_spaces_brackets_and_units(capsys, logs, command):
    extra = {"identify": ["--estimator", "arx-rls"], "sweep": ["--orders", "1", "--degrees", "2"],
             "doctor": ["--max-steps", "0"]}[command]  # fmt: skip
    code, out, err = run(capsys, command, str(logs["export.csv"]), *LOGGER_OPTIONS[1][1], *extra, "--json")
    assert code == 0 and isinstance(out, dict), err
    # each option was used: without it the column is missing
    for option in ("--time", "--input", "--output"):
        argv = list(LOGGER_OPTIONS[1][1])
        at = argv.index(option)
        del argv[at : at + 2]
        code, _, err = run(capsys, command, str(logs["export.csv"]), *argv, *extra)
        missing = "no time column 't'" if option == "--time" else "is missing from"  # the time may be absent
        assert code == 2 and missing in err and len(err.splitlines()) == 1, (option, err)


def test_fleet_identify_reads_the_same_options(capsys, logs, tmp_path):
    code, _, err = run(capsys, "fleet", "identify", str(logs["export.csv"]), *LOGGER_OPTIONS[1][1],
                       "--estimator", "arx-rls", "--out", str(tmp_path / "fleet"), "--json")  # fmt: skip
    assert code == 0, err


def test_separator_and_decimal_are_detected_and_said_at_v(logs, caplog):
    with caplog.at_level(logging.INFO, logger="motorid.io.records"):
        rec = read_record(
            logs["export.csv"], time="Zeit [s]", input="Spannung [V]", output="Drehzahl [1/min]"
        )
    assert "separator ';' (detected), decimal mark ',' (detected)" in caplog.text
    explicit = read_record(logs["export.csv"], time="Zeit [s]", input="Spannung [V]", output="Drehzahl [1/min]",
                           sep=";", decimal=",")  # fmt: skip
    pd.testing.assert_frame_equal(rec, explicit)
    with caplog.at_level(logging.INFO, logger="motorid.io.records"):
        read_record(logs["tab.tsv"], time="t_us", time_unit="us", output="w")
    assert "separator '\\t' (detected)" in caplog.text


def test_each_logger_file_reads_as_the_simulated_record(logs, planted):
    """The four files are the same drive: each reads as the record simulated, within what the file keeps."""
    rec = planted.record
    arduino = read_record(logs["arduino.csv"], time="time_ms", time_unit="ms", input="pwm", input_unit="%",
                          supply_voltage=SUPPLY, output="rpm", output_unit="rpm")  # fmt: skip
    assert arduino.attrs["dt"] == DT and arduino.attrs["units"] == {"t": "s", "u": "V", "y": "rad/s"}
    assert arduino.attrs["time_origin"] == pytest.approx(123.456, abs=1e-3)  # millis() since boot, kept aside
    np.testing.assert_array_equal(arduino["t"], np.arange(len(arduino)) * DT)
    # the input is held and the output interpolated between stamps 1 ms off: within a step's change
    n = len(arduino)
    assert np.max(np.abs(arduino["u"] - rec["u"][:n])) <= 0.01 * SUPPLY / 100 * 2 + np.max(
        np.abs(np.diff(rec["u"]))
    )
    assert np.max(np.abs(arduino["y"] - rec["y"][:n])) <= np.max(np.abs(np.diff(rec["y"])))
    export = read_record(logs["export.csv"], time="Zeit [s]", input="Spannung [V]", output="Drehzahl [1/min]",
                         output_unit="rpm")  # fmt: skip
    np.testing.assert_allclose(export["y"], rec["y"], rtol=1e-12, atol=1e-12)  # decimal commas parse exactly
    tab = read_record(logs["tab.tsv"], time="t_us", time_unit="us", output="w")
    assert tab["t"].iloc[0] == 0.0 and tab.attrs["time_origin"] == pytest.approx(5000.000123, abs=200e-6)


def test_unix_time_in_ns_keeps_its_precision(tmp_path):
    """Integers of nanoseconds since 1970 (1.7e18: past float64's 2**53) read exactly, from 0."""
    n = 1000
    start = 1_732_492_800_123_456_789
    ns = start + 1_000_000 * np.arange(n, dtype=np.int64)  # 1 kHz
    path = tmp_path / "unix.csv"
    pd.DataFrame({"t": ns, "u": np.sin(np.arange(n)), "y": np.cos(np.arange(n))}).to_csv(path, index=False)
    rec = read_record(path, time_unit="ns")
    assert rec.attrs["dt"] == 1e-3  # exact: the steps are taken in integers
    np.testing.assert_array_equal(rec["t"], (ns - start) * 1e-9)
    # read as float64, the same stamps are 256 ns apart at best: the steps would jitter by 2.6e-4 of dt
    assert float(np.float64(start + 1_000_000)) - float(np.float64(start)) != 1_000_000


def test_a_time_unit_that_cannot_be_right_is_refused_naming_the_option(logs):
    for unit in (None, "s", "ns"):
        with pytest.raises(DataError, match=r"'time_ms'.*time_unit=\.\.\."):
            read_record(logs["arduino.csv"], time="time_ms", time_unit=unit, input="pwm", output="rpm")


def test_jitter_is_accepted_up_to_the_limit_and_gaps_are_refused_unless_resampled(tmp_path, caplog):
    n = 200
    rng = np.random.default_rng(0)
    u, y = np.sin(0.1 * np.arange(n)), np.cos(0.1 * np.arange(n))
    steps = DT * (1 + rng.uniform(-0.3, 0.3, n - 1))
    t = np.concatenate([[0.0], np.cumsum(steps)])
    path = tmp_path / "jitter.csv"
    pd.DataFrame({"t": t, "u": u, "y": y}).to_csv(path, index=False)
    rec = read_record(path)
    grid = np.arange(len(rec)) * rec.attrs["dt"]
    np.testing.assert_array_equal(rec["t"], grid)
    held = np.searchsorted(t, grid, side="right") - 1  # the input held from each stamp to the next
    np.testing.assert_array_equal(rec["u"], u[held])
    np.testing.assert_allclose(rec["y"], np.interp(grid, t, y), rtol=0, atol=1e-15)  # the output interpolated
    # a missing sample: refused naming the row, then resampled across with resample=True, said
    gap = pd.DataFrame(
        {"t": np.delete(np.arange(n) * DT, 120), "u": np.delete(u, 120), "y": np.delete(y, 120)}
    )
    gap.to_csv(path, index=False)
    with pytest.raises(DataError, match=r"gap of 1 sample before row 120 .*resample=True"):
        read_record(path)
    with caplog.at_level(logging.WARNING, logger="motorid.io.records"):
        filled = read_record(path, resample=True)
    assert len(filled) == n and "1 gap of missing samples" in caplog.text and "row 120" in caplog.text
    assert filled["u"].iloc[120] == u[119]  # held across the gap
    # beyond the jitter limit (a step 1.45 dt: no whole missing sample) refused too
    odd = np.arange(n) * DT
    odd[50:] += 0.45 * DT
    pd.DataFrame({"t": odd, "u": u, "y": y}).to_csv(path, index=False)
    with pytest.raises(DataError, match=rf"not uniformly sampled at row 50.*{JITTER_LIMIT:.0%}"):
        read_record(path)


def test_dt_that_contradicts_the_time_column_is_refused_and_dt_without_one_still_works(
    logs, planted, tmp_path
):
    with pytest.raises(DataError, match=r"dt = 20 ms.*contradicts the time column 'time'.*10 ms"):
        read_record(logs["jitter.csv"], time="time", input="volts", output="speed", dt=0.02)
    assert (
        read_record(logs["jitter.csv"], time="time", input="volts", output="speed", dt=0.01).attrs["dt"] == DT
    )
    bare = tmp_path / "bare.csv"
    planted.record[["u", "y"]].to_csv(bare, index=False)
    rec = read_record(bare, dt=DT)
    np.testing.assert_array_equal(rec["t"], np.arange(len(rec)) * DT)


def test_duty_beyond_100_percent_is_refused_and_pwm_counts_map_to_duty(tmp_path, planted):
    rec = planted.record
    counts = tmp_path / "counts.csv"
    duty = (rec["u"] / SUPPLY * 100).to_numpy()
    # a 10-bit PWM: 1023 counts are full duty, so 27 % duty is 276 counts
    pd.DataFrame({"t": rec["t"], "pwm": np.round(duty * 1023 / 100), "y": rec["y"]}).to_csv(
        counts, index=False
    )
    with pytest.raises(DataError, match=r"input column 'pwm' is -?\d+ at row \d+ \(line \d+ of .*counts.csv\), "
                                        r"beyond ±100 %.*input_unit='counts'"):  # fmt: skip
        read_record(counts, input="pwm", input_unit="%")
    read = read_record(counts, input="pwm", input_unit="counts", input_full_scale=1023, supply_voltage=SUPPLY)
    # 1023 counts are 100 % of the supply; the counts were rounded: within half a count
    np.testing.assert_allclose(read["u"], rec["u"], atol=0.5 / 1023 * SUPPLY)
    with pytest.raises(DataError, match="input_full_scale="):
        read_record(counts, input="pwm", input_unit="counts")
    with pytest.raises(DataError, match=r"beyond ±100 counts"):
        read_record(counts, input="pwm", input_unit="counts", input_full_scale=100)


def test_diagnose_takes_the_users_dataframe_with_the_command_lines_options(logs, planted, capsys):
    """diagnose(df, input=..., input_unit=...) on the DataFrame pandas reads equals the doctor on the file."""
    log = pd.read_csv(logs["arduino.csv"])
    options = {"time": "time_ms", "time_unit": "ms", "input": "pwm", "input_unit": "%", "output": "rpm",
               "output_unit": "rpm", "supply_voltage": SUPPLY}  # fmt: skip
    d = diagnose(log, **options, input_gain=planted.input_gain, base=planted.base, max_steps=1)
    code, out, err = run(capsys, "doctor", str(logs["arduino.csv"]), *LOGGER_OPTIONS[0][1],
                         "--input-gain", repr(planted.input_gain), "--max-steps", "1", "--json")  # fmt: skip
    assert code == 0, err
    assert d.named == [s["effect"] for s in out["steps"]] == ["coulomb_friction"]
    assert d.model.params["coulomb"] == out["steps"][0]["params"]["coulomb"]  # the same reading, the same fit
    assert d.settings.input == "pwm" and d.units["v"] == "rad/s"
    # and a second record of the user's is scored read the same way
    scores = d.evaluate(log)
    assert scores.loc["+coulomb_friction", "overall"] < scores.loc["initial", "overall"]


def test_normalise_record_takes_a_datetime_column_and_names_a_bad_cell():
    n = 100
    stamps = pd.Timestamp("2026-01-02 03:04:05") + pd.to_timedelta(np.arange(n) * 10, unit="ms")
    df = pd.DataFrame({"when": stamps, "cmd": np.sin(np.arange(n)), "speed": np.cos(np.arange(n))})
    rec = normalise_record(df, time="when", input="cmd", output="speed")
    assert rec.attrs["dt"] == DT and list(rec.columns) == ["t", "u", "y"]
    df.loc[7, "speed"] = np.nan
    with pytest.raises(DataError, match=r"'speed' is not a finite number at sample 7"):
        normalise_record(df, time="when", input="cmd", output="speed")
    with pytest.raises(DataError, match=r"output=\.\.\. 'cmd' is the same column as input"):
        normalise_record(df, input="cmd", output="cmd")


def test_a_record_with_no_units_gets_no_rpm_or_rad_s_label(capsys, tmp_path, planted):
    path = tmp_path / "plain.csv"
    planted.record[["t", "u", "y"]].to_csv(path, index=False)  # no attribute line: no units
    code, out, err = run(capsys, "identify", str(path), "--estimator", "arx-rls", "--json")
    assert code == 0, err
    assert "rpm^2" not in err and "rad/s" not in err and "(output units)^2" in err
    assert out["output_unit"] is None and "mse_rpm2" not in out["scores"]["one_step"]
    code, out, err = run(capsys, "sweep", str(path), "--orders", "1", "--degrees", "2", "--json")
    assert code == 0 and "rpm^2" not in err and "MSE [(output units)^2]" in err
    assert out["mse_unit"] == "(output units)^2"
    write_record(planted.record, path)  # the same record naming its units: rpm, as the paper
    code, out, err = run(capsys, "identify", str(path), "--estimator", "arx-rls", "--json")
    assert code == 0 and "rpm^2" in err and out["output_unit"] == "rad/s"


# ------------------------------------------------------------------ the files of issue: hostile or broken
def test_a_utf8_bom_is_stripped_from_the_first_column_name(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbft,u,y\n0,1,2\n0.01,2,3\n")
    assert list(read_record(path).columns) == ["t", "u", "y"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="this system has no FIFOs")
def test_a_fifo_named_like_a_record_is_refused_before_it_is_opened(tmp_path, capsys):
    fifo = tmp_path / "x.csv"
    os.mkfifo(fifo)  # opening it for reading would block until a writer comes: none will
    with pytest.raises(DataError, match=r"x.csv is a FIFO, not a regular file"):
        read_record(fifo)
    os.mkfifo(tmp_path / "x.parquet")  # the binary formats too
    with pytest.raises(DataError, match="FIFO"):
        read_record(tmp_path / "x.parquet")
    code, _, err = run(capsys, "identify", str(fifo))
    assert code == 2 and "FIFO" in err


def test_the_duplicate_header_check_is_linear(tmp_path):
    """A header of 1,000,000 columns is checked in one pass (it took hours when each name was searched)."""
    names = [f"c{k}" for k in range(1_000_000)]
    path = tmp_path / "wide.csv"
    path.write_text(",".join(names) + ",c17\n" + ",".join("0" for _ in range(1_000_001)) + "\n")
    start = time.process_time()
    with pytest.raises(DataError, match=r"'c17' appears twice"):
        read_record(path)
    assert time.process_time() - start < 60  # a bound against hours, not a speed test (about 1 s here)


def test_a_row_with_extra_fields_is_refused_naming_the_row(tmp_path):
    path = tmp_path / "extra.csv"
    path.write_text("t,u,y\n0,1,2\n0.01,2,3,4\n0.02,3,4\n")
    with pytest.raises(DataError, match=r"row 1 \(line 3 of .*extra.csv\) has 4 fields, the header has 3"):
        read_record(path)
    path.write_text("t,u,y\n0,1,2,9\n0.01,2,3\n0.02,3,4\n")  # on the first row pandas would take an index
    with pytest.raises(DataError, match=r"row 0 \(line 2 .*\) has 4 fields"):
        read_record(path)


def test_a_long_line_with_no_separator_gives_one_line_naming_the_file(tmp_path, capsys):
    path = tmp_path / "blob.csv"
    path.write_text("x" * 2_000_000 + "\n1\n")  # beyond the csv module's field limit of 131072 characters
    code, _, err = run(capsys, "identify", str(path))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "blob.csv" in err


def test_a_corrupt_parquet_page_and_a_cut_mat_file_name_the_file(tmp_path, capsys):
    import scipy.io

    n = 2000
    df = pd.DataFrame({"t": np.arange(n) * DT, "u": np.sin(np.arange(n)), "y": np.cos(np.arange(n))})
    df.to_parquet(tmp_path / "a.parquet")  # snappy pages
    data = bytearray((tmp_path / "a.parquet").read_bytes())
    for i in range(200, 3000, 7):
        data[i] ^= 0xFF
    (tmp_path / "bad.parquet").write_bytes(bytes(data))
    scipy.io.savemat(tmp_path / "a.mat", {k: df[k].to_numpy() for k in df}, do_compression=True)
    data = (tmp_path / "a.mat").read_bytes()
    (tmp_path / "cut.mat").write_bytes(data[: len(data) * 2 // 3])
    for name in ("bad.parquet", "cut.mat"):
        code, _, err = run(capsys, "identify", str(tmp_path / name))
        assert code == 2 and len(err.strip().splitlines()) == 1 and name in err, err


def test_tdms_warnings_once_random_bytes_refused_and_time_from_the_increment(tmp_path, capsys, caplog):
    from nptdms import ChannelObject, RootObject, TdmsWriter

    n = 300
    with TdmsWriter(tmp_path / "a.tdms") as writer:
        writer.write_segment([RootObject(), *[
            ChannelObject("g", k, v, properties={"wf_increment": DT})
            for k, v in (("u", np.sin(np.arange(n) * 0.1)), ("y", np.cos(np.arange(n) * 0.1)))
        ]])  # fmt: skip
    # no time channel: the increment gives the time, as the README says
    code, out, err = run(capsys, "identify", str(tmp_path / "a.tdms"), "--estimator", "arx-rls", "--json")
    assert code == 0 and out["samples"] == n, err
    data = (tmp_path / "a.tdms").read_bytes()
    (tmp_path / "random.tdms").write_bytes(data[:28] + np.random.default_rng(0).bytes(3000))
    code, _, err = run(capsys, "identify", str(tmp_path / "random.tdms"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "random.tdms" in err, err
    # a cut last segment: npTDMS's warning said once (it printed twice), naming the file; the channel
    # it leaves whole reads (the cut one, 175 of 300 samples, is refused as shorter, with no warning)
    (tmp_path / "cut.tdms").write_bytes(data[: len(data) - 1000])
    with caplog.at_level(logging.WARNING):
        assert len(read_record(tmp_path / "cut.tdms", columns=["u"], other_columns=False)) == n
    warned = [r for r in caplog.records if "less data than expected" in r.getMessage()]
    assert (
        len(warned) == 1
        and "cut.tdms" in warned[0].getMessage()
        and warned[0].name.startswith("motorid.io.records.")
    )


def test_the_records_own_attrs_name_the_time_unit(tmp_path):
    """A record whose attrs say its time is in ms reads as --time-unit ms says, with no option."""
    n = 50
    df = pd.DataFrame({"t": 7 + 10 * np.arange(n), "u": np.sin(np.arange(n)), "y": np.cos(np.arange(n))})
    df.attrs["units"] = {"t": "ms", "u": "V", "y": "rad/s"}
    write_record(df, tmp_path / "ms.csv")
    rec = read_record(tmp_path / "ms.csv")
    assert (
        rec.attrs["dt"] == DT and rec.attrs["units"]["t"] == "s" and rec.attrs["converted_from"]["t"] == "ms"
    )
    np.testing.assert_array_equal(rec["t"], np.arange(n) * 10 * 1e-3)
    with pytest.raises(DataError, match="time_unit="):  # the option overrides the attrs
        read_record(tmp_path / "ms.csv", time_unit="s")


def test_a_unit_in_brackets_at_the_end_of_a_named_columns_header_is_read_as_its_unit(
    tmp_path, planted, capsys
):
    """``Zeit [ms]``, ``PWM (%)``, ``Drehzahl [rpm]``: with the columns named and no unit option, the
    headers say the units; an option overrides its header; a bracket that names no unit motorid
    knows for that column (``[sec]``, ``[counts/s]``) says nothing."""
    rec = planted.record
    path = tmp_path / "headers.csv"
    pd.DataFrame({
        "Zeit [ms]": 5_000 + 10 * np.arange(len(rec)), "PWM (%)": rec["u"] / SUPPLY * 100,
        "Drehzahl [rpm]": rec["y"] * RPM, "Strom [A]": 0.0,
    }).to_csv(path, sep=";", decimal=",", index=False)  # fmt: skip
    names = {"time": "Zeit [ms]", "input": "PWM (%)", "output": "Drehzahl [rpm]"}
    got = read_record(path, **names, supply_voltage=SUPPLY)
    assert got.attrs["dt"] == DT and got.attrs["time_origin"] == pytest.approx(5.0)
    assert got.attrs["units"] == {"t": "s", "u": "V", "y": "rad/s"}
    assert got.attrs["converted_from"] == {"t": "ms", "u": "%", "y": "rpm"}
    # against the simulated record: rpm -> rad/s and duty -> volts, independently of the reader
    np.testing.assert_allclose(got["y"], rec["y"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got["u"], rec["u"], rtol=1e-9, atol=1e-12)
    # the option wins over the header: the speed read as it stands, in rad/s
    as_given = read_record(path, **names, supply_voltage=SUPPLY, output_unit="rad/s")
    np.testing.assert_allclose(as_given["y"], rec["y"] * RPM, rtol=1e-9)
    # the command line alike: the doctor's forces in volts, its speed in rad/s, with no unit option
    code, out, err = run(capsys, "doctor", str(path), "--time", "Zeit [ms]", "--input", "PWM (%)", "--output",
                         "Drehzahl [rpm]", "--supply-voltage", str(SUPPLY), "--max-steps", "0", "--json")  # fmt: skip
    assert code == 0, err
    assert out["settings"]["dt"] == pytest.approx(DT)
    assert out["units"]["velocity"] == "rad/s" and out["units"]["input"] == "V"
    # revolutions per minute as a spreadsheet writes them, and µs
    for header in ("n [1/min]", "n [U/min]"):
        pd.DataFrame(
            {"t [µs]": 10_000 * np.arange(len(rec)), "u [V]": rec["u"], header: rec["y"] * RPM}
        ).to_csv(tmp_path / "alias.csv", index=False)
        alias = read_record(tmp_path / "alias.csv", time="t [µs]", input="u [V]", output=header)
        assert alias.attrs["dt"] == DT and alias.attrs["converted_from"] == {"t": "us", "y": "rpm"}
        np.testing.assert_allclose(alias["y"], rec["y"], rtol=1e-9, atol=1e-12)
    # brackets that name no unit of that column leave it unnamed
    other = tmp_path / "other.csv"
    pd.DataFrame({"t [sec]": rec["t"], "u [V]": rec["u"], "n [counts/s]": rec["y"]}).to_csv(
        other, index=False
    )
    plain = read_record(other, time="t [sec]", input="u [V]", output="n [counts/s]")
    assert plain.attrs["units"] == {"t": "s", "u": "V"}  # t in s by default, y unnamed
    np.testing.assert_allclose(plain["y"], rec["y"], rtol=1e-12)
