"""The conformance suite every motorid estimator passes, built in or plugged in.

In the spirit of scikit-learn's ``check_estimator``: hand it a factory that
returns a fresh estimator and it checks the interface contract of
:class:`motorid.estimators.Estimator` (shapes, filterpy's ``Saver``, skipping a
sample with ``None``, ``batch_filter`` equal to the sample loop, clear errors on
bad input with nothing lost, ``reset``, ``simulate`` and ``repr``)::

    from motorid.testing import check_estimator
    report = check_estimator(lambda: MyEstimator(order=2))
    report["check_batch_equals_loop"]   # 0.0: batch_filter gives the loop's numbers bit for bit

Each failure raises ``AssertionError`` naming the check and what was wrong.

What the suite promises, and why it holds on every CPU
-------------------------------------------------------
Where the contract is about no arithmetic at all (a skipped update, a rejected
input, a saved copy, the symmetry of P, which any estimator keeps exactly by
mirroring one triangle or averaging ``P`` and ``P.T``), the checks compare bit for
bit. Where two runs compute the same quantities along two code paths
(``batch_filter`` against the sample loop, a reset estimator against a fresh one),
they allow for rounding, because a plugin's two paths may round differently on
some CPUs though they agree on others: NumPy dispatches SIMD code per CPU, so a
vectorised ``u**3`` can differ in the last bit from a scalar one on AVX-512, and a
recursive estimator carries that bit forward and amplifies it, by as much as the
conditioning of its problem allows (RLS: up to about ``eps cond(P)``, with
``cond(P)`` of 1e8 to 1e10 on the conformance record). Rather than guess that
amplification, the checks measure it: the loop runs once more on the record with
every input and measurement moved by one unit in the last place, and the two paths
may differ by up to :data:`ROUNDING_MARGIN` times the estimator's response to that
change, each estimate relative to its own size (:func:`rounding_comparison`). A
different rounding of one intermediate value per sample (``u**3`` vectorised
against scalar, in the Hammerstein RLS) measured 0.4 to 3 times that response, so
the margin leaves room for paths that round differently in many places; a real
disagreement (a sample skipped or updated twice, an offset of 1e-3, a forgetting
factor off by even one part in 10^7) exceeds it by orders of magnitude. motorid's own
estimators compute both paths with the same operations in the same order, and the
figures the checks return are 0.0 for them (bit for bit; the project's tests
assert it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from filterpy.common import Saver

from motorid.drive.rigid import RigidDrive
from motorid.estimators.base import Estimator

EstimatorFactory = Callable[[], Estimator]

#: How many times the estimator's response to a last-bit change of its data two
#: code paths may differ before a check calls it a disagreement (module docstring).
ROUNDING_MARGIN = 1000.0
#: Differences below this many units in the last place of an estimate's size pass
#: even where the estimator does not respond to a last-bit change at all.
_ULPS_ALWAYS_ALLOWED = 64.0


def every_input_memory_drive() -> RigidDrive:
    """A rigid drive at 100 Hz with every input-path memory and a stick/slip free run: dead zone
    0.4 V, saturation 8 V (its rating), a 2.5-sample delay, a 20 ms lag, a 30 ms backlash dwell,
    Coulomb, Stribeck, viscous and static friction (SI units). The drive the rig-server tests and
    ``benchmarks/bench_rigid.py`` run."""
    return RigidDrive(
        ("coulomb_friction", "stribeck_friction", "viscous_friction", "input_dead_zone", "input_saturation",
         "backlash", "input_delay", "input_lag", "static_friction"),
        {"inertia": 2e-3, "input_gain": 0.05, "coulomb": 0.02, "stribeck": 0.01, "stribeck_velocity": 2.0,
         "viscous": 2e-3, "dead_zone": 0.4, "saturation": 8.0, "backlash_time": 0.03, "input_delay": 0.025,
         "lag_time_constant": 0.02, "breakaway_excess": 0.01},
        dt=0.01,
    )  # fmt: skip


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


def _run(est: Estimator, u: np.ndarray, z: Sequence[float | None]) -> np.ndarray:
    """Sample loop; returns the predictions."""
    out = np.empty(len(u))
    for k, (u_k, z_k) in enumerate(zip(u, z, strict=True)):
        out[k] = est.predict(u_k)
        est.update(z_k)
    return out


Run = dict[str, np.ndarray]


def _loop_run(est: Estimator, u: np.ndarray, z: Sequence[float | None]) -> Run:
    """The predict/update loop over a record: per-sample predictions and estimates,
    then the final estimate and covariance, posterior and prior."""
    y_hat = np.empty(len(u))
    x_hist = np.empty((len(u), est.dim_x))
    for k in range(len(u)):
        y_hat[k] = est.predict(u[k])
        est.update(z[k])
        x_hist[k] = est.x
    return {"y_hat": y_hat, "x": x_hist, **_final(est)}


def _final(est: Estimator) -> Run:
    return {
        "final x": np.array(est.x, dtype=float),
        "final P": np.array(est.P, dtype=float),
        "final x_prior": np.array(est.x_prior, dtype=float),
        "final P_prior": np.array(est.P_prior, dtype=float),
    }


def last_bit_changed(u: np.ndarray, z: Sequence[float | None]) -> tuple[np.ndarray, list[float | None]]:
    """The record with every input and measurement moved one unit in the last place
    up (skipped measurements stay None): the probe of :func:`rounding_comparison`."""
    return np.nextafter(u, np.inf), [None if v is None else float(np.nextafter(v, np.inf)) for v in z]


def _scales(reference: Run) -> dict[str, np.ndarray | float]:
    """The size each quantity is measured against: the largest |y_hat|; per state
    component its largest |x| over the record; for a covariance entry
    sqrt(P_ii P_jj), so units and scalings of the state cancel."""
    tiny = np.finfo(float).tiny
    scales: dict[str, np.ndarray | float] = {}
    if "y_hat" in reference:
        scales["y_hat"] = max(float(np.max(np.abs(reference["y_hat"]), initial=0.0)), tiny)
    x_scale = np.maximum(np.max(np.abs(reference["x"]), axis=0), tiny)
    for key in reference:
        if key in ("x", "final x", "final x_prior"):
            scales[key] = x_scale
        elif key in ("final P", "final P_prior"):
            root = np.sqrt(np.maximum(np.abs(np.diag(reference[key])), tiny))
            scales[key] = np.outer(root, root)
    return scales


def _relative_difference(a: np.ndarray, b: np.ndarray, scale: np.ndarray | float) -> float:
    """max |a - b| / scale; NaN in the same place counts as equal, elsewhere as infinite."""
    both_nan = np.isnan(a) & np.isnan(b)
    with np.errstate(invalid="ignore"):
        diff = np.where(both_nan, 0.0, np.abs(a - b) / scale)
    diff = np.nan_to_num(diff, nan=np.inf)
    return float(np.max(diff, initial=0.0))


def rounding_comparison(check: str, what: str, got: Run, want: Run, response: Run) -> float:
    """Compare two runs that compute the same quantities along two code paths.

    Parameters
    ----------
    check : str
        Name of the calling check, for the error.
    what : str
        What ``got`` is, e.g. ``"batch_filter"``, and ``want`` the reference.
    got, want : dict of str to ndarray
        The two runs, quantity by quantity (``y_hat``, ``x``, ``final P``, ...).
    response : dict of str to ndarray
        The reference code path run again on the record with every value moved
        one unit in the last place (:func:`last_bit_changed`).

    Returns
    -------
    float
        The largest difference of ``got`` from ``want`` as a fraction of what is
        allowed: 0.0 where every number is the same, at most 1.0 on success.

    Raises
    ------
    AssertionError
        Where a quantity's shape differs, or it differs by more than
        :data:`ROUNDING_MARGIN` times the estimator's response to the last-bit
        change plus 64 units in the last place, each estimate relative to its size
        (largest |y_hat|; per state component its largest |x|; sqrt(P_ii P_jj) for
        a covariance entry). The module docstring says why.
    """
    scales = _scales(want)
    eps = np.finfo(float).eps
    worst = 0.0
    for label, reference in want.items():
        if np.shape(got[label]) != np.shape(reference):
            raise _fail(
                check, f"{label} of {what} has shape {np.shape(got[label])}, expected {np.shape(reference)}"
            )
        deviation = _relative_difference(got[label], reference, scales[label])
        if deviation == 0.0:
            continue
        sensitivity = _relative_difference(response[label], reference, scales[label])
        allowed = ROUNDING_MARGIN * sensitivity + _ULPS_ALWAYS_ALLOWED * eps
        if not deviation <= allowed:
            raise _fail(
                check,
                f"{label} of {what} differs by {deviation:.3g} of its size, more than rounding explains "
                f"({allowed:.3g}: {ROUNDING_MARGIN:g} x its response to a last-bit change of the data)",
            )
        worst = max(worst, deviation / allowed)
    return worst


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
    """P stays symmetric positive definite over the whole record.

    Symmetry is checked bit for bit: an estimator keeps it exactly, on every CPU,
    by computing one triangle and mirroring it (or averaging ``P`` and ``P.T``,
    which rounds both triangles alike), so any asymmetry is a fault.
    """
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


def check_batch_equals_loop(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> float:
    """``batch_filter`` gives the numbers of the predict/update loop, skips included.

    Predictions, the estimate after every sample, and the final estimate and
    covariance (posterior and prior) are compared by :func:`rounding_comparison`:
    equal up to what rounding explains on any CPU (module docstring). Returns the
    largest difference as a fraction of that allowance, 0.0 where the two paths
    give the same numbers bit for bit.
    """
    z: list[float | None] = [None if k % 17 == 5 else float(v) for k, v in enumerate(y)]
    loop = factory()
    want = _loop_run(loop, u, z)
    batch = factory()
    result = batch.batch_filter(u, z)
    got = {"y_hat": np.asarray(result.y_hat), "x": np.asarray(result.x), **_final(batch)}
    if batch.sample_index != loop.sample_index:
        raise _fail("check_batch_equals_loop", "batch_filter did not advance sample_index like the loop")
    skipped = [k for k, v in enumerate(z) if v is None]
    if not np.all(np.isnan(np.asarray(result.innovation)[skipped])):
        raise _fail("check_batch_equals_loop", "skipped samples must have a NaN innovation")
    response = _loop_run(factory(), *last_bit_changed(u, z))
    return rounding_comparison("check_batch_equals_loop", "batch_filter", got, want, response)


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


def check_reset(factory: EstimatorFactory, u: np.ndarray, y: np.ndarray) -> float:
    """``reset`` returns to the initial estimate and covariance, and the reset
    estimator then repeats a fresh one.

    The repeat is compared by :func:`rounding_comparison`: a rerun allocates new
    arrays, and some libraries round differently with another memory alignment
    (Intel MKL outside its reproducible mode). Returns the largest difference as a
    fraction of that allowance, 0.0 where the repeat is bit for bit.
    """
    est = factory()
    x_init, P_init = _snapshot(est)
    est.batch_filter(u[:50], y[:50])
    est.reset()
    if not (np.array_equal(est.x, x_init) and np.array_equal(est.P, P_init)) or est.sample_index != 0:
        raise _fail("check_reset", "reset() did not restore x, P and sample_index")
    u50, z50 = u[:50], [float(v) for v in y[:50]]
    first = factory().batch_filter(u50, z50)
    again = est.batch_filter(u50, z50)
    changed = factory().batch_filter(*last_bit_changed(u50, z50))
    return rounding_comparison(
        "check_reset",
        "the reset estimator",
        {"y_hat": np.asarray(again.y_hat), "x": np.asarray(again.x)},
        {"y_hat": np.asarray(first.y_hat), "x": np.asarray(first.x)},
        {"y_hat": np.asarray(changed.y_hat), "x": np.asarray(changed.x)},
    )


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
) -> dict[str, float | None]:
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
    dict of str to float or None
        For each check, by name, the figure it measured: for
        :func:`check_batch_equals_loop` and :func:`check_reset` the largest
        difference between their two runs as a fraction of what rounding explains
        (0.0: the same numbers bit for bit; at most 1.0, or the check fails); None
        for the checks that compare nothing numerically.

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
    return {check.__name__: check(factory, u, y) for check in CHECKS}
