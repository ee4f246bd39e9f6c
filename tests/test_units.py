"""Units at the edge: records in rpm, rev/s, degrees or PWM duty are converted once, as they are read."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from cli_fixtures import run
from emps_fixtures import real_motor_file

from motorid.errors import DataError
from motorid.units import convert_record

WHEEL = real_motor_file("wheel_free_train_motor1.csv")


def _record(u, y, units=None) -> pd.DataFrame:
    df = pd.DataFrame({"t": 0.01 * np.arange(len(u)), "u": u, "y": y})
    if units is not None:
        df.attrs["units"] = units
    return df


@pytest.mark.parametrize(
    ("unit", "value", "si", "si_unit"),
    [
        ("rpm", 60.0, 2 * math.pi, "rad/s"),  # one revolution a second
        ("rev/min", 30.0, math.pi, "rad/s"),
        ("rev/s", 0.5, math.pi, "rad/s"),
        ("rps", 2.0, 4 * math.pi, "rad/s"),
        ("deg/s", 180.0, math.pi, "rad/s"),
        ("rad/s", 3.0, 3.0, "rad/s"),
        ("deg", 90.0, math.pi / 2, "rad"),
        ("rev", 1.0, 2 * math.pi, "rad"),
        ("mm", 250.0, 0.25, "m"),
        ("mm/s", 5.0, 0.005, "m/s"),
    ],
)
def test_output_units_convert_to_si(unit, value, si, si_unit):
    out = convert_record(_record([1.0, 2.0], [value, -value]), output_unit=unit)
    # one product with a factor of a few ulps of error: 4 eps relative
    np.testing.assert_allclose(out["y"], [si, -si], rtol=4 * np.finfo(float).eps)
    assert out.attrs["units"]["y"] == si_unit
    if unit != si_unit:
        assert out.attrs["converted_from"]["y"] == unit


def test_pwm_duty_becomes_volts_only_with_a_supply_voltage():
    record = _record([-50.0, 25.0], [0.0, 1.0])
    kept = convert_record(record, input_unit="%")
    np.testing.assert_array_equal(kept["u"], [-50.0, 25.0])
    assert kept.attrs["units"]["u"] == "%"
    volts = convert_record(record, input_unit="%", supply_voltage=15.0)
    np.testing.assert_allclose(volts["u"], [-7.5, 3.75], rtol=4 * np.finfo(float).eps)
    assert volts.attrs["units"]["u"] == "V" and volts.attrs["converted_from"]["u"] == "%"
    np.testing.assert_array_equal(record["u"], [-50.0, 25.0])  # the caller's record is untouched


def test_the_files_own_units_are_used_and_an_option_overrides_them():
    record = _record([1.0, 2.0], [60.0, 120.0], units={"t": "s", "u": "mV", "y": "rpm"})
    out = convert_record(record)
    np.testing.assert_allclose(out["u"], [1e-3, 2e-3])
    np.testing.assert_allclose(out["y"], [2 * math.pi, 4 * math.pi])
    overridden = convert_record(record, input_unit="V", output_unit="rev/s")
    np.testing.assert_allclose(overridden["y"], [120 * math.pi, 240 * math.pi])
    # a unit the file declares without a factor here (a force input) is kept as it is
    force = convert_record(_record([1.0, 2.0], [0.1, 0.2], units={"u": "N", "y": "m"}))
    np.testing.assert_array_equal(force["u"], [1.0, 2.0])
    assert force.attrs["units"] == {"u": "N", "y": "m"}


def test_bad_units_are_named():
    with pytest.raises(DataError, match=r"output_unit=\.\.\.: unknown unit 'furlong/s'.*rpm"):
        convert_record(_record([1.0], [1.0]), output_unit="furlong/s")
    with pytest.raises(DataError, match="supply_voltage="):
        convert_record(_record([1.0], [1.0]), input_unit="%", supply_voltage=-5.0)


@pytest.mark.skipif(not WHEEL.exists(), reason=f"real motor data not found at {WHEEL} (set MOTORID_DATA)")
def test_a_real_record_in_rev_s_identifies_as_the_same_record_in_rad_s(capsys, tmp_path):
    """The wheel motor record (PWM %, rev/s) read with --output-unit rev/s is the record converted by hand."""
    by_hand = pd.read_csv(WHEEL)
    by_hand["y"] = by_hand["y"] * (2 * math.pi)  # the README's rule: rev/s times 2 pi
    by_hand.to_csv(tmp_path / "rad_s.csv", index=False)
    argv = ["identify", "--estimator", "arx-rls", "--na", "2", "--nb", "2", "--json", "--input-unit", "%"]
    code, converted, _ = run(capsys, *argv, str(WHEEL), "--output-unit", "rev/s")
    assert code == 0
    # named rad/s: a record that names no unit gets no rpm band (the low-speed scores would differ)
    code, reference, _ = run(capsys, *argv, str(tmp_path / "rad_s.csv"), "--output-unit", "rad/s")
    assert code == 0
    assert converted["params"] == reference["params"] and converted["scores"] == reference["scores"]


def test_a_record_that_names_no_units_is_used_as_it_is():
    record = _record([1.0, 2.0], [3.0, 4.0])
    out = convert_record(record)
    pd.testing.assert_frame_equal(out, record)
    assert "units" not in out.attrs  # nothing invents V and rad/s for it
    with pytest.raises(DataError, match=r"supply_voltage=\.\.\..*input_unit='%'"):
        convert_record(record, supply_voltage=12.0)


# --------------------------------------------------------------------------- how units are shown
@pytest.mark.parametrize(
    ("unit", "quantity", "shown", "factor"),
    [
        ("rad/s", "speed", "rpm", 60.0 / (2.0 * math.pi)),  # the paper's rpm: 1 rad/s = 9.549 rpm
        ("rev/s", "speed", "rev/s", 1.0),
        ("mm/s", "speed", "mm/s", 1.0),
        ("rad", "position", "rad", 1.0),
        ("N", "output", "N", 1.0),  # a unit with no factor here is shown as it is
        (None, "output", "output units", 1.0),  # none named: none invented
    ],
)
def test_an_output_is_shown_in_its_own_unit_and_rad_s_as_rpm(unit, quantity, shown, factor):
    from motorid.units import shown_output

    result = shown_output(unit)
    assert (result.quantity, result.unit) == (quantity, shown)
    assert result.factor == pytest.approx(factor, rel=1e-15)


def test_unit_names_of_inputs_rates_and_ratios():
    from motorid.units import input_unit_name, per, rate

    assert input_unit_name("%") == "%" and input_unit_name(None) == "input units"
    assert rate("rad") == "rad/s" and rate(None) == "output units/s"
    assert per("rad/s", "V") == "rad/s per V"
    assert per("output units", input_unit_name(None)) == "output units per input unit"
