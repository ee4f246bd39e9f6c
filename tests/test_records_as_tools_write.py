"""Records as loggers and tools write them: each file kind written as its tool writes it, loaded with
the documented options, gives the record (and the model) of the original.

The original is one simulated drive with a planted Coulomb friction
(:func:`motorid.diagnose.synthetic.planted_record`, 3000 samples of 10 ms), rounded to
the digits a logger keeps and written as a plain CSV: time [s], input [V], speed [rpm].
Every other file holds the same digits in another form (comment lines, a units row,
dates, thousands separators, compression, a repeated row, encoder counts, sign and
magnitude, Excel), so it must read as the same record, and ``motorid identify`` must
give the same model.
"""

from __future__ import annotations

import gzip
import logging
import math
import re
import zipfile
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run
from hypothesis import given, settings
from hypothesis import strategies as st

from motorid.diagnose.synthetic import planted_record
from motorid.errors import DataError
from motorid.io.records import FORMATS_READ, iter_record, normalise_record, read_record

RPM = 60.0 / (2.0 * math.pi)
DT = 0.01
N = 2048  # encoder counts per revolution
SUPPLY = 24.0  # [V]
START = pd.Timestamp("2026-11-28T10:00:00")


@pytest.fixture(scope="module")
def original():
    """The logger's numbers: t [s], u [V] to 4 decimals, y [rpm] to 2 decimals."""
    rec = planted_record("coulomb_friction", 7, sizes={"coulomb": 8e-3}).record
    return pd.DataFrame({
        "t": np.round(np.arange(len(rec)) * DT, 2),
        "u": rec["u"].round(4),
        "y": (rec["y"] * RPM).round(2),
    })  # fmt: skip


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("tools")


@pytest.fixture(scope="module")
def reference(original, folder):
    path = folder / "original.csv"
    original.to_csv(path, index=False)
    return read_record(path, output_unit="rpm")


def _same(record: pd.DataFrame, reference: pd.DataFrame, t_atol: float = 0.0) -> None:
    """u and y equal bit for bit (the same decimal digits parsed); t within ``t_atol`` [s]."""
    assert len(record) == len(reference)
    np.testing.assert_array_equal(record["u"].to_numpy(), reference["u"].to_numpy())
    np.testing.assert_array_equal(record["y"].to_numpy(), reference["y"].to_numpy())
    np.testing.assert_allclose(record["t"].to_numpy(), reference["t"].to_numpy(), rtol=0, atol=t_atol)
    assert record.attrs["dt"] == pytest.approx(DT, rel=1e-12)
    assert record.attrs["units"]["y"] == "rad/s"


# --------------------------------------------------------------------------- comment lines, units row
def test_comment_lines_before_the_header_are_the_records_notes(original, folder, reference):
    path = folder / "arduino.csv"
    path.write_text("# Arduino speed log\n# motor 1, 24 V supply\n" + original.to_csv(index=False))
    record = read_record(path, output_unit="rpm")
    _same(record, reference)
    assert record.attrs["notes"] == ["Arduino speed log", "motor 1, 24 V supply"]
    other = folder / "slashes.csv"
    other.write_text("// logger v2\n" + original.to_csv(index=False))
    _same(read_record(other, output_unit="rpm", comment="//"), reference)
    with pytest.raises(
        DataError, match=r"is the header a comment line\? name the comment lines' prefix with comment="
    ):
        read_record(other, output_unit="rpm")
    hashed = folder / "hashed.csv"  # a header whose first name begins with '#', read with no comment prefix
    hashed.write_text(original.rename(columns={"t": "#t"}).to_csv(index=False))
    _same(read_record(hashed, time="#t", output_unit="rpm", comment=""), reference)


def test_a_units_row_under_the_header_gives_the_columns_units(original, folder, reference):
    path = folder / "units_row.csv"
    path.write_text("t,u,y\ns,V,rpm\n" + original.to_csv(index=False, header=False))
    record = read_record(path)  # no option names a unit: the row does
    _same(record, reference)
    assert record.attrs["converted_from"] == {"y": "rpm"}
    # a data row's line is counted past the units row
    bad = folder / "units_row_bad.csv"
    bad.write_text("t,u,y\ns,V,rpm\n0,1,2\n0.01,x,3\n")
    with pytest.raises(DataError, match=r"'x' at row 1 \(line 4 of"):
        read_record(bad)
    wrong = folder / "units_row_wrong.csv"
    wrong.write_text("t,u,y\ns,rpm,rpm\n0,1,2\n0.01,1,3\n")
    with pytest.raises(
        DataError, match=r"gives column 'u' the unit 'rpm', which is no unit of its kind .*input_unit"
    ):
        read_record(wrong)


