"""motorid.datasets: the EMPS loader against the published reference, and its errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.io
from emps_fixtures import emps_folder, force_error_percent, published_inverse_dynamics, requires_emps

from motorid.datasets import (
    DATA_ENV_VAR,
    EMPS_INIT_SAMPLES,
    EMPS_REFERENCE,
    emps_benchmark_rmse,
    emps_path,
    initial_state,
    load_emps,
    simulate_position,
)
from motorid.drive import RigidDrive


@requires_emps
def test_estimation_set_columns_units_and_scaling():
    record = load_emps(emps_folder())
    raw = scipy.io.loadmat(emps_folder() / "DATA_EMPS.mat")
    assert len(record) == 24841
    assert list(record.columns) == ["t", "u", "force", "y", "reference"]
    assert record.attrs["dt"] == pytest.approx(1e-3, rel=1e-4)
    assert record.attrs["input_gain"] == pytest.approx(35.15065, rel=1e-6)
    assert record.attrs["units"]["force"] == "N" and record.attrs["units"]["y"] == "m"
    np.testing.assert_array_equal(record["y"].to_numpy(), raw["qm"].ravel())
    np.testing.assert_allclose(record["force"], raw["gtau"].item() * raw["vir"].ravel())


@requires_emps
def test_validation_set_has_the_load_pulses():
    record = load_emps(emps_folder(), which="validation")
    assert "pulses" in record.columns
    assert set(np.unique(record["pulses"])) == {0.0, 5.0}


@requires_emps
@pytest.mark.parametrize(
    ("which", "published"),
    [("estimation", EMPS_REFERENCE["force_error_estimation"]), ("validation", None)],
)
def test_published_reference_model_reproduced_from_the_loaded_record(which, published):
    """M + Fv + Fc + offset by least squares on the loaded data gives the published model.

    The parameters are fitted on the estimation set and applied unchanged to the
    validation set, whose published force error is 5.98 %.
    """
    estimation = load_emps(emps_folder(), which="estimation")
    qd, qdd, force = published_inverse_dynamics(
        estimation["t"].to_numpy(), estimation["y"].to_numpy(), estimation["force"].to_numpy()
    )
    regressors = np.column_stack([qdd, qd, np.sign(qd), np.ones_like(qd)])
    theta, *_ = np.linalg.lstsq(regressors, force, rcond=None)
    mass, viscous, coulomb, offset = theta
    assert mass == pytest.approx(EMPS_REFERENCE["mass"], rel=0.02)
    assert viscous == pytest.approx(EMPS_REFERENCE["viscous"], rel=0.02)
    assert coulomb == pytest.approx(EMPS_REFERENCE["coulomb"], rel=0.02)
    assert offset == pytest.approx(EMPS_REFERENCE["offset"], rel=0.05)
    record = load_emps(emps_folder(), which=which)
    qd, qdd, force = published_inverse_dynamics(
        record["t"].to_numpy(), record["y"].to_numpy(), record["force"].to_numpy()
    )
    error = force_error_percent(force, np.column_stack([qdd, qd, np.sign(qd), np.ones_like(qd)]) @ theta)
    expected = published if published is not None else EMPS_REFERENCE["force_error_validation"]
    assert error == pytest.approx(expected, abs=0.3)


@requires_emps
def test_environment_variable_names_the_data_root(monkeypatch):
    monkeypatch.setenv(DATA_ENV_VAR, str(emps_folder().parent))
    assert emps_path(which="validation").name == "DATA_EMPS_PULSES.mat"
    assert len(load_emps()) == 24841


def test_missing_file_names_where_it_looked(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"DATA_EMPS\.mat not found; looked at .*emps"):
        load_emps(tmp_path)


def test_no_path_and_no_environment_variable(monkeypatch):
    monkeypatch.delenv(DATA_ENV_VAR, raising=False)
    with pytest.raises(FileNotFoundError, match=DATA_ENV_VAR):
        load_emps()


def test_unknown_set_is_named():
    with pytest.raises(ValueError, match="which must be one of"):
        emps_path("anywhere", which="training")


def _write(path, **overrides):
    n = 20
    data = {
        "t": np.arange(n, dtype=float)[:, None] * 1e-3,
        "qm": np.zeros((n, 1)),
        "qg": np.zeros((n, 1)),
        "vir": np.zeros((n, 1)),
        "gtau": np.array([[35.0]]),
        "kp": np.array([[160.0]]),
        "kv": np.array([[243.0]]),
    }
    data.update(overrides)
    scipy.io.savemat(path, {k: v for k, v in data.items() if v is not None})
    return path


def test_bad_files_name_the_variable_and_sample(tmp_path):
    with pytest.raises(ValueError, match=r"lacks the variable.*vir"):
        load_emps(_write(tmp_path / "a.mat", vir=None))
    qm = np.zeros((20, 1))
    qm[7] = np.nan
    with pytest.raises(ValueError, match="variable qm is not finite at sample 7"):
        load_emps(_write(tmp_path / "b.mat", qm=qm))
    with pytest.raises(ValueError, match="variable qg has 19 samples, t has 20"):
        load_emps(_write(tmp_path / "c.mat", qg=np.zeros((19, 1))))
    t = np.arange(20, dtype=float)[:, None] * 1e-3
    t[12] = t[11]
    with pytest.raises(ValueError, match="t does not increase at sample 12"):
        load_emps(_write(tmp_path / "d.mat", t=t))
    (tmp_path / "e.mat").write_text("not a mat file")
    with pytest.raises(ValueError, match="not a readable MATLAB file"):
        load_emps(tmp_path / "e.mat")


# --------------------------------------------------------------------------- benchmark protocol
EMPS_LIKE = RigidDrive(
    ("coulomb_friction", "viscous_friction", "offset"),
    {"inertia": 95.0, "input_gain": 35.15, "coulomb": 20.4, "viscous": 203.5, "offset": -3.2},
    dt=1e-3,
)


def simulated_test_set(timing: str) -> pd.DataFrame:
    """A "test set" of EMPS_LIKE: 6 s of a smooth force with reversals, positions [m] as ``y``;
    ``"sampled"``: ``y[k]`` read before ``u[k]`` is applied (the start position first)."""
    t = np.arange(6000) * 1e-3
    u = 1.2 * np.sin(2 * np.pi * 0.7 * t) + 0.4 * np.sin(2 * np.pi * 3.1 * t) + 0.2
    record = EMPS_LIKE.simulate(u, w0=0.02, q0=0.05)
    y = record["position"].to_numpy()
    if timing == "sampled":
        y = np.r_[0.05, y[:-1]]
    frame = pd.DataFrame({"t": t, "u": u, "y": y})
    frame.attrs.update(dt=1e-3, timing=timing, units={"t": "s", "u": "V", "y": "m"})
    return frame


@pytest.mark.parametrize("timing", ["hold", "sampled"])
def test_the_state_read_from_twenty_positions_is_the_one_the_drive_started_from(timing):
    """The drive left 0.05 m at 0.02 m/s. The search stops within 1e-9 of its interval
    (2 x 0.03 m/s): the speed within 1e-10 m/s, the position to rounding."""
    test = simulated_test_set(timing)
    w0, q0 = initial_state(EMPS_LIKE, test)
    assert w0 == pytest.approx(0.02, abs=1e-10) and q0 == pytest.approx(0.05, abs=1e-12)
    with pytest.raises(ValueError, match="at least 3"):
        initial_state(EMPS_LIKE, test, samples=2)
    with pytest.raises(ValueError, match="fewer than the 20"):
        initial_state(EMPS_LIKE, test.iloc[:10])


@pytest.mark.parametrize("timing", ["hold", "sampled"])
def test_the_drive_that_made_the_test_set_scores_zero(timing):
    """From the state it started from (above), the drive repeats its own run: a speed 1e-10 m/s
    off drifts at most 1e-10 m/s x 6 s = 6e-7 mm; 1e-6 mm bounds it."""
    test = simulated_test_set(timing)
    assert emps_benchmark_rmse(EMPS_LIKE, test) < 1e-6
    assert emps_benchmark_rmse(EMPS_LIKE.with_params(coulomb=22.0), test) > 1.0  # another drive does not


def test_a_constant_offset_of_one_mm_after_the_initialisation_scores_one_mm():
    test = simulated_test_set("sampled")
    exact = simulate_position(EMPS_LIKE, test)
    shifted = test.copy()
    shifted.loc[EMPS_INIT_SAMPLES:, "y"] += 1e-3  # the 20 samples the state is read from are unchanged
    assert np.array_equal(
        simulate_position(EMPS_LIKE, shifted)[EMPS_INIT_SAMPLES:], exact[EMPS_INIT_SAMPLES:]
    )
    assert emps_benchmark_rmse(EMPS_LIKE, shifted) == pytest.approx(1.0, abs=1e-6)  # the 1e-6 mm above


@requires_emps
def test_the_published_reference_model_by_the_benchmark_protocol():
    """The published symmetric model (M, Fv, Fc, offset of the inverse dynamics), simulated on the
    test set from its 20 first positions, scores 8.39 mm with the rigid drive's exact integrator (8.26
    with the semi-implicit Euler it replaced): a physical model of four parameters, fitted to the
    force, lands above the black-box figures (LTI 5.53, NARX 5.17 mm). The run is deterministic;
    0.01 mm leaves room for rounding across machines, not for a change of protocol."""
    reference = EMPS_LIKE.with_params(
        inertia=EMPS_REFERENCE["mass"], viscous=EMPS_REFERENCE["viscous"], coulomb=EMPS_REFERENCE["coulomb"],
        offset=EMPS_REFERENCE["offset"], input_gain=35.15065,
    )  # fmt: skip
    figure = emps_benchmark_rmse(reference, path=emps_folder())
    assert figure == pytest.approx(8.39, abs=0.01)
