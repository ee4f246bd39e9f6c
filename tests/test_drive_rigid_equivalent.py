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
    AsymmetricLaw,
    CoulombLaw,
    LuGreLaw,
    RigidDrive,
    StribeckLaw,
    Tachogenerator,
    ViscousLaw,
    paper_rig,
)
from motorid.drive.two_mass import NOT_ON_A_RIG
from motorid.signals import two_sine_signal

RIGS = {
    "paper": paper_rig(),
    "linear": paper_rig(friction=(), amplifier=Amplifier()),
    "every law": paper_rig(
        friction=(
            CoulombLaw(alpha=4e-3, side="both"),
            StribeckLaw(alpha0=1e-3, alpha1=2e-3, alpha2=0.1, side="motor"),
            AsymmetricLaw(
                alpha0=1e-3, alpha1=1e-3, alpha2=0.3, alpha3=2e-3, alpha4=5e-4, alpha5=0.2, side="load"
            ),
            ViscousLaw(B=1e-5, side="load"),
        ),
        T_d=1e-3,
    ),
    "lugre": paper_rig(
        friction=(
            LuGreLaw(sigma0=2.0, sigma1=1e-3, sigma2=1e-5, Fc=3e-3, Fs=5e-3, omega_s=2.0, side="motor"),
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


def test_summed_levels_asymmetry_and_stribeck_of_several_laws():
    drive = RIGS["every law"].rigid_equivalent()
    p = drive.params
    # forward C+ = 2 x 4 + 1 + 1 = 10 mN m, backward C- = 8 + 1 + 2 = 11 mN m
    assert p["coulomb"] == pytest.approx(10.5e-3, rel=1e-12)
    assert p["coulomb_asymmetry"] == pytest.approx(-0.5e-3, rel=1e-12)
    # excesses S+ = 2 + 1, S- = 2 + 0.5 mN m; the rates weighted by them: (2 x 0.1 x 2 + 0.3 + 0.1) / 5.5
    assert p["stribeck"] == pytest.approx(2.75e-3, rel=1e-12)
    assert 1.0 / p["stribeck_velocity"] == pytest.approx((0.4 + 0.3 + 0.5e-3 * 0.2 / 1e-3) / 5.5, rel=1e-12)
    assert p["offset"] == 1e-3 and p["viscous_asymmetry"] == 0.0
    lugre = RIGS["lugre"].rigid_equivalent()
    assert lugre.stribeck_shape == "gaussian" and lugre.params["stribeck_velocity"] == pytest.approx(2.0)
    assert lugre.params["coulomb"] == 3e-3 and lugre.params["stribeck"] == pytest.approx(2e-3)


@pytest.mark.parametrize("name", ["paper", "every law"])
def test_the_rigid_equivalent_follows_the_stiff_rig(name):
    """A rig with a stiff shaft, a short electrical time constant and ideal sensors moves as its
    rigid equivalent: the two free runs on the paper's signal agree to 0.5 % of the peak speed
    (measured: 0.07 % for "paper", 0.20 % for "every law": what is left is the 0.05 ms current
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
    rig = RIGS["every law"]
    here = rig.rigid_equivalent()
    p = {**here.params, "inertia": 1.25 * here.params["inertia"], "input_gain": 0.8 * here.params["input_gain"],
         "viscous": 1.1 * here.params["viscous"], "coulomb": 1.5 * here.params["coulomb"],
         "coulomb_asymmetry": 1e-3, "stribeck": 0.5 * here.params["stribeck"], "stribeck_velocity": 4.0,
         "dead_zone": 0.3, "saturation": 10.0, "offset": -2e-3}  # fmt: skip
    better = rig.with_rigid_equivalent(here.with_params(**p))
    # the inertia and gain proportionally: J_m/J_L and the motor constants kept
    assert better.J_m == pytest.approx(1.25 * rig.J_m) and better.J_l == pytest.approx(1.25 * rig.J_l)
    assert better.amplifier.gain == pytest.approx(0.8) and (better.K_m, better.R_a) == (rig.K_m, rig.R_a)
    assert better.amplifier.dead_zone == pytest.approx(0.3 * 0.8) and better.amplifier.v_max == pytest.approx(
        8.0
    )
    assert better.T_d == -2e-3 and better.k_s == rig.k_s
    # the mechanical viscous part in the rig's proportions
    ratio = better.B_m / rig.B_m
    assert better.B_l / rig.B_l == pytest.approx(ratio) and better.friction[3].B / 1e-5 == pytest.approx(
        ratio
    )
    # and its rigid equivalent is the drive put back (the rounding of the ratios)
    again = better.rigid_equivalent()
    assert again.effects == here.effects
    for key, value in p.items():
        assert again.params[key] == pytest.approx(value, rel=1e-12, abs=1e-15), key
    # the symmetric laws became asymmetric where the fitted levels differ forwards and backwards
    assert isinstance(better.friction[0], AsymmetricLaw) and better.friction[0].side == "both"


def test_an_effect_new_to_the_rig_is_its_own_law_on_the_motor_side():
    rig = paper_rig()
    here = rig.rigid_equivalent()
    drive = here.with_effects(
        (*here.effects, "stribeck_friction"), {**here.params, "stribeck": 3e-3, "stribeck_velocity": 5.0}
    )
    better = rig.with_rigid_equivalent(drive)
    assert better.friction == (*rig.friction, StribeckLaw(alpha1=3e-3, alpha2=0.2, side="motor"))
    assert better.rigid_equivalent().params == {**drive.params}
    linear = RIGS["linear"]
    coulomb = linear.rigid_equivalent()
    coulomb = coulomb.with_effects(
        (*coulomb.effects, "coulomb_friction"), {**coulomb.params, "coulomb": 2e-3}
    )
    assert linear.with_rigid_equivalent(coulomb).friction == (CoulombLaw(alpha=2e-3, side="motor"),)


@pytest.mark.parametrize("effect", sorted(NOT_ON_A_RIG))
def test_an_effect_the_rig_cannot_carry_is_refused_by_name(effect):
    from motorid.drive.effects import get as get_effect

    here = paper_rig().rigid_equivalent()
    values = {"quadratic_drag": 1e-6, "backlash_time": 0.01, "input_delay": 0.01, "lag_time_constant": 0.01,
              "breakaway_excess": 1e-3,
              **{f"position_friction_{k}": 1e-4 for k in ("sin", "cos", "sin2", "cos2", "sin3", "cos3")},
              "position_friction_periods": 1.0}  # fmt: skip
    drive = here.with_effects(
        (*here.effects, effect),
        {**here.params, **{p.name: values[p.name] for p in get_effect(effect).parameters}},
    )
    with pytest.raises(ValueError, match=f"^{effect}: a two-mass rig cannot carry it"):
        paper_rig().with_rigid_equivalent(drive)


def test_what_has_no_place_on_the_other_side_is_refused():
    rig = paper_rig()
    here = rig.rigid_equivalent()
    asym = here.with_effects((*here.effects, "asymmetric_friction"),
                             {**here.params, "coulomb_asymmetry": 0.0, "viscous_asymmetry": 1e-5})  # fmt: skip
    with pytest.raises(ValueError, match=r"^asymmetric_friction: viscous_asymmetry = 1e-05"):
        rig.with_rigid_equivalent(asym)
    with pytest.raises(ValueError, match=r"^viscous_friction: viscous = .* below the back-EMF"):
        rig.with_rigid_equivalent(here.with_params(viscous=0.5 * rig.K_m**2 / rig.R_a))
    with pytest.raises(ValueError, match=r"^coulomb_friction: a level of -0.001 N m < 0 is not physical"):
        rig.with_rigid_equivalent(here.with_params(coulomb=-1e-3))
    with pytest.raises(ValueError, match=r"^backlash: the rig's shaft has a gap"):
        rig.replace(backlash=1e-3).rigid_equivalent()
    mixed = (StribeckLaw(alpha1=1e-3, alpha2=0.1, side="motor"),
             StribeckLaw(alpha1=1e-3, alpha2=0.1, stribeck_shape="gaussian", side="load"))  # fmt: skip
    with pytest.raises(
        ValueError, match=r"^stribeck_friction: the rig's Stribeck laws have both decay shapes"
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
    assert [f.alpha for f in better.friction] == [0.0, 0.0]  # type: ignore[attr-defined]
