"""The python-control export: identified models as transfer functions, drive models linearised
and whole, each held against motorid's own simulation of the same model."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control_design import (
    friction_slope,
    linearise,
    nonlinear_system,
    rest_state,
    state_space,
    transfer_function,
)
from motorid.drive import (
    ADConverter,
    Amplifier,
    Friction,
    RigidDrive,
    Tachogenerator,
    paper_rig,
)
from motorid.estimators import create

DT = 0.01


def steps(n_levels: int = 40, hold: int = 20, seed: int = 0) -> np.ndarray:
    """Held random levels in ±6 V, through zero speed many times."""
    return np.repeat(np.random.default_rng(seed).uniform(-6.0, 6.0, n_levels), hold)


def sines(n: int = 800) -> np.ndarray:
    t = np.arange(n) * DT
    return 4.0 * np.sin(2 * np.pi * 0.7 * t) + 1.5 * np.sin(2 * np.pi * 2.3 * t)


def linear_drive(**extra: float) -> RigidDrive:
    effects = ["viscous_friction"] + [
        {"lag_time_constant": "input_lag", "input_delay": "input_delay"}[k] for k in extra
    ]
    return RigidDrive(tuple(effects), {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044, **extra}, DT)


def friction_drive() -> RigidDrive:
    return RigidDrive(
        ("viscous_friction", "coulomb_friction", "stribeck_friction", "input_dead_zone", "input_lag",
         "input_delay", "backlash"),
        {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044, "coulomb": 0.3, "stribeck": 0.2,
         "stribeck_velocity": 2.0, "dead_zone": 0.6, "lag_time_constant": 0.02, "input_delay": 0.015,
         "backlash_time": 0.03},
        DT,
    )  # fmt: skip


def pc_response(sys, u: np.ndarray, **kw) -> np.ndarray:
    return control.forced_response(sys, np.arange(u.size) * DT, u, **kw).outputs


# --------------------------------------------------------------------------- identified models
@pytest.mark.parametrize("direct_term", [True, False])
def test_arx_transfer_function_simulates_as_the_estimator(direct_term):
    u = steps()
    y = linear_drive().simulate(u)["y"].to_numpy()
    est = create("arx-rls", na=2, nb=3, direct_term=direct_term)
    est.batch_filter(u, y)
    tf = transfer_function(est, DT)
    assert tf.dt == DT
    # the free run of the exported model equals the estimator's, up to rounding (1e-9 of the range)
    for sys in (tf, state_space(est, DT)):
        assert np.max(np.abs(pc_response(sys, u) - est.simulate(u))) < 1e-9 * np.ptp(y)
    # b_0 is the feed-through; without a direct term there is none
    assert float(control.ss(tf).D[0, 0]) == pytest.approx(
        est.params["b"][0] if direct_term else 0.0, abs=1e-12
    )


def test_hammerstein_transfer_function_is_the_block_after_the_static_map():
    u = steps(seed=3)
    y = friction_drive().simulate(u)["y"].to_numpy()
    est = create("hammerstein-rls", na=3, nb=3, degree=3)
    est.batch_filter(u, y)
    x = est.basis_functions.evaluate(u) @ est.params["gamma"]  # x = Σ γ_j g_j(u)
    y_pc = pc_response(transfer_function(est, DT), x)
    assert np.max(np.abs(y_pc - est.simulate(u))) < 1e-8 * np.ptp(y)


def test_an_estimator_without_a_and_b_is_refused():
    with pytest.raises(ValueError, match="params 'a' and 'b'"):
        transfer_function(object(), DT)
    with pytest.raises(ValueError, match="dt"):
        transfer_function(create("arx-rls", na=1, nb=1), 0.0)


# --------------------------------------------------------------------------- linearisation
def test_linear_rigid_drive_exported_equals_its_free_run():
    drive = linear_drive()
    u = steps()
    dsys = control.c2d(linearise(drive), DT, "zoh")
    y_pc = pc_response(dsys, u)[1:]  # python-control's y[k+1] is motorid's y[k] (module notes)
    fine = drive.free_run(u, substeps=400)[:-1]
    y = drive.simulate(u)["y"].to_numpy()[:-1]
    # both exact for a held input (the zero-order-hold discretisation and the free run's exponential
    # Euler at 400 steps a sample and at its default 20 steps per time constant): they differ by
    # rounding only, a few eps per step over the record's steps, far below 1e-9 of the range
    assert np.max(np.abs(y_pc - fine)) < 1e-9 * np.ptp(fine)
    assert np.max(np.abs(y_pc - y)) < 1e-9 * np.ptp(y)


def test_input_lag_and_delay_are_in_the_linear_model():
    u = sines()
    for extra, tolerance in (({"lag_time_constant": 0.02}, 0.01), ({"input_delay": 0.02}, 0.01)):
        drive = linear_drive(**extra)
        sys = linearise(drive, pade_order=3)
        # the speed and the lag's state, or the speed and the third-order Padé's three
        assert sys.nstates == (2 if "lag_time_constant" in extra else 4)
        y_pc = pc_response(control.c2d(sys, DT, "zoh"), u)[1:]
        y = drive.free_run(u, substeps=400)[:-1]
        # a smooth input: the model holds each sample's mean of the lagged/delayed input, and the
        # delay is a Padé approximant; both are within 1 % of the range here
        assert np.max(np.abs(y_pc - y)) < tolerance * np.ptp(y), extra
        # without them the error is several times larger: the lag and delay are really in the model
        y_without = pc_response(control.c2d(linearise(linear_drive()), DT, "zoh"), u)[1:]
        assert np.max(np.abs(y_without - y)) > 3 * np.max(np.abs(y_pc - y))


def test_linearisation_about_a_speed_predicts_a_small_step_of_the_friction_drive():
    drive = friction_drive().with_effects(
        ("viscous_friction", "coulomb_friction", "stribeck_friction", "quadratic_drag"),
        {"inertia": 0.005, "input_gain": 1.0, "viscous": 0.044, "coulomb": 0.3, "stribeck": 0.2,
         "stribeck_velocity": 2.0, "quadratic_drag": 1e-4},
    )  # fmt: skip
    u0, du, n = 2.0, 0.05, 300
    base = drive.simulate(np.full(n, u0))["y"].to_numpy()
    w0 = base[-1]
    u = np.concatenate([np.full(n, u0), np.full(n, u0 + du)])
    dy = drive.simulate(u)["y"].to_numpy()[n:] - w0
    lin = control.c2d(linearise(drive, speed=w0), DT, "zoh")
    dy_pc = pc_response(lin, np.full(n, du))[1:]
    # the deviation of a 2.5 % step: second-order terms are (du/u0)² small; 3 % of the step's
    # response covers them and the free run's Euler error
    assert np.max(np.abs(dy_pc - dy[:-1])) < 0.03 * abs(dy[-1])
    # the friction's slope there is not the viscous term alone: the Stribeck decay lowers it
    assert friction_slope(drive, w0) < 0.044 + 2e-4 * w0


def test_zero_speed_takes_the_one_sided_slope():
    drive = friction_drive()
    up, down = friction_slope(drive, 0.0, +1), friction_slope(drive, 0.0, -1)
    # Stribeck F_s/v_s decay slope on either side: β = B - F_s / v_s, the same on both sides
    assert up == pytest.approx(0.044 - 0.2 / 2.0) and down == pytest.approx(up)
    with pytest.raises(ValueError, match="direction"):
        linearise(drive, 0.0, direction=0)


def test_two_mass_rig_linearised_has_its_shaft_mode_and_predicts_the_load_speed():
    rig = paper_rig(friction=(), amplifier=Amplifier(), dt=DT, substeps=10,
                    tacho=Tachogenerator(noise_std=0.0), adc=ADConverter(bits=0))  # fmt: skip
    sys = linearise(rig)
    assert sys.nstates == 4
    poles = sys.poles()
    shaft = np.abs(poles[np.abs(poles.imag) > 0].imag).max() / (2 * np.pi)
    assert 20.0 < shaft < 40.0  # the rig's shaft mode, near 30 Hz (TwoMassRig's k_s note)
    u = sines()
    y_pc = pc_response(control.c2d(sys, DT, "zoh"), u)[1:]
    y = rig.simulate(u)["omega_l"].to_numpy()[:-1]
    # the rig's integrator is exact for the linear part at its internal step: rounding only
    assert np.max(np.abs(y_pc - y)) < 1e-6 * np.ptp(y)


def test_rig_static_friction_slope_enters_the_linear_model():
    rig = paper_rig(friction=(Friction(("coulomb_friction", "stribeck_friction"), {"coulomb": 4e-3, "stribeck": 3e-3, "stribeck_velocity": 10.0}, side="motor"),
                              Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="load")))  # fmt: skip
    a_moving = linearise(rig, speed=100.0).A[1, 1]
    a_slow = linearise(rig, speed=1.0).A[1, 1]
    # d/dω of α1 exp(-α2 ω) is -α1 α2 exp(-α2 ω): larger (less damping) near rest
    expected = 3e-3 * 0.1 * (np.exp(-0.1) - np.exp(-10.0)) / rig.J_m
    assert a_slow - a_moving == pytest.approx(expected, rel=1e-9)


# --------------------------------------------------------------------------- the whole drive
def test_nonlinear_rigid_drive_in_python_control_equals_motorid_bit_for_bit():
    drive = friction_drive()
    u = steps(seed=5)
    sys = nonlinear_system(drive)
    t = np.arange(u.size) * DT
    resp = control.input_output_response(sys, t, u, initial_state=rest_state(drive))
    y = drive.simulate(u)["y"].to_numpy()
    assert np.array_equal(resp.outputs[1:], y[:-1])  # the same compiled step, one sample later
    assert np.count_nonzero(y == 0.0) > 10  # the record sticks at rest: friction and dead zone act


def test_nonlinear_two_mass_rig_equals_the_rigs_load_speed():
    rig = paper_rig(dt=DT, substeps=10)
    u = steps(seed=6)
    resp = control.input_output_response(nonlinear_system(rig), np.arange(u.size) * DT, u,
                                         initial_state=rest_state(rig))  # fmt: skip
    assert np.array_equal(resp.outputs[1:], rig.simulate(u)["omega_l"].to_numpy()[:-1])


def test_nonlinear_drive_closes_a_loop_in_python_control():
    """A user's discrete PI around the exported drive: the loop reaches the set speed."""
    drive = friction_drive()
    plant = nonlinear_system(drive, name="drive")
    kp, ki = 0.1, 2.0
    pi = control.ss([[1.0]], [[ki * DT]], [[1.0]], [[kp]], dt=DT, inputs="e", outputs="u", name="pi")
    error = control.summing_junction(inputs=["r", "-y"], output="e", dt=DT)
    loop = control.interconnect([plant, pi, error], inputs="r", outputs="y")
    t = np.arange(400) * DT
    x0 = np.concatenate([rest_state(drive), [0.0]])
    resp = control.input_output_response(loop, t, np.full(t.size, 20.0), initial_state=x0)
    # integral action: the speed settles on the set point despite friction and the dead zone (0.5 %:
    # the loop's remaining transient after 4 s)
    assert resp.outputs[-1] == pytest.approx(20.0, rel=0.005)


