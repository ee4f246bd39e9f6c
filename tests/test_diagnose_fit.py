"""The doctor's balance fit against plain NumPy references: the solve (least squares compensated
for the acceleration's noise) and its covariance, the dropped column, and the per-model results the workflow keeps (decimated
balance, gaps) returned for the model asked about and no other."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from balance_reference import reference_columns, reference_target

from motorid.diagnose.kinematics import CUTOFF_PER_BAND, lowpass
from motorid.diagnose.model import _linear_solve, model_balance, model_key
from motorid.diagnose.synthetic import planted_record
from motorid.diagnose.workflow import gaps, prepare
from motorid.drive.rigid import RigidDrive


@pytest.fixture(scope="module")
def prep():
    planted = planted_record("coulomb_friction", 0, duration=10.0)
    return prepare(planted.record)


def compensation(data, rows, k: int) -> np.ndarray:
    """D: the noise the fitted rows put on the inertia's entry of XᵀX, M σ_a²."""
    D = np.zeros((k, k))
    D[0, 0] = rows.sum() * data.accel_noise
    return D


def test_the_balance_solve_equals_the_compensated_normal_equations_and_their_inverse(prep):
    """θ = (XᵀX - D)⁻¹ Xᵀy, solved by NumPy from the columns written out; the record's speed is
    noisy, so the compensation is not nil (and without it, plain least squares fits a lower J)."""
    data = prep.data
    rows = data.moving
    solve = _linear_solve(
        data, ("coulomb_friction", "viscous_friction", "offset"), {}, 1.0, rows, "exponential"
    )
    names = ["offset", "coulomb", "viscous"]  # the solve puts an offset first, then the library order
    X = reference_columns(prep, names)[rows]
    y = reference_target(prep)[rows]
    normal = X.T @ X - compensation(data, rows, 4)
    theta = np.linalg.solve(normal, X.T @ y)
    cov = np.linalg.inv(normal)
    plain, *_ = np.linalg.lstsq(X, y, rcond=None)
    assert data.accel_noise > 0.0 and plain[0] < theta[0]
    unit = X / np.linalg.norm(X, axis=0)
    # two ways to the normal matrix (the QR factor of the unit-norm columns; XᵀX written out) agree
    # to about cond² * 1e-16 relative: the tolerance holds for a condition number up to 1e3, checked
    assert np.linalg.cond(unit) < 1e3
    assert list(solve.theta) == ["inertia", *names]
    np.testing.assert_allclose(list(solve.theta.values()), theta, rtol=1e-10)
    np.testing.assert_allclose(solve.unit_cov(), cov, rtol=1e-10)
    residual = reference_target(prep) - reference_columns(prep, names) @ theta
    assert solve.rank == 4 and solve.residual.shape == (data.n,)
    np.testing.assert_allclose(solve.residual, residual, rtol=0, atol=1e-10 * np.abs(y).max())
    assert solve.rss == pytest.approx(float(np.sum(residual[rows] ** 2)), rel=1e-9)


def test_a_search_over_the_input_path_reuses_the_regressors_and_solves_as_without(prep):
    """Points of a dead-zone search change the force only: solved one after the other with the
    regressors kept, each equals its solve from scratch to the bit (and the kept ones are
    replaced when the columns change)."""
    data = prep.data
    effects = ("viscous_friction", "input_dead_zone", "offset")
    last: dict = {}
    for dead_zone in (0.05, 0.2, 0.4):
        kept = _linear_solve(data, effects, {"dead_zone": dead_zone}, 1.0, data.moving, "exponential", last)
        fresh = _linear_solve(data, effects, {"dead_zone": dead_zone}, 1.0, data.moving, "exponential")
        assert kept.theta == fresh.theta and kept.rss == fresh.rss
        np.testing.assert_array_equal(kept.residual, fresh.residual)
    assert len(last) == 1
    (regressors,) = last.values()
    other = _linear_solve(data, ("coulomb_friction", "viscous_friction", "offset"), {}, 1.0, data.moving,
                          "exponential", last)  # fmt: skip
    assert len(last) == 1 and next(iter(last.values())) is not regressors and len(other.theta) == 4


