"""One RecordOptions, passed whole: the readers, the doctor and the application layer take the object
and its fields as keyword arguments alike, a bad field is refused naming it, and the command line
builds the object from its flags and says each field as its flag."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from motorid.diagnose import diagnose
from motorid.diagnose.synthetic import planted_record
from motorid.errors import DataError, UniformGridError
from motorid.io.records import RecordOptions, iter_record, normalise_record, read_head, read_record

SUPPLY = 24.0  # [V]
RPM = 60.0 / (2.0 * np.pi)


@pytest.fixture(scope="module")
def drive():
    return planted_record("coulomb_friction", 7, sizes={"coulomb": 8e-3})


@pytest.fixture(scope="module")
def logged(drive):
    """The drive as a logger writes it: ms stamps, duty in %, speed in rpm."""
    rec = drive.record
    return pd.DataFrame(
        {"ms": 10 * np.arange(len(rec)), "pwm": rec["u"] / SUPPLY * 100.0, "rpm": rec["y"] * RPM}
    )


OPTIONS = RecordOptions(time="ms", time_unit="ms", input="pwm", input_unit="%", supply_voltage=SUPPLY,
                        output="rpm", output_unit="rpm")  # fmt: skip
FIELDS = {"time": "ms", "time_unit": "ms", "input": "pwm", "input_unit": "%", "supply_voltage": SUPPLY,
          "output": "rpm", "output_unit": "rpm"}  # fmt: skip


@pytest.fixture()
def log_csv(tmp_path, logged):
    path = tmp_path / "log.csv"
    logged.to_csv(path, index=False)
    return path


def test_the_object_and_its_fields_read_the_same_record(log_csv, drive):
    """read_record(path, options) equals read_record(path, **fields), and both give the drive's
    own record back in V and rad/s (the CSV's 18 digits: within 1e-12 relative)."""
    whole = read_record(log_csv, OPTIONS)
    pd.testing.assert_frame_equal(whole, read_record(log_csv, **FIELDS), check_exact=True)
    np.testing.assert_allclose(whole["u"], drive.record["u"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(whole["y"], drive.record["y"], rtol=1e-12, atol=1e-15)
    assert whole.attrs["dt"] == pytest.approx(0.01) and whole.attrs["units"] == {
        "t": "s",
        "u": "V",
        "y": "rad/s",
    }


def test_a_field_given_by_name_overrides_the_objects(log_csv):
    spanned = read_record(log_csv, OPTIONS, start=5.0, stop=15.0)
    assert spanned["t"].iloc[0] == pytest.approx(5.0) and spanned["t"].iloc[-1] == pytest.approx(15.0)
    assert len(spanned) == 1001  # 5 s to 15 s at 10 ms, both ends kept
    assert OPTIONS.start is None  # the object itself is as it was


def test_the_blocks_are_the_whole_record_and_a_span_is_cut_from_the_whole(log_csv):
    whole = read_record(log_csv, OPTIONS)
    blocks = list(iter_record(log_csv, OPTIONS, chunk_rows=700))
    assert [len(b) for b in blocks] == [700, 700, 700, 700, 200]
    pd.testing.assert_frame_equal(pd.concat(blocks), whole, check_exact=True)
    with pytest.raises(UniformGridError, match=r"a span \(start, stop\) is cut from the record read whole"):
        next(iter_record(log_csv, OPTIONS, stop=10.0))


def test_read_head_takes_max_samples_from_the_options(log_csv):
    head, segment = read_head(log_csv, OPTIONS, max_samples=1000)
    assert segment and len(head) == 1000
    pd.testing.assert_frame_equal(head, read_record(log_csv, OPTIONS).iloc[:1000], check_exact=True)
    whole, segment = read_head(log_csv, OPTIONS)  # no limit: the whole record
    assert not segment and len(whole) == 3000
    with pytest.raises(DataError, match=r"has 3000 rows, more than the limit of 1000 samples \(max_samples"):
        read_record(log_csv, OPTIONS, max_samples=1000)


def test_normalise_record_takes_the_object_and_keeps_its_span(logged, log_csv):
    from_frame = normalise_record(logged, OPTIONS, stop=10.0)
    from_file = read_record(log_csv, OPTIONS, stop=10.0)
    assert len(from_frame) == 1001
    pd.testing.assert_frame_equal(
        from_frame[["t", "u", "y"]], from_file[["t", "u", "y"]], check_exact=False, rtol=1e-12
    )  # fmt: skip  (the CSV's shortest round-trip digits)


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"time_unit": "min"}, r"time_unit=\.\.\. must be one of s, ms, us, ns, got 'min'"),
        ({"start": 3.0, "stop": 1.0}, r"stop=1 must be after start=3 \[s\]"),
        ({"start": -1.0}, r"start=\.\.\. must be a time >= 0 \[s\]"),
        ({"max_samples": 0}, r"max_samples=\.\.\. must be an integer >= 1, got 0"),
        ({"sep": ",", "decimal": ","}, r"sep=\.\.\. and decimal=\.\.\. are both ','"),
        ({"comment": "a\nb"}, r"comment=\.\.\. must be the text comment lines begin with"),
        ({"sheet": 3}, r"sheet=\.\.\. must name a sheet"),
        ({"input": "u", "output": "u"}, r"output=\.\.\. 'u' is the same column as input=\.\.\. 'u'"),
    ],
)
def test_a_bad_field_is_refused_naming_it(fields, message):
    with pytest.raises(DataError, match=message):
        RecordOptions(**fields)
    with pytest.raises(DataError, match=message):  # the same through a reader's keyword arguments
        RecordOptions.of(OPTIONS, **fields)