def test_systems_name_their_input_and_output_with_units():
    """A model's units travel into python-control's signal names (a card's, or a two-mass rig's own)."""
    from motorid.control_design import signal_names
    from motorid.drive import paper_rig
    from motorid.estimators import ARXRLS

    drive = linear_drive()
    sys = linearise(drive, units=("%", "rad/s"))
    assert (sys.input_labels, sys.output_labels) == (["u [%]"], ["y [rad/s]"])
    rig = linearise(paper_rig())
    assert (rig.input_labels, rig.output_labels) == (["u [V]"], ["y [rad/s]"])
    assert linearise(drive).input_labels == ["u"]  # nothing said, nothing invented
    arx = ARXRLS(na=2, nb=2)
    arx.batch_filter(np.sin(np.arange(200) * 0.1), np.cos(np.arange(200) * 0.1))
    H = state_space(arx, DT, units=("V", "m/s"))
    assert (H.input_labels, H.output_labels) == (["u [V]"], ["y [m/s]"])
    with pytest.raises(ValueError, match="units must be"):
        signal_names(("V",))


# --------------------------------------------------------------------------- the model's units
def duty_card(supply_voltage: float | None = None):
    from motorid.drive.files import ModelCard

    return ModelCard(input_unit="%", supply_voltage=supply_voltage, output_unit="rad/s", dt=DT, timing="hold")


