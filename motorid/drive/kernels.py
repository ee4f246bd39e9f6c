"""The drive's physics, compiled (numba): the effect laws, Karnopp's stick/slip rule, the
two-mass rig's fast integrator, the rigid drive's terms and free run, and the friction
filters' process model, in one module so numba's on-disk cache never holds a stale
inlined copy of a law (it tracks only the file of the function it compiles).

The two-mass rig's fixed-step integrator (the product path). Method: exponential integration of the linear part with the nonlinear torques
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
linear: the masses' friction terms (eqs. 8, 9, 11: :func:`static_friction`) evaluated at the start of the
step, the LuGre torque, the load disturbance -T_d, the backlash offset and the motor's
position ripple (cogging) at θ_m = θ_L + δ (:func:`ripple_torque`).

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

The rigid drive (:class:`~motorid.drive.rigid.RigidDrive`, the doctor's model) is
here too: its terms (:func:`rigid_term`, with the one Stribeck decay
:func:`stribeck_decay`, exponential or Gaussian), their regressor columns
(:func:`rigid_columns`), its input path's maps with memory (:func:`rigid_input_dynamics`,
:func:`backlash_dwell` on :func:`reversal_clock`), each on an explicit state so that a record
in one call and the same record a sample at a time (``RigidDrive.simulation``) are one
computation, and its free run on :func:`stick_or_slip` (:func:`rigid_motion`: speed and
position; :func:`rigid_free_run`: the speed alone), exponential Euler with each zero crossing of
the speed located inside its step.

So is the friction filters' process model (the EKF/UKF of
:mod:`motorid.estimators.friction_kf`, state layout in
:mod:`motorid.estimators.friction_model`): :func:`filter_drift` and its Jacobian with
:func:`friction_law` and :func:`stribeck_decay_slope`, :func:`filter_direction` on
:func:`stick_or_slip`, the sub-stepped :func:`filter_propagate`, and the EKF kernels
that inline it (:func:`ekf_predict`, :func:`ekf_batch` ...). The filter's model is the
drive's physics, so it is compiled with it.

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
P_RIPPLE_SIN = 18  # the motor's position ripple A_s sin(p θ_m) + A_c cos(p θ_m) [N m]
P_RIPPLE_COS = 19
P_RIPPLE_PERIODS = 20  # p [1/rad]
N_PARAMS = 21


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
def stribeck_decay_slope(omega: float, rate: float, shape: int, direction: float) -> float:
    """d/dω of :func:`stribeck_decay` [s/rad] at speed ω [rad/s].

    ``-rate sgn(ω) decay`` for the exponential shape and ``-2 rate² ω decay`` for the
    Gaussian one. At ω == 0 the exponential shape has a corner: the slope returned is the
    one-sided slope for motion in ``direction`` (±1), the side the friction filter's
    Jacobian linearises on.
    """
    if shape == STRIBECK_GAUSSIAN:
        return -2.0 * rate * rate * omega * stribeck_decay(omega, rate, shape)
    s = (1.0 if omega > 0.0 else -1.0) if omega != 0.0 else direction
    return -rate * s * stribeck_decay(omega, rate, shape)


@numba.njit(cache=True)
def friction_law(
    a0: float,
    a1: float,
    a2: float,
    a3: float,
    a4: float,
    a5: float,
    omega: float,
    direction: float,
    shape: int,
) -> float:
    """Torque [N m] of one static friction law, eq. (11), for motion in ``direction``.

    ``a0 + a1 d(ω; a2)`` for ``direction > 0``, ``-(a3 + a4 d(ω; a5))`` for
    ``direction < 0`` and 0 for ``direction == 0`` (ω [rad/s]), with d the Stribeck decay
    of ``shape`` (:func:`stribeck_decay`; eq. 11 is the exponential shape,
    d = exp(-a2 |ω|)). Coulomb (eq. 8) and Stribeck (eq. 9) friction are its special
    cases. The friction filters' process model evaluates it on its states (the rig and the
    rigid drive evaluate their effects' terms, :func:`rigid_term`).
    """
    if direction > 0.0:
        return a0 + a1 * stribeck_decay(omega, a2, shape)
    if direction < 0.0:
        return -(a3 + a4 * stribeck_decay(omega, a5, shape))
    return 0.0


@numba.njit(cache=True)
def friction_torques(rows: np.ndarray, omega: np.ndarray, direction: float) -> np.ndarray:
    """:func:`static_friction` of the rows of mass 0 at each speed of ``omega``, moving in the
    direction sgn(ω), or sgn(``direction``) where ω == 0 (impending motion)."""
    out = np.empty_like(omega)
    for k in range(omega.size):
        w = omega[k]
        d = w if w != 0.0 else direction
        out[k] = static_friction(rows, 0, w, 1.0 if d > 0.0 else (-1.0 if d < 0.0 else 0.0))
    return out


@numba.njit(cache=True)
def static_friction(fric: np.ndarray, side: int, omega: float, direction: float) -> float:
    """The friction torque on mass ``side`` of the rig [N m] for motion in ``direction``, from the
    rows ``[side, term, coefficient, rate, shape]`` of its effects' terms
    (:meth:`motorid.drive.friction.Friction.rows`): ``Σ coefficient T_term(ω)``, each term the
    rigid drive's (:func:`rigid_term`), so a mass of the rig and a rigid drive evaluate one law.
    """
    total = 0.0
    for r in range(fric.shape[0]):
        if fric[r, 0] == side:
            total += fric[r, 2] * rigid_term(int(fric[r, 1]), omega, direction, fric[r, 3], int(fric[r, 4]))
    return total


@numba.njit(cache=True)
def lugre_level(fc: float, fs: float, rate: float, shape: int, omega: float) -> float:
    """LuGre's Stribeck curve g(ω) = F_c + F_s decay(ω) [N m] (F_s the excess over F_c, decay of
    ``rate`` [s/rad] and ``shape``, :func:`stribeck_decay`; the one implementation)."""
    return fc + fs * stribeck_decay(omega, rate, shape)


@numba.njit(cache=True)
def lugre_rate(sigma0: float, fc: float, fs: float, rate: float, shape: int, z: float, omega: float) -> float:
    """LuGre's bristle rate dz/dt = ω - σ0 |ω| z / g(ω) [rad/s] (the one implementation)."""
    return omega - sigma0 * abs(omega) * z / lugre_level(fc, fs, rate, shape, omega)


