"""Friction EKF and UKF speed: motorid's filters beside filterpy's ExtendedKalmanFilter
and UnscentedKalmanFilter driven directly with a plain-NumPy version of the same
model, the way a filterpy user would write it, in one process.

The model is the default ``FrictionEKF``: the paper's rig (dt = 0.04 s) with the
friction on the motor mass, state [ω_m, ω_L, δ, T_c, B] (n = 5), quasi-static
current, 26 Heun sub-steps per sample with Karnopp stick/slip, the Jacobian chained
through the sub-steps. Data: 60 s of the two-sine excitation on that rig with its
Coulomb + viscous friction. Each peer's final estimate is checked equal to ours
before its time counts: the EKF's to 1e-6; the UKF's to 1 %, because its sigma
points start at rest, on the stick/slip switch, where rounding differences between
two implementations of one model (the models agree to 1e-11) decide whether a point
sticks, and the filters then part by a few tenths of a percent.

The EKF's predict+update is given in wall time and in the CPU time of the process (steadier
on a machine shared with other work; the peer is timed the same way).

Run: ``python benchmarks/bench_ekf.py``. Target: EKF predict+update <= 15 us.
"""

from __future__ import annotations

import logging
import math

import numpy as np
from _table import Row, best_of, best_times, print_rows
from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter

from motorid.drive import Friction, paper_rig
from motorid.estimators import FrictionEKF, FrictionUKF
from motorid.signals import two_sine_signal

TITLE = "Friction EKF / UKF, n = 5 (paper rig, dt = 40 ms, 26 sub-steps), best of 3"
logger = logging.getLogger(__name__)


# --------------------------------------------------------------------------- the peer's model
class NumpyFrictionModel:
    """The same model in plain NumPy: Coulomb + viscous on the motor mass, quasi-static
    current, Heun sub-steps with the friction direction held per sub-step, Karnopp
    stick/slip, and the Jacobian chained through the sub-steps."""

    def __init__(self, rig, substeps: int):
        self.rig = rig
        self.h = rig.dt / substeps
        self.substeps = substeps

    def drift(self, x, v, s, stuck):
        r = self.rig
        wm, wl, d, tc, b = x
        t_m = r.K_m * (v - r.K_m * wm) / r.R_a
        t_s = r.k_s * d + r.B_s * (wm - wl)
        f = np.array([(t_m - t_s - (s * tc + b * wm)) / r.J_m, (t_s - r.T_d) / r.J_l, wm - wl, 0.0, 0.0])
        A = np.zeros((5, 5))
        A[0] = [
            (-(r.K_m**2) / r.R_a - r.B_s - b) / r.J_m,
            r.B_s / r.J_m,
            -r.k_s / r.J_m,
            -s / r.J_m,
            -wm / r.J_m,
        ]
        A[1, :3] = [r.B_s / r.J_l, -r.B_s / r.J_l, r.k_s / r.J_l]
        A[2, :2] = [1.0, -1.0]
        if stuck:
            f[0] = 0.0
            A[0] = 0.0
        return f, A

    def direction(self, x, v):
        r = self.rig
        if x[0] != 0.0:
            return math.copysign(1.0, x[0]), False
        t_net = r.K_m * (v - r.K_m * x[0]) / r.R_a - r.k_s * x[2] - r.B_s * (x[0] - x[1])
        if abs(t_net) <= x[3]:
            return 0.0, True
        return math.copysign(1.0, t_net), False

    def step(self, x, v):
        """``(x_next, F)`` over one sample."""
        h = self.h
        F = np.eye(5)
        for _ in range(self.substeps):
            s, stuck = self.direction(x, v)
            k1, A1 = self.drift(x, v, s, stuck)
            k2, A2 = self.drift(x + h * k1, v, s, stuck)
            x_new = x + 0.5 * h * (k1 + k2)
            Fk = np.eye(5) + 0.5 * h * (A1 + A2 @ (np.eye(5) + h * A1))
            if stuck or s * x_new[0] < 0.0:
                x_new[0] = 0.0
                Fk[0] = 0.0
            F = Fk @ F
            x = x_new
        return x, F


