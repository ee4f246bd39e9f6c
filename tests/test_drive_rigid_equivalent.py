"""The two-mass rig's rigid equivalent and back: the round trip keeps the rig, the rigid drive
follows the stiff rig's free run, changed parameters map back proportionally, and what one side
cannot carry is refused by name."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from motorid.drive import (
    ADConverter,
    Amplifier,
    Friction,
    RigidDrive,
    Tachogenerator,
    effects,
    paper_rig,
)
from motorid.drive.two_mass import RIG_PARTS
from motorid.signals import two_sine_signal

STRIBECK = ("coulomb_friction", "stribeck_friction")
RIGS = {
    "paper": paper_rig(),
    "linear": paper_rig(friction=(), amplifier=Amplifier()),
    "every effect": paper_rig(
        friction=(
            Friction(("coulomb_friction",), {"coulomb": 4e-3}, side="both"),
            Friction(STRIBECK, {"coulomb": 1e-3, "stribeck": 2e-3, "stribeck_velocity": 10.0}, side="motor"),
            Friction(
                (*STRIBECK, "asymmetric_friction", "quadratic_drag", "static_friction"),
                {
                    "coulomb": 1.5e-3,
                    "stribeck": 1e-3,
                    "stribeck_velocity": 5.0,
                    "coulomb_asymmetry": -5e-4,
                    "viscous_asymmetry": 2e-7,
                    "quadratic_drag": 1e-9,
                    "breakaway_excess": 3e-4,
                },
                side="load",
            ),
            Friction(("viscous_friction",), {"viscous": 1e-5}, side="load"),
        ),
        T_d=1e-3,
    ),
    "lugre": paper_rig(
        friction=(
            Friction(
                (*STRIBECK, "viscous_friction", "lugre_friction"),
                {
                    "coulomb": 3e-3,
                    "stribeck": 2e-3,
                    "stribeck_velocity": 2.0,
                    "viscous": 1e-5,
                    "bristle_stiffness": 2.0,
                    "bristle_damping": 1e-3,
                },
                side="motor",
                stribeck_shape="gaussian",
            ),
        ),
        substeps=200,
    ),
}


@pytest.mark.parametrize("name", RIGS)
def test_rig_to_rigid_to_rig_keeps_the_rig(name):
    rig = RIGS[name]
    assert rig.with_rigid_equivalent(rig.rigid_equivalent()) == rig
    assert rig.with_rigid_equivalent(rig.rigid_equivalent(dt=0.01)) == rig  # the rig keeps its own dt


def test_the_rigid_equivalent_of_the_paper_rig():
    rig = paper_rig()
    drive = rig.rigid_equivalent()
    K, R = rig.K_m, rig.R_a
    assert drive.effects == (
        "coulomb_friction",
        "viscous_friction",
        "input_dead_zone",
        "input_saturation",
        "offset",
    )
    assert drive.params == {
        "inertia": rig.J_m + rig.J_l, "input_gain": K / R, "coulomb": 6e-3,
        "viscous": rig.B_m + rig.B_l + K * K / R, "dead_zone": 0.6, "saturation": 12.0, "offset": 0.0,
    }  # fmt: skip
    assert drive.dt == rig.dt


def test_the_masses_parameters_are_summed():
    drive = RIGS["every effect"].rigid_equivalent()
    p = drive.params
    assert drive.effects == (
        "coulomb_friction", "stribeck_friction", "asymmetric_friction", "viscous_friction", "quadratic_drag",
        "input_dead_zone", "input_saturation", "offset", "static_friction",
    )  # fmt: skip
    # a friction on both masses counts twice: 2 x 4 + 1 + 1.5 mN m
    assert p["coulomb"] == pytest.approx(10.5e-3, rel=1e-12)
    assert (p["coulomb_asymmetry"], p["viscous_asymmetry"], p["quadratic_drag"]) == (-5e-4, 2e-7, 1e-9)
    assert p["breakaway_excess"] == 3e-4  # on a stiff shaft both masses break away together
    # the excesses 2 + 1 mN m; their rates 1/v_s weighted by them
    assert p["stribeck"] == pytest.approx(3e-3, rel=1e-12)
    assert 1.0 / p["stribeck_velocity"] == pytest.approx((2e-3 * 0.1 + 1e-3 * 0.2) / 3e-3, rel=1e-12)
    assert p["offset"] == 1e-3
    rig = RIGS["lugre"]
    lugre = rig.rigid_equivalent()
    assert "lugre_friction" not in lugre.effects and lugre.stribeck_shape == "gaussian"
    assert lugre.params["stribeck_velocity"] == 2.0 and lugre.params["stribeck"] == 2e-3
    assert lugre.params["coulomb"] == 3e-3
    assert lugre.params["viscous"] == rig.B_m + rig.B_l + 1e-5 + rig.K_m**2 / rig.R_a


@pytest.mark.parametrize("name", ["paper", "every effect"])
def test_the_rigid_equivalent_follows_the_stiff_rig(name):
    """A rig with a stiff shaft, a short electrical time constant and ideal sensors moves as its
    rigid equivalent: the two free runs on the paper's signal agree to 0.5 % of the peak speed
    (measured: 0.07 % for "paper", 0.20 % for "every effect": what is left is the 0.05 ms current
    lag and the shaft's twist; the paper's own soft shaft gives 0.85 %)."""
    rig = dataclasses.replace(
        RIGS[name], k_s=50.0, B_s=0.05, L_a=1e-4, dt=0.01, substeps=100,
        tacho=Tachogenerator(noise_std=0.0), adc=ADConverter(bits=0),
    )  # fmt: skip
    _, u = two_sine_signal(duration=30.0, dt=rig.dt, seed=3)
    y_rig = rig.simulate(u)["omega_l"].to_numpy()
    y_rigid = rig.rigid_equivalent().free_run(u, substeps=100)
    assert np.max(np.abs(y_rig - y_rigid)) < 5e-3 * np.max(np.abs(y_rig))


def test_changed_parameters_map_back_proportionally_and_forward_again():
    rig = RIGS["every effect"]
    here = rig.rigid_equivalent()
    p = {**here.params, "inertia": 1.25 * here.params["inertia"], "input_gain": 0.8 * here.params["input_gain"],
         "viscous": 1.1 * here.params["viscous"], "coulomb": 1.5 * here.params["coulomb"],
         "coulomb_asymmetry": 1e-3, "viscous_asymmetry": 4e-7, "quadratic_drag": 3e-9,
         "breakaway_excess": 6e-4, "stribeck": 0.5 * here.params["stribeck"], "stribeck_velocity": 4.0,
         "dead_zone": 0.3, "saturation": 10.0, "offset": -2e-3}  # fmt: skip
    better = rig.with_rigid_equivalent(here.with_params(**p))
    # the inertia and gain proportionally: J_m/J_L and the motor constants kept
    assert better.J_m == pytest.approx(1.25 * rig.J_m) and better.J_l == pytest.approx(1.25 * rig.J_l)
    assert better.amplifier.gain == pytest.approx(0.8) and (better.K_m, better.R_a) == (rig.K_m, rig.R_a)
    assert better.amplifier.dead_zone == pytest.approx(0.3 * 0.8)
    assert better.amplifier.v_max == pytest.approx(8.0)
    assert better.T_d == -2e-3 and better.k_s == rig.k_s
    # the mechanical viscous part in the rig's proportions
    ratio = better.B_m / rig.B_m
    assert better.B_l / rig.B_l == pytest.approx(ratio)
    assert better.friction[3].params["viscous"] / 1e-5 == pytest.approx(ratio)
    # every mass's level in proportion, and one Stribeck velocity for all
    for old, new in zip(rig.friction[:3], better.friction[:3], strict=True):
        assert new.params["coulomb"] == pytest.approx(1.5 * old.params["coulomb"])
        assert new.params.get("stribeck_velocity", 4.0) == 4.0
    assert better.friction[2].params["coulomb_asymmetry"] == pytest.approx(1e-3)
    # and its rigid equivalent is the drive put back (the rounding of the ratios)
    again = better.rigid_equivalent()
    assert again.effects == here.effects
    for key, value in p.items():
        assert again.params[key] == pytest.approx(value, rel=1e-12, abs=1e-15), key


def test_an_effect_new_to_the_rig_goes_on_the_motor():
    rig = paper_rig()
    here = rig.rigid_equivalent()
    new = {"stribeck": 3e-3, "stribeck_velocity": 5.0, "coulomb_asymmetry": 1e-3, "viscous_asymmetry": 2e-6,
           "breakaway_excess": 1e-3, "quadratic_drag": 1e-8}  # fmt: skip
    drive = here.with_effects(
        (*here.effects, "stribeck_friction", "asymmetric_friction", "static_friction", "quadratic_drag"),
        {**here.params, **new},
    )
    better = rig.with_rigid_equivalent(drive)
    motor = Friction(
        (*STRIBECK, "asymmetric_friction", "quadratic_drag", "static_friction"),
        {"coulomb": 4e-3, **new},
        "motor",
    )
    assert better.friction == (motor, rig.friction[1])
    assert better.rigid_equivalent().params == {**drive.params}
    linear = RIGS["linear"]
    coulomb = linear.rigid_equivalent()
    coulomb = coulomb.with_effects(
        (*coulomb.effects, "coulomb_friction"), {**coulomb.params, "coulomb": 2e-3}
    )
    assert linear.with_rigid_equivalent(coulomb).friction == (
        Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="motor"),
    )


NOT_ON_A_RIG = sorted(e for e in effects.names() if effects.get(e).not_on_a_mass and e not in RIG_PARTS)


def test_what_a_rig_cannot_carry_is_the_input_path_it_lacks_and_the_position_friction():
    assert NOT_ON_A_RIG == ["backlash", "input_delay", "input_lag", "position_friction"]


@pytest.mark.parametrize("effect", NOT_ON_A_RIG)
def test_an_effect_the_rig_cannot_carry_is_refused_by_name(effect):
    here = paper_rig().rigid_equivalent()
    values = {"backlash_time": 0.01, "input_delay": 0.01, "lag_time_constant": 0.01,
              **{f"position_friction_{k}": 1e-4 for k in ("sin", "cos", "sin2", "cos2", "sin3", "cos3")},
              "position_friction_periods": 1.0}  # fmt: skip
    drive = here.with_effects(
        (*here.effects, effect),
        {**here.params, **{p.name: values[p.name] for p in effects.get(effect).parameters}},
    )
    with pytest.raises(ValueError, match=f"^{effect}: a two-mass rig cannot carry it"):
        paper_rig().with_rigid_equivalent(drive)


def test_what_has_no_place_on_the_other_side_is_refused():
    rig = paper_rig()
    here = rig.rigid_equivalent()
    with pytest.raises(ValueError, match=r"^viscous_friction: viscous = .* below the back-EMF"):
        rig.with_rigid_equivalent(here.with_params(viscous=0.5 * rig.K_m**2 / rig.R_a))
    with pytest.raises(ValueError, match=r"^coulomb_friction: coulomb = -0.001 N m < 0 is not physical"):
        rig.with_rigid_equivalent(here.with_params(coulomb=-1e-3))
    with pytest.raises(ValueError, match=r"^backlash: the rig's shaft has a gap"):
        rig.replace(backlash=1e-3).rigid_equivalent()
    mixed = (Friction(("stribeck_friction",), {"stribeck": 1e-3, "stribeck_velocity": 10.0}, "motor"),
             Friction(("stribeck_friction",), {"stribeck": 1e-3, "stribeck_velocity": 10.0}, "load", "gaussian"))  # fmt: skip
    with pytest.raises(
        ValueError, match=r"^stribeck_friction: the rig's masses have Stribeck friction of both decay shapes"
    ):
        rig.replace(friction=mixed).rigid_equivalent()
    with pytest.raises(ValueError, match="drive must be a RigidDrive"):
        rig.with_rigid_equivalent(rig)  # type: ignore[arg-type]
    assert math.isinf(RIGS["linear"].with_rigid_equivalent(RIGS["linear"].rigid_equivalent()).amplifier.v_max)


def test_a_rigid_drive_without_the_rigs_effects_removes_them():
    rig = paper_rig()
    here = rig.rigid_equivalent()
    bare = RigidDrive(("viscous_friction", "offset"),
                      {k: here.params[k] for k in ("inertia", "input_gain", "viscous", "offset")}, here.dt)  # fmt: skip
    better = rig.with_rigid_equivalent(bare)
    assert better.amplifier == Amplifier(gain=1.0, dead_zone=0.0, v_max=math.inf)
    assert better.friction == ()