# --------------------------------------------------------------------------- time as dates and clock times
def test_iso_8601_and_clock_time_columns_read_as_time(original, folder, reference):
    stamps = START + pd.to_timedelta(original["t"], unit="s")
    iso = original.assign(t=stamps.dt.strftime("%Y-%m-%dT%H:%M:%S.%f").str[:-3])
    iso.to_csv(folder / "iso.csv", index=False)
    record = read_record(folder / "iso.csv", output_unit="rpm")
    # ns since 1970 to s from 0: k * 1e7 ns * 1e-9 and the parsed decimal k * 0.01 agree within 1e-15 s
    _same(record, reference, t_atol=1e-12)
    assert record.attrs["time"] == "2026-11-28T10:00:00"
    clock = original.assign(t=stamps.dt.strftime("%H:%M:%S.%f").str[:-3])
    clock.to_csv(folder / "clock.csv", index=False)
    _same(read_record(folder / "clock.csv", output_unit="rpm"), reference, t_atol=1e-12)
    # a clock that passes midnight goes on the next day
    midnight = original.assign(t=(pd.Timestamp("2026-11-28T23:59:50") + pd.to_timedelta(original["t"], unit="s"))
                               .dt.strftime("%H:%M:%S.%f").str[:-3])  # fmt: skip
    midnight.to_csv(folder / "midnight.csv", index=False)
    _same(read_record(folder / "midnight.csv", output_unit="rpm"), reference, t_atol=1e-9)
    with pytest.raises(
        DataError, match=r"time_unit='ms' was given, but the time column 't' .* holds iso stamps"
    ):
        read_record(folder / "iso.csv", output_unit="rpm", time_unit="ms")


def test_datetime64_from_pandas_parquet_and_a_dataframe_read_as_time(original, folder, reference):
    frame = original.assign(t=START + pd.to_timedelta(original["t"], unit="s"))
    _same(normalise_record(frame, output_unit="rpm"), reference, t_atol=1e-12)
    frame.to_parquet(folder / "dates.parquet")
    _same(read_record(folder / "dates.parquet", output_unit="rpm"), reference, t_atol=1e-12)
    blocks = pd.concat(list(iter_record(folder / "dates.parquet", output_unit="rpm", chunk_rows=700)))
    _same(blocks.reset_index(drop=True), reference, t_atol=1e-12)
    zoned = frame.assign(t=frame["t"].dt.tz_localize("Europe/Berlin"))
    _same(normalise_record(zoned, output_unit="rpm"), reference, t_atol=1e-12)


# --------------------------------------------------------------------------- thousands separators
def _grouped(values: pd.Series, thousands: str, decimal: str) -> pd.Series:
    text = values.map(lambda v: f"{v:,.2f}")
    return text.str.replace(",", "\0").str.replace(".", decimal).str.replace("\0", thousands)


def test_thousands_separators_are_detected_with_the_decimal_mark(original, folder, reference, caplog):
    assert (original["y"].abs() >= 1000).any() and (original["y"].abs().iloc[:50] < 1000).all()
    english = original.assign(y=_grouped(original["y"], ",", "."))  # -1,035.70, quoted by pandas
    english.to_csv(folder / "thousands.csv", index=False)
    german = original.assign(y=_grouped(original["y"], ".", ","), u=original["u"].map(lambda v: f"{v}".replace(".", ",")),
                             t=original["t"].map(lambda v: f"{v}".replace(".", ",")))  # fmt: skip
    german.to_csv(folder / "tausend.csv", sep=";", index=False)
    for name in ("thousands.csv", "tausend.csv"):
        # the grouped numbers start past the first lines: found where they are, the record read again
        _same(read_record(folder / name, output_unit="rpm"), reference)
        given = read_record(
            folder / name, output_unit="rpm", thousands="," if name == "thousands.csv" else "."
        )
        _same(given, reference)
    first = int(np.flatnonzero(original["y"].abs() >= 1000)[0]) - 5  # a grouped number in the first lines
    german.iloc[first:].to_csv(folder / "tausend_head.csv", sep=";", index=False)
    original.iloc[first:].to_csv(folder / "original_head.csv", index=False)
    with caplog.at_level(logging.INFO, logger="motorid.io.records"):
        head = read_record(folder / "tausend_head.csv", output_unit="rpm")
    assert (
        "separator ';' (detected), decimal mark ',' (detected), thousands separator '.' (detected)"
        in caplog.text
    )
    _same(head, read_record(folder / "original_head.csv", output_unit="rpm"))
    with pytest.raises(DataError, match="thousands=',' is also the decimal mark"):
        read_record(folder / "thousands.csv", decimal=",", thousands=",")


