"""The physics of the friction filters: the two-mass drive with unknown friction as a
state-space model, its analytic Jacobian and its sub-stepped discretisation.

One implementation, compiled with numba, shared by
:class:`~motorid.estimators.friction_kf.FrictionEKF` (which also uses the Jacobian)
and :class:`~motorid.estimators.friction_kf.FrictionUKF` (which only uses the map).
The EKF's compiled kernels (time update, Joseph-form update, the NIS window and the
batch loop) live here too, beside the model they inline: numba's on-disk cache
tracks only the file of the function it compiles, so keeping every compiled
function in this one module means the cache can never hold a stale inlined copy.

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
def propagate(x: np.ndarray, v: float, c: np.ndarray, F: np.ndarray, want_jacobian: bool) -> np.ndarray:
    """The discrete model: ``x`` advanced over one sample with armature voltage ``v``
    held (module docstring). Returns the new state; with ``want_jacobian`` fills ``F``
    (n, n) with its exact derivative d x_next / d x, else leaves ``F`` alone.

    Per Heun sub-step, with A1, A2 the Jacobians of f at the two stages,
    ``F_k = I + h/2 (A1 + A2 (I + h A1))`` and ``F = F_k F``; a stop at zero zeroes
    row j of F_k, and so does a stuck sub-step (a state a little off zero stops
    within the sub-step as well). The parameter rows of A are zero (random walks), so only the
    first ``nd`` rows (the physical states) of F_k and F are formed.
    """
    n = x.shape[0]
    nd = int(c[C_I_COULOMB])
    h = c[C_H]
    side = int(c[C_SIDE])
    xk = x.copy()
    x1 = np.empty(n)
    xn = np.empty(n)
    k1 = np.empty(n)
    k2 = np.empty(n)
    A1 = np.zeros((n, n))
    A2 = np.zeros((n, n))
    Fk = np.empty((nd, n))
    Fd = np.empty((nd, n))
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
            for i in range(nd):
                for k in range(n):
                    acc = 0.0
                    for m in range(nd):
                        acc += A2[i, m] * A1[m, k]
                    Fk[i, k] = (1.0 if i == k else 0.0) + 0.5 * h * (A1[i, k] + A2[i, k] + h * acc)
            if stop or stuck:
                # stopped or held at exactly zero: nearby states end there too
                for k in range(n):
                    Fk[side, k] = 0.0
            for i in range(nd):
                for k in range(n):
                    acc = Fk[i, k] if k >= nd else 0.0
                    for m in range(nd):
                        acc += Fk[i, m] * F[m, k]
                    Fd[i, k] = acc
            for i in range(nd):
                for k in range(n):
                    F[i, k] = Fd[i, k]
        for i in range(n):
            xk[i] = xn[i]
    return xk


@njit(cache=True)
def congruence(P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``F P F^T + Q`` on one triangle, mirrored (exactly symmetric): the covariance
    prediction, and the Joseph update with ``F = I - K h^T``, ``Q = r K K^T``."""
    n = P.shape[0]
    FP = np.empty((n, n))
    for i in range(n):
        for k in range(n):
            acc = 0.0
            for m in range(n):
                acc += F[i, m] * P[m, k]
            FP[i, k] = acc
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


