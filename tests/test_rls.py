"""ARX-RLS against independent references: filterpy's KalmanFilter, the paper's RLS
equations in plain NumPy, the closed-form exponentially weighted least squares and
scipy's lfilter; convergence, tracking, windup and input checks."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import examples
from filterpy.kalman import KalmanFilter
from hypothesis import given
from hypothesis import strategies as st
from scipy.signal import lfilter

from motorid.estimators import ARXRLS

SETTINGS = examples(12)
EPS = np.finfo(float).eps


def rls_rtol(n_samples: int, P: np.ndarray) -> float:
    """How far two correct implementations of RLS may drift apart, relative to the
    size of what they estimate: ``n_samples eps cond(P)``.

    RLS solves the normal equations recursively, so the rounding of each step reaches
    the estimate amplified by up to the condition number of P (the sensitivity of
    the normal equations, Golub & Van Loan, Matrix Computations, sec. 5.3), and the
    steps' errors add up, at worst linearly over the record. Measured against
    filterpy and the paper's equations: at most 0.6-17 eps cond(P).
    """
    return n_samples * EPS * float(np.linalg.cond(P))


def arx_regressors(u: np.ndarray, y: np.ndarray, na: int, nb: int, k0: int = 0) -> np.ndarray:
    """phi(t) = (-y(t-1..t-na), u(t-k0..t-nb)) with zeros before the record starts."""
    N = len(u)
    cols = []
    for i in range(1, na + 1):
        cols.append(-np.concatenate([np.zeros(i), y[: N - i]]))
    for k in range(k0, nb + 1):
        cols.append(np.concatenate([np.zeros(k), u[: N - k]]))
    return np.column_stack(cols)


def paper_rls(Phi: np.ndarray, z: np.ndarray, lam: float, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Step (iii) of the paper, literally, in plain NumPy; returns theta and P per sample."""
    n = Phi.shape[1]
    theta, P = np.zeros(n), delta * np.eye(n)
    out = np.empty((len(z), n))
    covariances = np.empty((len(z), n, n))
    for t, phi in enumerate(Phi):
        eps = z[t] - phi @ theta
        P = (P / lam) @ (np.eye(n) - np.outer(phi, phi) @ P / (lam + phi @ P @ phi))
        theta = theta + P @ phi * eps
        out[t] = theta
        covariances[t] = P
    return out, covariances


def stable_arx(rng: np.random.Generator, na: int, nb: int) -> tuple[np.ndarray, np.ndarray]:
    """a (A = 1 + a1 q^-1 + ...) with poles of modulus <= 0.9, and b."""
    poles: list[complex] = []
    while len(poles) < na:
        r, ang = rng.uniform(0.1, 0.9), rng.uniform(0, np.pi)
        if na - len(poles) >= 2 and rng.random() < 0.5:
            poles += [r * np.exp(1j * ang), r * np.exp(-1j * ang)]
        else:
            poles.append(r * np.sign(rng.uniform(-1, 1)))
    a = np.real(np.poly(poles))[1:]
    b = rng.uniform(-2, 2, nb + 1)
    b[np.abs(b) < 0.2] += 0.5
    return a, b


def simulate_arx(a: np.ndarray, b: np.ndarray, u: np.ndarray) -> np.ndarray:
    return lfilter(b, np.concatenate([[1.0], a]), u)


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1)
    u = rng.uniform(-1, 1, 1000)
    y = simulate_arx(np.array([-1.2, 0.5]), np.array([0.1, 0.8, 0.3]), u) + 0.05 * rng.standard_normal(1000)
    return u, y