def test_the_command_line_reads_thousands_in_blocks_by_reading_the_record_whole(capsys, folder, reference):
    code, out, err = run(capsys, "identify", str(folder / "thousands.csv"), "--output-unit", "rpm",
                         "--estimator", "arx-rls", "--json")  # fmt: skip
    assert code == 0, err
    code, base, err = run(capsys, "identify", str(folder / "original.csv"), "--output-unit", "rpm",
                          "--estimator", "arx-rls", "--json")  # fmt: skip
    assert code == 0, err
    assert out["params"] == base["params"]


# --------------------------------------------------------------------------- compressed files
@pytest.mark.parametrize("suffix", [".csv.gz", ".csv.bz2", ".csv.xz", ".zip"])
def test_compressed_records_read_as_they_decompress(original, folder, reference, suffix):
    path = folder / f"packed{suffix}"
    compression = {"method": "zip", "archive_name": "log.csv"} if suffix == ".zip" else "infer"
    original.to_csv(path, index=False, compression=compression)
    _same(read_record(path, output_unit="rpm"), reference)
    blocks = pd.concat(list(iter_record(path, output_unit="rpm", chunk_rows=1000)))
    _same(blocks.reset_index(drop=True), reference)


def test_cut_or_crowded_archives_are_refused_naming_the_file(original, folder):
    whole = gzip.compress(original.to_csv(index=False).encode())
    (folder / "cut.csv.gz").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(DataError, match=r"cut\.csv\.gz: its gzip data cannot be read \(cut or corrupt\?\)"):
        read_record(folder / "cut.csv.gz")
    with zipfile.ZipFile(folder / "two.zip", "w") as archive:
        archive.writestr("a.csv", "t,u,y\n")
        archive.writestr("b.csv", "t,u,y\n")
    with pytest.raises(DataError, match=r"two\.zip holds 2 files \['a\.csv', 'b\.csv'\], not one record"):
        read_record(folder / "two.zip")
    original.to_parquet(folder / "inner.parquet")
    with zipfile.ZipFile(folder / "parquet.zip", "w") as archive:
        archive.write(folder / "inner.parquet", "inner.parquet")
    with pytest.raises(
        DataError, match=r"holds 'inner\.parquet', a Parquet file: compressed records are read when"
    ):
        read_record(folder / "parquet.zip")
    (folder / "x.parquet.gz").write_bytes(gzip.compress(b"PAR1"))
    with pytest.raises(DataError, match="compressed Parquet file"):
        read_record(folder / "x.parquet.gz")


# --------------------------------------------------------------------------- repeated time stamps
def test_a_sample_logged_twice_is_dropped_with_one_line(original, folder, reference, caplog):
    twice = pd.concat([original.iloc[:1500], original.iloc[1499:]]).reset_index(drop=True)
    twice.to_csv(folder / "twice.csv", index=False)
    with caplog.at_level(logging.WARNING, logger="motorid.io.records"):
        record = read_record(folder / "twice.csv", output_unit="rpm")
    _same(record, reference)
    said = [r.getMessage() for r in caplog.records if "repeated" in r.getMessage()]
    assert (
        len(said) == 1
        and "1 row repeated the time stamp of the row before with the same values; dropped" in said[0]
    )
    assert "the first at row 1500 (line 1502 of" in said[0]


def test_a_stamp_with_other_values_is_refused_naming_the_row_or_merged_as_asked(original, folder, reference):
    other = original.iloc[[1499]].assign(u=original["u"].iloc[1499] + 0.5)
    mixed = pd.concat([original.iloc[:1500], other, original.iloc[1500:]]).reset_index(drop=True)
    mixed.to_csv(folder / "mixed.csv", index=False)
    with pytest.raises(DataError, match=r"repeats the time stamp 14\.99 at row 1500 \(line 1502 .*column 'u'.*"
                                        r"duplicates=first\|last\|mean"):  # fmt: skip
        read_record(folder / "mixed.csv", output_unit="rpm")
    _same(read_record(folder / "mixed.csv", output_unit="rpm", duplicates="first"), reference)
    last = read_record(folder / "mixed.csv", output_unit="rpm", duplicates="last")
    assert last["u"].iloc[1499] == reference["u"].iloc[1499] + 0.5
    mean = read_record(folder / "mixed.csv", output_unit="rpm", duplicates="mean")
    assert mean["u"].iloc[1499] == pytest.approx(reference["u"].iloc[1499] + 0.25, rel=1e-12)
    np.testing.assert_array_equal(
        np.delete(mean["u"].to_numpy(), 1499), np.delete(reference["u"].to_numpy(), 1499)
    )


