"""The inertia's share of the input force below which a record does not determine it
(``INERTIA_SHARE_LIMIT``) holds its calibration (:func:`motorid.diagnose.calibration.inertia_shares`)
on kit-like records of an encoder's speed: a slow sine fits the inertia off the truth by many
standard errors and is flagged, a chirp fits it and is not."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.diagnose import diagnose
from motorid.diagnose.calibration import INERTIA_TOLERANCE, inertia_record, inertia_shares, main
from motorid.diagnose.results import INERTIA_SHARE_LIMIT


def test_records_below_the_share_limit_do_not_determine_the_inertia_and_those_above_do():
    # two drives, the signals at either side of the limit (the calibration's 300 records: 1.4-7.1 %
    # on the 0.25 and 0.5 Hz sines, 5.7-31.9 % on the rest)
    shares = inertia_shares([0, 1], ("sine 0.25", "sine 0.5", "chirp 2", "sine 2"))
    share, determined = np.array(shares.share), shares.determined
    assert np.all(determined == (share >= INERTIA_SHARE_LIMIT)), list(
        zip(shares.signals, share, shares.error, strict=True)
    )
    slow = np.array([s.startswith("sine 0.") for s in shares.signals])
    assert np.all(share[slow] < INERTIA_SHARE_LIMIT) and np.all(share[~slow] >= INERTIA_SHARE_LIMIT)
    # the slow sines' inertia is off by more than the tolerance and more than 2 standard errors
    assert np.all(np.abs(np.array(shares.error)[slow]) > INERTIA_TOLERANCE)
    assert np.all(np.abs(np.array(shares.z)[slow]) > 2.0)


def test_the_doctor_flags_the_inertia_of_a_slow_sine_and_not_of_a_chirp():
    base = ("viscous_friction", "coulomb_friction", "offset")
    record, _ = inertia_record("sine 0.5", 3)
    d = diagnose(record, base=base, max_steps=0)
    assert "inertia" in d.undetermined
    assert d.undetermined["inertia"].endswith(f"below {100 * INERTIA_SHARE_LIMIT:g} %")
    record, inertia = inertia_record("chirp 2", 3)
    d = diagnose(record, base=base, max_steps=0)
    assert "inertia" not in d.undetermined
    assert d.model.params["inertia"] == pytest.approx(inertia, rel=INERTIA_TOLERANCE)


def test_the_inertia_calibration_prints_what_it_measured(capsys):
    assert main(["--inertia", "--seeds", "1", "--first", "0"]) == 0
    out = capsys.readouterr().out
    shares = inertia_shares([0])
    assert out.startswith(f"{len(shares.share)} records; a record determines the inertia")
    assert f"every one: {shares.limit(1.0):.3f}" in out


def test_an_unknown_signal_is_refused():
    with pytest.raises(ValueError, match="signal must be one of"):
        inertia_record("square 1", 0)


def test_a_slow_sine_fits_the_inertia_low_by_the_noise_its_acceleration_carries():
    """Why a slow sine does not determine the inertia: the acceleration is the derivative of the
    measured speed, and the encoder's noise in it (errors in a regressor) pulls the least-squares
    inertia towards 0 by var(noise) / var(acceleration), which grows as the sine slows. Kept in a
    useful band of 10 Hz instead of the default 40 Hz (at 1 kHz), the same record fits it within
    1 % (measured: -8.1 % at 40 Hz, -0.2 % at 10 Hz; -56 % at 100 Hz)."""
    base = ("viscous_friction", "coulomb_friction", "offset")
    record, inertia = inertia_record("sine 0.25", 0)
    fitted = {
        band: diagnose(record, base=base, max_steps=0, band=band, structure=False).model.params["inertia"]
        for band in (10.0, 40.0, 100.0)
    }
    assert fitted[10.0] == pytest.approx(inertia, rel=INERTIA_TOLERANCE)
    assert fitted[40.0] < 0.95 * inertia
    assert fitted[100.0] < 0.6 * fitted[40.0]  # the more noise the band lets in, the lower


def test_a_sine_trades_the_inertia_for_an_input_delay_at_the_viscous_coefficient():
    """Why records that choose different input delays state different inertias: at frequencies
    well below 1 / τ_d a delay τ_d only adds the phase ω τ_d that an inertia J / B adds, so a
    record's balance determines J + B τ_d (B the viscous coefficient). On a 1 Hz sine of a drive
    without delay, each millisecond of delay held in the fit takes B x 1 ms off the inertia
    (measured: 0.99-1.00 B per second of delay on the 0.5 and 1 Hz sines and the 2 Hz chirp)."""
    from motorid.diagnose.model import fit_model
    from motorid.diagnose.workflow import prepare

    record, inertia = inertia_record("sine 1", 0)
    prep = prepare(record, band=10.0)
    effects = ("viscous_friction", "coulomb_friction", "offset", "input_delay")
    fits = [
        fit_model(prep.data, effects, fixed={"input_delay": delay}).model.params for delay in (0.0, 0.002)
    ]
    assert fits[0]["inertia"] == pytest.approx(inertia, rel=INERTIA_TOLERANCE)
    slope = (fits[0]["inertia"] - fits[1]["inertia"]) / 0.002
    assert slope == pytest.approx(fits[0]["viscous"], rel=0.1)
