"""Hammerstein two-step RLS: recovery of b and gamma by both methods, the basis
options, the factored free-run model, argument checks."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from conftest import examples
from hypothesis import given
from hypothesis import strategies as st
from scipy.signal import lfilter

from motorid.estimators import (
    Basis,
    BasisFunction,
    HammersteinRLS,
    basis_from_spec,
    dead_zone,
    polynomial,
    power,
    sign,
)
from motorid.estimators.basis import POWER, SIGN
from motorid.validation import mse

SETTINGS = examples(12)
EPS = np.finfo(float).eps


def hammerstein_output(a, b, static, u):
    """y = B/A applied to x = static(u), by scipy's lfilter (an independent reference)."""
    return lfilter(b, np.concatenate([[1.0], a]), static(u))


@SETTINGS
@given(
    seed=st.integers(0, 10_000),
    na=st.integers(1, 3),
    nb=st.integers(1, 3),
    degree=st.integers(2, 4),
    method=st.sampled_from(["paper", "svd"]),
)
def test_recovers_b_and_gamma_of_random_hammerstein_systems(seed, na, nb, degree, method):
    """Noise-free random systems (stable A, gamma_1 = 1): b and gamma to 1e-4."""
    rng = np.random.default_rng(seed)
    poles = rng.uniform(-0.8, 0.8, na)
    a = np.real(np.poly(poles))[1:]
    b = rng.uniform(0.3, 1.5, nb + 1) * rng.choice([-1, 1], nb + 1)
    gamma = np.concatenate([[1.0], rng.uniform(-0.6, 0.6, degree - 1)])
    u = rng.uniform(-1.5, 1.5, 3000)
    y = hammerstein_output(a, b, lambda v: np.polyval(np.r_[gamma[::-1], 0.0], v), u)
    est = HammersteinRLS(na, nb, degree=degree, delta=1e8, gamma_method=method)
    est.batch_filter(u, y)
    params = est.params
    np.testing.assert_allclose(params["a"], a, atol=1e-4)
    np.testing.assert_allclose(params["b"], b, atol=1e-4)
    np.testing.assert_allclose(params["gamma"], gamma, atol=1e-4)
    np.testing.assert_allclose(est.simulate(u), y, atol=1e-3 * max(1.0, np.abs(y).max()))


def test_svd_recovery_is_better_than_the_paper_formula_with_noise():
    """With noisy data the rank-1 fit of all products beats the b-row formula on gamma."""
    rng = np.random.default_rng(11)
    a, b, gamma = np.array([-0.6]), np.array([0.2, 1.0, 0.5]), np.array([1.0, 0.0, 0.4])
    errors = {"paper": [], "svd": []}
    for _ in range(8):
        u = rng.uniform(-1.5, 1.5, 600)
        y = hammerstein_output(a, b, lambda v: v + 0.4 * v**3, u) + 0.3 * rng.standard_normal(600)
        for method in errors:
            est = HammersteinRLS(1, 2, degree=3, gamma_method=method)
            est.batch_filter(u, y)
            errors[method].append(np.linalg.norm(est.params["gamma"] - gamma))
    assert np.mean(errors["svd"]) < np.mean(errors["paper"])


def test_factorize_works_on_a_stack_of_estimates():
    rng = np.random.default_rng(2)
    u = rng.uniform(-1, 1, 400)
    y = hammerstein_output(np.array([-0.5]), np.array([0.0, 1.0, 0.4]), lambda v: v + 0.3 * v**2, u)
    for method in ("paper", "svd"):
        est = HammersteinRLS(1, 2, degree=2, gamma_method=method)
        result = est.batch_filter(u, y)
        b_hist, gamma_hist = est.factorize(result.x)
        assert b_hist.shape == (400, 3) and gamma_hist.shape == (400, 2)
        b_now, gamma_now = est.factorize()
        # The stack and the single estimate go through NumPy's einsum and SVD in other
        # shapes, which may take other SIMD loops (fused multiply-adds or not): they
        # agree to a few roundings of the largest entry, 64 eps of it. Not relative to
        # each entry: a singular vector is accurate to eps |M| / (sigma_1 - sigma_2) in
        # absolute terms (Golub & Van Loan, sec. 8.6), and b_0 is about 1e-7 here.
        np.testing.assert_allclose(b_hist[-1], b_now, rtol=0, atol=64 * EPS * np.abs(b_now).max())
        np.testing.assert_allclose(gamma_hist[-1], gamma_now, rtol=0, atol=64 * EPS * np.abs(gamma_now).max())
    assert np.isnan(HammersteinRLS(1, 2).params["gamma"]).all()  # undefined before any data