def filterpy_ekf(ours: FrictionEKF, model: NumpyFrictionModel, u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """filterpy's ExtendedKalmanFilter with the NumPy model; returns the final estimate."""
    ekf = ExtendedKalmanFilter(dim_x=5, dim_z=1)
    ekf.x = ours.x0.reshape(5, 1).copy()
    ekf.P = ours.P0.copy()
    ekf.Q = ours.Q.copy()
    ekf.R = np.array([[ours.R_speed]])
    H = np.array([[0.0, 1.0, 0.0, 0.0, 0.0]])
    amp = model.rig.amplifier
    v_now = {"v": 0.0}

    def predict_x(u=0):
        x, F = model.step(ekf.x.ravel(), v_now["v"])
        ekf.x = x.reshape(5, 1)
        ekf.F = F

    ekf.predict_x = predict_x
    for k in range(len(u)):
        v_now["v"] = float(amp(u[k]))
        ekf.predict()
        ekf.update(np.array([[y[k]]]), lambda x: H, lambda x: x[1:2])
    return ekf.x.ravel()


def filterpy_ukf(ours: FrictionUKF, model: NumpyFrictionModel, u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """filterpy's UnscentedKalmanFilter with the NumPy model (no Jacobian used)."""
    points = MerweScaledSigmaPoints(5, alpha=ours.alpha, beta=ours.beta, kappa=ours.kappa)
    ukf = UnscentedKalmanFilter(
        dim_x=5,
        dim_z=1,
        dt=model.rig.dt,
        hx=lambda x: x[1:2],
        fx=lambda x, dt, v: model.step(x, v)[0],
        points=points,
    )
    ukf.x = ours.x0.copy()
    ukf.P = ours.P0.copy()
    ukf.Q = ours.Q.copy()
    ukf.R = np.array([[ours.R_speed]])
    amp = model.rig.amplifier
    for k in range(len(u)):
        ukf.predict(v=float(amp(u[k])))
        ukf.update(np.array([y[k]]))
    return ukf.x.copy()


def check_same_estimate(peer: str, theta: np.ndarray, ours: np.ndarray, rtol: float) -> None:
    """The peer solved the same problem: its final friction estimate equals ours."""
    gap = float(np.max(np.abs(theta[3:] - ours[3:]) / np.abs(ours[3:])))
    if not gap <= rtol:
        raise AssertionError(f"{peer} and motorid disagree on the friction estimate by {gap:.3g} (relative)")
    logger.info("%s vs motorid friction estimate: max relative difference %.2e", peer, gap)


def measure() -> list[Row]:
    friction = (Friction(("coulomb_friction",), {"coulomb": 6e-3}, side="motor"),)
    rig = paper_rig(friction=friction, B_m=3e-5, B_l=0.0)
    _, u = two_sine_signal(60.0, rig.dt, seed=0)
    y = rig.simulate(u, seed=0)["y"].to_numpy()
    n_ekf, n_ukf, n_peer_ekf, n_peer_ukf = len(u), 300, 300, 40

    def run(cls, n):
        est = cls.from_rig(rig)
        for k in range(n):
            est.predict(u[k])
            est.update(y[k])
        return est

    run(FrictionEKF, 20)  # load the compiled kernels
    run(FrictionUKF, 5)
    FrictionEKF.from_rig(rig).batch_filter(u[:20], y[:20])
    t_ekf = best_times(3, lambda: run(FrictionEKF, n_ekf))
    t_ukf = best_of(3, lambda: run(FrictionUKF, n_ukf))
    t_batch = best_of(3, lambda: FrictionEKF.from_rig(rig).batch_filter(u, y))

    ekf_ref = FrictionEKF.from_rig(rig)
    model = NumpyFrictionModel(rig, ekf_ref.n_substeps)
    t_peer_ekf = best_times(3, lambda: filterpy_ekf(ekf_ref, model, u[:n_peer_ekf], y[:n_peer_ekf]))
    t_peer_ukf = best_of(3, lambda: filterpy_ukf(run(FrictionUKF, 0), model, u[:n_peer_ukf], y[:n_peer_ukf]))

    check_same_estimate(
        "filterpy EKF",
        filterpy_ekf(ekf_ref, model, u[:n_peer_ekf], y[:n_peer_ekf]),
        run(FrictionEKF, n_peer_ekf).x,
        1e-6,
    )
    check_same_estimate(
        "filterpy UKF",
        filterpy_ukf(run(FrictionUKF, 0), model, u[:n_peer_ukf], y[:n_peer_ukf]),
        run(FrictionUKF, n_peer_ukf).x,
        1e-2,
    )

    ekf_us = t_ekf.wall / n_ekf * 1e6
    ukf_us = t_ukf / n_ukf * 1e6
    peer_ekf_us = t_peer_ekf.wall / n_peer_ekf * 1e6
    peer_ukf_us = t_peer_ukf / n_peer_ukf * 1e6
    return [
        Row("friction EKF predict+update per sample, n = 5", ekf_us, peer_ekf_us, "us", "filterpy EKF + NumPy model", False),
        Row("friction EKF predict+update per sample, n = 5, CPU time", t_ekf.cpu / n_ekf * 1e6,
            t_peer_ekf.cpu / n_peer_ekf * 1e6, "us", "filterpy EKF + NumPy model", False),
        Row("friction UKF predict+update per sample, n = 5", ukf_us, peer_ukf_us, "us", "filterpy UKF + NumPy model", False),
        Row("friction EKF batch_filter, n = 5", len(u) / t_batch, 1e6 / peer_ekf_us, "samples/s", "filterpy EKF + NumPy model", True),
    ]  # fmt: skip


if __name__ == "__main__":
    print_rows(measure(), TITLE)
    print("target: friction EKF predict+update <= 15 us")