def test_the_command_line_reads_a_plc_trace_with_a_repeated_sample(capsys, folder):
    code, out, err = run(capsys, "identify", str(folder / "twice.csv"), "--output-unit", "rpm",
                         "--estimator", "arx-rls", "--json")  # fmt: skip
    assert code == 0, err
    code, base, _ = run(capsys, "identify", str(folder / "original.csv"), "--output-unit", "rpm",
                        "--estimator", "arx-rls", "--json")  # fmt: skip
    assert out["params"] == base["params"]
    code, _, err = run(
        capsys, "identify", str(folder / "mixed.csv"), "--output-unit", "rpm", "--estimator", "arx-rls"
    )
    assert code == 2 and "--duplicates first|last|mean" in err and "duplicates=" not in err, err
    code, _, err = run(capsys, "identify", str(folder / "mixed.csv"), "--output-unit", "rpm", "--estimator", "arx-rls",
                       "--duplicates", "first")  # fmt: skip
    assert code == 0, err


# --------------------------------------------------------------------------- encoder counts
def test_an_encoders_counts_read_as_a_position_and_give_the_speed(
    original, folder, reference, capsys, caplog
):
    speed = reference["y"].to_numpy()
    theta = np.cumsum(speed) * DT  # theta[k] - theta[k-1] = speed[k] dt
    counts = np.round(theta * N / (2 * np.pi)).astype(np.int64)
    pd.DataFrame({"t": original["t"], "u": original["u"], "enc": counts}).to_csv(
        folder / "encoder.csv", index=False
    )
    record = read_record(folder / "encoder.csv", output="enc", output_unit="counts", counts_per_rev=N)
    assert record.attrs["units"]["y"] == "rad" and record.attrs["converted_from"]["y"] == "counts"
    np.testing.assert_allclose(record["y"], counts * 2 * np.pi / N, rtol=1e-15)
    with pytest.raises(
        DataError, match=r"output_unit='counts' needs the encoder's counts per revolution: counts_per_rev="
    ):
        read_record(folder / "encoder.csv", output="enc", output_unit="counts")
    step = 2 * np.pi / N / DT  # [rad/s]: one count in one sample
    with caplog.at_level(logging.WARNING, logger="motorid.io.records"):
        code, out, err = run(capsys, "identify", str(folder / "encoder.csv"), "--output", "enc", "--output-unit",
                             "counts", "--counts-per-rev", str(N), "--estimator", "arx-rls", "--json")  # fmt: skip
    assert code == 0, err
    said = [r.getMessage() for r in caplog.records if "quantised" in r.getMessage()]
    assert len(said) == 1 and f"quantised in steps of {step:.4g} rad/s" in said[0], said
    assert out["samples"] == len(reference) - 1 and out["output_unit"] == "rad/s"
    differentiated = read_record(
        folder / "encoder.csv",
        output="enc",
        output_unit="counts",
        counts_per_rev=N,
        other_columns=False,
        speed=True,
    )
    # each speed within one count per sample of the original's (the counts are rounded to the nearest)
    assert np.max(np.abs(differentiated["y"].to_numpy() - speed[1:])) <= step * (1 + 1e-9)
    code, _, err = run(
        capsys, "identify", str(folder / "encoder.csv"), "--output", "enc", "--output-unit", "counts"
    )
    assert code == 2 and "--counts-per-rev" in err and "counts_per_rev" not in err, err
    caplog.clear()
    with caplog.at_level(
        logging.WARNING, logger="motorid.io.records"
    ):  # the doctor reads a segment, in blocks
        code, out, err = run(capsys, "doctor", str(folder / "encoder.csv"), "--output", "enc", "--output-unit",
                             "counts", "--counts-per-rev", str(N), "--max-steps", "0", "--json")  # fmt: skip
    assert code == 0, err
    assert [r.getMessage() for r in caplog.records if "quantised" in r.getMessage()] == said


# --------------------------------------------------------------------------- sign and magnitude
@pytest.fixture(scope="module")
def sign_magnitude(original, folder):
    """An 8-bit PWM's magnitude (0..255 of the 24 V supply) and a direction pin (1 forward, 0 backward)."""
    duty = np.round(original["u"].to_numpy() / SUPPLY * 255)
    signed = pd.DataFrame({"t": original["t"], "pwm": duty, "y": original["y"]})
    signed.to_csv(folder / "signed.csv", index=False)
    unsigned = pd.DataFrame({"t": original["t"], "pwm": np.abs(duty), "dir": (duty >= 0).astype(int),
                             "y": original["y"]})  # fmt: skip
    unsigned.to_csv(folder / "sign_magnitude.csv", index=False)
    return folder


PWM = ["--input", "pwm", "--input-unit", "counts", "--input-full-scale", "255", "--supply-voltage", str(SUPPLY),
       "--output-unit", "rpm"]  # fmt: skip