def test_a_system_asked_in_other_units_is_converted_where_the_conversion_is_known():
    """A drive fitted on % duty with a 12 V supply, asked for in V and rpm: its input is 100 / 12 % per
    volt and its output 60 / (2 pi) rpm per rad/s. Held against motorid's own free run of the model on
    the duty the volts make, in rpm (rel 1e-12: the factors' products round once or twice apart)."""
    drive = friction_drive()
    card = duty_card(12.0)
    u_volts = steps(seed=7) / 100.0 * 12.0 * 1.3  # within ±7.8 V
    sys = nonlinear_system(drive, units=("V", "rpm"), card=card)
    assert (sys.input_labels, sys.output_labels) == (["u [V]"], ["y [rpm]"])
    resp = control.input_output_response(
        sys, np.arange(u_volts.size) * DT, u_volts, initial_state=rest_state(drive)
    )
    y_rpm = drive.simulate(u_volts * (100.0 / 12.0))["y"].to_numpy() * 60.0 / (2.0 * np.pi)
    assert resp.outputs[1:] == pytest.approx(y_rpm[:-1], rel=1e-12, abs=1e-9)
    # the linearised drive: its static gain in rpm per volt
    own, asked = (
        linearise(linear_drive(), card=card),
        linearise(linear_drive(), units=("V", "rpm"), card=card),
    )
    assert (own.input_labels, own.output_labels) == (["u [%]"], ["y [rad/s]"])
    assert asked.input_labels == ["u [V]"] and asked.output_labels == ["y [rpm]"]
    assert control.dcgain(asked) == pytest.approx(
        control.dcgain(own) * 100.0 / 12.0 * 60.0 / (2.0 * np.pi), rel=1e-12
    )
    # a supply voltage given beside a card that has none
    given = linearise(linear_drive(), units=("V", "rad/s"), card=duty_card(), supply_voltage=12.0)
    assert control.dcgain(given) == pytest.approx(control.dcgain(own) * 100.0 / 12.0, rel=1e-12)