@numba.njit(cache=True)
def lugre_zdot(lug: np.ndarray, k: int, z: float, omega: float) -> float:
    """:func:`lugre_rate` of mass k's row ``[active, σ0, σ1, F_c, F_s, rate, shape]``
    (:meth:`motorid.drive.friction.Friction.lugre_row`)."""
    return lugre_rate(lug[k, 1], lug[k, 3], lug[k, 4], lug[k, 5], int(lug[k, 6]), z, omega)


@numba.njit(cache=True)
def _lugre_advance(lug: np.ndarray, k: int, z: float, omega: float, h: float) -> float:
    """Exact bristle update over h for ω held constant: z relaxes to g(ω) sgn(ω)/σ0."""
    if omega == 0.0:
        return z
    g = lugre_level(lug[k, 3], lug[k, 4], lug[k, 5], int(lug[k, 6]), omega)
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
        f_lug_m = lug[0, 1] * x[5] + lug[0, 2] * lugre_zdot(lug, 0, x[5], wm)
    if lug[1, 0] != 0.0:
        f_lug_l = lug[1, 1] * x[6] + lug[1, 2] * lugre_zdot(lug, 1, x[6], wl)

    # the motor's position ripple at θ_m = θ_L + δ (nothing evaluated without it)
    cog = 0.0
    if p[P_RIPPLE_SIN] != 0.0 or p[P_RIPPLE_COS] != 0.0:
        cog = ripple_torque(x[4] + d, p[P_RIPPLE_SIN], p[P_RIPPLE_COS], p[P_RIPPLE_PERIODS])

    tau_m = offset - f_lug_m - cog
    tau_l = -offset - t_d - f_lug_l

    # Karnopp stick test on each mass at exactly zero speed
    has_m = p[P_BREAK_POS_M] > 0.0 or p[P_BREAK_NEG_M] > 0.0
    stuck_m, dir_m = stick_or_slip(wm, K * i_a - t_s - f_lug_m - cog, p[P_BREAK_POS_M], p[P_BREAK_NEG_M])
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


# --------------------------------------------------------------------------- friction filter
# The process model of the friction EKF/UKF (:mod:`motorid.estimators.friction_model` holds
# its state layout and describes it): the drive of the rig (two masses) or of the rigid
# drive (one mass) with its friction parameters as states, sub-stepped by Heun's method,
# with eq. (11) (:func:`friction_law`), the Stribeck decay and its slope and Karnopp's rule
# (:func:`stick_or_slip`) evaluated by the functions above. The EKF's kernels are here too,
# beside the model they inline.