def test_a_direction_column_gives_the_unsigned_pwm_its_sign(sign_magnitude, capsys):
    options = dict(
        input="pwm", input_unit="counts", input_full_scale=255, supply_voltage=SUPPLY, output_unit="rpm"
    )
    signed = read_record(sign_magnitude / "signed.csv", **options)
    with pytest.raises(DataError, match=r"the input 'pwm' never changes sign \(>= 0\) while the output reverses.*"
                                        r"direction="):  # fmt: skip
        read_record(sign_magnitude / "sign_magnitude.csv", **options)
    record = read_record(sign_magnitude / "sign_magnitude.csv", **options, direction="dir")
    pd.testing.assert_frame_equal(record, signed)
    inverted = pd.read_csv(sign_magnitude / "sign_magnitude.csv").assign(dir=lambda d: 1 - d["dir"])
    inverted.to_csv(sign_magnitude / "inverted.csv", index=False)
    polarity = read_record(sign_magnitude / "inverted.csv", **options, direction="dir", direction_forward=0)
    pd.testing.assert_frame_equal(polarity, signed)
    # the command line: refused without --direction (the flag named), the same model with it
    code, _, err = run(
        capsys, "identify", str(sign_magnitude / "sign_magnitude.csv"), *PWM, "--estimator", "arx-rls"
    )
    assert code == 2 and "--direction" in err and "direction=" not in err and len(err.splitlines()) == 1, err
    code, out, err = run(capsys, "identify", str(sign_magnitude / "sign_magnitude.csv"), *PWM, "--direction", "dir",
                         "--estimator", "arx-rls", "--json")  # fmt: skip
    assert code == 0, err
    code, base, err = run(capsys, "identify", str(sign_magnitude / "signed.csv"), *PWM, "--estimator", "arx-rls",
                          "--json")  # fmt: skip
    assert code == 0, err
    assert out["params"] == base["params"]


def test_a_direction_column_with_a_third_value_or_a_signed_input_is_refused(sign_magnitude):
    frame = pd.read_csv(sign_magnitude / "sign_magnitude.csv")
    frame.loc[7, "dir"] = 2
    frame.to_csv(sign_magnitude / "three.csv", index=False)
    with pytest.raises(
        DataError, match=r"direction column 'dir' holds 2 at row 7 \(line 9 of .*a third value"
    ):
        read_record(sign_magnitude / "three.csv", input="pwm", direction="dir")
    pd.read_csv(sign_magnitude / "signed.csv").assign(dir=1).to_csv(sign_magnitude / "both.csv", index=False)
    with pytest.raises(DataError, match=r"input column 'pwm' is -\d+ at row \d+ .*must be a magnitude"):
        read_record(sign_magnitude / "both.csv", input="pwm", direction="dir")


# --------------------------------------------------------------------------- Excel
def test_an_excel_workbook_reads_by_sheet(original, folder, reference):
    path = folder / "log.xlsx"
    with pd.ExcelWriter(path, engine="openpyxl") as writer:
        pd.DataFrame({"note": ["bench 3"]}).to_excel(writer, sheet_name="about", index=False)
        original.to_excel(writer, sheet_name="log", index=False)
        original.assign(t=START + pd.to_timedelta(original["t"], unit="s")).to_excel(
            writer, sheet_name="dates", index=False
        )
    _same(read_record(path, output_unit="rpm", sheet="log"), reference)
    _same(read_record(path, output_unit="rpm", sheet="dates"), reference, t_atol=1e-9)  # Excel keeps µs
    with pytest.raises(DataError, match=r"column 'u' is missing from .*log\.xlsx; columns are \['note'\]"):
        read_record(path, output_unit="rpm")  # the first sheet
    with pytest.raises(
        DataError, match=r"has no sheet 'Tabelle1'; its sheets are \['about', 'log', 'dates'\] \(sheet="
    ):
        read_record(path, sheet="Tabelle1")
    blocks = pd.concat(list(iter_record(path, output_unit="rpm", sheet="log", chunk_rows=1000)))
    _same(blocks.reset_index(drop=True), reference)


def test_formats_that_are_not_read_say_which_are(original, folder, capsys):
    (folder / "old.xls").write_bytes(b"\xd0\xcf\x11\xe0" + bytes(100))
    with pytest.raises(DataError, match=r"old\.xls is an Excel 97-2003 workbook \(\.xls\), which is not read: "
                                        r"motorid reads CSV"):  # fmt: skip
        read_record(folder / "old.xls")
    (folder / "renamed.csv").write_bytes((folder / "log.xlsx").read_bytes())
    with pytest.raises(
        DataError, match=r"is not a text CSV file .*it looks like a ZIP archive \(an \.xlsx workbook"
    ):
        read_record(folder / "renamed.csv")
    code, _, err = run(capsys, "identify", str(folder / "old.xls"))
    assert code == 2 and FORMATS_READ in err, err