def test_an_identified_model_in_rpm_simulates_as_the_estimator_times_the_factor():
    from motorid.drive.files import ModelCard
    from motorid.estimators import ARXRLS

    u = sines()
    y = linear_drive().simulate(u)["y"].to_numpy()
    arx = ARXRLS(na=2, nb=2)
    arx.batch_filter(u, y)
    card = ModelCard(input_unit="V", output_unit="rad/s")
    H = transfer_function(arx, DT, ("V", "rpm"), card=card)
    assert (H.input_labels, H.output_labels) == (["u [V]"], ["y [rpm]"])
    expected = arx.simulate(u) * 60.0 / (2.0 * np.pi)
    assert pc_response(H, u) == pytest.approx(expected, rel=1e-9, abs=1e-9)  # lfilter against the free run
    assert state_space(arx, DT, card=card).input_labels == ["u [V]"]  # the card names them


@pytest.mark.parametrize(
    ("units", "card", "words"),
    [
        (("V", "rad/s"), duty_card(), "the model was fitted on % duty; the system asked for is in V: give "
                                      "supply_voltage= or ask for % duty"),
        (("counts", "rad/s"), duty_card(12.0), "no conversion to 'counts' is known"),
        (("%", "m/s"), duty_card(), "the model was fitted on an output in rad/s; no conversion to 'm/s' is known"),
        (("%", "rad"), duty_card(), "no conversion to 'rad' is known (known: deg/s, rad/s, rev/min, rev/s, rpm, rps)"),
    ],
)  # fmt: skip
def test_a_unit_mismatch_without_a_known_conversion_is_refused_in_one_line(units, card, words):
    from motorid.errors import DataError

    with pytest.raises(DataError) as caught:
        linearise(linear_drive(), units=units, card=card)
    assert words in str(caught.value) and "\n" not in str(caught.value)
    with pytest.raises(DataError):
        nonlinear_system(linear_drive(), units=units, card=card)