def test_a_column_that_repeats_the_offset_is_dropped_with_zero_estimate_and_covariance(prep):
    """While the drive moves, the Coulomb asymmetry |sgn w| is the offset's column: it adds no rank,
    its parameter is 0, its row and column of C are 0 and the rest is the fit without it."""
    data = prep.data
    effects = ("coulomb_friction", "asymmetric_friction", "viscous_friction", "offset")
    solve = _linear_solve(data, effects, {}, 1.0, data.moving, "exponential")
    names = list(solve.theta)
    dropped = names.index("coulomb_asymmetry")
    assert solve.rank == len(names) - 1 and solve.theta["coulomb_asymmetry"] == 0.0
    cov = solve.unit_cov()
    assert not cov[dropped].any() and not cov[:, dropped].any()
    kept = [n for n in names[1:] if n != "coulomb_asymmetry"]
    X = reference_columns(prep, kept)[data.moving]
    normal = X.T @ X - compensation(data, data.moving, X.shape[1])
    theta = np.linalg.solve(normal, X.T @ reference_target(prep)[data.moving])
    rest = [i for i in range(len(names)) if i != dropped]
    # as above: two algorithms on a well-conditioned matrix
    np.testing.assert_allclose([solve.theta[n] for n in ["inertia", *kept]], theta, rtol=1e-10)
    np.testing.assert_allclose(cov[np.ix_(rest, rest)], np.linalg.inv(normal), rtol=1e-10)


def test_each_model_gets_its_own_balance_and_gaps_not_another_ones(prep):
    """The workflow keeps each model's decimated balance and gaps; asking again, or for a model
    one bit apart, gives that model's own."""
    kin, data = prep.kin, prep.data
    params = {"inertia": 0.01, "input_gain": 1.0, "viscous": 1e-3, "offset": 0.0, "coulomb": 5e-3}
    one = RigidDrive(("coulomb_friction", "viscous_friction", "offset"), params, kin.dt)
    bit_apart = one.with_params(coulomb=float(np.nextafter(5e-3, 1.0)))
    other = one.with_params(coulomb=8e-3, offset=-0.0)
    assert model_key(one) == model_key(one.with_params()) and model_key(one) != model_key(bit_apart)
    assert model_key(one.with_params(offset=-0.0)) != model_key(one)  # -0.0 == 0.0, but not the same bits
    for model in (one, other, one, bit_apart, other):
        f_in, f_model = model_balance(model, data)
        f_held = np.where(data.holds, data.balance_force(model.input_force(kin.u)), 0.0)
        np.testing.assert_array_equal(f_in, kin.decimate(f_held))
        inertia = data.balance_inertia(model.inertia, model.params["viscous"])
        friction = kin.decimate(np.where(data.holds, model.friction(kin.balance_w), 0.0))
        np.testing.assert_array_equal(f_model, inertia * data.a + friction)
    first = gaps(one, prep, None)
    with pytest.raises(dataclasses.FrozenInstanceError):
        first.overall = -1.0  # a gap kept for the next caller cannot be changed by this one
    again, far = gaps(one, prep, None), gaps(other, prep, None)
    assert again is first and again.overall > 0.0 and again.overall != far.overall
    run = prep.simulate(one)  # the free run, through the velocity's own low-pass from its start
    run[prep.start :] = lowpass(run[prep.start :], kin.dt, CUTOFF_PER_BAND * kin.band)
    err = kin.w - run
    ok = kin.valid & np.isfinite(err)
    assert again.overall == pytest.approx(
        np.sqrt(np.mean(err[ok] ** 2)), rel=1e-12
    )  # the RMS; rel 1e-12 allows another summation order


def test_a_level_below_zero_beyond_its_errors_is_not_physical():
    """A fit whose Coulomb level lies more than two standard errors below zero is no drive (a
    dead zone traded against it); within two errors of zero it is kept (a drive without Coulomb
    friction fits a small level of either sign)."""
    from motorid.diagnose.model import fit_model
    from motorid.diagnose.search import NEGATIVE_ERRORS, negative_levels

    record = planted_record("coulomb_friction", 3, sizes={"coulomb": 8e-3}).record
    fit = fit_model(prepare(record).data, ("viscous_friction", "coulomb_friction", "offset"))
    assert negative_levels(fit) == ""  # the fitted level is positive
    sigma = fit.param_std["coulomb"]
    assert sigma > 0
    for level, said in ((-(NEGATIVE_ERRORS + 0.5) * sigma, True), (-0.5 * NEGATIVE_ERRORS * sigma, False)):
        traded = dataclasses.replace(fit, model=fit.model.with_params(coulomb=level))
        assert bool(negative_levels(traded)) is said
        assert not said or negative_levels(traded).startswith("coulomb = -")