# --------------------------------------------------------------------------- bounded and contained
def test_a_huge_field_is_quoted_to_80_characters(folder, capsys):
    path = folder / "huge_field.csv"
    path.write_text("t,u,y\n0,1,2\n0.01," + "7" * 50 + "x" * 3_000_000 + ",3\n0.02,1,2\n")
    with pytest.raises(DataError) as refused:
        read_record(path)
    assert "3000050 characters" in str(refused.value) and len(str(refused.value)) < 400
    code, _, err = run(capsys, "identify", str(path))
    assert code == 2 and len(err) < 400, err[:500]


def test_hdf5_data_kept_in_other_files_is_refused(original, folder):
    outside = folder / "outside.h5"
    with h5py.File(outside, "w") as f:
        f["y"] = original["y"].to_numpy()
    linked = folder / "linked.h5"
    with h5py.File(linked, "w") as f:
        f["t"], f["u"] = original["t"].to_numpy(), original["u"].to_numpy()
        f["y"] = h5py.ExternalLink(str(outside), "/y")
    with pytest.raises(
        DataError, match=r"linked\.h5: 'y' is a link to .*outside\.h5.*read from its own file only"
    ):
        read_record(linked)
    raw = folder / "secret.bin"
    raw.write_bytes(original["y"].to_numpy().tobytes())
    external = folder / "external.h5"
    with h5py.File(external, "w") as f:
        f["t"], f["u"] = original["t"].to_numpy(), original["u"].to_numpy()
        f.create_dataset(
            "y", shape=(len(original),), dtype="f8", external=[(str(raw), 0, raw.stat().st_size)]
        )
    with pytest.raises(
        DataError, match=r"external\.h5: the dataset 'y' keeps its data in other files \(external"
    ):
        read_record(external)
    with pytest.raises(DataError, match="keeps its data in other files"):
        next(iter_record(external))


def test_library_errors_name_fields_and_the_command_line_flags(folder):
    with pytest.raises(DataError) as refused:
        read_record(folder / "encoder.csv", output="enc", output_unit="counts")
    assert "counts_per_rev=" in str(refused.value) and "--" not in str(refused.value)


# --------------------------------------------------------------------------- MATLAB v7.3 as Simulink logs it
def _mat73(path, write) -> None:
    """A MATLAB v7.3 MAT-file as MATLAB writes it: HDF5 behind a 512-byte header of version 2.0."""
    with h5py.File(path, "w", userblock_size=512) as f:
        write(f)
    header = (
        b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sat Nov 28 10:00:00 2026 HDF5 schema 1.00 ."
    )
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116) + bytes(8) + b"\x00\x02IM")


def _char(text: str) -> np.ndarray:
    return np.array([[ord(c)] for c in text], dtype=np.uint16)  # MATLAB char: UTF-16 codes, one column


def _structure_with_time(f, name: str, time: np.ndarray, values: np.ndarray, label: str) -> None:
    """A To Workspace block's 'Structure With Time': name.time, name.signals.values, .label, .blockName."""
    group = f.create_group(name)
    group.attrs["MATLAB_class"] = np.bytes_("struct")
    group["time"] = time.reshape(1, -1)
    group["time"].attrs["MATLAB_class"] = np.bytes_("double")
    signals = group.create_group("signals")
    signals.attrs["MATLAB_class"] = np.bytes_("struct")
    signals["values"] = values.reshape(1, -1)
    signals["values"].attrs["MATLAB_class"] = np.bytes_("double")
    signals["dimensions"] = np.ones((1, 1))
    signals["label"] = _char(label)
    signals["label"].attrs["MATLAB_class"] = np.bytes_("char")
    group["blockName"] = _char(f"rig/{name}")
    group["blockName"].attrs["MATLAB_class"] = np.bytes_("char")


def test_a_simulink_structure_with_time_reads_by_signal_name(original, folder, reference):
    path = folder / "sim.mat"
    time = original["t"].to_numpy()

    def write(f):
        _structure_with_time(f, "u_log", time, original["u"].to_numpy(), "voltage")
        _structure_with_time(f, "y_log", time, original["y"].to_numpy(), "speed")

    _mat73(path, write)
    _same(read_record(path, input="u_log", output="y_log", output_unit="rpm"), reference)
    _same(read_record(path, input="voltage", output="speed", output_unit="rpm"), reference)  # by label
    blocks = pd.concat(
        list(iter_record(path, input="voltage", output="speed", output_unit="rpm", chunk_rows=999))
    )
    _same(blocks.reset_index(drop=True), reference)


def _matlab_object(f, name: str, kind: str) -> None:
    """A MATLAB object as a v7.3 MAT-file holds it: a reference into the file's subsystem, marked by
    its class and ``MATLAB_object_decode`` (3: a MATLAB class object)."""
    f[name] = np.array([[3707764736, 2, 1, 1, 1, 1]], dtype=np.uint32)
    f[name].attrs["MATLAB_class"] = np.bytes_(kind)
    f[name].attrs["MATLAB_object_decode"] = 3