@pytest.mark.parametrize("lam", [1.0, 0.98, 0.9])
def test_equals_filterpy_kalman_filter(record, lam):
    """RLS is filterpy's KalmanFilter with F = I, P_prior = P / lam (alpha^2 = 1/lam),
    Q = 0, H = phi^T, R = 1: equal sample by sample over 1000 samples, to what two
    correct implementations may differ by (:func:`rls_rtol`; filterpy updates P in
    Joseph form through NumPy's matrix products, we in the standard form in
    compiled loops)."""
    u, y = record
    na, nb = 2, 2
    est = ARXRLS(na, nb, lam=lam, delta=1e3, max_trace=np.inf)
    kf = KalmanFilter(dim_x=na + nb + 1, dim_z=1)
    kf.P *= 1e3
    kf.Q = np.zeros((5, 5))
    kf.R = np.eye(1)
    kf.alpha = 1.0 / np.sqrt(lam)
    Phi = arx_regressors(u, y, na, nb)
    for t in range(len(u)):
        y_hat = est.predict(u[t])
        kf.predict()
        kf.H = Phi[t][None, :]
        rtol = rls_rtol(len(u), kf.P_prior)
        # y_hat = phi^T x: its error is at most |phi|^T |error of x|
        assert abs(y_hat - (kf.H @ kf.x).item()) <= rtol * (np.abs(Phi[t]) @ np.abs(kf.x.ravel()))
        np.testing.assert_allclose(est.P_prior, kf.P_prior, rtol=0, atol=rtol * np.abs(kf.P_prior).max())
        np.testing.assert_allclose(est.x_prior, kf.x_prior.ravel(), rtol=0, atol=rtol * np.abs(kf.x).max())
        assert est.P is est.P_prior and est.x is est.x_prior
        est.update(y[t])
        kf.update(np.array([[y[t]]]))
        rtol = rls_rtol(len(u), kf.P)
        np.testing.assert_allclose(est.x, kf.x.ravel(), rtol=0, atol=rtol * np.abs(kf.x).max())
        np.testing.assert_allclose(est.P, kf.P, rtol=0, atol=rtol * np.abs(kf.P).max())
        np.testing.assert_allclose(est.x_post, kf.x_post.ravel(), rtol=0, atol=rtol * np.abs(kf.x).max())
        np.testing.assert_allclose(est.P_post, kf.P_post, rtol=0, atol=rtol * np.abs(kf.P).max())
        # K = P_prior phi / S: each factor within rtol of filterpy's, so K too, relative to its size
        np.testing.assert_allclose(est.K, kf.K.ravel(), rtol=0, atol=rtol * np.abs(kf.K).max())
        assert est.y == pytest.approx(float(kf.y[0, 0]), abs=rtol * (np.abs(Phi[t]) @ np.abs(kf.x.ravel())))
        assert est.S == pytest.approx(float(kf.S[0, 0]), rel=rtol)
        # -(y^2/S + log 2 pi S)/2 and |y|/sqrt(S), from y and S above
        nis = float(kf.y[0, 0]) ** 2 / float(kf.S[0, 0])
        assert est.log_likelihood == pytest.approx(kf.log_likelihood, abs=rtol * (1.0 + nis))
        assert est.mahalanobis == pytest.approx(kf.mahalanobis, abs=rtol * (1.0 + kf.mahalanobis))
        # the likelihood is exp of the log-likelihood above: its relative error is that absolute one
        assert est.likelihood == pytest.approx(kf.likelihood, rel=rtol * (1.0 + nis))


@pytest.mark.parametrize("direct_term", [True, False])
def test_compiled_batch_equals_plain_numpy_paper_equations(record, direct_term):
    """The compiled batch path against step (iii) of the paper written in NumPy
    (another, non-symmetric form of the covariance update), sample by sample to
    what two correct implementations may differ by (:func:`rls_rtol`)."""
    u, y = record
    lam, delta = 0.97, 100.0
    est = ARXRLS(3, 2, lam=lam, delta=delta, direct_term=direct_term, max_trace=np.inf)
    result = est.batch_filter(u, y)
    reference, covariances = paper_rls(arx_regressors(u, y, 3, 2, k0=0 if direct_term else 1), y, lam, delta)
    for t in range(len(u)):
        atol = rls_rtol(len(u), covariances[t]) * np.abs(reference[t]).max()
        np.testing.assert_allclose(result.x[t], reference[t], rtol=0, atol=atol)


