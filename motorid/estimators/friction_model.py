"""The friction filters' model: the drive with unknown friction as a state-space model,
its analytic Jacobian and its sub-stepped discretisation.

The model is the drive's physics, so it is compiled where the drive's physics is:
:mod:`motorid.drive.kernels` (``filter_drift``, ``filter_direction``,
``filter_propagate``, ``filter_free_run`` and the EKF's kernels ``ekf_predict``,
``joseph_update``, ``ekf_batch``). Its friction torque is eq. (11)'s ``friction_law``
with the ``stribeck_decay`` (exponential or Gaussian) and its slope, and its stick/slip
rule is ``stick_or_slip``: the functions the rig's integrators, its friction objects
and the rigid drive evaluate. This module holds what only the filters need: the
layout of the state (:func:`state_layout`), the packing of the known constants
(:func:`pack_constants`) and the stiffness probe that sets the sub-steps
(:func:`stiffest_rate`). :class:`~motorid.estimators.friction_kf.FrictionEKF` uses the
map and its Jacobian, :class:`~motorid.estimators.friction_kf.FrictionUKF` only the map.

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

A rigid drive (:class:`~motorid.drive.rigid.RigidDrive`) has one mass: the state is
``x = [ω, (θ), T_c, B, (T_c-), (T_s)]`` and ω is what is measured. θ [rad or m], the position,
is in the state of a drive with a torque that depends on it (cogging, position-dependent
friction: :attr:`Effect.position <motorid.drive.effects.base.Effect.position>`); its torque
``T_p(θ) = Σ_k A_s,k sin(k p θ) + A_c,k cos(k p θ)`` (times sgn ω for a level against the
motion) is a known part of the model, its amplitudes and p held at the drive's values; a
measured position is taken as θ (``kernels.hold_position``), between two measurements θ
follows the speed.

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
    T_f  = s (T_c,s + T_s d(ω_j)) + B ω_j                                  (eqs. 8, 9, 11)

where s is the direction of motion of mass j, T_c,s the Coulomb level for that
direction (T_c forwards, T_c- backwards when asymmetric, else T_c both ways) and d
the Stribeck decay, exp(-α2 |ω_j|) (eq. 9) or exp(-(α2 ω_j)²) (``stribeck_shape``
"gaussian"), with α2 (``stribeck_decay``, s/rad) a known constant. The rigid drive's
one mass obeys ``J dω/dt = g v - T_0 - T_f(ω) - T_p(θ)``, ``dθ/dt = ω``, with its
inertia J, input gain g, offset torque T_0 and position torque T_p known (its viscous term B
holds the back-EMF and the bearings together), v its input after its dead zone and saturation.

Zero speed (sgn is not differentiable at 0)
-------------------------------------------
The sample is integrated in ``n`` sub-steps of h = dt/n by Heun's method (RK2).
Within a sub-step the direction s is *frozen* at its value at the start of the
sub-step, exactly as the plant's integrator holds its friction torques over an
internal step, and the plant's Karnopp stick/slip rule (``stick_or_slip``) makes the
model stick like the plant:

- ω_j != 0 at the start: s = sgn(ω_j). If the sub-step ends with s ω_j < 0 (the
  mass passed through zero) ω_j is set to exactly 0.
- ω_j == 0 at the start: the mass stays stuck (dω_j/dt = 0 over the sub-step)
  while the net driving torque on it lies in [-(T_c- + T_s + ΔF_s), T_c + T_s + ΔF_s]
  (ΔF_s a rigid drive's static friction excess, known; 0 otherwise); else it breaks
  away with s the sign of that torque.

Within a sub-step the Stribeck decay is evaluated at the stage's own speed, d(ω_j);
only its side (the level T_c or T_c- and the sign s) is frozen.

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

import numpy as np

from motorid.drive import kernels

#: indices of the mechanical states in x (two-mass drive; a rigid drive's ω is at 0)
I_OMEGA_M = 0
I_OMEGA_L = 1
I_TWIST = 2


def state_layout(
    current_state: bool, asymmetric: bool, stribeck: bool, rigid: bool = False, position: bool = False
) -> tuple[tuple[str, ...], dict[str, int]]:
    """Names of the entries of x and the index of each entry (-1 when absent).

    ``index["speed"]`` is the measured speed: ω_L of the two-mass drive, the rigid
    drive's ω.

    Parameters
    ----------
    current_state : bool
        Whether the armature current is a state.
    asymmetric : bool
        Whether the backward Coulomb level is a state.
    stribeck : bool
        Whether the Stribeck level is a state.
    rigid : bool
        A rigid drive (no shaft twist, one speed).
    position : bool
        The rigid drive's position θ is a state (a drive with a position torque).
    """
    index = {"position": -1}
    if rigid:
        names = ["omega"]
        index.update(omega_m=0, omega_l=-1, twist=-1, speed=0)
        if position:
            index["position"] = len(names)
            names.append("position")
    else:
        names = ["omega_m", "omega_l", "twist"]
        index.update(omega_m=I_OMEGA_M, omega_l=I_OMEGA_L, twist=I_TWIST, speed=I_OMEGA_L)
    index.update({"i_a": -1, "coulomb_neg": -1, "stribeck": -1})
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
    stribeck_shape: str,
    dt: float,
    substeps: int,
    friction_side: str,
    index: dict[str, int],
    input_gain: float = 0.0,
    breakaway_excess: float = 0.0,
    ripple: tuple = (),
) -> np.ndarray:
    """The constant vector ``c`` the compiled model reads (SI units; indices ``C_*`` of
    :mod:`motorid.drive.kernels`). A layout with ``index["twist"] == -1`` is the
    rigid drive: ``J_m`` its inertia, ``T_d`` its offset torque, ``input_gain`` its g,
    ``breakaway_excess`` its static friction's ΔF_s [N m] (the stick rule's levels at rest),
    ``ripple`` its position torque (with ``index["position"]`` its state).

    Parameters
    ----------
    J_m, J_l : float
        Motor and load inertia [kg m^2].
    K_m : float
        Motor constant [N m/A = V s/rad].
    R_a : float
        Armature resistance [Ω].
    L_a : float
        Armature inductance [H].
    k_s : float
        Shaft stiffness [N m/rad].
    B_s : float
        Shaft damping [N m s/rad].
    T_d : float
        Constant disturbance (offset) torque [N m].
    stribeck_decay : float
        Stribeck rate 1/v_s [s/rad].
    stribeck_shape : str
        A shape of :data:`motorid.drive.kernels.STRIBECK_SHAPES`.
    dt : float
        Sample time [s].
    substeps : int
        Integration steps per sample.
    friction_side : {"motor", "load"}
        The mass the estimated friction acts on.
    index : dict
        The state layout (:func:`state_layout`).
    input_gain : float
        The rigid drive's input gain g [N m/V].
    breakaway_excess : float
        The rigid drive's static friction ΔF_s [N m].
    ripple : tuple
        The rigid drive's position torque as :meth:`Effect.ripple
        <motorid.drive.effects.base.Effect.ripple>` gives it, ``(A_s,1, A_c,1, p, directed,
        A_s,2.., A_c,2..)`` [N m, 1/rad]; empty for a drive without one.
    """
    c = np.zeros(kernels.N_FILTER_CONSTANTS)
    c[kernels.C_JM], c[kernels.C_JL], c[kernels.C_KM], c[kernels.C_RA], c[kernels.C_LA] = (
        J_m,
        J_l,
        K_m,
        R_a,
        L_a,
    )
    c[kernels.C_KS], c[kernels.C_BS], c[kernels.C_TD], c[kernels.C_DECAY] = k_s, B_s, T_d, stribeck_decay
    c[kernels.C_SHAPE] = kernels.STRIBECK_SHAPES.index(stribeck_shape)
    c[kernels.C_H] = dt / substeps
    c[kernels.C_NSUB] = substeps
    c[kernels.C_SIDE] = 0 if friction_side == "motor" else 1
    c[kernels.C_I_CURRENT] = index["i_a"]
    c[kernels.C_I_COULOMB] = index["coulomb"]
    c[kernels.C_I_VISCOUS] = index["viscous"]
    c[kernels.C_I_COULOMB_NEG] = index["coulomb_neg"]
    c[kernels.C_I_STRIBECK] = index["stribeck"]
    c[kernels.C_RIGID] = 1.0 if index["twist"] < 0 else 0.0
    c[kernels.C_GAIN] = input_gain
    c[kernels.C_I_SPEED] = index["speed"]
    c[kernels.C_BREAKAWAY] = breakaway_excess
    c[kernels.C_I_POSITION] = index["position"]
    if ripple:
        a_s, a_c, periods, directed, harmonic_sin, harmonic_cos = ripple
        amplitudes = [a_s, a_c]
        for h_s, h_c in zip(harmonic_sin, harmonic_cos, strict=True):
            amplitudes += [h_s, h_c]
        if len(amplitudes) > 2 * kernels.FILTER_HARMONICS:
            raise ValueError(
                f"ripple: the filters hold at most {kernels.FILTER_HARMONICS} harmonics of a position torque, "
                f"got {len(amplitudes) // 2}"
            )
        c[kernels.C_RIPPLE_DIRECTED] = 1.0 if directed else 0.0
        c[kernels.C_RIPPLE_PERIODS] = periods
        c[kernels.C_RIPPLE_HARMONICS] = len(amplitudes) // 2
        start = kernels.C_RIPPLE_AMPLITUDES
        c[start : start + len(amplitudes)] = amplitudes
    return c


def stiffest_rate(c: np.ndarray, x: np.ndarray, v: float = 0.0) -> float:
    """Largest |eigenvalue| [1/s] of the continuous Jacobian at ``x`` (moving forwards).

    Parameters
    ----------
    c : ndarray
        The model's constants (:func:`pack_constants`).
    x : ndarray
        The state.
    v : float
        The armature voltage [V].
    """
    n = x.shape[0]
    f = np.zeros(n)
    A = np.zeros((n, n))
    kernels.filter_drift(x, v, c, 1.0, False, f, A)
    return float(np.max(np.abs(np.linalg.eigvals(A))))


__all__ = ["I_OMEGA_L", "I_OMEGA_M", "I_TWIST", "pack_constants", "state_layout", "stiffest_rate"]
