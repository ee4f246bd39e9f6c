"""Noise floors that hold on real sensors: the floor per speed band where the noise grows with
speed, and the quantisation step of an encoder when it shows."""

from __future__ import annotations

import math

import numpy as np
import pytest
from cli_fixtures import run

from motorid.diagnose.kinematics import kinematics, noise_bands, quantisation_step
from motorid.diagnose.synthetic import planted_record
from motorid.drive import paper_rig
from motorid.io.records import write_record


def test_the_quantisation_step_of_an_encoder_is_found_when_it_shows():
    rng = np.random.default_rng(3)
    w = 150.0 * np.sin(np.linspace(0.0, 20.0, 20_000)) + rng.normal(0.0, 1.0, 20_000)
    step = 2 * math.pi * 100 / 4096  # a 4096-count encoder read every 10 ms, in rad/s
    counts = np.round(w / step)
    # found to 1e-6 of the step from a 150 rad/s swing, also after a file rounded it to 3 decimals
    assert quantisation_step(counts * step) == pytest.approx(step, rel=1e-6)
    assert quantisation_step(np.round(counts * step, 3)) == pytest.approx(step, rel=1e-4)
    assert quantisation_step(w) is None  # a continuous output has none
    assert quantisation_step(np.zeros(10)) is None


def test_the_noise_floor_per_speed_band_follows_noise_that_grows_with_speed():
    """White noise of σ = 0.05 + 0.01 |w| on a sine: each band's floor is what the low-pass leaves
    of the σ in it, σ_rms sqrt(2 f_c dt) (:func:`filtered_noise`), with f_c = 2.5 f_b."""
    dt, n = 0.001, 60_000
    t = np.arange(n) * dt
    w = 200.0 * np.sin(2 * np.pi * 0.5 * t)
    sigma = 0.05 + 0.01 * np.abs(w)
    y = w + sigma * np.random.default_rng(0).standard_normal(n)
    kin = kinematics(np.sin(t), y, dt)
    speed, valid = np.abs(kin.w), kin.valid
    edges = np.array([0.0, 20.0, 60.0, 120.0, speed[valid].max()])
    bands = noise_bands(speed[valid], kin.hf[valid], edges, kin.band, dt)
    cutoff = 2.5 * kin.band
    for band in bands:
        inside = valid & (speed >= band.speed_from) & (speed <= band.speed_to)
        expected = math.sqrt(np.mean(sigma[inside] ** 2)) * math.sqrt(2 * cutoff * dt)
        # the band's σ varies by up to 3x across it and the filter smears across band edges: 10 %
        assert band.noise_floor == pytest.approx(expected, rel=0.1), band
    floors = [b.noise_floor for b in bands]
    assert floors == sorted(floors) and floors[-1] > 5 * floors[0]  # grows with speed
    assert sum(b.samples for b in bands) == int(valid.sum())


def test_the_doctor_reports_the_floor_per_speed_band_and_the_step(capsys, tmp_path):
    planted = planted_record("coulomb_friction", 7)
    path = tmp_path / "rec.csv"
    write_record(planted.record, path)
    code, out, err = run(capsys, "doctor", str(path), "--max-steps", "0", "--json")
    assert code == 0, err
    bands = out["noise_bands"]
    w_max = bands[-1]["speed_to"]
    assert [b["speed_from"] / w_max for b in bands] == pytest.approx([0.0, 0.1, 0.3, 0.6])
    # the rig's tachogenerator read by a 12-bit A/D converter: one step is its LSB over the tacho gain
    rig = paper_rig()
    assert out["quantisation_step"] == pytest.approx(rig.adc.lsb / rig.tacho.gain, rel=1e-6)
    line = "  noise floor by speed [rad/s]: " + ", ".join(
        f"{b['noise_floor']:.3g} "
        + (f"below {b['speed_to']:.3g}" if k == 0 else f"at {b['speed_from']:.3g}-{b['speed_to']:.3g}")
        for k, b in enumerate(bands)
    )
    assert line + f"; the output steps by {out['quantisation_step']:.4g}" in err