def test_dead_zone_basis_fits_a_dead_zone_that_a_cubic_cannot():
    """A drive behind a 1 V dead zone: the dead-zone basis gives a near-perfect free
    run; the paper's cubic leaves a clear error."""
    rng = np.random.default_rng(5)
    t = np.arange(3000) * 0.04
    u = 4 * np.sin(2 * np.pi * 0.2 * t) + 1.5 * np.sin(2 * np.pi * 0.9 * t) + 0.3 * rng.standard_normal(3000)
    a, b = np.array([-1.1, 0.3]), np.array([0.0, 2.0, 1.0])
    zone = dead_zone(1.0)
    y = hammerstein_output(a, b, zone, u)
    with_zone = HammersteinRLS(2, 2, basis=[zone], delta=1e6)
    cubic = HammersteinRLS(2, 2, degree=3, delta=1e6)
    with_zone.batch_filter(u, y)
    cubic.batch_filter(u, y)
    mse_zone, mse_cubic = mse(y, with_zone.simulate(u)), mse(y, cubic.simulate(u))
    assert mse_zone < 1e-8 * np.var(y)
    assert mse_cubic > 1e-3 * np.var(y)
    assert with_zone.params["gamma"].tolist() == [1.0]


def test_sign_basis_recovers_a_coulomb_like_input_offset():
    """x = u + 0.8 sgn(u): basis "u,sign" returns gamma = (1, 0.8)."""
    rng = np.random.default_rng(9)
    u = rng.uniform(-3, 3, 2000)
    y = hammerstein_output(np.array([-0.7]), np.array([0.0, 1.5]), lambda v: v + 0.8 * np.sign(v), u)
    for method in ("paper", "svd"):
        est = HammersteinRLS(1, 1, basis="u,sign", delta=1e8, gamma_method=method)
        est.batch_filter(u, y)
        np.testing.assert_allclose(est.params["gamma"], [1.0, 0.8], atol=1e-6)
        assert est.params["basis"] == ("u", "sign(u)")


