"""The physics of the friction filters: the two-mass drive with unknown friction as a
state-space model, its analytic Jacobian and its sub-stepped discretisation.

One implementation, compiled with numba, shared by
:class:`~motorid.estimators.friction_kf.FrictionEKF` (which also uses the Jacobian)
and :class:`~motorid.estimators.friction_kf.FrictionUKF` (which only uses the map).

State
-----
``x = [ω_m, ω_L, δ, (i_a), T_c, B, (T_c-), (T_s)]`` with

========= ============ =====================================================
ω_m, ω_L  rad/s        motor and load speed
δ         rad          shaft twist θ_m - θ_L
i_a       A            armature current (only with ``current_state``)
T_c       N m          Coulomb level (forward level with ``asymmetric``)
B         N m s/rad    viscous coefficient
T_c-      N m          backward Coulomb level (only with ``asymmetric``)
T_s       N m          Stribeck excess α1 (only with ``stribeck``)
========= ============ =====================================================

The friction parameters are random walks (zero drift in f; their process noise
is the filter's business).

Continuous model (paper eqs. 1-7, 12-13) with the friction on one mass, the
*friction side* j (motor or load), given the armature voltage v [V]::

    L_a di_a/dt = v - R_a i_a - K_m ω_m          (current in the state), or
    i_a         = (v - K_m ω_m) / R_a            (quasi-static current)
    T_s  = k_s δ + B_s (ω_m - ω_L)
    J_m dω_m/dt = K_m i_a - T_s          - [j = motor] T_f
    J_L dω_L/dt = T_s - T_d              - [j = load]  T_f
    dδ/dt       = ω_m - ω_L
    T_f  = s (T_c,s + T_s exp(-α2 s ω_j)) + B ω_j                         (eqs. 8, 9, 11)

where s is the direction of motion of mass j and T_c,s the Coulomb level for that
direction (T_c forwards, T_c- backwards when asymmetric, else T_c both ways).
With s = sgn(ω_j) the exponent is -α2 |ω_j|, eq. (9); α2 (``stribeck_decay``,
s/rad) is a known constant.

Zero speed (sgn is not differentiable at 0)
-------------------------------------------
The sample is integrated in ``n`` sub-steps of h = dt/n by Heun's method (RK2).
Within a sub-step the direction s is *frozen* at its value at the start of the
sub-step, exactly as the plant's integrator holds its friction torques over an
internal step, and a Karnopp stick/slip rule makes the model stick like the plant:

- ω_j != 0 at the start: s = sgn(ω_j). If the sub-step ends with s ω_j < 0 (the
  mass passed through zero) ω_j is set to exactly 0.
- ω_j == 0 at the start: the mass stays stuck (dω_j/dt = 0 over the sub-step)
  while the net driving torque on it lies in [-(T_c- + T_s), T_c + T_s]; else it
  breaks away with s the sign of that torque.

So the map is smooth in x inside each mode and the Jacobian is the exact
derivative of the sub-stepped map along the path actually taken: the Coulomb term
contributes s to dT_f/dT_c and nothing to dT_f/dω_j (the Dirac delta of sgn at 0
is ignored), a stop at zero or a stuck sub-step zeroes the row of ω_j. The
consequences: (i) the model holds a resting drive exactly still, as the plant and
a real drive do, instead of chattering around zero; (ii) while the friction-side
mass is stuck the output does not depend on the friction parameters, so a stuck
stretch teaches the filter nothing about them and the EKF learns T_c and B from
the moving stretches only (low-speed motion after reversals is where T_c is best
seen against B ω); (iii) on the sample of a reversal the linearisation is
one-sided. The UKF propagates its sigma points through the same map, so it sees
the stick/slip switch itself rather than a one-sided slope.

Armature current
----------------
L_a/R_a is 0.5 ms on the paper's rig against a 40 ms sample: the current settles
within a hundredth of a sample, no speed measurement at that rate can see its
transient, and keeping it in the state would add an eigenvalue -R_a/L_a that
forces sub-steps of about 0.1 ms. The quasi-static value is then used; it leaves
the steady state exact and changes the mechanical transients by about
(L_a/R_a)/(J R_a/K_m^2), 0.5 % on that rig. Where the sampling is fast enough to
see the current (dt < 10 L_a/R_a) it is kept in the state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# indices into the packed constant vector ``c``
C_JM = 0
C_JL = 1
C_KM = 2
C_RA = 3
C_LA = 4
C_KS = 5
C_BS = 6
C_TD = 7
C_DECAY = 8
C_H = 9
C_NSUB = 10
C_SIDE = 11
C_I_CURRENT = 12
C_I_COULOMB = 13
C_I_VISCOUS = 14
C_I_COULOMB_NEG = 15
C_I_STRIBECK = 16
N_CONSTANTS = 17

#: indices of the mechanical states in x
I_OMEGA_M = 0
I_OMEGA_L = 1
I_TWIST = 2


def state_layout(
    current_state: bool, asymmetric: bool, stribeck: bool
) -> tuple[tuple[str, ...], dict[str, int]]:
    """Names of the entries of x and the index of each optional one (-1 when absent)."""
    names = ["omega_m", "omega_l", "twist"]
    index = {"i_a": -1, "coulomb_neg": -1, "stribeck": -1}
    if current_state:
        index["i_a"] = len(names)
        names.append("i_a")
    index["coulomb"] = len(names)
    names.append("coulomb")
    index["viscous"] = len(names)
    names.append("viscous")
    if asymmetric:
        index["coulomb_neg"] = len(names)
        names.append("coulomb_neg")
    if stribeck:
        index["stribeck"] = len(names)
        names.append("stribeck")
    return tuple(names), index


def pack_constants(
    *,
    J_m: float,
    J_l: float,
    K_m: float,
    R_a: float,
    L_a: float,
    k_s: float,
    B_s: float,
    T_d: float,
    stribeck_decay: float,
    dt: float,
    substeps: int,
    friction_side: str,
    index: dict[str, int],
) -> np.ndarray:
    """The constant vector ``c`` the kernels read (SI units)."""
    c = np.zeros(N_CONSTANTS)
    c[C_JM], c[C_JL], c[C_KM], c[C_RA], c[C_LA] = J_m, J_l, K_m, R_a, L_a
    c[C_KS], c[C_BS], c[C_TD], c[C_DECAY] = k_s, B_s, T_d, stribeck_decay
    c[C_H] = dt / substeps
    c[C_NSUB] = substeps
    c[C_SIDE] = 0 if friction_side == "motor" else 1
    c[C_I_CURRENT] = index["i_a"]
    c[C_I_COULOMB] = index["coulomb"]
    c[C_I_VISCOUS] = index["viscous"]
    c[C_I_COULOMB_NEG] = index["coulomb_neg"]
    c[C_I_STRIBECK] = index["stribeck"]
    return c


# --------------------------------------------------------------------------- kernels
@njit(cache=True)
def drift(
    x: np.ndarray, v: float, c: np.ndarray, s: float, stuck: bool, f: np.ndarray, A: np.ndarray
) -> None:
    """Continuous model ``f = dx/dt`` and its Jacobian ``A = df/dx`` for the friction
    direction ``s`` (+1 or -1) held fixed; ``stuck`` freezes the friction-side speed.

    ``v`` is the armature voltage [V]. Fills ``f`` (n,) and ``A`` (n, n).
    """
    n = x.shape[0]
    jm = c[C_JM]
    jl = c[C_JL]
    K = c[C_KM]
    R = c[C_RA]
    ks = c[C_KS]
    bs = c[C_BS]
    side = int(c[C_SIDE])
    ic = int(c[C_I_CURRENT])
    i_c = int(c[C_I_COULOMB])
    i_b = int(c[C_I_VISCOUS])
    i_n = int(c[C_I_COULOMB_NEG])
    i_s = int(c[C_I_STRIBECK])
    for i in range(n):
        f[i] = 0.0
        for k in range(n):
            A[i, k] = 0.0
    wm = x[0]
    wl = x[1]
    t_s = ks * x[2] + bs * (wm - wl)

    # motor torque K_m i_a
    if ic >= 0:
        L = c[C_LA]
        i_a = x[ic]
        t_m = K * i_a
        f[ic] = (v - R * i_a - K * wm) / L
        A[ic, ic] = -R / L
        A[ic, 0] = -K / L
        A[0, ic] = K / jm
        dtm_dwm = 0.0
    else:
        t_m = K * (v - K * wm) / R
        dtm_dwm = -K * K / R

    f[0] = (t_m - t_s) / jm
    f[1] = (t_s - c[C_TD]) / jl
    f[2] = wm - wl
    A[0, 0] = (dtm_dwm - bs) / jm
    A[0, 1] = bs / jm
    A[0, 2] = -ks / jm
    A[1, 0] = bs / jl
    A[1, 1] = -bs / jl
    A[1, 2] = ks / jl
    A[2, 0] = 1.0
    A[2, 1] = -1.0

    if stuck:
        f[side] = 0.0
        for k in range(n):
            A[side, k] = 0.0
        return

    # friction on mass ``side``, direction s held
    w = x[side]
    J = jm if side == 0 else jl
    i_level = i_c if (s > 0.0 or i_n < 0) else i_n
    t_f = s * x[i_level] + x[i_b] * w
    dtf_dw = x[i_b]
    A[side, i_level] -= s / J
    A[side, i_b] -= w / J
    if i_s >= 0:
        decay = c[C_DECAY]
        e = math.exp(-decay * s * w)
        t_f += s * x[i_s] * e
        dtf_dw -= x[i_s] * decay * e
        A[side, i_s] -= s * e / J
    f[side] -= t_f / J
    A[side, side] -= dtf_dw / J


@njit(cache=True)
def _direction(x: np.ndarray, v: float, c: np.ndarray) -> tuple[float, bool]:
    """Karnopp's rule at the start of a sub-step: ``(s, stuck)`` for the friction side."""
    side = int(c[C_SIDE])
    w = x[side]
    if w > 0.0:
        return 1.0, False
    if w < 0.0:
        return -1.0, False
    K = c[C_KM]
    t_s = c[C_KS] * x[2] + c[C_BS] * (x[0] - x[1])
    if side == 0:
        ic = int(c[C_I_CURRENT])
        t_m = K * x[ic] if ic >= 0 else K * (v - K * x[0]) / c[C_RA]
        t_net = t_m - t_s
    else:
        t_net = t_s - c[C_TD]
    i_c = int(c[C_I_COULOMB])
    i_n = int(c[C_I_COULOMB_NEG])
    i_s = int(c[C_I_STRIBECK])
    excess = x[i_s] if i_s >= 0 else 0.0
    b_pos = x[i_c] + excess
    b_neg = (x[i_n] if i_n >= 0 else x[i_c]) + excess
    if -b_neg <= t_net <= b_pos:
        return 0.0, True
    return (1.0 if t_net > 0.0 else -1.0), False