@pytest.mark.parametrize("lam", [1.0, 0.95])
def test_equals_closed_form_weighted_least_squares(record, lam):
    """theta_N = (lam^N P0^-1 + sum lam^(N-t) phi phi^T)^-1 (sum lam^(N-t) phi z),
    solved by LAPACK, to what two correct solutions of these normal equations may
    differ by (:func:`rls_rtol` with the information matrix, whose condition number
    is P's)."""
    u, y = record
    u, y = u[:300], y[:300]
    delta, N = 10.0, 300
    est = ARXRLS(2, 1, lam=lam, delta=delta, max_trace=np.inf)
    est.batch_filter(u, y)
    Phi = arx_regressors(u, y, 2, 1)
    w = lam ** (N - 1 - np.arange(N))
    info = lam**N * np.eye(4) / delta + (Phi * w[:, None]).T @ Phi
    theta = np.linalg.solve(info, (Phi * w[:, None]).T @ y)
    rtol = rls_rtol(N, info)
    np.testing.assert_allclose(est.x, theta, rtol=0, atol=rtol * np.abs(theta).max())
    np.testing.assert_allclose(np.linalg.inv(est.P), info, rtol=0, atol=rtol * np.abs(info).max())


@SETTINGS
@given(seed=st.integers(0, 10_000), na=st.integers(1, 4), nb=st.integers(0, 3))
def test_converges_to_true_parameters_without_noise(seed, na, nb):
    """Random stable ARX systems, white uniform input, no noise: the estimate is the
    truth but for the pull of the prior P0 = delta I, which RLS with lam = 1 keeps as
    regularised least squares does: |theta_hat - theta| <= |theta| / (delta
    lambda_min(Phi^T Phi)), about 1e-10 for a well excited system and up to 1e-6
    where a zero of B nearly cancels a pole of A (seed 2, na 2, nb 3: -0.34 and
    -0.31), plus what rounding explains (:func:`rls_rtol`)."""
    rng = np.random.default_rng(seed)
    a, b = stable_arx(rng, na, nb)
    u = rng.uniform(-1, 1, 3000)
    y = simulate_arx(a, b, u)
    delta = 1e8
    est = ARXRLS(na, nb, delta=delta)
    est.batch_filter(u, y)
    Phi = arx_regressors(u, y, na, nb)
    theta = np.concatenate([a, b])
    pull = np.linalg.norm(theta) / (delta * np.linalg.eigvalsh(Phi.T @ Phi).min())
    atol = pull + rls_rtol(len(u), est.P) * np.abs(theta).max()
    np.testing.assert_allclose(est.params["a"], a, rtol=0, atol=atol)
    np.testing.assert_allclose(est.params["b"], b, rtol=0, atol=atol)
    np.testing.assert_allclose(est.simulate(u), y, atol=1e-4 * max(1.0, np.abs(y).max()))


def test_tracks_a_step_change_of_the_parameters():
    """lam < 1 follows a jump of the true parameters; lam = 1 averages over it."""
    rng = np.random.default_rng(7)
    u = rng.uniform(-1, 1, 2000)
    a1, b1 = np.array([-0.8]), np.array([0.0, 1.0])
    a2, b2 = np.array([-0.5]), np.array([0.0, 2.0])
    y = np.empty(2000)
    y[:1000] = simulate_arx(a1, b1, u[:1000])
    y_prev, u_prev = y[999], u[999]
    for t in range(1000, 2000):
        y[t] = -a2[0] * y_prev + b2[1] * u_prev
        y_prev, u_prev = y[t], u[t]
    tracking, averaging = ARXRLS(1, 1, lam=0.95), ARXRLS(1, 1, lam=1.0)
    res = tracking.batch_filter(u, y)
    averaging.batch_filter(u, y)
    np.testing.assert_allclose(res.x[999], [*a1, *b1], atol=1e-6)
    np.testing.assert_allclose(tracking.x, [*a2, *b2], atol=1e-6)
    assert np.abs(averaging.x - [*a2, *b2]).max() > 0.05