# --------------------------------------------------------------------------- filter kernels
@njit(cache=True)
def ekf_predict(
    x: np.ndarray, P: np.ndarray, v: float, c: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """EKF time update: ``(x_prior, P_prior, F)`` for armature voltage ``v`` [V]."""
    n = x.shape[0]
    F = np.empty((n, n))
    x_prior = propagate(x, v, c, F, True)
    return x_prior, congruence(P, F, Q), F


@njit(cache=True)
def joseph_update(
    x: np.ndarray, P: np.ndarray, h: np.ndarray, h0: float, z: float, r: float, lower: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """Scalar measurement update ``z = h^T x + h0 + noise(r)``, Joseph form.

    Returns ``(x_post, P_post, K, innovation, S)``; ``x_post`` is projected onto
    ``x >= lower`` and ``P_post`` is mirrored to exact symmetry.
    """
    n = x.shape[0]
    Ph = np.empty(n)
    s = r
    z_hat = h0
    for i in range(n):
        acc = 0.0
        for k in range(n):
            acc += P[i, k] * h[k]
        Ph[i] = acc
        s += h[i] * acc
        z_hat += h[i] * x[i]
    e = z - z_hat
    K = Ph / s
    x_post = np.empty(n)
    for i in range(n):
        x_post[i] = max(x[i] + K[i] * e, lower[i])
    # (I - K h^T) P (I - K h^T)^T + r K K^T
    IKH = np.empty((n, n))
    rKK = np.empty((n, n))
    for i in range(n):
        for k in range(n):
            IKH[i, k] = (1.0 if i == k else 0.0) - K[i] * h[k]
            rKK[i, k] = r * K[i] * K[k]
    P_post = congruence(P, IKH, rKK)
    return x_post, P_post, K, e, s


@njit(cache=True)
def is_positive_definite(P: np.ndarray) -> bool:
    """True when the Cholesky factorisation of ``P`` succeeds (and P is finite)."""
    n = P.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        d = P[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            acc = P[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            L[i, j] = acc / L[j, j]
    return True


@njit(cache=True)
def push_nis(ring: np.ndarray, count: int, nis: float) -> tuple[int, float]:
    """Store ``nis`` in the ring buffer of the window; returns the new count and the
    mean over the window (NaN until it is full)."""
    W = ring.shape[0]
    ring[count % W] = nis
    count += 1
    if count < W:
        return count, math.nan
    acc = 0.0
    for k in range(W):
        acc += ring[k]
    return count, acc / W


@njit(cache=True)
def ekf_update_step(
    x: np.ndarray,
    P: np.ndarray,
    h: np.ndarray,
    z: float,
    r: float,
    lower: np.ndarray,
    ring: np.ndarray,
    count: int,
):
    """Speed update of one sample: :func:`joseph_update` with ``h0 = 0``, the NIS
    pushed into the window, and the health of the result.

    Returns ``(x_post, P_post, K, innovation, S, count, nis_mean, healthy)``.
    """
    x_post, P_post, K, e, s = joseph_update(x, P, h, 0.0, z, r, lower)
    count, nis_mean = push_nis(ring, count, e * e / s)
    return x_post, P_post, K, e, s, count, nis_mean, is_healthy(x_post, P_post)


@njit(cache=True)
def is_healthy(x: np.ndarray, P: np.ndarray) -> bool:
    """x finite and P positive definite."""
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return False
    return is_positive_definite(P)


#: codes of the batch kernel for what stopped or flagged it
FLAG_OK, FLAG_NIS, FLAG_BREAKDOWN = 0, 1, 2


@njit(cache=True)
def ekf_batch(
    v: np.ndarray,
    z: np.ndarray,
    present: np.ndarray,
    cur: np.ndarray,
    cur_present: np.ndarray,
    x: np.ndarray,
    P: np.ndarray,
    c: np.ndarray,
    Q: np.ndarray,
    r: float,
    r_cur: float,
    h_speed: np.ndarray,
    h_cur: np.ndarray,
    cur_gain: float,
    lower: np.ndarray,
    ring: np.ndarray,
    count: int,
    threshold: float,
    stop_on_nis: bool,
):
    """The sample loop of :func:`ekf_predict` and :func:`joseph_update` over a record.

    Stops after the sample where the covariance breaks down, or where the windowed
    NIS passes ``threshold`` when ``stop_on_nis``. Returns the per-sample arrays
    (filled up to ``done`` samples) and the last sample's quantities.
    """
    N = v.shape[0]
    n = x.shape[0]
    X = np.empty((N, n))
    P_diag = np.empty((N, n))
    y_hat = np.empty(N)
    innovation = np.full(N, np.nan)
    S = np.empty(N)
    NIS = np.full(N, np.nan)
    x_prior = x.copy()
    P_prior = P.copy()
    F = np.eye(n)
    K = np.zeros(n)
    e = 0.0
    s = 0.0
    nis_mean = math.nan
    flag_at = -1
    flag_mean = math.nan
    flag = FLAG_OK
    done = 0
    for t in range(N):
        x_prior, P_prior, F = ekf_predict(x, P, v[t], c, Q)
        x = x_prior
        P = P_prior
        y_hat[t] = x_prior[1]
        s = P_prior[1, 1] + r
        healthy = True
        if present[t]:
            x, P, K, e, s, count, nis_mean, healthy = ekf_update_step(
                x, P, h_speed, z[t], r, lower, ring, count
            )
            innovation[t] = e
            NIS[t] = e * e / s
        else:
            K = np.zeros(n)
            e = 0.0
        if cur_present[t]:
            x, P, _, _, _ = joseph_update(x, P, h_cur, cur_gain * v[t], cur[t], r_cur, lower)
            healthy = is_healthy(x, P)
        S[t] = s
        X[t] = x
        for i in range(n):
            P_diag[t, i] = P[i, i]
        done = t + 1
        if not present[t] and not cur_present[t]:
            healthy = is_healthy(x, P)
        if not healthy:
            flag, flag_at = FLAG_BREAKDOWN, t
            break
        if nis_mean > threshold and flag == FLAG_OK:
            flag, flag_at, flag_mean = FLAG_NIS, t, nis_mean
            if stop_on_nis:
                break
    return (
        X, P_diag, y_hat, innovation, S, NIS, x, P, x_prior, P_prior, F, K, e, s,
        count, nis_mean, flag, flag_at, flag_mean, done,
    )  # fmt: skip


def stiffest_rate(c: np.ndarray, x: np.ndarray, v: float = 0.0) -> float:
    """Largest |eigenvalue| [1/s] of the continuous Jacobian at ``x`` (moving forwards)."""
    n = x.shape[0]
    f = np.zeros(n)
    A = np.zeros((n, n))
    drift(x, v, c, 1.0, False, f, A)
    return float(np.max(np.abs(np.linalg.eigvals(A))))


__all__ = [
    "I_OMEGA_L",
    "I_OMEGA_M",
    "I_TWIST",
    "congruence",
    "drift",
    "free_run",
    "pack_constants",
    "propagate",
    "state_layout",
    "stiffest_rate",
]