@njit(cache=True)
def _matmul(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:
    n = A.shape[0]
    for i in range(n):
        for k in range(n):
            acc = 0.0
            for m in range(n):
                acc += A[i, m] * B[m, k]
            out[i, k] = acc


@njit(cache=True)
def propagate(x: np.ndarray, v: float, c: np.ndarray, F: np.ndarray, want_jacobian: bool) -> np.ndarray:
    """The discrete model: ``x`` advanced over one sample with armature voltage ``v``
    held (module docstring). Returns the new state; with ``want_jacobian`` fills ``F``
    (n, n) with its exact derivative d x_next / d x, else leaves ``F`` alone.
    """
    n = x.shape[0]
    h = c[C_H]
    side = int(c[C_SIDE])
    xk = x.copy()
    x1 = np.empty(n)
    xn = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    A1 = np.empty((n, n))
    A2 = np.empty((n, n))
    Fk = np.empty((n, n))
    tmp = np.empty((n, n))
    if want_jacobian:
        for i in range(n):
            for k in range(n):
                F[i, k] = 1.0 if i == k else 0.0
    for _ in range(int(c[C_NSUB])):
        s, stuck = _direction(xk, v, c)
        drift(xk, v, c, s, stuck, k1, A1)
        for i in range(n):
            x1[i] = xk[i] + h * k1[i]
        drift(x1, v, c, s, stuck, k2, A2)
        for i in range(n):
            xn[i] = xk[i] + 0.5 * h * (k1[i] + k2[i])
        stop = (not stuck) and s * xn[side] < 0.0
        if stop:
            xn[side] = 0.0
        if want_jacobian:
            # Fk = I + h/2 (A1 + A2 (I + h A1))
            _matmul(A2, A1, tmp)
            for i in range(n):
                for k in range(n):
                    Fk[i, k] = (1.0 if i == k else 0.0) + 0.5 * h * (A1[i, k] + A2[i, k] + h * tmp[i, k])
            if stop:
                for k in range(n):
                    Fk[side, k] = 0.0
            _matmul(Fk, F, tmp)
            F[:, :] = tmp
        for i in range(n):
            xk[i] = xn[i]
    return xk


@njit(cache=True)
def covariance_predict(P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``F P F^T + Q`` on one triangle, mirrored (exactly symmetric)."""
    n = P.shape[0]
    FP = np.empty((n, n))
    _matmul(F, P, FP)
    out = np.empty((n, n))
    for i in range(n):
        for k in range(i, n):
            acc = Q[i, k]
            for m in range(n):
                acc += FP[i, m] * F[k, m]
            out[i, k] = acc
            out[k, i] = acc
    return out


@njit(cache=True)
def free_run(v: np.ndarray, x0: np.ndarray, c: np.ndarray) -> np.ndarray:
    """States after each sample of a record of armature voltages ``v`` from ``x0``, shape (N, n)."""
    N = v.shape[0]
    n = x0.shape[0]
    out = np.empty((N, n))
    F = np.empty((0, 0))
    x = x0.copy()
    for t in range(N):
        x = propagate(x, v[t], c, F, False)
        out[t] = x
    return out


def stiffest_rate(c: np.ndarray, x: np.ndarray, v: float = 0.0) -> float:
    """Largest |eigenvalue| [1/s] of the continuous Jacobian at ``x`` (moving forwards)."""
    n = x.shape[0]
    f = np.empty(n)
    A = np.empty((n, n))
    drift(x, v, c, 1.0, False, f, A)
    return float(np.max(np.abs(np.linalg.eigvals(A))))


__all__ = [
    "I_OMEGA_L",
    "I_OMEGA_M",
    "I_TWIST",
    "covariance_predict",
    "drift",
    "free_run",
    "pack_constants",
    "propagate",
    "state_layout",
    "stiffest_rate",
]