def test_covariance_stays_bounded_and_positive_definite_under_weak_excitation():
    """lam = 0.95 on a long record with almost no excitation: P stays symmetric
    positive definite, its trace under the bound; without the bound it winds up."""
    rng = np.random.default_rng(3)
    n = 20_000
    u = np.concatenate([rng.uniform(-1, 1, 200), 1.0 + 1e-6 * rng.standard_normal(n - 200)])
    y = simulate_arx(np.array([-0.9]), np.array([0.0, 0.5]), u)
    est = ARXRLS(1, 1, lam=0.95, delta=100.0)
    assert est.max_trace is None  # stored as given; the bound in use is resolved
    bound = est.trace_bound
    assert bound == pytest.approx(100.0 * 3)
    for chunk in np.array_split(np.arange(n), 20):
        est.batch_filter(u[chunk], y[chunk])
        assert np.array_equal(est.P, est.P.T)
        assert np.linalg.eigvalsh(est.P).min() > 0
        assert np.trace(est.P) <= bound * (1 + 1e-12)
        assert np.all(np.isfinite(est.x))
    unbounded = ARXRLS(1, 1, lam=0.95, delta=100.0, max_trace=np.inf)
    unbounded.batch_filter(u[:2000], y[:2000])
    assert np.trace(unbounded.P) > 1e6 * bound


def test_predict_twice_closes_the_open_sample_as_skipped():
    est, ref = ARXRLS(1, 1), ARXRLS(1, 1)
    est.predict(1.0)
    est.predict(0.5)
    ref.predict(1.0)
    ref.update(None)
    ref.predict(0.5)
    np.testing.assert_array_equal(est.phi, ref.phi)
    with pytest.raises(RuntimeError, match="predict"):
        ARXRLS(1, 1).update(1.0)


@pytest.mark.parametrize("where", ["u", "z"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_sample_raises_naming_the_index_and_keeps_the_estimate(record, where, bad):
    u, y = (arr[:50].copy() for arr in record)
    est = ARXRLS(2, 2)
    est.batch_filter(u[:20], y[:20])
    x0, P0 = est.x.copy(), est.P.copy()
    (u if where == "u" else y)[37] = bad
    with pytest.raises(ValueError, match=rf"{where}\[37\]"):
        est.batch_filter(u, y)
    np.testing.assert_array_equal(est.x, x0)
    np.testing.assert_array_equal(est.P, P0)
    # the sample loop names the running sample index
    for t in range(20, 37):
        est.predict(u[t])
        est.update(y[t])
    x1, P1 = est.x.copy(), est.P.copy()
    if where == "u":
        with pytest.raises(ValueError, match="u at sample 37"):
            est.predict(u[37])
    else:
        est.predict(u[37])
        x1, P1 = est.x.copy(), est.P.copy()
        with pytest.raises(ValueError, match="z at sample 37"):
            est.update(y[37])
    np.testing.assert_array_equal(est.x, x1)
    np.testing.assert_array_equal(est.P, P1)


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"lam": 0.0}, "lam"),
        ({"lam": 1.5}, "lam"),
        ({"lam": float("nan")}, "lam"),
        ({"lam": "fast"}, "lam"),
        ({"na": -1}, "na"),
        ({"na": 1.5}, "na"),
        ({"na": True}, "na"),
        ({"nb": -2}, "nb"),
        ({"nb": 0, "direct_term": False}, "nb"),
        ({"delta": 0.0}, "delta"),
        ({"delta": float("inf")}, "delta"),
        ({"max_trace": -1.0}, "max_trace"),
        ({"R": 0.0}, "R"),
        ({"x0": [1.0, 2.0]}, "x0"),
    ],
)
def test_bad_arguments_raise_naming_the_argument(kwargs, argument):
    args = {"na": 2, "nb": 1, **kwargs}
    with pytest.raises(ValueError, match=rf"^{argument}\b"):
        ARXRLS(**args)


def test_skipped_measurement_keeps_the_prior_and_feeds_the_prediction_forward(record):
    u, y = record
    est = ARXRLS(2, 1)
    est.batch_filter(u[:100], y[:100])
    y_hat = est.predict(u[100])
    est.update(None)
    assert est.y_history[0] == y_hat
    assert est.z is None
    np.testing.assert_array_equal(est.x, est.x_prior)


