"""RLS speed: motorid's compiled batch path and per-sample loop beside two peers on
the same regressors, in one process.

p = 19 parameters: Hammerstein na = 4, nb = 4, degree 3, lam = 0.99, P0 = 1e3 I.

Peers, each fed the regressors phi(t) that motorid forms (taken from a motorid run,
so all three solve one problem; each peer's final estimate is checked
equal to ours to rounding before its time counts):

- filterpy's ``KalmanFilter`` as RLS: F = I, alpha^2 = 1/lam, Q = 0, H = phi^T, R = 1;
- SysIdentPy's ``RecursiveLeastSquares(lam=0.99, delta=1e-3)`` (its P0 = I/delta),
  whose ``optimize(psi, y)`` runs the whole record at once, the counterpart of our
  ``batch_filter``. SysIdentPy is in the ``bench`` extra only
  (``pip install -e ".[bench]"``); without it that row has no peer.

Each figure is given twice, from the same runs: wall time, and the CPU time of the
process (steadier on a machine shared with other work, since waiting for a core is
not counted; the peers are timed the same way).

Run: ``python benchmarks/bench_rls.py``.
Targets: batch >= 2,500,000 samples/s and >= 60x filterpy; predict+update <= 5 us.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np
from _table import Row, best_times, print_rows
from filterpy.kalman import KalmanFilter

from motorid.estimators import HammersteinRLS

TITLE = "RLS, p = 19 (Hammerstein na=4, nb=4, degree=3), best of 5 (peers: 3)"
LAM, DELTA = 0.99, 1e3
logger = logging.getLogger(__name__)


def make() -> HammersteinRLS:
    return HammersteinRLS(4, 4, degree=3, lam=LAM, delta=DELTA)


def regressors(u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The regressors phi(t) motorid forms on (u, y), one row per sample."""
    phis = np.empty((len(u), make().dim_x))
    ref = make()
    for k in range(len(u)):
        ref.predict(u[k])
        phis[k] = ref.phi
        ref.update(y[k])
    return phis


def filterpy_rls(phis: np.ndarray, y: np.ndarray) -> np.ndarray:
    """filterpy's KalmanFilter set up as RLS over the given regressors; the final estimate."""
    p = phis.shape[1]
    kf = KalmanFilter(dim_x=p, dim_z=1)
    kf.P *= DELTA
    kf.Q = np.zeros((p, p))
    kf.alpha = 1.0 / np.sqrt(LAM)
    for k in range(len(y)):
        kf.predict()
        kf.H = phis[k][None, :]
        kf.update(y[k])
    return kf.x.ravel()


def sysidentpy_rls() -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
    """SysIdentPy's RecursiveLeastSquares as ``f(phis, y) -> theta``; None when not installed."""
    try:
        from sysidentpy.parameter_estimation import RecursiveLeastSquares
    except ImportError:
        return None

    def run(phis: np.ndarray, y: np.ndarray) -> np.ndarray:
        rls = RecursiveLeastSquares(lam=LAM, delta=1.0 / DELTA)
        return rls.optimize(phis, y.reshape(-1, 1)).ravel()

    return run


def check_same_estimate(peer: str, theta: np.ndarray, ours: np.ndarray) -> None:
    """The peer solved the same problem: its final estimate equals ours to rounding."""
    gap = float(np.max(np.abs(theta - ours)))
    if gap > 1e-9 * (1.0 + float(np.max(np.abs(ours)))):
        raise AssertionError(f"{peer} and motorid disagree on the final estimate by {gap:.3g}")
    logger.info("%s vs motorid final estimate: max |difference| %.2e", peer, gap)


def measure() -> list[Row]:
    rng = np.random.default_rng(0)
    n_batch, n_loop, n_peer = 500_000, 50_000, 10_000
    u = rng.uniform(-1, 1, n_batch)
    y = rng.standard_normal(n_batch)
    assert make().dim_x == 19

    warm = make()
    warm.batch_filter(u[:100], y[:100])
    for k in range(100):
        warm.predict(u[k])
        warm.update(y[k])

    t_batch = best_times(5, lambda: make().batch_filter(u, y))

    def loop() -> None:
        est = make()
        for k in range(n_loop):
            est.predict(u[k])
            est.update(y[k])

    t_loop = best_times(5, loop)

    phis = regressors(u[:n_peer], y[:n_peer])
    y_peer = y[:n_peer]
    t_filterpy = best_times(3, lambda: filterpy_rls(phis, y_peer))

    ours_theta = make().batch_filter(u[:n_peer], y_peer).x[-1]
    check_same_estimate("filterpy", filterpy_rls(phis, y_peer), ours_theta)
    sysid = sysidentpy_rls()
    t_sysid = None
    if sysid is not None:
        check_same_estimate("SysIdentPy", sysid(phis, y_peer), ours_theta)
        t_sysid = best_times(3, lambda: sysid(phis, y_peer))

    rows = []
    for clock in ("wall", "cpu"):
        label = "" if clock == "wall" else ", CPU time"
        batch_rate = n_batch / getattr(t_batch, clock)
        filterpy_rate = n_peer / getattr(t_filterpy, clock)
        rows.append(
            Row(
                f"RLS batch, p = 19{label}",
                batch_rate,
                filterpy_rate,
                "samples/s",
                "filterpy KalmanFilter",
                True,
            )
        )
        if t_sysid is None:
            rows.append(
                Row(
                    f"RLS batch, p = 19{label}",
                    batch_rate,
                    None,
                    "samples/s",
                    "SysIdentPy (not installed)",
                    True,
                )
            )
        else:
            sysid_rate = n_peer / getattr(t_sysid, clock)
            rows.append(
                Row(f"RLS batch, p = 19{label}", batch_rate, sysid_rate, "samples/s", "SysIdentPy RLS", True)
            )
        rows.append(
            Row(
                f"RLS predict+update per sample, p = 19{label}",
                getattr(t_loop, clock) / n_loop * 1e6,
                1e6 / filterpy_rate,
                "us",
                "filterpy KalmanFilter",
                False,
            )
        )
    return rows


if __name__ == "__main__":
    print_rows(measure(), TITLE)
    print("targets: batch >= 2,500,000 samples/s and >= 60x filterpy; per sample <= 5 us")