def test_basis_spec_and_objects():
    assert basis_from_spec("u,u^2,sign,dead_zone:0.5").names == ("u", "u^2", "sign(u)", "dead_zone(u, 0.5)")
    assert basis_from_spec("poly:3").names == polynomial(3).names
    assert sign()(np.array([-2.0, 0.0, 3.0])).tolist() == [-1.0, 0.0, 1.0]
    np.testing.assert_array_equal(dead_zone(1.0)(np.array([-3.0, -0.5, 0.5, 2.0])), [-2.0, 0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="unknown basis item 'cos'"):
        basis_from_spec("u,cos")
    with pytest.raises(ValueError, match="dead zone half-width"):
        dead_zone(-1.0)
    with pytest.raises(ValueError, match="no built-in"):
        BasisFunction("u^2.5", builtin=(POWER, 2.5))
    with pytest.raises(ValueError, match="func or builtin"):
        BasisFunction("g", np.tanh, builtin=(SIGN, 0.0))
    bad = HammersteinRLS(1, 1, basis=[lambda v: v, lambda v: np.where(v < 0, np.inf, v)])
    with pytest.raises(ValueError, match="basis function 'g2'"):
        bad.batch_filter(np.array([1.0, -1.0]), np.array([0.0, 0.0]))
    with pytest.raises(ValueError, match="basis function 'g2'"):
        bad.predict(-1.0)
    assert bad.sample_index == 0


@pytest.mark.cpu_sensitive
def test_basis_gives_a_sample_the_same_bits_alone_and_in_a_record():
    """The one evaluation of the basis: a sample evaluated on its own (the per-sample
    path) gets the very bits it gets inside a record (batch_filter), for the compiled
    built-ins and for a custom NumPy function alike."""
    u = np.random.default_rng(4).uniform(-9.0, 9.0, 1001)
    basis = Basis([*polynomial(5), sign(), dead_zone(0.5), np.tanh, lambda v: np.exp(-(v**2))])
    record = basis.evaluate(u)
    alone = np.vstack([basis.evaluate(u[t : t + 1]) for t in range(len(u))])
    np.testing.assert_array_equal(alone, record)


def test_a_basis_value_that_overflows_raises_in_predict_and_changes_nothing():
    """u^3 of 1e150 V overflows: predict names the function and the sample, and the
    estimator is as before, also when a sample was left open (it stays open)."""
    est = HammersteinRLS(1, 1, degree=3)
    est.batch_filter(np.array([0.5, -0.2]), np.array([0.1, 0.3]))
    est.predict(0.4)
    state = (est.x.copy(), est.P.copy(), est.y_history.copy(), est.g_history.copy(), est.sample_index)
    with pytest.raises(ValueError, match=r"basis function 'u\^3' is inf at sample 3"):
        est.predict(1e150)
    for before, after in zip(
        state, (est.x, est.P, est.y_history, est.g_history, est.sample_index), strict=True
    ):
        np.testing.assert_array_equal(after, before)
    est.update(0.2)  # the open sample still takes its measurement
    assert est.z == 0.2 and est.sample_index == 3
    with pytest.raises(ValueError, match=r"basis function 'u\^2' is inf at sample 3"):
        est.predict(-1e200)
    assert est.sample_index == 3


def test_custom_functions_are_called_one_sample_at_a_time():
    """A custom function sees one-sample arrays in batch_filter and simulate as in the
    loop, so a sample's value never depends on the SIMD path NumPy takes for a record."""
    shapes = set()

    def cubic(v):
        shapes.add(v.shape)
        return v**3

    est = HammersteinRLS(1, 1, basis=[lambda v: v, cubic])
    u = np.linspace(-2.0, 2.0, 50)
    est.batch_filter(u, u**3)
    est.simulate(u)
    est.predict(0.5)
    assert shapes == {(1,)}


@given(u=st.floats(-1e50, 1e50, allow_nan=False), j=st.integers(1, 5))
def test_power_is_within_its_roundings_of_the_exact_power(u, j):
    """u^j as j - 1 correctly rounded products: relative to the exact power (computed
    in rational arithmetic) within gamma_(j-1) = (j - 1) u / (1 - (j - 1) u) <= (j - 1) eps,
    u = eps / 2 (Higham, Accuracy and Stability of Numerical Algorithms, Lemma 3.1),
    plus j times the smallest subnormal where the power underflows."""
    exact = Fraction(u) ** j
    value = power(j)(np.array([u]))[0]
    if abs(exact) > np.finfo(float).max:
        assert np.isinf(value) or abs(value) >= np.finfo(float).max / 2
        return
    bound = Fraction((j - 1) * EPS) * abs(exact) + Fraction(j * np.finfo(float).smallest_subnormal)
    assert abs(Fraction(value) - exact) <= bound


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"degree": 0}, "degree"),
        ({"degree": 2.5}, "degree"),
        ({"degree": 3, "basis": "u,sign"}, "give degree or basis"),
        ({"gamma_method": "mean"}, "gamma_method"),
        ({"nb": 0}, "nb"),
        ({"basis": [1.0, 2.0]}, "basis entry 1"),
        ({"lam": 2.0}, "lam"),
    ],
)
def test_bad_arguments_raise_naming_the_argument(kwargs, argument):
    args = {"na": 2, "nb": 2, **kwargs}
    with pytest.raises(ValueError, match=rf"^{argument}"):
        HammersteinRLS(**args)


def test_state_names_follow_the_paper_theta():
    est = HammersteinRLS(2, 1, degree=3)
    assert est.state_names == ("a1", "a2", "b0", "b1", "s2_0", "s2_1", "s3_0", "s3_1")
    assert HammersteinRLS(1, 2, degree=2, direct_term=False).state_names == ("a1", "b1", "b2", "s2_1", "s2_2")
