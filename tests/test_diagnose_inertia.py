"""The inertia on kit-like records of an encoder's speed (:func:`motorid.diagnose.calibration.inertia_shares`):
the fit compensated for the noise in the acceleration states it within 1 % on every signal, and
the share of the input force below which a record does not determine it (``INERTIA_SHARE_LIMIT``)
still flags the slow sines, not the chirps."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.diagnose import diagnose
from motorid.diagnose.calibration import INERTIA_TOLERANCE, inertia_record, inertia_shares, main
from motorid.diagnose.kinematics import acceleration_noise, acceleration_noise_gain, kinematics
from motorid.diagnose.results import INERTIA_SHARE_LIMIT


def test_records_at_or_above_the_share_limit_determine_the_inertia_and_no_slow_sine_fits_it_low():
    # two drives, the signals at either side of the limit (the calibration's 300 records: 1.5-7.2 %
    # on the 0.25 and 0.5 Hz sines, 5.7-31.9 % on the rest). Compensated for the noise in the
    # acceleration, a slow sine's inertia is no longer pulled low (it was by 1-9 %): what is left is
    # the rigid model's own error on a filtered record, +0.2 to +0.9 % on every signal, and the
    # scatter of the weakest sines (the calibration: -0.9 to +1.5 % on the 0.25 Hz sines)
    shares = inertia_shares([0, 1], ("sine 0.25", "sine 0.5", "chirp 2", "sine 2"))
    share, determined, error = np.array(shares.share), shares.determined, np.array(shares.error)
    assert np.all(determined[share >= INERTIA_SHARE_LIMIT])
    slow = np.array([s.startswith("sine 0.") for s in shares.signals])
    assert np.all(share[slow] < INERTIA_SHARE_LIMIT) and np.all(share[~slow] >= INERTIA_SHARE_LIMIT)
    assert np.all(np.abs(error) < INERTIA_TOLERANCE), list(zip(shares.signals, error, strict=True))


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


def test_the_noise_gain_of_the_acceleration_is_that_of_white_noise_through_the_recipe():
    """G(dt, f_b) against the variance of the decimated acceleration of 200,000 samples of white
    noise of unit variance (20,000 decimated: the variance is known to about 1 %, 4 % is 4 of
    those) at 1 kHz in the default and a narrower band."""
    noise = np.random.default_rng(23).standard_normal(200_000)
    for band in (40.0, 10.0):
        kin = kinematics(np.zeros_like(noise), noise, 0.001, band=band)
        measured = float(np.var(kin.decimate(kin.a)))
        assert measured == pytest.approx(acceleration_noise_gain(0.001, band), rel=0.04)


def test_the_acceleration_noise_is_that_of_the_speed_noise_through_the_recipe():
    """A drive at a steady speed read with white noise of 0.5 rad/s: the record's estimate of the
    noise variance on its decimated acceleration against that of the noise alone through the
    recipe (5 % on 20,000 decimated samples: the variance is known to 1 %, the estimate from the
    part above the band to about 2 %)."""
    rng = np.random.default_rng(5)
    noise = 0.5 * rng.standard_normal(200_000)
    kin = kinematics(np.ones_like(noise), 100.0 + noise, 0.001)
    alone = kinematics(np.zeros_like(noise), noise, 0.001)
    assert acceleration_noise(kin, kin.valid) == pytest.approx(
        float(np.var(alone.decimate(alone.a))), rel=0.05
    )
    position = kinematics(np.ones_like(noise), np.cumsum(100.0 + noise) * 0.001, 0.001, "position")
    assert acceleration_noise(position, position.valid) == 0.0  # a position's noise is not described


def test_a_slow_sine_states_the_inertia_whatever_band_lets_the_noise_in():
    """Compensated for the noise in the acceleration, a 0.25 Hz sine fits the inertia within 1 % in
    the useful bands of 10 Hz and the default 40 Hz (least squares alone: -0.2 and -8.1 %), and
    within 15 % in 100 Hz, where the noise is larger than the acceleration (least squares: -56 %;
    measured compensated: -0.1, -0.3 and -7.9 %), with the truth within 2 standard errors in the
    default band."""
    base = ("viscous_friction", "coulomb_friction", "offset")
    record, inertia = inertia_record("sine 0.25", 0)
    fits = {
        band: diagnose(record, base=base, max_steps=0, band=band, structure=False)
        for band in (10.0, 40.0, 100.0)
    }
    fitted = {band: d.model.params["inertia"] for band, d in fits.items()}
    assert fitted[10.0] == pytest.approx(inertia, rel=INERTIA_TOLERANCE)
    assert fitted[40.0] == pytest.approx(inertia, rel=INERTIA_TOLERANCE)
    assert fitted[100.0] == pytest.approx(inertia, rel=0.15)
    assert abs(fitted[40.0] - inertia) < 2.0 * fits[40.0].param_std["inertia"]


def test_least_squares_alone_fits_a_slow_sine_low_by_the_noise_its_acceleration_carries():
    """Why the fit is compensated: with the record's acceleration noise set to nil, least squares
    pulls the 0.25 Hz sine's inertia low by about var(noise) / var(acceleration) (measured -8.1 %
    in the default band), as errors in a regressor do."""
    from motorid.diagnose.model import fit_model
    from motorid.diagnose.workflow import prepare

    base = ("viscous_friction", "coulomb_friction", "offset")
    record, inertia = inertia_record("sine 0.25", 0)
    data = prepare(record).data
    compensated = fit_model(data, base).model.params["inertia"]
    data.accel_noise = 0.0
    plain = fit_model(data, base).model.params["inertia"]
    assert compensated == pytest.approx(inertia, rel=INERTIA_TOLERANCE)
    assert plain < 0.95 * inertia


def test_records_of_one_drive_are_compensated_each_for_its_own_noise():
    """A 0.25 Hz sine and a chirp of one drive fitted as one model: the inertia within the
    tolerance."""
    (sine, inertia), (chirp, same) = inertia_record("sine 0.25", 4), inertia_record("chirp 2", 4)
    assert same == inertia  # one seed, one drive
    d = diagnose([sine, chirp], base=("viscous_friction", "coulomb_friction", "offset"), max_steps=0)
    assert d.model.params["inertia"] == pytest.approx(inertia, rel=INERTIA_TOLERANCE)


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
