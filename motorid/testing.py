"""The conformance suite every motorid estimator passes, built in or plugged in.

In the spirit of scikit-learn's ``check_estimator``: hand it a factory that
returns a fresh estimator and it checks the interface contract of
:class:`motorid.estimators.Estimator` (shapes, filterpy's ``Saver``, skipping a
sample with ``None``, ``batch_filter`` equal to the sample loop, clear errors on
bad input with nothing lost, ``reset``, ``simulate`` and ``repr``)::

    from motorid.testing import check_estimator
    check_estimator(lambda: MyEstimator(order=2))

Each failure raises ``AssertionError`` naming the check and what was wrong.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from filterpy.common import Saver

from motorid.estimators.base import Estimator

EstimatorFactory = Callable[[], Estimator]


def conformance_record(n_samples: int = 300, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A small bidirectional record for the checks: input [V] and output [rad/s].

    A stable second-order drive-like response to a sum of sines with a dead band,
    plus a little measurement noise, so every estimator has something to learn.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n_samples) * 0.04
    u = 6.0 * np.sin(2 * np.pi * 0.3 * t) + 3.0 * np.sin(2 * np.pi * 1.1 * t + 0.5)
    drive = np.sign(u) * np.maximum(np.abs(u) - 0.5, 0.0)
    y = np.zeros(n_samples)
    for k in range(2, n_samples):
        y[k] = 1.2 * y[k - 1] - 0.4 * y[k - 2] + 3.0 * drive[k - 1] + 1.0 * drive[k - 2]
    return u, y + 0.05 * rng.standard_normal(n_samples)


def _fail(check: str, message: str) -> AssertionError:
    return AssertionError(f"{check}: {message}")


def _snapshot(est: Estimator) -> tuple[np.ndarray, np.ndarray]:
    return np.array(est.x, copy=True), np.array(est.P, copy=True)


def _run(est: Estimator, u: np.ndarray, z: list[float | None]) -> np.ndarray:
    """Sample loop; returns the predictions."""
    out = np.empty(len(u))
    for k, (u_k, z_k) in enumerate(zip(u, z, strict=True)):
        out[k] = est.predict(u_k)
        est.update(z_k)
    return out


def check_interface(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """The object is an Estimator with a usable ``name`` and ``state_names``."""
    est = factory()
    if not isinstance(est, Estimator):
        raise _fail("check_interface", f"factory built {type(est).__name__}, not a motorid Estimator")
    if len(est.state_names) != est.dim_x:
        raise _fail("check_interface", f"{len(est.state_names)} state_names for dim_x = {est.dim_x}")


def check_shapes(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """x is 1-D (n,), every covariance (n, n), K (n,), y and S floats, predictions finite."""
    est = factory()
    n = est.dim_x
    for k in range(20):
        y_hat = est.predict(u[k])
        if not isinstance(y_hat, float) or not math.isfinite(y_hat):
            raise _fail("check_shapes", f"predict returned {y_hat!r} at sample {k}, not a finite float")
        est.update(y[k])
    for attr in ("x", "x_prior", "x_post", "K"):
        shape = np.shape(getattr(est, attr))
        if shape != (n,):
            raise _fail("check_shapes", f"{attr} has shape {shape}, expected ({n},)")
    for attr in ("P", "P_prior", "P_post"):
        shape = np.shape(getattr(est, attr))
        if shape != (n, n):
            raise _fail("check_shapes", f"{attr} has shape {shape}, expected ({n}, {n})")
    for attr in ("y", "S", "log_likelihood", "likelihood", "mahalanobis"):
        value = getattr(est, attr)
        if not isinstance(value, float) or not math.isfinite(value):
            raise _fail("check_shapes", f"{attr} = {value!r} is not a finite float")
    params = est.params
    if not isinstance(params, dict) or not all(isinstance(key, str) for key in params):
        raise _fail("check_shapes", "params must be a dict keyed by str")


def check_covariance(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """P stays symmetric positive definite over the whole record."""
    est = factory()
    est.batch_filter(u, y)
    if not np.array_equal(est.P, est.P.T):
        asym = float(np.max(np.abs(est.P - est.P.T)))
        raise _fail("check_covariance", f"P is not symmetric (max |P - P^T| = {asym:g})")
    smallest = float(np.linalg.eigvalsh(est.P).min())
    if not smallest > 0.0:
        raise _fail("check_covariance", f"P is not positive definite (smallest eigenvalue {smallest:g})")


def check_saver(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """filterpy's ``Saver`` records every sample and converts to arrays."""
    est = factory()
    saver = Saver(est)
    n_samples = 30
    for k in range(n_samples):
        est.predict(u[k])
        est.update(y[k])
        saver.save()
    saver.to_array()
    if len(saver) != n_samples or np.shape(saver.x) != (n_samples, est.dim_x):
        raise _fail(
            "check_saver", f"Saver holds x of shape {np.shape(saver.x)}, expected ({n_samples}, {est.dim_x})"
        )
    if not np.array_equal(saver.x[-1], est.x):
        raise _fail("check_saver", "the last saved x differs from the estimator's x")
    for prop in ("log_likelihood", "likelihood", "mahalanobis"):
        if len(saver[prop]) != n_samples:
            raise _fail("check_saver", f"Saver did not record the property {prop}")
    saver_batch = Saver(est)
    est.batch_filter(u[:10], y[:10], saver=saver_batch)
    if len(saver_batch) != 10:
        raise _fail("check_saver", f"batch_filter(saver=...) saved {len(saver_batch)} of 10 samples")


