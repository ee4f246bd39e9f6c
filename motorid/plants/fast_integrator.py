"""Fast fixed-step integrator of the two-mass drive (numba, the product path).

Method: exponential integration of the linear part with the nonlinear torques
held over each internal step (first-order exponential Euler), plus hybrid
stick/slip switching.

The linear part, eqs. (1)-(7), with state ``x = [i_a, ω_m, ω_L, δ, θ_L]``
(δ = θ_m - θ_L the shaft twist) and input ``w = [v_a, τ_m, τ_L]``::

    L_a di_a/dt  = v_a - R_a i_a - K_m ω_m
    J_m dω_m/dt  = K_m i_a - T_s - B_m ω_m + τ_m
    J_L dω_L/dt  = T_s - B_L ω_L + τ_L
    dδ/dt        = ω_m - ω_L,        dθ_L/dt = ω_L
    T_s          = k_s δ + B_s (ω_m - ω_L)

is advanced exactly over one internal step h by ``x+ = Φ x + Γ w`` with
``[Φ Γ] = expm([[A, B], [0, 0]] h)``. The extra torques τ collect what is not
linear: the static friction laws (eqs. 8, 9, 11) evaluated at the start of the
step, the LuGre torque, the load disturbance -T_d and the backlash offset.

Modes. There is one (Φ, Γ) pair per mode ``stuck_m + 2 stuck_L + 4 gap``:

- A mass with static friction whose speed is exactly 0 is *stuck* while the
  torque on it, T_net, lies in ``[-T_break-, T_break+]``; its speed row is
  removed from A, so its speed stays exactly 0.0 (no creep). Otherwise it
  slips in the direction sgn(T_net), against the kinetic friction at 0±.
- A slipping mass whose speed changes sign during a step is stopped at exactly
  0 at the end of the step; the stick test of the next step decides whether it
  sticks or reverses. Events are thus resolved to one internal step h.
- Backlash of half-width b: for |δ| < b the shaft transmits nothing (gap mode,
  no shaft coupling in A); in contact T_s = k_s (δ - b sgn δ) + B_s (ω_m - ω_L),
  i.e. the linear law plus the constant offset ``k_s b sgn δ`` carried in τ.

With every nonlinearity off the method is exact for a zero-order-hold input
(to rounding). With Coulomb friction and dead zone the only errors are the
event times, resolved to h.

The rigid drive (:class:`~motorid.plants.rigid.RigidDrive`, the doctor's model) is
here too: its terms (:func:`rigid_term`, with the one Stribeck decay
:func:`stribeck_decay`, exponential or Gaussian), their regressor columns
(:func:`rigid_columns`) and its free run (:func:`rigid_free_run`, on
:func:`stick_or_slip`).

Everything here is compiled with ``numba.njit(cache=True)``, including the
amplifier (:func:`armature_voltage`) and the tacho + A/D chain
(:func:`tacho_reading`), kept in this one module so the on-disk cache of the
kernels never holds a stale copy of them. :func:`advance_sample` is the one
implementation of a sample: called once per sample by online loops
(``TwoMassRig.step``) and in a loop by :func:`simulate_kernel` (a whole record
in one call).
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Length of the full state vector [i_a, ω_m, ω_L, δ, θ_L, z_m, z_L].
N_STATE = 7
#: Number of linear states advanced by Φ.
N_LINEAR = 5
#: Columns of one output row: [y, v_a, i_a, ω_m, ω_L, δ, θ_L, z_m, z_L].
N_OUT = 9

# indices into the packed parameter vector
P_K = 0
P_KS = 1
P_BS = 2
P_BACKLASH = 3
P_H = 4
P_NSUB = 5
P_AMP_GAIN = 6
P_DEAD_ZONE = 7
P_VMAX = 8
P_TACHO_GAIN = 9
P_TACHO_NOISE = 10
P_ADC_BITS = 11
P_ADC_VMIN = 12
P_ADC_VMAX = 13
P_BREAK_POS_M = 14
P_BREAK_NEG_M = 15
P_BREAK_POS_L = 16
P_BREAK_NEG_L = 17
N_PARAMS = 18


@numba.njit(cache=True)
def armature_voltage(u: float, gain: float, dead_zone: float, v_max: float) -> float:
    """Armature voltage v_a [V] for one command ``u`` [V] (compiled; the one implementation)."""
    v = gain * u
    if v > v_max:
        v = v_max
    elif v < -v_max:
        v = -v_max
    if abs(v) <= dead_zone:
        return 0.0
    return v - dead_zone if v > 0.0 else v + dead_zone


@numba.njit(cache=True)
def tacho_reading(
    omega: float,
    noise: float,
    gain: float,
    noise_std: float,
    bits: int,
    v_min: float,
    v_max: float,
) -> float:
    """Measured speed y [rad/s] for true load speed ``omega`` [rad/s].

    ``noise`` is a standard normal draw, scaled by ``noise_std`` [V]. Compiled;
    the one implementation of the tacho + A/D chain.
    """
    v = gain * omega + noise_std * noise
    if bits > 0:
        levels = 2.0**bits
        q = (v_max - v_min) / levels
        code = np.floor((v - v_min) / q + 0.5)
        if code < 0.0:
            code = 0.0
        elif code > levels - 1.0:
            code = levels - 1.0
        v = v_min + q * code
    return v / gain


@numba.njit(cache=True)
def armature_voltages(u: np.ndarray, gain: float, dead_zone: float, v_max: float) -> np.ndarray:
    """Vectorised :func:`armature_voltage`."""
    out = np.empty_like(u)
    for k in range(u.size):
        out[k] = armature_voltage(u[k], gain, dead_zone, v_max)
    return out


@numba.njit(cache=True)
def tacho_readings(
    omega: np.ndarray,
    noise: np.ndarray,
    gain: float,
    noise_std: float,
    bits: int,
    v_min: float,
    v_max: float,
) -> np.ndarray:
    """Vectorised :func:`tacho_reading`."""
    out = np.empty_like(omega)
    for k in range(omega.size):
        out[k] = tacho_reading(omega[k], noise[k], gain, noise_std, bits, v_min, v_max)
    return out


@numba.njit(cache=True)
def stick_or_slip(omega: float, t_net: float, break_pos: float, break_neg: float) -> tuple[int, float]:
    """Karnopp's stick/slip rule for one mass: ``(stuck, direction)`` (the one implementation:
    the fast and the reference integrator call it).

    A moving mass slips in the direction of its speed. A mass at exactly zero
    speed stays stuck while the net driving torque ``t_net`` [N m] lies within
    ``[-break_neg, break_pos]``, and otherwise breaks away in the direction of
    ``t_net``. Without static friction (both limits 0) it is neither stuck nor
    given a direction.
    """
    if omega != 0.0:
        return 0, (1.0 if omega > 0.0 else -1.0)
    if break_pos <= 0.0 and break_neg <= 0.0:
        return 0, 0.0
    if -break_neg <= t_net <= break_pos:
        return 1, 0.0
    return 0, (1.0 if t_net > 0.0 else -1.0)


#: Shapes of the Stribeck decay (:func:`stribeck_decay`).
STRIBECK_EXPONENTIAL = 0
STRIBECK_GAUSSIAN = 1
#: Names of the shapes in model files, by code.
STRIBECK_SHAPES = ("exponential", "gaussian")


@numba.njit(cache=True)
def stribeck_decay(omega: float, rate: float, shape: int) -> float:
    """The Stribeck decay at speed ω [rad/s or m/s] (dimensionless, 1 at rest).

    ``exp(-rate |ω|)`` for ``shape == STRIBECK_EXPONENTIAL`` (eq. 9, rate = α2 = 1/v_s) and
    ``exp(-(rate ω)²)`` for ``STRIBECK_GAUSSIAN`` (the shape of LuGre's g(ω), rate = 1/ω_s),
    rate [s/rad or s/m] >= 0. The one implementation of the decay: eq. (11), LuGre's level
    and the rigid drive's Stribeck term evaluate it.
    """
    if shape == STRIBECK_GAUSSIAN:
        x = rate * omega
        return math.exp(-(x * x))
    return math.exp(-rate * abs(omega))


@numba.njit(cache=True)
def friction_law(
    a0: float, a1: float, a2: float, a3: float, a4: float, a5: float, omega: float, direction: float
) -> float:
    """Torque [N m] of one static friction law, eq. (11), for motion in ``direction``.

    ``a0 + a1 exp(-a2 |ω|)`` for ``direction > 0``, ``-(a3 + a4 exp(-a5 |ω|))`` for
    ``direction < 0`` and 0 for ``direction == 0`` (ω [rad/s]). Coulomb (eq. 8) and
    Stribeck (eq. 9) friction are its special cases. The one implementation of the
    law: the friction objects, the fast and the reference integrator evaluate it.
    """
    if direction > 0.0:
        return a0 + a1 * stribeck_decay(omega, a2, STRIBECK_EXPONENTIAL)
    if direction < 0.0:
        return -(a3 + a4 * stribeck_decay(omega, a5, STRIBECK_EXPONENTIAL))
    return 0.0


@numba.njit(cache=True)
def friction_torques(coefficients: np.ndarray, omega: np.ndarray, direction: float) -> np.ndarray:
    """:func:`friction_law` at each speed of ``omega``, moving in the direction sgn(ω), or
    sgn(``direction``) where ω == 0 (impending motion)."""
    c = coefficients
    out = np.empty_like(omega)
    for k in range(omega.size):
        w = omega[k]
        out[k] = friction_law(c[0], c[1], c[2], c[3], c[4], c[5], w, w if w != 0.0 else direction)
    return out


@numba.njit(cache=True)
def static_friction(fric: np.ndarray, side: int, omega: float, direction: float) -> float:
    """Sum of the static friction laws on ``side`` [N m] for motion in ``direction``.

    Row layout ``[side, α0..α5]`` (:func:`friction_law`).
    """
    total = 0.0
    for r in range(fric.shape[0]):
        if fric[r, 0] == side:
            total += friction_law(
                fric[r, 1], fric[r, 2], fric[r, 3], fric[r, 4], fric[r, 5], fric[r, 6], omega, direction
            )
    return total


@numba.njit(cache=True)
def lugre_level(fc: float, fs: float, omega_s: float, omega: float) -> float:
    """LuGre's Stribeck curve g(ω) = Fc + (Fs - Fc) exp(-(ω/ωs)²) [N m] (the one implementation)."""
    return fc + (fs - fc) * stribeck_decay(omega, 1.0 / omega_s, STRIBECK_GAUSSIAN)


@numba.njit(cache=True)
def lugre_rate(sigma0: float, fc: float, fs: float, omega_s: float, z: float, omega: float) -> float:
    """LuGre's bristle rate dz/dt = ω - σ0 |ω| z / g(ω) [rad/s] (the one implementation)."""
    return omega - sigma0 * abs(omega) * z / lugre_level(fc, fs, omega_s, omega)


@numba.njit(cache=True)
def lugre_levels(fc: float, fs: float, omega_s: float, omega: np.ndarray) -> np.ndarray:
    """Vectorised :func:`lugre_level`."""
    out = np.empty_like(omega)
    for k in range(omega.size):
        out[k] = lugre_level(fc, fs, omega_s, omega[k])
    return out


@numba.njit(cache=True)
def lugre_rates(
    sigma0: float, fc: float, fs: float, omega_s: float, z: np.ndarray, omega: np.ndarray
) -> np.ndarray:
    """Vectorised :func:`lugre_rate` (``z`` and ``omega`` of one shape)."""
    out = np.empty_like(omega)
    for k in range(omega.size):
        out[k] = lugre_rate(sigma0, fc, fs, omega_s, z[k], omega[k])
    return out


@numba.njit(cache=True)
def _lugre_zdot(lug: np.ndarray, k: int, z: float, omega: float) -> float:
    return lugre_rate(lug[k, 1], lug[k, 3], lug[k, 4], lug[k, 5], z, omega)


@numba.njit(cache=True)
def _lugre_advance(lug: np.ndarray, k: int, z: float, omega: float, h: float) -> float:
    """Exact bristle update over h for ω held constant: z relaxes to g(ω) sgn(ω)/σ0."""
    if omega == 0.0:
        return z
    g = lugre_level(lug[k, 3], lug[k, 4], lug[k, 5], omega)
    rate = lug[k, 1] * abs(omega) / g
    z_ss = omega / rate
    return z_ss + (z - z_ss) * math.exp(-rate * h)


@numba.njit(cache=True)
def _substep(
    x: np.ndarray,
    v: float,
    t_d: float,
    phi: np.ndarray,
    gam: np.ndarray,
    p: np.ndarray,
    fric: np.ndarray,
    lug: np.ndarray,
    xn: np.ndarray,
) -> None:
    K = p[P_K]
    ks = p[P_KS]
    bs = p[P_BS]
    b = p[P_BACKLASH]
    h = p[P_H]
    i_a = x[0]
    wm = x[1]
    wl = x[2]
    d = x[3]

    # shaft: gap or contact (with the backlash offset k_s b sgn δ)
    gap = 0
    offset = 0.0
    if b > 0.0:
        if abs(d) < b:
            gap = 1
        else:
            offset = ks * b if d > 0.0 else -ks * b
    t_s = 0.0 if gap == 1 else ks * d + bs * (wm - wl) - offset

    # LuGre torques σ0 z + σ1 dz/dt (σ2 is in the linear part)
    f_lug_m = 0.0
    f_lug_l = 0.0
    if lug[0, 0] != 0.0:
        f_lug_m = lug[0, 1] * x[5] + lug[0, 2] * _lugre_zdot(lug, 0, x[5], wm)
    if lug[1, 0] != 0.0:
        f_lug_l = lug[1, 1] * x[6] + lug[1, 2] * _lugre_zdot(lug, 1, x[6], wl)

    tau_m = offset - f_lug_m
    tau_l = -offset - t_d - f_lug_l

    # Karnopp stick test on each mass at exactly zero speed
    has_m = p[P_BREAK_POS_M] > 0.0 or p[P_BREAK_NEG_M] > 0.0
    stuck_m, dir_m = stick_or_slip(wm, K * i_a - t_s - f_lug_m, p[P_BREAK_POS_M], p[P_BREAK_NEG_M])
    if stuck_m == 0 and dir_m != 0.0:
        tau_m -= static_friction(fric, 0, wm, dir_m)
    has_l = p[P_BREAK_POS_L] > 0.0 or p[P_BREAK_NEG_L] > 0.0
    stuck_l, dir_l = stick_or_slip(wl, t_s - t_d - f_lug_l, p[P_BREAK_POS_L], p[P_BREAK_NEG_L])
    if stuck_l == 0 and dir_l != 0.0:
        tau_l -= static_friction(fric, 1, wl, dir_l)

    mode = stuck_m + 2 * stuck_l + 4 * gap
    for r in range(N_LINEAR):
        acc = gam[mode, r, 0] * v + gam[mode, r, 1] * tau_m + gam[mode, r, 2] * tau_l
        for c in range(N_LINEAR):
            acc += phi[mode, r, c] * x[c]
        xn[r] = acc

    # a stuck mass stays at exactly zero; a slipping mass that reverses stops at zero
    if stuck_m == 1:
        xn[1] = 0.0
    elif has_m and dir_m * xn[1] < 0.0:
        xn[1] = 0.0
    if stuck_l == 1:
        xn[2] = 0.0
    elif has_l and dir_l * xn[2] < 0.0:
        xn[2] = 0.0

    if lug[0, 0] != 0.0:
        x[5] = _lugre_advance(lug, 0, x[5], wm, h)
    if lug[1, 0] != 0.0:
        x[6] = _lugre_advance(lug, 1, x[6], wl, h)
    for r in range(N_LINEAR):
        x[r] = xn[r]


@numba.njit(cache=True)
def advance_sample(
    x: np.ndarray,
    u: float,
    t_d: float,
    noise: float,
    phi: np.ndarray,
    gam: np.ndarray,
    p: np.ndarray,
    fric: np.ndarray,
    lug: np.ndarray,
    out: np.ndarray,
) -> float:
    """Hold ``u`` [V] and ``t_d`` [N m] over one sample; update ``x`` in place.

    Fills ``out`` with ``[y, v_a, i_a, ω_m, ω_L, δ, θ_L, z_m, z_L]`` at the end of
    the sample and returns the measured load speed y [rad/s].
    """
    v = armature_voltage(u, p[P_AMP_GAIN], p[P_DEAD_ZONE], p[P_VMAX])
    xn = np.empty(N_LINEAR)
    for _ in range(int(p[P_NSUB])):
        _substep(x, v, t_d, phi, gam, p, fric, lug, xn)
    y = tacho_reading(
        x[2], noise, p[P_TACHO_GAIN], p[P_TACHO_NOISE], int(p[P_ADC_BITS]),
        p[P_ADC_VMIN], p[P_ADC_VMAX],
    )  # fmt: skip
    out[0] = y
    out[1] = v
    for k in range(N_STATE):
        out[2 + k] = x[k]
    return y


@numba.njit(cache=True)
def simulate_kernel(
    x: np.ndarray,
    u: np.ndarray,
    t_d: np.ndarray,
    noise: np.ndarray,
    phi: np.ndarray,
    gam: np.ndarray,
    p: np.ndarray,
    fric: np.ndarray,
    lug: np.ndarray,
) -> np.ndarray:
    """A whole record: returns an (N, 9) array of output rows, one per sample."""
    n = u.shape[0]
    rows = np.empty((n, N_OUT))
    for k in range(n):
        advance_sample(x, u[k], t_d[k], noise[k], phi, gam, p, fric, lug, rows[k])
    return rows


# --------------------------------------------------------------------------- rigid drive
# The terms of the rigid drive's torque balance J dω/dt = F_in - Σ θ_t T_t(ω)
# (:class:`~motorid.plants.rigid.RigidDrive`), by code. Speed terms scale with ω
# (T_t = ω k_t(ω, s)) and are integrated implicitly; level terms do not.
TERM_VISCOUS = 0  # B ω
TERM_VISCOUS_ASYMMETRY = 1  # ΔF_v s ω = ΔF_v |ω| while moving
TERM_QUADRATIC_DRAG = 2  # c |ω| ω
TERM_COULOMB = 3  # F_c s
TERM_STRIBECK = 4  # F_s s decay(ω)
TERM_COULOMB_ASYMMETRY = 5  # ΔF_c |s|
TERM_OFFSET = 6  # T_0, also at rest
N_SPEED_TERMS = 3
N_TERMS = 7


@numba.njit(cache=True)
def rigid_speed_factor(term: int, omega: float, direction: float) -> float:
    """k_t of a speed term (``term < N_SPEED_TERMS``): its torque per unit parameter is ω k_t."""
    if term == TERM_VISCOUS:
        return 1.0
    if term == TERM_VISCOUS_ASYMMETRY:
        return direction
    return abs(omega)


@numba.njit(cache=True)
def rigid_level(term: int, omega: float, direction: float, rate: float, shape: int) -> float:
    """Torque per unit parameter of a level term (``term >= N_SPEED_TERMS``) for motion in
    ``direction`` (s = ±1, or 0 at rest)."""
    if term == TERM_COULOMB:
        return direction
    if term == TERM_STRIBECK:
        return direction * stribeck_decay(omega, rate, shape)
    if term == TERM_COULOMB_ASYMMETRY:
        return abs(direction)
    return 1.0


@numba.njit(cache=True)
def rigid_term(term: int, omega: float, direction: float, rate: float, shape: int) -> float:
    """Torque per unit parameter T_t(ω) of any term of the rigid drive (the one implementation:
    the free run and the doctor's regressor columns evaluate it)."""
    if term < N_SPEED_TERMS:
        return omega * rigid_speed_factor(term, omega, direction)
    return rigid_level(term, omega, direction, rate, shape)


@numba.njit(cache=True)
def rigid_columns(terms: np.ndarray, omega: np.ndarray, rate: float, shape: int) -> np.ndarray:
    """Columns ``T_t(ω[k])`` of the ``terms`` for a drive moving in the direction sgn(ω[k]),
    shape (N, len(terms)) (0 for sgn at ω == 0)."""
    out = np.empty((omega.size, terms.size))
    for k in range(omega.size):
        w = omega[k]
        s = 1.0 if w > 0.0 else (-1.0 if w < 0.0 else 0.0)
        for j in range(terms.size):
            out[k, j] = rigid_term(terms[j], w, s, rate, shape)
    return out


@numba.njit(cache=True)
def rigid_input_dynamics(x: np.ndarray, dt: float, delay: float, time_constant: float) -> np.ndarray:
    """Mean over each sample of the held signal ``x`` delayed by ``delay`` [s] and then passed
    through the first-order lag ``T dz/dt = x_d - z`` of time constant ``time_constant`` [s].

    With ``delay = (m + f) dt`` (m whole samples, 0 <= f < 1; a negative delay is 0) the
    delayed held signal covers sample k with ``x[k-m-1]`` for its first share f and
    ``x[k-m]`` for the rest (``x[0]`` before the record). Over a piece of length L holding v
    the lag, with ``e = exp(-L/T)``, integrates exactly::

        ∫ z = v L + (z_0 - v) T (1 - e),    z_L = v + (z_0 - v) e

    and the sample's value is the integral over it / dt, from ``z = x[0]`` (at rest on the
    first input). ``T <= 0`` is no lag (then z follows the delayed signal), so without a lag
    ``(1 - f) x[k-m] + f x[k-m-1]``. Exact for the held input, whole and fractional delays.
    """
    n = x.size
    out = np.empty(n)
    steps = max(delay, 0.0) / dt
    m = int(steps)  # the whole samples
    f = steps - m
    lag = time_constant > 0.0
    z = x[0] if n > 0 else 0.0
    for k in range(n):
        i = k - m
        late = x[i] if i >= 0 else x[0]
        early = x[i - 1] if i >= 1 else x[0]
        total = 0.0
        for piece in range(2):
            v = early if piece == 0 else late
            length = f * dt if piece == 0 else (1.0 - f) * dt
            if length <= 0.0:
                continue
            if lag:
                e = math.exp(-length / time_constant)
                total += v * length + (z - v) * time_constant * (1.0 - e)
                z = v + (z - v) * e
            else:
                total += v * length
                z = v
        out[k] = total / dt
    return out


@numba.njit(cache=True)
def rigid_free_run(
    force: np.ndarray,
    dt: float,
    nsub: int,
    inertia: float,
    coef: np.ndarray,
    rate: float,
    shape: int,
    w0: float,
    breakaway_excess: float = 0.0,
) -> np.ndarray:
    """Speed of a rigid drive at the end of each sample for the input force [F] held over it.

    ``coef[t]`` is the parameter θ_t of term t. Fixed step h = dt/nsub, semi-implicit Euler::

        ω+ = (ω + h/J (F - Σ_levels θ_t T_t(ω, s))) / (1 + h/J Σ_speed θ_t k_t(ω, s))

    (the speed terms implicit, so the step is stable for any h; the denominator is kept
    >= 0.1 for non-physical negative fits), with Karnopp's rule (:func:`stick_or_slip`)
    at ω == 0: the breakaway levels are the level terms at 0± minus the torque at rest
    (the offset), each raised by ``breakaway_excess`` [F] >= 0 (static friction above the
    kinetic level: a drive at rest breaks away only beyond it, and once moving slows
    against the kinetic level alone, so it keeps moving down to a lower force). A drive without (or with a non-physical negative) static friction at
    rest moves towards the side the net force exceeds most. A step that would carry a
    drive with static friction (or one starting at rest) through zero stops it at 0.
    """
    n = force.size
    out = np.empty(n)
    h = dt / nsub
    rest = 0.0
    up = 0.0
    down = 0.0
    for t in range(N_SPEED_TERMS, N_TERMS):
        rest += coef[t] * rigid_level(t, 0.0, 0.0, rate, shape)
        up += coef[t] * rigid_level(t, 0.0, 1.0, rate, shape)
        down += coef[t] * rigid_level(t, 0.0, -1.0, rate, shape)
    break_pos = up - rest + breakaway_excess
    break_neg = rest - down + breakaway_excess
    static = break_pos > 0.0 or break_neg > 0.0
    w = w0
    for k in range(n):
        f = force[k]
        for _ in range(nsub):
            at_rest = w == 0.0
            if at_rest:
                t_net = f - rest
                stuck, s = stick_or_slip(w, t_net, break_pos, break_neg)
                if stuck == 1:
                    continue
                if s == 0.0:
                    s = 1.0 if t_net >= 0.5 * (break_pos - break_neg) else -1.0
            else:
                s = 1.0 if w > 0.0 else -1.0
            level = 0.0
            for t in range(N_SPEED_TERMS, N_TERMS):
                level += coef[t] * rigid_level(t, w, s, rate, shape)
            damp = 0.0
            for t in range(N_SPEED_TERMS):
                damp += coef[t] * rigid_speed_factor(t, w, s)
            den = 1.0 + h * damp / inertia
            if den < 0.1:
                den = 0.1
            wn = (w + h / inertia * (f - level)) / den
            if (static or at_rest) and wn * s < 0.0:
                wn = 0.0
            w = wn
        out[k] = w
    return out