# indices into the filter's packed constant vector ``c``
C_JM = 0  # J_m [kg m²] (the rigid drive's inertia J)
C_JL = 1  # J_L [kg m²]
C_KM = 2  # K_m [N m/A]
C_RA = 3  # R_a [Ω]
C_LA = 4  # L_a [H]
C_KS = 5  # k_s [N m/rad]
C_BS = 6  # B_s [N m s/rad]
C_TD = 7  # T_d [N m] (the rigid drive's offset torque T_0)
C_DECAY = 8  # Stribeck rate [s/rad]
C_H = 9  # sub-step h [s]
C_NSUB = 10  # sub-steps per sample
C_SIDE = 11  # friction side: 0 motor, 1 load
C_I_CURRENT = 12  # index of i_a in x, -1 without
C_I_COULOMB = 13  # index of T_c in x (= number of physical states)
C_I_VISCOUS = 14
C_I_COULOMB_NEG = 15  # -1 without asymmetry
C_I_STRIBECK = 16  # -1 without Stribeck
C_SHAPE = 17  # Stribeck shape code
C_RIGID = 18  # 1: one rigid mass, x = [ω, friction...]
C_GAIN = 19  # the rigid drive's input gain g [N m/V]
C_I_SPEED = 20  # index of the measured speed in x
C_BREAKAWAY = 21  # static friction's breakaway excess ΔF_s [N m] above the kinetic levels at rest
C_I_POSITION = 22  # index of the rigid drive's position θ in x, -1 without a position torque
C_RIPPLE_DIRECTED = 23  # 1: the position torque is a level against the motion, F(θ) sgn ω
C_RIPPLE_PERIODS = 24  # p [1/rad or 1/m] of the position torque's fundamental
C_RIPPLE_HARMONICS = 25  # its harmonics K (1 to FILTER_HARMONICS)
C_RIPPLE_AMPLITUDES = 26  # A_s,1, A_c,1, A_s,2, A_c,2, ... [N m]: 2 FILTER_HARMONICS entries from here
FILTER_HARMONICS = 3
N_FILTER_CONSTANTS = C_RIPPLE_AMPLITUDES + 2 * FILTER_HARMONICS


@numba.njit(cache=True)
def _filter_drive_torque(x: np.ndarray, v: float, c: np.ndarray) -> float:
    """Net torque [N m] on the friction-side mass without its friction, for voltage ``v``."""
    if c[C_RIGID] != 0.0:
        return c[C_GAIN] * v - c[C_TD]
    t_s = c[C_KS] * x[2] + c[C_BS] * (x[0] - x[1])
    if int(c[C_SIDE]) == 1:
        return t_s - c[C_TD]
    K = c[C_KM]
    ic = int(c[C_I_CURRENT])
    t_m = K * x[ic] if ic >= 0 else K * (v - K * x[0]) / c[C_RA]
    return t_m - t_s


@numba.njit(cache=True)
def filter_position_torque(x: np.ndarray, c: np.ndarray) -> tuple[float, float]:
    """The rigid drive's position torque at the filter's position state θ = ``x[c[C_I_POSITION]]``
    and its slope d/dθ: ``Σ_k A_s,k sin(k p θ) + A_c,k cos(k p θ)`` [N m] (:func:`ripple_torque`
    of each harmonic, as :func:`position_torque` sums them) and ``Σ_k k p (A_s,k cos(k p θ) -
    A_c,k sin(k p θ))`` [N m/rad]. The amplitudes and p are known constants of ``c``."""
    q = x[int(c[C_I_POSITION])]
    p = c[C_RIPPLE_PERIODS]
    torque = 0.0
    slope = 0.0
    for k in range(int(c[C_RIPPLE_HARMONICS])):
        a_s = c[C_RIPPLE_AMPLITUDES + 2 * k]
        a_c = c[C_RIPPLE_AMPLITUDES + 2 * k + 1]
        kp = (k + 1) * p
        torque += ripple_torque(q, a_s, a_c, kp)
        slope += ripple_torque(q, -kp * a_c, kp * a_s, kp)
    return torque, slope