#: What every refusal of a MATLAB object says: what is read, and how to save the object's signals.
READ_INSTEAD = (
    r"a MATLAB record is read as a numeric vector per variable \(any version of MAT-file, v7\.3 included\) or as "
    r"Simulink's 'Structure With Time' by signal name: log the signals as 'Structure With Time'.*"
    r"t = ts\.Time; y = ts\.Data"
)


@pytest.mark.parametrize(
    ("objects", "held"),
    [
        (
            {"logsout": "Simulink.SimulationData.Dataset"},
            "'logsout' \\(a Simulink\\.SimulationData\\.Dataset object\\)",
        ),
        (
            {"u_ts": "timeseries", "y_ts": "timeseries"},
            "'u_ts' \\(a timeseries object\\), 'y_ts' \\(a timeseries object\\)",
        ),
    ],
)
def test_a_file_of_simulink_objects_is_refused_saying_what_is_read_and_how_to_save_its_signals(
    folder, objects, held
):
    path = folder / f"{'_'.join(objects)}.mat"
    _mat73(path, lambda f: [_matlab_object(f, name, kind) for name, kind in objects.items()])
    with pytest.raises(
        DataError, match=f"holds only MATLAB objects, which are not read: {held}; {READ_INSTEAD}"
    ):
        read_record(path, input="u_log", output="y_log")


def test_the_objects_beside_a_record_are_no_columns(original, folder, reference, capsys):
    """A record saved beside the Dataset ``sim`` logged reads as the record; the Dataset asked for as a
    column is refused as an object (its reference into MATLAB's subsystem is no samples), and a
    column that is missing is refused naming the objects too."""
    path = folder / "beside_logsout.mat"

    def write(f):
        for column in original:
            f[column] = original[column].to_numpy().reshape(1, -1)
            f[column].attrs["MATLAB_class"] = np.bytes_("double")
        _matlab_object(f, "logsout", "Simulink.SimulationData.Dataset")

    _mat73(path, write)
    _same(read_record(path, output_unit="rpm"), reference)
    with pytest.raises(DataError, match=f"'logsout' is a Simulink\\.SimulationData\\.Dataset object, which is not read; "
                                        f"{READ_INSTEAD}"):  # fmt: skip
        read_record(path, output="logsout")
    with pytest.raises(DataError, match=r"column 'speed' is missing .* columns are \['t', 'u', 'y'\]; name the output "
                                        r"column with output=\.\.\.; .* also holds MATLAB objects, which are not read: "
                                        r"'logsout' \(a Simulink\.SimulationData\.Dataset object\)"):  # fmt: skip
        read_record(path, output="speed")
    code, _, err = run(capsys, "identify", str(path), "--output", "speed")  # the command line says its flag
    assert code == 2 and err.count("\n") == 1 and "name the output column with --output;" in err, err
    assert "'logsout' (a Simulink.SimulationData.Dataset object)" in err and "output=" not in err


def test_a_v7_mat_file_with_a_matlab_object_reads_its_vectors_and_refuses_the_object(
    original, folder, reference
):
    """MATLAB's default MAT-file (v7, scipy's reader): an object saved beside the record (here an
    old-style class object, as scipy writes one) is no column, and is refused when asked for."""
    import scipy.io
    from scipy.io.matlab import MatlabObject

    fields = np.zeros((1, 1), dtype=[("Data", object), ("Time", object)])
    fields[0, 0]["Data"], fields[0, 0]["Time"] = original["y"].to_numpy(), original["t"].to_numpy()
    ts = MatlabObject(fields, "timeseries")
    path = folder / "beside_ts_v7.mat"
    scipy.io.savemat(path, {**{c: original[c].to_numpy() for c in original}, "ts": ts})
    _same(read_record(path, output_unit="rpm"), reference)
    with pytest.raises(DataError, match=f"'ts' is a MATLAB object, which is not read; {READ_INSTEAD}"):
        read_record(path, output="ts")
    alone = folder / "ts_v7.mat"
    scipy.io.savemat(alone, {"ts": ts})
    with pytest.raises(DataError, match=f"holds only MATLAB objects, which are not read: 'ts' \\(a MATLAB object\\); "
                                        f"{READ_INSTEAD}"):  # fmt: skip
        read_record(alone)


# --------------------------------------------------------------------------- fields in the library, flags on the command line
ROOT = Path(__file__).resolve().parent.parent
#: A command-line flag in a string: ``--time-unit``, ``--model`` (not ``x--y`` nor a lone ``--``).
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z-]+")