def recursion_rounding_bound(a: np.ndarray, b: np.ndarray, u: np.ndarray, y: np.ndarray) -> float:
    """How far two implementations of ``A(q^-1) y = B(q^-1) u`` that round differently
    may drift apart.

    Each output is a sum of m = na + nb + 1 products; its rounding error is at most
    m eps times the sum of their magnitudes (Higham, Accuracy and Stability of
    Numerical Algorithms, sec. 3.1), and 1/A passes an error on with a gain of at
    most the l1 norm of its impulse response. Two implementations: twice that.
    """
    m = len(a) + len(b)
    magnitudes = lfilter(np.abs(b), [1.0], np.abs(u)) + lfilter(np.r_[0.0, np.abs(a)], [1.0], np.abs(y))
    impulse = lfilter([1.0], np.r_[1.0, a], np.r_[1.0, np.zeros(len(u) - 1)])
    return 2.0 * m * EPS * float(magnitudes.max()) * float(np.abs(impulse).sum())


def test_simulate_equals_lfilter_with_the_same_coefficients():
    """The free run against scipy's lfilter (direct form II transposed, another order
    of the same sums), to :func:`recursion_rounding_bound`."""
    a, b = np.array([-1.5, 0.7]), np.array([0.2, 0.5, 0.1])
    est = ARXRLS(2, 2, x0=np.concatenate([a, b]))
    u = np.random.default_rng(0).uniform(-3, 3, 500)
    y = simulate_arx(a, b, u)
    np.testing.assert_allclose(est.simulate(u), y, rtol=0, atol=recursion_rounding_bound(a, b, u, y))
    strict = ARXRLS(2, 2, direct_term=False, x0=np.concatenate([a, b[1:]]))
    y = simulate_arx(a, np.r_[0.0, b[1:]], u)
    np.testing.assert_allclose(
        strict.simulate(u), y, rtol=0, atol=recursion_rounding_bound(a, np.r_[0.0, b[1:]], u, y)
    )


def test_an_assigned_covariance_is_used_and_checked(record):
    """P set by the user is used as given (here: the same numbers as a fresh estimator
    with that P0, bit for bit); one of the wrong shape or not symmetric is rejected
    by name before anything changes, since the kernels read P's rows as its columns."""
    u, y = record
    est, ref = ARXRLS(2, 1, delta=1e3), ARXRLS(2, 1, delta=5.0)
    est.P = 5.0 * np.eye(4)
    np.testing.assert_array_equal(est.batch_filter(u, y).x, ref.batch_filter(u, y).x)
    for bad, message in (
        (np.eye(3), r"P must have shape \(4, 4\)"),
        (np.triu(np.ones((4, 4))), "P must be symmetric"),
    ):
        est = ARXRLS(2, 1)
        est.batch_filter(u[:10], y[:10])
        x0, index = est.x.copy(), est.sample_index
        est.P = bad
        with pytest.raises(ValueError, match=message):
            est.predict(u[10])
        with pytest.raises(ValueError, match=message):
            est.batch_filter(u[10:20], y[10:20])
        np.testing.assert_array_equal(est.x, x0)
        assert est.sample_index == index


def test_arrays_read_after_a_step_are_not_changed_by_later_steps(record):
    """x, P, the priors, the posteriors and K (read from its work array when first
    asked for) are new arrays each step: what a user keeps stays as it was."""
    u, y = record
    est = ARXRLS(2, 1, lam=0.98)
    names = ("x", "P", "x_prior", "P_prior", "x_post", "P_post", "K")
    kept = []
    for t in range(6):
        est.predict(u[t])
        est.update(None if t == 3 else y[t])
        kept.append({name: (getattr(est, name), getattr(est, name).copy()) for name in names})
    est.batch_filter(u[6:20], y[6:20])
    for step in kept:
        for name, (array, copy) in step.items():
            np.testing.assert_array_equal(array, copy, err_msg=name)
    assert not np.array_equal(kept[2]["K"][1], kept[4]["K"][1])  # the gain did change