@numba.njit(cache=True)
def filter_drift(
    x: np.ndarray, v: float, c: np.ndarray, s: float, stuck: bool, f: np.ndarray, A: np.ndarray
) -> None:
    """Continuous model ``f = dx/dt`` and its Jacobian ``A = df/dx`` for the friction
    direction ``s`` (+1 or -1) held fixed; ``stuck`` freezes the friction-side speed.

    ``v`` is the armature voltage [V] (the rigid drive's input after its dead zone,
    saturation, delay and lag: ``RigidDrive.input_signal``). Fills ``f`` (n,) and ``A`` (n, n). The friction torque is
    :func:`friction_law` with the forward level T_c, the backward level T_c- (T_c when
    symmetric) and the Stribeck excess T_s both ways, plus B ω, plus on a rigid drive with a
    position state θ its known position torque (:func:`filter_position_torque`, times s for a
    level against the motion), with dθ/dt = ω.
    """
    n = x.shape[0]
    jm = c[C_JM]
    side = int(c[C_SIDE])
    i_c = int(c[C_I_COULOMB])
    i_b = int(c[C_I_VISCOUS])
    i_n = int(c[C_I_COULOMB_NEG])
    i_s = int(c[C_I_STRIBECK])
    for i in range(n):
        f[i] = 0.0
        for k in range(n):
            A[i, k] = 0.0
    i_q = int(c[C_I_POSITION])
    if c[C_RIGID] != 0.0:
        J = jm
        f[0] = _filter_drive_torque(x, v, c) / jm
        if i_q >= 0:  # dθ/dt = ω
            f[i_q] = x[0]
            A[i_q, 0] = 1.0
    else:
        jl = c[C_JL]
        J = jm if side == 0 else jl
        K = c[C_KM]
        R = c[C_RA]
        ks = c[C_KS]
        bs = c[C_BS]
        ic = int(c[C_I_CURRENT])
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
    rate = c[C_DECAY]
    shape = int(c[C_SHAPE])
    level_neg = x[i_n] if i_n >= 0 else x[i_c]
    excess = x[i_s] if i_s >= 0 else 0.0
    t_f = friction_law(x[i_c], excess, rate, level_neg, excess, rate, w, s, shape) + x[i_b] * w
    dtf_dw = x[i_b]
    i_level = i_c if (s > 0.0 or i_n < 0) else i_n
    A[side, i_level] -= s / J
    A[side, i_b] -= w / J
    if i_s >= 0:
        dtf_dw += s * excess * stribeck_decay_slope(w, rate, shape, s)
        A[side, i_s] -= s * stribeck_decay(w, rate, shape) / J
    if i_q >= 0:  # the position torque, known: a ripple, or a level against the motion
        ripple, ripple_slope = filter_position_torque(x, c)
        if c[C_RIPPLE_DIRECTED] != 0.0:
            ripple *= s
            ripple_slope *= s
        t_f += ripple
        A[side, i_q] -= ripple_slope / J
    f[side] -= t_f / J
    A[side, side] -= dtf_dw / J


@numba.njit(cache=True)
def filter_direction(x: np.ndarray, v: float, c: np.ndarray) -> tuple[float, bool]:
    """``(s, stuck)`` for the friction side at the start of a sub-step: Karnopp's rule
    (:func:`stick_or_slip`) with the breakaway levels T_c + T_s + ΔF_s forwards and
    T_c- + T_s + ΔF_s backwards (ΔF_s the static friction's excess, ``c[C_BREAKAWAY]``, as
    in :func:`rigid_free_run`). A drive without static friction at rest (both levels 0)
    moves the way the net torque pushes it (held still only by a net torque of exactly 0). A
    position torque acts at rest as in :func:`rigid_motion`: a ripple joins the net torque, a
    level against the motion raises both breakaway levels."""
    w = x[int(c[C_SIDE])]
    i_c = int(c[C_I_COULOMB])
    i_n = int(c[C_I_COULOMB_NEG])
    i_s = int(c[C_I_STRIBECK])
    excess = x[i_s] if i_s >= 0 else 0.0
    b_pos = x[i_c] + excess + c[C_BREAKAWAY]
    b_neg = (x[i_n] if i_n >= 0 else x[i_c]) + excess + c[C_BREAKAWAY]
    t_net = _filter_drive_torque(x, v, c) if w == 0.0 else 0.0
    if w == 0.0 and c[C_I_POSITION] >= 0.0:  # at rest: the position torque as in rigid_motion
        ripple = filter_position_torque(x, c)[0]
        if c[C_RIPPLE_DIRECTED] != 0.0:
            b_pos += ripple
            b_neg += ripple
        else:
            t_net -= ripple
    stuck, s = stick_or_slip(w, t_net, b_pos, b_neg)
    if stuck == 1:
        return 0.0, True
    if s == 0.0:
        if t_net == 0.0:
            return 0.0, True
        s = 1.0 if t_net > 0.0 else -1.0
    return s, False