def test_a_keyword_that_is_no_field_names_the_fields(log_csv):
    with pytest.raises(
        DataError, match=r"'time_units' is no record option; the record options are .*time_unit"
    ):
        read_record(log_csv, time_units="ms")
    with pytest.raises(DataError, match="options must be a RecordOptions, got dict"):
        read_record(log_csv, dict(FIELDS))


def test_split_tells_the_records_fields_from_a_commands_own():
    options, rest = RecordOptions.split(OPTIONS, {"na": 2, "output": "speed", "lam": 0.99})
    assert options == RecordOptions.of(OPTIONS, output="speed") and rest == {"na": 2, "lam": 0.99}


def test_diagnose_takes_the_object_as_its_fields_and_records_as_read(logged, drive):
    """diagnose(df, record_options=...) is diagnose(df, **fields); the records read already
    (as_read) give the same diagnosis without being read again."""
    kw = {"input_gain": drive.input_gain, "max_steps": 1, "structure": False}
    by_object = diagnose(logged, record_options=OPTIONS, **kw)
    by_fields = diagnose(logged, **FIELDS, **kw)
    as_read = diagnose(normalise_record(logged, OPTIONS, min_samples=20), as_read=True, **kw)
    assert by_object.to_dict() == by_fields.to_dict()
    assert by_object.named == ["coulomb_friction"] == as_read.named
    assert as_read.to_dict()["final_gap"] == by_object.to_dict()["final_gap"]  # the same record, fitted alike
    with pytest.raises(DataError, match="record_options: records as_read are not read again"):
        diagnose(logged, as_read=True, input="pwm", **kw)


def test_the_command_line_builds_the_object_from_its_flags_and_says_fields_as_flags(log_csv):
    from motorid.cli import build_parser
    from motorid.cli.options import FLAGS, record_options_from_args, with_flags

    args = build_parser().parse_args(
        ["identify", str(log_csv), "--time", "ms", "--time-unit", "ms", "--input", "pwm", "--input-unit", "%",
         "--supply-voltage", "24", "--output", "rpm", "--output-unit", "rpm", "--stop", "10"]
    )  # fmt: skip
    assert record_options_from_args(args) == RecordOptions.of(OPTIONS, stop=10.0, max_samples=2_000_000)
    assert {f for f in FLAGS if f in RecordOptions.__dataclass_fields__} == set(
        RecordOptions.__dataclass_fields__
    ) - {"dt_rtol"}  # every field but the tolerance has its flag
    assert with_flags("model=rig.json: holds a ARXRLS (a rigid drive the doctor's save_model=... wrote)") == (
        "--model rig.json: holds a ARXRLS (a rigid drive the doctor's --save-model wrote)"
    )