def check_skip_none(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """``update(None)`` leaves the estimate and covariance at the prior."""
    est = factory()
    _run(est, u[:10], list(y[:10]))
    est.predict(u[10])
    x_prior, P_prior = _snapshot(est)
    est.update(None)
    if not (np.array_equal(est.x, x_prior) and np.array_equal(est.P, P_prior)):
        raise _fail("check_skip_none", "update(None) changed x or P")
    if not (np.array_equal(est.x_post, x_prior) and np.array_equal(est.P_post, P_prior)):
        raise _fail("check_skip_none", "update(None) must set x_post, P_post to the prior")
    if est.y != 0.0:
        raise _fail("check_skip_none", f"update(None) must set the innovation y to 0, got {est.y}")


def check_batch_equals_loop(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """``batch_filter`` gives the numbers of the predict/update loop, skips included."""
    z: list[float | None] = [None if k % 17 == 5 else float(v) for k, v in enumerate(y)]
    loop = factory()
    predictions = np.empty(len(u))
    x_hist = np.empty((len(u), loop.dim_x))
    for k in range(len(u)):
        predictions[k] = loop.predict(u[k])
        loop.update(z[k])
        x_hist[k] = loop.x
    batch = factory()
    result = batch.batch_filter(u, z)
    for label, got, want in (
        ("y_hat", result.y_hat, predictions),
        ("x", result.x, x_hist),
        ("final x", batch.x, loop.x),
        ("final P", batch.P, loop.P),
        ("final x_prior", batch.x_prior, loop.x_prior),
        ("final P_prior", batch.P_prior, loop.P_prior),
    ):
        if np.shape(got) != np.shape(want) or not np.allclose(got, want, rtol=1e-9, atol=1e-12):
            raise _fail("check_batch_equals_loop", f"{label} of batch_filter differs from the sample loop")
    if batch.sample_index != loop.sample_index:
        raise _fail("check_batch_equals_loop", "batch_filter did not advance sample_index like the loop")
    skipped = [k for k, v in enumerate(z) if v is None]
    if not np.all(np.isnan(result.innovation[skipped])):
        raise _fail("check_batch_equals_loop", "skipped samples must have a NaN innovation")


def check_bad_input(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """Non-finite input raises ValueError naming the sample; nothing is lost."""
    est = factory()
    _run(est, u[:10], list(y[:10]))
    x0, P0 = _snapshot(est)
    for bad in (float("nan"), float("inf")):
        try:
            est.predict(bad)
        except ValueError as exc:
            if "sample" not in str(exc):
                raise _fail("check_bad_input", f"error for u={bad} does not name the sample: {exc}") from None
        else:
            raise _fail("check_bad_input", f"predict({bad}) did not raise ValueError")
        if not (np.array_equal(est.x, x0) and np.array_equal(est.P, P0)):
            raise _fail("check_bad_input", f"predict({bad}) changed x or P")
    u_bad = u[:20].copy()
    u_bad[13] = np.nan
    try:
        est.batch_filter(u_bad, y[:20])
    except ValueError as exc:
        if "13" not in str(exc):
            raise _fail("check_bad_input", f"batch error does not name index 13: {exc}") from None
    else:
        raise _fail("check_bad_input", "batch_filter with NaN in u did not raise ValueError")
    if not (np.array_equal(est.x, x0) and np.array_equal(est.P, P0)):
        raise _fail("check_bad_input", "a rejected batch_filter changed x or P")
    for args, what in (((u[:20], y[:19]), "z shorter than u"), ((u[:20].reshape(4, 5), y[:20]), "2-D u")):
        try:
            est.batch_filter(*args)
        except ValueError:
            pass
        else:
            raise _fail("check_bad_input", f"batch_filter accepted {what}")
    est.predict(u[10])
    x_prior, P_prior = _snapshot(est)
    try:
        est.update(float("inf"))
    except ValueError:
        pass
    else:
        raise _fail("check_bad_input", "update(inf) did not raise ValueError")
    if not (np.array_equal(est.x, x_prior) and np.array_equal(est.P, P_prior)):
        raise _fail("check_bad_input", "update(inf) changed x or P")


def check_reset(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """``reset`` returns to the initial estimate and covariance."""
    est = factory()
    x_init, P_init = _snapshot(est)
    est.batch_filter(u[:50], y[:50])
    est.reset()
    if not (np.array_equal(est.x, x_init) and np.array_equal(est.P, P_init)) or est.sample_index != 0:
        raise _fail("check_reset", "reset() did not restore x, P and sample_index")
    fresh = factory()
    first = fresh.batch_filter(u[:50], y[:50])
    again = est.batch_filter(u[:50], y[:50])
    if not np.allclose(first.x, again.x, rtol=1e-12, atol=0.0):
        raise _fail("check_reset", "a reset estimator does not repeat a fresh one")


def check_simulate(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """``simulate`` returns a finite free-run output and leaves the estimate alone."""
    est = factory()
    est.batch_filter(u, y)
    x0, P0 = _snapshot(est)
    y_sim = est.simulate(u)
    if np.shape(y_sim) != np.shape(u) or not np.all(np.isfinite(y_sim)):
        raise _fail("check_simulate", f"simulate returned shape {np.shape(y_sim)} or non-finite values")
    if not (np.array_equal(est.x, x0) and np.array_equal(est.P, P0)):
        raise _fail("check_simulate", "simulate changed x or P")
    try:
        est.simulate(np.array([0.0, np.inf, 0.0]))
    except ValueError:
        pass
    else:
        raise _fail("check_simulate", "simulate accepted a non-finite input")


def check_repr(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> None:
    """``repr`` names the class and shows x and P, as filterpy does."""
    est = factory()
    text = repr(est)
    for needle in (type(est).__name__, "x =", "P ="):
        if needle not in text:
            raise _fail("check_repr", f"repr does not contain {needle!r}")


CHECKS = (
    check_interface,
    check_shapes,
    check_covariance,
    check_saver,
    check_skip_none,
    check_batch_equals_loop,
    check_bad_input,
    check_reset,
    check_simulate,
    check_repr,
)


def check_estimator(
    factory: EstimatorFactory, u: np.ndarray | None = None, y: np.ndarray | None = None
) -> list[str]:
    """Run every conformance check on estimators built by ``factory``.

    Parameters
    ----------
    factory : callable
        Returns a fresh estimator each call.
    u, y : ndarray, optional
        The record to run on, input [V] and output; at least 60 samples.
        :func:`conformance_record` by default.

    Returns
    -------
    list of str
        The names of the checks, all passed.

    Raises
    ------
    AssertionError
        From the first failing check, naming it.
    """
    if u is None or y is None:
        u, y = conformance_record()
    u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
    if u.shape != y.shape or u.ndim != 1 or len(u) < 60:
        raise ValueError(f"u and y must be 1-D of one length >= 60, got {u.shape} and {y.shape}")
    for check in CHECKS:
        check(factory, u, y)
    return [check.__name__ for check in CHECKS]
