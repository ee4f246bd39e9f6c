"""RLS speed: motorid's compiled batch path and per-sample loop beside filterpy's
KalmanFilter used as RLS, on the same regressors, in one process.

p = 19 parameters: Hammerstein na = 4, nb = 4, degree 3. Run: python benchmarks/bench_rls.py
Targets: batch >= 1,000,000 samples/s and >= 30x filterpy; predict+update <= 10 us.
"""

from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import KalmanFilter

from motorid.estimators import HammersteinRLS


def best_of(repeats: int, func) -> float:
    """Smallest wall time of ``repeats`` runs [s] (the least disturbed by other load)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    rng = np.random.default_rng(0)
    n_batch, n_loop, n_peer = 500_000, 50_000, 10_000
    u = rng.uniform(-1, 1, n_batch)
    y = rng.standard_normal(n_batch)
    make = lambda: HammersteinRLS(4, 4, degree=3, lam=0.99)  # noqa: E731
    assert make().dim_x == 19

    warm = make()
    warm.batch_filter(u[:100], y[:100])
    for k in range(100):
        warm.predict(u[k])
        warm.update(y[k])

    t_batch = best_of(3, lambda: make().batch_filter(u, y))

    def loop() -> None:
        est = make()
        for k in range(n_loop):
            est.predict(u[k])
            est.update(y[k])

    t_loop = best_of(3, loop)

    # filterpy's KalmanFilter as RLS: F = I, alpha^2 = 1/lam, Q = 0, H = phi^T, R = 1,
    # on the regressors motorid forms (taken from a motorid run, so both solve one problem)
    phis = np.empty((n_peer, 19))
    ref = make()
    for k in range(n_peer):
        ref.predict(u[k])
        phis[k] = ref.phi
        ref.update(y[k])

    def peer() -> None:
        kf = KalmanFilter(dim_x=19, dim_z=1)
        kf.P *= 1e3
        kf.Q = np.zeros((19, 19))
        kf.alpha = 1.0 / np.sqrt(0.99)
        for k in range(n_peer):
            kf.predict()
            kf.H = phis[k][None, :]
            kf.update(y[k])

    t_peer = best_of(3, peer)

    batch_rate = n_batch / t_batch
    loop_us = t_loop / n_loop * 1e6
    peer_us = t_peer / n_peer * 1e6
    peer_rate = 1e6 / peer_us
    print("RLS, p = 19 (Hammerstein na=4, nb=4, degree=3), best of 3")
    print(f"{'figure':<44}{'motorid':>14}{'filterpy KF':>14}{'ratio':>10}")
    print(
        f"{'batch_filter [samples/s]':<44}{batch_rate:>14,.0f}{peer_rate:>14,.0f}{batch_rate / peer_rate:>9.0f}x"
    )
    print(f"{'predict+update per sample [us]':<44}{loop_us:>14.2f}{peer_us:>14.2f}{peer_us / loop_us:>9.1f}x")
    print("targets: batch >= 1,000,000 samples/s and >= 30x; per sample <= 10 us")


if __name__ == "__main__":
    main()