@numba.njit(cache=True)
def filter_propagate(
    x: np.ndarray, v: float, c: np.ndarray, F: np.ndarray, want_jacobian: bool
) -> np.ndarray:
    """The discrete model: ``x`` advanced over one sample with armature voltage ``v``
    held. Returns the new state; with ``want_jacobian`` fills ``F`` (n, n) with its
    exact derivative d x_next / d x, else leaves ``F`` alone.

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
        s, stuck = filter_direction(xk, v, c)
        filter_drift(xk, v, c, s, stuck, k1, A1)
        for i in range(n):
            x1[i] = xk[i] + h * k1[i]
        filter_drift(x1, v, c, s, stuck, k2, A2)
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


@numba.njit(cache=True)
def filter_free_run(v: np.ndarray, x0: np.ndarray, c: np.ndarray) -> np.ndarray:
    """States after each sample of a record of armature voltages ``v`` from ``x0``, shape (N, n)."""
    N = v.shape[0]
    n = x0.shape[0]
    out = np.empty((N, n))
    F = np.empty((0, 0))
    x = x0.copy()
    for t in range(N):
        x = filter_propagate(x, v[t], c, F, False)
        out[t] = x
    return out


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def ekf_predict(
    x: np.ndarray, P: np.ndarray, v: float, c: np.ndarray, Q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """EKF time update: ``(x_prior, P_prior, F)`` for armature voltage ``v`` [V]."""
    n = x.shape[0]
    F = np.empty((n, n))
    x_prior = filter_propagate(x, v, c, F, True)
    return x_prior, congruence(P, F, Q), F


@numba.njit(cache=True)
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


@numba.njit(cache=True)
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


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def is_healthy(x: np.ndarray, P: np.ndarray) -> bool:
    """x finite and P positive definite."""
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return False
    return is_positive_definite(P)


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def hold_position(x: np.ndarray, P: np.ndarray, i: int, position: float, var: float) -> None:
    """The measured ``position`` [rad or m] as the filter's position state ``x[i]``, in place: a
    known input of the next sample's position torque, not a measurement of the speed (a speed
    read from an encoder is that position's difference already). Its row and column of ``P`` are
    zeroed and its variance set to ``var`` > 0, so P stays positive definite."""
    x[i] = position
    for k in range(x.shape[0]):
        P[i, k] = 0.0
        P[k, i] = 0.0
    P[i, i] = var


#: No measured positions (:func:`ekf_batch` on a drive without a position state).
NO_POSITIONS = np.zeros(0)
NO_MEASUREMENTS = np.zeros(0, dtype=np.bool_)

#: codes of the batch kernel for what stopped or flagged it
FLAG_OK, FLAG_NIS, FLAG_BREAKDOWN = 0, 1, 2


@numba.njit(cache=True)
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
    position: np.ndarray = NO_POSITIONS,
    position_present: np.ndarray = NO_MEASUREMENTS,
    position_var: float = 0.0,
):
    """The sample loop of :func:`ekf_predict` and :func:`joseph_update` over a record.

    A drive with a position state (``c[C_I_POSITION]`` >= 0) takes ``position[t]``, where
    ``position_present[t]``, as its state after each sample (:func:`hold_position`).

    Stops after the sample where the covariance breaks down, or where the windowed
    NIS passes ``threshold`` when ``stop_on_nis``. Returns the per-sample arrays
    (filled up to ``done`` samples) and the last sample's quantities.
    """
    N = v.shape[0]
    n = x.shape[0]
    i_y = int(c[C_I_SPEED])
    i_q = int(c[C_I_POSITION])
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
        y_hat[t] = x_prior[i_y]
        s = P_prior[i_y, i_y] + r
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
        if i_q >= 0 and position_present[t]:
            x = x.copy()  # x_prior stays the prior
            P = P.copy()
            hold_position(x, P, i_q, position[t], position_var)
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


# --------------------------------------------------------------------------- rigid drive
# The terms of the rigid drive's torque balance J dω/dt = F_in - Σ θ_t T_t(ω)
# (:class:`~motorid.drive.rigid.RigidDrive`), by code. Speed terms scale with ω
# (T_t = ω k_t(ω, s)) and join the exactly integrated linear part; level terms do not.
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
def rigid_friction(
    terms: np.ndarray, coefs: np.ndarray, omega: float, direction: float, rate: float, shape: int
) -> float:
    """Σ_j coefs[j] T_terms[j](ω) [F] at one speed ω for motion in ``direction`` (a fraction of ±1
    ramps the level terms: the friction compensation's smoothed sign), in one call."""
    total = 0.0
    for j in range(terms.size):
        total += coefs[j] * rigid_term(terms[j], omega, direction, rate, shape)
    return total


@numba.njit(cache=True)
def rigid_delay_samples(dt: float, delay: float) -> tuple[int, float]:
    """``(m, f)`` of a delay [s] at sample time ``dt`` [s]: ``delay = (m + f) dt`` with m whole
    samples and 0 <= f < 1 (a negative delay is 0). An input-dynamics ring holds m + 2 inputs."""
    steps = max(delay, 0.0) / dt
    m = int(steps)
    return m, steps - m


@numba.njit(cache=True)
def rigid_input_dynamics(
    x: np.ndarray, dt: float, delay: float, time_constant: float, ring: np.ndarray, state: np.ndarray
) -> np.ndarray:
    """Mean over each sample of the held signal ``x`` delayed by ``delay`` [s] and then passed
    through the first-order lag ``T dz/dt = x_d - z`` of time constant ``time_constant`` [s].

    With ``delay = (m + f) dt`` (:func:`rigid_delay_samples`) the delayed held signal covers
    sample k with ``x[k-m-1]`` for its first share f and ``x[k-m]`` for the rest. Over a piece
    of length L holding v the lag, with ``e = exp(-L/T)``, integrates exactly::

        ∫ z = v L + (z_0 - v) T (1 - e),    z_L = v + (z_0 - v) e

    and the sample's value is the integral over it / dt. ``T <= 0`` is no lag (then z follows
    the delayed signal), so without a lag ``(1 - f) x[k-m] + f x[k-m-1]``. Exact for the held
    input, whole and fractional delays.

    The map runs on its state, updated in place: ``ring`` (m + 2 values) holds the latest
    inputs (``x[k]`` at ``ring[k % (m + 2)]``) and ``state = [z, samples seen]``. A fresh state
    (``state[1] == 0``) starts at rest on the first input: ``x[0]`` before the record and
    ``z = x[0]``. So a record in one call and the same record a sample at a time (the running
    simulation of a rigid drive) are the same computation.
    """
    n = x.size
    out = np.empty(n)
    m, f = rigid_delay_samples(dt, delay)
    size = m + 2
    if ring.size != size:
        raise ValueError("rigid_input_dynamics: the ring must hold m + 2 inputs")
    lag = time_constant > 0.0
    for k in range(n):
        seen = int(state[1])
        if seen == 0:
            ring[:] = x[k]
            state[0] = x[k]
        ring[seen % size] = x[k]
        late = ring[(seen + 2) % size]  # x[k-m]
        early = ring[(seen + 1) % size]  # x[k-m-1]
        z = state[0]
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
        state[0] = z
        state[1] = seen + 1
        out[k] = total / dt
    return out


@numba.njit(cache=True)
def reversal_clock(x: np.ndarray, dt: float, before_first: float, clock: np.ndarray) -> np.ndarray:
    """Time [s] since the last change of sign of ``x`` (zeros keep the previous sign).

    Before the first reversal the time counts from the start, or is ``before_first`` when it
    is not NaN. The clock runs on its state, updated in place: ``clock = [last non-zero sign,
    samples since the last reversal (or the start), 1 once reversed]``, fresh ``[0, -1, 0]``;
    a record in one call and a sample at a time are the same computation.
    """
    out = np.empty(x.size)
    count_from_start = math.isnan(before_first)
    for k in range(x.size):
        v = x[k]
        s = 1.0 if v > 0.0 else (-1.0 if v < 0.0 else 0.0)
        clock[1] += 1.0
        if s != 0.0:
            if clock[0] != 0.0 and s != clock[0]:
                clock[1] = 0.0
                clock[2] = 1.0
            clock[0] = s
        out[k] = clock[1] * dt if (clock[2] == 1.0 or count_from_start) else before_first
    return out


@numba.njit(cache=True)
def backlash_dwell(force: np.ndarray, dt: float, backlash_time: float, clock: np.ndarray) -> np.ndarray:
    """``B(F)``: the force [F] is not transmitted for ``backlash_time`` [s] after each reversal
    of its sign (before the first reversal it is), on the state ``clock`` of
    :func:`reversal_clock`."""
    since = reversal_clock(force, dt, math.inf, clock)
    out = np.empty(force.size)
    for k in range(force.size):
        out[k] = force[k] * (1.0 if since[k] >= backlash_time else 0.0)
    return out


@numba.njit(cache=True)
def ripple_torque(position: float, ripple_sin: float, ripple_cos: float, periods: float) -> float:
    """A torque ripple periodic in the position, ``A_s sin(p θ) + A_c cos(p θ)`` [F] at position θ
    [rad or m], with ``p`` = ``periods`` [1/rad or 1/m]: for a rotary drive the ripple's count per
    revolution (p periods over 2π rad), for a linear one 2π over its pitch; amplitude
    sqrt(A_s² + A_c²), phase atan2(A_c, A_s). The one law of a torque that depends on the position
    (the ``cogging`` effect): the rigid drive, the two-mass rig's motor and the doctor's columns
    evaluate it."""
    x = periods * position
    return ripple_sin * math.sin(x) + ripple_cos * math.cos(x)


#: No harmonics beyond the first of a position torque (:func:`position_torque`).
NO_HARMONICS = np.zeros(0)


@numba.njit(cache=True)
def position_torque(
    position: float,
    ripple_sin: float,
    ripple_cos: float,
    periods: float,
    harmonic_sin: np.ndarray,
    harmonic_cos: np.ndarray,
) -> float:
    """A torque periodic in the position with harmonics, ``Σ_k A_s,k sin(k p θ) + A_c,k cos(k p θ)``
    [F] at position θ [rad or m], k = 1 (``ripple_sin``, ``ripple_cos``) then 2, 3, ...
    (``harmonic_sin[k - 2]``, ``harmonic_cos[k - 2]``): :func:`ripple_torque` of each harmonic.
    Without harmonics it is the ripple's bits."""
    total = ripple_torque(position, ripple_sin, ripple_cos, periods)
    for k in range(harmonic_sin.size):
        total += ripple_torque(position, harmonic_sin[k], harmonic_cos[k], (k + 2) * periods)
    return total


@numba.njit(cache=True)
def position_torques(
    position: np.ndarray,
    ripple_sin: float,
    ripple_cos: float,
    periods: float,
    harmonic_sin: np.ndarray,
    harmonic_cos: np.ndarray,
) -> np.ndarray:
    """Vectorised :func:`position_torque`: the torque [F] at each position."""
    out = np.empty(position.size)
    for k in range(position.size):
        out[k] = position_torque(position[k], ripple_sin, ripple_cos, periods, harmonic_sin, harmonic_cos)
    return out


@numba.njit(cache=True)
def ripple_columns(position: np.ndarray, periods: float) -> np.ndarray:
    """The ripple's torque per unit ``A_s`` and ``A_c`` (:func:`ripple_torque`),
    ``sin(p θ[k])`` and ``cos(p θ[k])``, as two rows, shape (2, N): each column of the
    transpose (N, 2) lies contiguous in memory."""
    out = np.empty((2, position.size))
    for k in range(position.size):
        out[0, k] = ripple_torque(position[k], 1.0, 0.0, periods)
        out[1, k] = ripple_torque(position[k], 0.0, 1.0, periods)
    return out


@numba.njit(cache=True)
def relative_growth(z: float) -> float:
    """φ1(z) = (e^z - 1)/z, 1 at z = 0 (dimensionless): the share of its distance to the steady
    state that a first-order system covers over a step, ``x(h) = x0 + h ẋ0 φ1(-h/τ)``; accurate
    at every z (``expm1``)."""
    if z == 0.0:
        return 1.0
    return math.expm1(z) / z


@numba.njit(cache=True)
def relative_area(z: float) -> float:
    """φ2(z) = (e^z - 1 - z)/z², 1/2 at z = 0 (dimensionless): ``∫_0^h x dt = h x0 + h² ẋ0
    φ2(-h/τ)`` for the first-order course of :func:`relative_growth`. Its Taylor series
    Σ_k z^k/(k + 2)! below |z| = 1/2 (summed to k = 16: the next term is below 1e-22), the closed
    form above (where e^z - 1 - z loses at most a factor 4 to cancellation)."""
    if abs(z) < 0.5:
        total = 0.0
        term = 0.5
        for k in range(17):
            total += term
            term *= z / (k + 3)
        return total
    return (math.expm1(z) - z) / (z * z)


@numba.njit(cache=True)
def log1p_ratio(x: float) -> float:
    """log(1 + x)/x, 1 at x = 0 (x > -1), accurate at every x (``log1p``)."""
    if x == 0.0:
        return 1.0
    return math.log1p(x) / x


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
    """Speed of a rigid drive at the end of each sample for the input force [F] held over it:
    the speed of :func:`rigid_motion` (from position 0; without a position ripple the speed does not
    depend on it: a drive with one runs :func:`rigid_motion`)."""
    return rigid_motion(force, dt, nsub, inertia, coef, rate, shape, w0, 0.0, breakaway_excess)[0]


@numba.njit(cache=True)
def rigid_motion(
    force: np.ndarray,
    dt: float,
    nsub: int,
    inertia: float,
    coef: np.ndarray,
    rate: float,
    shape: int,
    w0: float,
    q0: float,
    breakaway_excess: float = 0.0,
    ripple_sin: float = 0.0,
    ripple_cos: float = 0.0,
    ripple_periods: float = 0.0,
    ripple_directed: bool = False,
    harmonic_sin: np.ndarray = NO_HARMONICS,
    harmonic_cos: np.ndarray = NO_HARMONICS,
) -> tuple[np.ndarray, np.ndarray]:
    """Speed and position of a rigid drive at the end of each sample for the input force [F]
    held over it, from speed ``w0`` [v] and position ``q0`` [v s: rad or m].

    ``coef[t]`` is the parameter θ_t of term t. Fixed internal step h = dt/nsub. Over each step
    (or each piece of it, below) the level terms and the speed terms' factors are held at their
    values at its start, ``F_l = Σ_levels θ_t T_t(ω0, s)`` and ``D = Σ_speed θ_t k_t(ω0, s)``,
    so the torque balance ``J dω/dt = F - F_l - D ω`` is linear and integrated exactly
    (exponential Euler) over a piece of length L::

        a   = (F - F_l - D ω0) / J                      (the acceleration at its start)
        ω   = ω0 + L a φ1(-D L/J)                       (:func:`relative_growth`)
        Δq  = L ω0 + L² a φ2(-D L/J)                    (:func:`relative_area`)

    which is ``ω = ω∞ + (ω0 - ω∞) e^(-D L/J)``, ω∞ = (F - F_l)/D, and its integral, with the
    limit D -> 0 (``ω = ω0 + L a``) in the same formula. A speed that changes sign inside a step
    is stopped at its zero, reached after (a root of the course above)::

        t0 = (J/D) log(1 - D ω0/(F - F_l)) = -(J ω0/(F - F_l)) log1p(x)/x,   x = -D ω0/(F - F_l)

    (:func:`log1p_ratio`; ``-J ω0/(F - F_l)`` as D -> 0), and Karnopp's rule
    (:func:`stick_or_slip`) decides there, as at the start of a step at rest: the breakaway
    levels are the level terms at 0± minus the torque at rest (the offset), each raised by
    ``breakaway_excess`` [F] >= 0 (static friction above the kinetic level: a drive at rest
    breaks away only beyond it, and once moving slows against the kinetic level alone, so it
    keeps moving down to a lower force). A drive that sticks stays at exactly 0 for the rest of
    the step; one that slips goes on from 0 with the other side's friction for the rest of the
    step. A drive without (or with a non-physical negative) static friction at rest moves towards
    the side the net force exceeds most. A drive at rest whose acceleration in the chosen
    direction is not positive stays at rest. So a reversal costs no time, and a step of a drive
    with constant levels (Coulomb and viscous friction, an offset) is exact for the held force:
    the only errors are those of holding the Stribeck decay, the quadratic drag's |ω| and the
    position ripple over a step.

    A non-physical negative D (a fit's negative viscous friction) grows as e^(|D| L/J), the exact
    course, with no singularity at any step.

    The position advances with the speed's exact integral over each piece (a stuck piece leaves
    it), so ``q[k] = q0 + Σ`` of the pieces, no second integrator. The position ripple
    :func:`ripple_torque` at the position at the start of each piece (``ripple_sin``,
    ``ripple_cos`` [F], ``ripple_periods`` [1/rad or 1/m]; cogging) joins the level terms, and at
    rest the torque the drive must overcome (a drive without it skips it: both amplitudes 0
    evaluate nothing). ``harmonic_sin[k]``, ``harmonic_cos[k]`` [F] add the harmonic ``k + 2`` of
    it (:func:`position_torque`). With ``ripple_directed`` the ripple is a level against the
    motion, ``F(θ) sgn ω`` (position-dependent friction): at rest it raises both breakaway levels
    by ``F(θ)`` instead.
    Returns ``(speed, position)``, each of shape (N,).
    """
    n = force.size
    out = np.empty(n)
    position = np.empty(n)
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
    rippled = ripple_sin != 0.0 or ripple_cos != 0.0 or harmonic_sin.size > 0
    w = w0
    q = q0
    for k in range(n):
        f = force[k]
        for _ in range(nsub):
            remaining = h
            # a zero crossing ends the first piece at w = 0, and a piece from rest never
            # crosses zero (its course is monotonic, away from 0): at most two pieces
            for _piece in range(2):
                ripple = 0.0
                if rippled:
                    ripple = position_torque(
                        q, ripple_sin, ripple_cos, ripple_periods, harmonic_sin, harmonic_cos
                    )
                at_rest = w == 0.0
                if at_rest:
                    if ripple_directed:
                        t_net = f - rest
                        stuck, s = stick_or_slip(w, t_net, break_pos + ripple, break_neg + ripple)
                    else:
                        t_net = f - rest - ripple
                        stuck, s = stick_or_slip(w, t_net, break_pos, break_neg)
                    if stuck == 1:
                        break
                    if s == 0.0:
                        s = 1.0 if t_net >= 0.5 * (break_pos - break_neg) else -1.0
                else:
                    s = 1.0 if w > 0.0 else -1.0
                level = s * ripple if ripple_directed else ripple
                for t in range(N_SPEED_TERMS, N_TERMS):
                    level += coef[t] * rigid_level(t, w, s, rate, shape)
                damp = 0.0
                for t in range(N_SPEED_TERMS):
                    damp += coef[t] * rigid_speed_factor(t, w, s)
                drive = f - level  # F - F_l
                acc = (drive - damp * w) / inertia  # a = (F - F_l - D ω0) / J
                if at_rest and acc * s <= 0.0:
                    break  # no motion in the chosen direction: at rest for the rest of the step
                z = -damp * remaining / inertia
                wn = w + remaining * acc * relative_growth(z)  # ω = ω0 + L a φ1(-D L/J)
                if wn * s >= 0.0:
                    q += remaining * w + remaining * remaining * acc * relative_area(z)  # Δq = L ω0 + L² a φ2
                    w = wn
                    break
                # the speed reaches 0 inside the piece, at t0 = -(J ω0/(F - F_l)) log1p(x)/x
                t0 = remaining  # (a crossing needs a net force against the motion: F - F_l != 0)
                if drive != 0.0:
                    x = -damp * w / drive
                    if x > -1.0:
                        t0 = -inertia * w / drive * log1p_ratio(x)
                t0 = min(max(t0, 0.0), remaining)
                q += t0 * w + t0 * t0 * acc * relative_area(-damp * t0 / inertia)
                w = 0.0
                remaining -= t0
        out[k] = w
        position[k] = q
    return out, position
