"""Two integrators, one model: both against the analytic linear response and each other."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal
from conftest import examples
from hypothesis import given
from hypothesis import strategies as st
from numpy.polynomial import polynomial as npoly

from motorid.drive import (
    ADConverter,
    Amplifier,
    Friction,
    Tachogenerator,
    TwoMassRig,
    paper_rig,
)
from motorid.drive.reference_integrator import ReferenceIntegrator
from motorid.signals import two_sine_signal

IDEAL_SENSOR = {"tacho": Tachogenerator(noise_std=0.0), "adc": ADConverter(bits=0)}


def transfer_functions(rig: TwoMassRig) -> tuple[scipy.signal.TransferFunction, ...]:
    """Ω_L/V and Ω_m/V of eqs. (1)-(7), derived by hand from the Laplace transforms.

    With N = B_s s + k_s, P_m = J_m s² + (B_m + B_s) s + k_s,
    P_L = J_L s² + (B_L + B_s) s + k_s and D' = (P_m P_L - N²)/s:

        Ω_L/V = K N / ((L s + R) D' + K² P_L),   Ω_m/V = K P_L / (same).
    """
    K, R, L = rig.K_m, rig.R_a, rig.L_a
    N = [rig.k_s, rig.B_s]  # ascending powers of s
    Pm = [rig.k_s, rig.B_m + rig.B_s, rig.J_m]
    Pl = [rig.k_s, rig.B_l + rig.B_s, rig.J_l]
    D = npoly.polysub(npoly.polymul(Pm, Pl), npoly.polymul(N, N))
    assert abs(D[0]) < 1e-12 * max(abs(D))
    Dp = D[1:]
    den = npoly.polyadd(npoly.polymul([R, L], Dp), K**2 * np.asarray(Pl))
    to_desc = lambda c: np.asarray(c, dtype=float)[::-1]  # noqa: E731
    G_l = scipy.signal.TransferFunction(to_desc(K * np.asarray(N)), to_desc(den))
    G_m = scipy.signal.TransferFunction(to_desc(K * np.asarray(Pl)), to_desc(den))
    return G_l, G_m


def analytic_response(rig: TwoMassRig, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ω_L and ω_m at the end of each sample for a zero-order-hold input (lsim, interp=False)."""
    t = np.arange(u.size + 1) * rig.dt
    uu = np.append(u, u[-1])
    out = []
    for G in transfer_functions(rig):
        _, y, _ = scipy.signal.lsim(G, uu, t, interp=False)
        out.append(y[1:])
    return out[0], out[1]


def linear_rig(**kw) -> TwoMassRig:
    return TwoMassRig(**IDEAL_SENSOR, **kw)


def assert_rel(actual: np.ndarray, expected: np.ndarray, rel: float) -> None:
    scale = np.max(np.abs(expected))
    err = np.max(np.abs(actual - expected))
    assert err <= rel * scale, f"max error {err:.3g} > {rel:g} x {scale:.3g}"


# ------------------------------------------------------------- linear: exact
@pytest.mark.parametrize("integrator", ["fast", "reference"])
def test_linear_rig_matches_analytic_response(integrator):
    """All nonlinearities off: both integrators equal the transfer function to 1e-6."""
    rig = linear_rig()
    rng = np.random.default_rng(3)
    u = np.repeat(rng.uniform(-12, 12, 12), 6)
    df = rig.simulate(u, integrator=integrator)
    w_l, w_m = analytic_response(rig, u)
    assert_rel(df["omega_l"].to_numpy(), w_l, 1e-6)
    assert_rel(df["omega_m"].to_numpy(), w_m, 1e-6)
    # ideal sensor: y = (G_t omega) / G_t, two roundings, within 2 eps of omega
    np.testing.assert_allclose(df["y"], df["omega_l"], rtol=1e-14)


@pytest.mark.filterwarnings("ignore::scipy.signal.BadCoefficients")
@examples(15)
@given(
    J_m=st.floats(1e-6, 1e-3),
    J_l=st.floats(1e-6, 1e-3),
    k_s=st.floats(0.05, 50.0),
    B_s=st.floats(0.0, 1e-2),
    L_a=st.floats(1e-4, 1e-2),
    substeps=st.integers(1, 50),
    seed=st.integers(0, 2**31),
)
def test_physics_is_exact_for_any_linear_rig(J_m, J_l, k_s, B_s, L_a, substeps, seed):
    rig = linear_rig(J_m=J_m, J_l=J_l, k_s=k_s, B_s=B_s, L_a=L_a, substeps=substeps, dt=0.01)
    u = np.random.default_rng(seed).uniform(-10, 10, 60)
    df = rig.simulate(u)
    w_l, w_m = analytic_response(rig, u)
    assert_rel(df["omega_l"].to_numpy(), w_l, 1e-6)
    assert_rel(df["omega_m"].to_numpy(), w_m, 1e-6)


# ------------------------------------------- nonlinear: the two agree
@pytest.fixture(scope="module")
def bidirectional_pair():
    """The paper rig (Coulomb friction on both masses, 0.6 V dead zone) on 10 s of the
    paper's two-sine signal with low-amplitude stretches, through both integrators."""
    rig = paper_rig(**IDEAL_SENSOR)
    _, u = two_sine_signal(duration=10.0, dt=rig.dt, seed=11)
    ref = rig.simulate(u, integrator="reference")
    return rig, u, ref


def test_integrators_agree_on_bidirectional_record(bidirectional_pair):
    """Fast (h = 1 ms) vs reference (solve_ivp, events, rtol 1e-10) with Coulomb and dead zone.

    Tolerances: 0.5 rad/s on ω_m and 0.2 rad/s on ω_L (0.8 % and 0.3 % of the
    65 rad/s swing), 10 mA on i_a, 0.05 rad on the angles (they integrate the
    speed error of every event over the 10 s). Why: with Coulomb
    friction and a dead zone the fast path is exact between switching events
    (the friction torque is constant while a mass slips, the input is held), so
    its only error is that a stop or a breakaway is resolved to the internal
    step h instead of located exactly, worth up to |dω/dt| h at that event. The
    worst case is a breakaway under a fast-rising torque (the 0.5 ms armature
    time constant is shorter than h): at the first sample the motor breaks away
    up to 1 ms late while accelerating at ~300 rad/s². Measured: 0.31 rad/s on
    ω_m, 0.11 rad/s on ω_L, 7 mA, 0.024 rad. The reference itself is accurate to
    ~1e-10 (see the linear test), and the error shrinks with h (next test).
    """
    rig, u, ref = bidirectional_pair
    fast = rig.simulate(u)
    assert (ref["omega_l"] > 20).any() and (ref["omega_l"] < -20).any()  # bidirectional
    assert (ref["omega_l"] == 0.0).sum() >= 10  # with stuck phases
    for col, tol in (("omega_m", 0.5), ("omega_l", 0.2), ("i_a", 1e-2),
                     ("theta_m", 0.05), ("theta_l", 0.05)):  # fmt: skip
        err = np.max(np.abs(fast[col] - ref[col]))
        assert err <= tol, f"{col}: {err:.3g} > {tol}"
    # stuck samples agree, up to the samples where a stop lands within h of a sample end
    stuck_fast = fast["omega_l"].to_numpy() == 0.0
    stuck_ref = ref["omega_l"].to_numpy() == 0.0
    assert np.sum(stuck_fast != stuck_ref) <= 4


def test_physics_converges_to_reference(bidirectional_pair):
    """The discrepancy is the event-time resolution: 8x finer internal steps, >= 4x smaller error."""
    rig, u, ref = bidirectional_pair
    errs = []
    for substeps in (40, 320):
        fast = rig.replace(substeps=substeps).simulate(u)
        errs.append(np.max(np.abs(fast["omega_l"] - ref["omega_l"])))
    assert errs[1] <= errs[0] / 4, errs


def test_both_integrators_hold_a_mass_below_breakaway_exactly():
    rig = paper_rig(friction=(Friction(("coulomb_friction",), {"coulomb": 5e-3}, side="motor"),),
                    amplifier=Amplifier(), **IDEAL_SENSOR)  # fmt: skip
    limit = 5e-3 * rig.R_a / rig.K_m
    u = limit * np.array([0.9, -0.9, 0.5, 0.99, -0.99, 0.0, 0.7, -0.3])
    for integrator in ("fast", "reference"):
        df = rig.simulate(u, integrator=integrator)
        assert (df["omega_m"] == 0.0).all(), integrator
        assert (df["omega_l"] == 0.0).all(), integrator


def test_integrators_agree_with_backlash_and_lugre():
    """Backlash (±0.05 rad) and LuGre friction: agreement within 0.15 rad/s at h = 1 ms
    (explicit bristle/contact switching within a step), converging with finer h."""
    t = np.arange(60) * 0.04
    u = 3 * np.sin(2 * np.pi * 0.3 * t) + np.sin(2 * np.pi * 1.1 * t)
    lugre = Friction(
        ("coulomb_friction", "stribeck_friction", "lugre_friction"),
        {"coulomb": 3e-3, "stribeck": 1e-3, "stribeck_velocity": 2.0, "bristle_stiffness": 2.0,
         "bristle_damping": 0.003},
        stribeck_shape="gaussian",
    )  # fmt: skip
    for rig, opts in (
        (paper_rig(backlash=0.05, **IDEAL_SENSOR), {}),
        (paper_rig(friction=(lugre,), **IDEAL_SENSOR), {"method": "LSODA"}),
    ):
        ref = rig.simulate(u, integrator="reference", **opts)
        fast = rig.simulate(u)
        err = np.max(np.abs(fast["omega_l"] - ref["omega_l"]))
        assert err <= 0.15, err
        finer = rig.replace(substeps=320).simulate(u)
        assert np.max(np.abs(finer["omega_l"] - ref["omega_l"])) <= err / 4


def test_reference_options_are_checked():
    with pytest.raises(ValueError, match="max_step"):
        ReferenceIntegrator(paper_rig(), max_step=0.0)
    with pytest.raises(ValueError, match="integrator"):
        paper_rig().simulate(np.zeros(3), integrator="euler")  # type: ignore[arg-type]