def _flags_named(path: Path) -> list[tuple[int, str]]:
    """The strings of a module, its docstrings left out, that name a command-line flag: (line, text)."""
    import ast

    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef)
        and node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)
    }  # fmt: skip
    return [
        (node.lineno, node.value[:80])
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings
        and FLAG.search(node.value)
    ]  # fmt: skip


def _is_a_command_line(path: Path) -> bool:
    """A module that is a command line of its own (``python -m ...``, its flags its argparse's)."""
    return "import argparse" in path.read_text(encoding="utf-8")


def test_no_module_outside_the_command_line_names_a_flag():
    """The library's messages name fields and arguments (``time_unit=...``), which the command line
    says as flags (``--time-unit``, :func:`motorid.cli.options.with_flags`): no string of a module
    outside ``motorid/cli/`` (docstrings aside) names a flag."""
    found = {}
    for path in sorted((ROOT / "motorid").rglob("*.py")):
        module = str(path.relative_to(ROOT))
        if module.startswith("motorid/cli/") or _is_a_command_line(path):
            continue
        named = _flags_named(path)
        if named:
            found[module] = named
    assert found == {}, "strings that name a command-line flag: name the field (field=...) instead"


def test_the_command_line_says_each_field_as_its_flag():
    from motorid.cli.options import with_flags

    message = (
        "dt = 20 ms (dt=...) contradicts the time column; leave it out (or give its unit with time_unit=...); "
        "name it with direction=... and merge with duplicates=first|last|mean (resample=True resamples)"
    )
    assert with_flags(message) == (
        "dt = 20 ms (--dt) contradicts the time column; leave it out (or give its unit with --time-unit); "
        "name it with --direction and merge with --duplicates first|last|mean (--resample resamples)"
    )
    assert with_flags("stop=5 must be after start=6 [s]") == "--stop 5 must be after --start 6 [s]"


def test_the_fleet_and_the_daq_fields_are_said_as_their_flags_with_values_as_a_shell_takes_them():
    """``url`` is ``--daq``; a quoted value keeps its quotes only where a shell needs them."""
    from motorid.cli.options import with_flags

    assert with_flags("url='bogus://x': expected 'sim'") == "--daq bogus://x: expected 'sim'"
    assert with_flags("pattern='{drive}_{date:%Y%m%d}.csv' has neither") == (
        "--pattern '{drive}_{date:%Y%m%d}.csv' has neither"
    )
    assert with_flags("input='motor speed' is missing") == "--input 'motor speed' is missing"
    assert with_flags("a run per record (a doctor run without per_drive=True)") == (
        "a run per record (a doctor run without --per-drive)"
    )
    assert with_flags("out='/tmp/run': holds the results") == "--out /tmp/run: holds the results"


def test_an_excel_sheet_with_a_units_row_reads_in_those_units(original, folder, reference):
    import openpyxl

    workbook = openpyxl.Workbook()
    sheet = workbook.active
    sheet.title = "Messung"
    sheet.append(["Zeit", "Spannung", "Drehzahl"])
    sheet.append(["s", "V", "1/min"])  # the units row under the header
    for row in original.itertuples(index=False):
        sheet.append([float(row.t), float(row.u), float(row.y)])
    workbook.save(folder / "units.xlsx")
    record = read_record(folder / "units.xlsx", time="Zeit", input="Spannung", output="Drehzahl")
    _same(record, reference)
    assert record.attrs["converted_from"] == {"y": "rpm"}


@settings(max_examples=30, deadline=None)
@given(
    values=st.lists(st.floats(-5e6, 5e6, allow_nan=False), min_size=3, max_size=40),
    marks=st.sampled_from([(",", ".", ","), (".", ",", ";"), ("'", ".", ",")]),
)
def test_numbers_with_thousands_separators_read_as_written_without(tmp_path_factory, values, marks):
    """Any number written with a thousands separator (and the decimal mark it goes with) reads as the
    same number written plainly: the same decimal digits, so the same float."""
    thousands, decimal, sep = marks
    plain = [f"{v:.3f}" for v in values]
    grouped = [f"{v:,.3f}".replace(",", "\0").replace(".", decimal).replace("\0", thousands) for v in values]
    folder = tmp_path_factory.mktemp("grouped")
    quote = '"' if sep in thousands + decimal else ""
    lines = [
        f"{k * 0.01:.2f}".replace(".", decimal) + f"{sep}{quote}{g}{quote}{sep}{(-1) ** k}"  # a bipolar input
        for k, g in enumerate(grouped)
    ]
    (folder / "grouped.csv").write_text(f"t{sep}y{sep}u\n" + "\n".join(lines) + "\n")
    record = read_record(folder / "grouped.csv", thousands=thousands, decimal=decimal, sep=sep)
    np.testing.assert_array_equal(record["y"].to_numpy(), np.array([float(p) for p in plain]))
