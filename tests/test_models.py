"""Model files: rigs and identified estimators saved and reloaded exactly, bad files refused
with one error naming the file and the key, and the commands that write and read them."""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from cli_fixtures import run
from conftest import examples
from hypothesis import given
from hypothesis import strategies as st
from io_fixtures import free_port

import motorid
from motorid.drive import (
    ADConverter,
    Amplifier,
    Encoder,
    Friction,
    RigidDrive,
    Tachogenerator,
    TwoMassRig,
    paper_rig,
)
from motorid.drive.files import FORMAT, VERSION, model_to_dict
from motorid.errors import DataError
from motorid.estimators import (
    Estimator,
    FrictionEKF,
    FrictionUKF,
    HammersteinRLS,
    create,
    load_model,
    save_model,
)
from motorid.signals import two_sine_signal

ROOT = Path(__file__).resolve().parent.parent
STRIBECK = ("coulomb_friction", "stribeck_friction")


def every_part_rig() -> TwoMassRig:
    """A rig using every effect a mass holds, a finite and every sensor part, backlash and a load torque."""
    friction = (
        Friction(("coulomb_friction",), {"coulomb": 3e-3}, side="motor"),
        Friction(STRIBECK, {"coulomb": 1e-3, "stribeck": 2e-3, "stribeck_velocity": 10.0}, side="motor"),
        Friction(
            (*STRIBECK, "asymmetric_friction", "quadratic_drag", "static_friction"),
            {"coulomb": 1.5e-3, "stribeck": 5e-4, "stribeck_velocity": 5.0, "coulomb_asymmetry": -5e-4,
             "viscous_asymmetry": 2e-7, "quadratic_drag": 1e-9, "breakaway_excess": 3e-4},
            side="load",
        ),
        Friction(("viscous_friction",), {"viscous": 1e-6}, side="both"),
        Friction(
            (*STRIBECK, "viscous_friction", "lugre_friction"),
            {"coulomb": 1e-3, "stribeck": 5e-4, "stribeck_velocity": 0.5, "viscous": 1e-6,
             "bristle_stiffness": 20.0, "bristle_damping": 0.01},
            side="load", stribeck_shape="gaussian",
        ),
    )  # fmt: skip
    return paper_rig(
        friction=friction, backlash=2e-3, T_d=1e-4, substeps=80,
        amplifier=Amplifier(gain=1.5, dead_zone=0.4, v_max=10.0),
        tacho=Tachogenerator(gain=0.03, noise_std=0.02), adc=ADConverter(bits=14, v_min=-5.0, v_max=5.0),
        encoder=Encoder(counts_per_rev=1000, side="load"),
    )  # fmt: skip


@pytest.fixture(scope="module")
def record():
    _, u = two_sine_signal(duration=20.0, dt=0.04, seed=3)
    return u, paper_rig().simulate(u, seed=3)["y"].to_numpy()


# --------------------------------------------------------------------------- rigs
def test_rig_round_trip_keeps_every_part_and_simulates_the_same_bits(tmp_path):
    rig = every_part_rig()
    path = tmp_path / "rig.json"
    rig.save(path)
    back = motorid.load_model(path)
    assert back == rig
    u = np.concatenate([np.linspace(0, 6, 30), np.linspace(6, -6, 60)])
    np.testing.assert_array_equal(back.simulate(u, seed=1).to_numpy(), rig.simulate(u, seed=1).to_numpy())
    data = json.loads(path.read_text())
    assert (data["format"], data["version"], data["kind"]) == (FORMAT, VERSION, "two-mass-rig")
    assert [f["effects"] for f in data["model"]["friction"]] == [
        ["coulomb_friction"],
        [*STRIBECK],
        [*STRIBECK, "asymmetric_friction", "quadratic_drag", "static_friction"],
        ["viscous_friction"],
        [*STRIBECK, "viscous_friction", "lugre_friction"],
    ]


positive = st.floats(1e-6, 1e3, allow_nan=False)
level = st.floats(0.0, 0.05, allow_nan=False)
side = st.sampled_from(["motor", "load", "both"])
shape = st.sampled_from(["exponential", "gaussian"])
laws = st.one_of(
    st.builds(lambda c, s: Friction(("coulomb_friction",), {"coulomb": c}, s), level, side),
    st.builds(lambda c, e, v, s, k: Friction(STRIBECK, {"coulomb": c, "stribeck": e, "stribeck_velocity": v}, s, k),
              level, level, st.floats(0.01, 100.0), side, shape),
    st.builds(lambda b, s: Friction(("viscous_friction",), {"viscous": b}, s), st.floats(0.0, 1e-3), side),
    st.builds(lambda c, share, dv, s: Friction(
        ("coulomb_friction", "asymmetric_friction"),
        {"coulomb": c, "coulomb_asymmetry": share * c, "viscous_asymmetry": dv}, s,
    ), level, st.floats(-1.0, 1.0), st.floats(-1e-4, 1e-4), side),
)  # fmt: skip


@examples(25)
@given(
    J_m=positive, k_s=positive, B_s=st.floats(0.0, 1.0), dt=st.floats(1e-4, 0.1), substeps=st.integers(1, 50),
    friction=st.lists(laws, max_size=4), dead_zone=st.floats(0.0, 2.0),
    v_max=st.one_of(st.just(math.inf), st.floats(0.5, 50.0)), bits=st.integers(0, 16),
)  # fmt: skip
def test_any_rig_survives_the_round_trip_exactly(tmp_path_factory, J_m, k_s, B_s, dt, substeps, friction,
                                                 dead_zone, v_max, bits):  # fmt: skip
    """Every float written with its shortest repr reads back to the same bits: the rigs are equal."""
    rig = paper_rig(
        J_m=J_m, k_s=k_s, B_s=B_s, dt=dt, substeps=substeps, friction=tuple(friction),
        amplifier=Amplifier(dead_zone=dead_zone, v_max=v_max), adc=ADConverter(bits=bits),
    )  # fmt: skip
    path = tmp_path_factory.mktemp("any") / "rig.json"
    rig.save(path)
    assert load_model(path) == rig


def test_infinite_saturation_is_written_as_null_and_read_back(tmp_path):
    rig = TwoMassRig()  # ideal amplifier: v_max = inf, which JSON cannot hold
    save_model(rig, tmp_path / "linear.json")
    assert json.loads((tmp_path / "linear.json").read_text())["model"]["amplifier"]["v_max"] is None
    assert load_model(tmp_path / "linear.json").amplifier.v_max == math.inf


# --------------------------------------------------------------------------- estimators
@pytest.mark.parametrize(
    "name, kwargs",
    [
        ("arx-rls", {"na": 3, "nb": 2, "lam": 0.995}),
        ("arx-rls", {"na": 2, "nb": 2, "direct_term": False, "max_trace": math.inf}),
        ("hammerstein-rls", {"na": 4, "nb": 4, "degree": 3, "lam": 0.99}),
        ("hammerstein-rls", {"na": 2, "nb": 2, "basis": "u,sign,dead_zone:0.35", "gamma_method": "svd"}),
    ],
)
def test_identified_rls_reloads_with_the_same_params_and_free_run_to_the_last_bit(
    tmp_path, record, name, kwargs
):
    u, y = record
    est = create(name, **kwargs)
    est.batch_filter(u[:300], y[:300])
    est.save(tmp_path / "est.json")
    back = load_model(tmp_path / "est.json")
    assert type(back) is type(est)
    for key, value in est.params.items():
        np.testing.assert_array_equal(back.params[key], value)
    np.testing.assert_array_equal(back.simulate(u), est.simulate(u))
    # and it continues filtering exactly where the saved one would
    a, b = est.batch_filter(u[300:], y[300:]), back.batch_filter(u[300:], y[300:])
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(est.P, back.P)


@pytest.mark.parametrize("cls", [FrictionEKF, FrictionUKF])
def test_friction_filter_reloads_with_its_rig_state_and_covariance(tmp_path, record, cls):
    u, y = record
    rig = paper_rig(B_m=3e-5)
    est = cls.from_rig(rig, stribeck=True, coulomb0=3e-3, nis_window=20, on_divergence="ignore")
    est.batch_filter(u[:150], y[:150])
    est.save(tmp_path / "filter.json")
    back = load_model(tmp_path / "filter.json")
    assert type(back) is cls and back.rig == rig and back.stribeck and back.nis_window == 20
    np.testing.assert_array_equal(back.x, est.x)
    np.testing.assert_array_equal(back.P, est.P)
    assert back.sample_index == est.sample_index == 150
    assert back.params == est.params
    np.testing.assert_array_equal(back.simulate(u), est.simulate(u))
    a, b = est.batch_filter(u[150:200], y[150:200]), back.batch_filter(u[150:200], y[150:200])
    np.testing.assert_array_equal(a.x, b.x)
    assert back.nis_mean == est.nis_mean  # the NIS window came along too


def test_friction_filter_starts_from_a_rig_model_file_with_its_friction(tmp_path):
    """A two-mass rig's friction, summed over both masses, is the filter's initial x:
    Coulomb 4 + 2 mN m, Stribeck excess 6 mN m at 0.1 s/rad, viscous B_m + B_L."""
    stribeck = Friction(("stribeck_friction",), {"stribeck": 6e-3, "stribeck_velocity": 10.0}, side="motor")
    friction = (
        Friction(("coulomb_friction",), {"coulomb": 4e-3}, side="motor"),
        Friction(("coulomb_friction",), {"coulomb": 2e-3}, side="load"),
        stribeck,
    )
    rig = paper_rig(J_l=9e-5, B_m=2e-5, B_l=1e-5, friction=friction)
    rig.save(tmp_path / "rig.json")
    ekf = FrictionEKF.from_rig(load_model(tmp_path / "rig.json"))
    assert ekf.rig == rig and ekf.dt == rig.dt
    assert ekf.stribeck and not ekf.asymmetric and ekf.stribeck_decay == 0.1
    x = dict(zip(ekf.state_names, ekf.x, strict=True))
    assert x["coulomb"] == 4e-3 + 2e-3 and x["stribeck"] == 6e-3 and x["viscous"] == 2e-5 + 1e-5
    # a given prior overrides the model's
    assert FrictionEKF.from_rig(rig, coulomb0=1e-3).x[ekf.state_names.index("coulomb")] == 1e-3
    # the rig's Stribeck shape is the filter's
    gaussian = (*friction[:2], stribeck.replace(stribeck_shape="gaussian"))
    assert FrictionEKF.from_rig(rig.replace(friction=gaussian)).stribeck_shape == "gaussian"


def test_friction_filter_starts_from_a_rigid_drive_model_file_with_its_friction(tmp_path):
    """The doctor's model: asymmetric levels F_c ± ΔF_c, viscous, Gaussian Stribeck with rate 1/v_s."""
    params = {
        "inertia": 8e-5, "input_gain": 0.02, "coulomb": 5e-3, "coulomb_asymmetry": 1e-3,
        "viscous_asymmetry": 0.0, "viscous": 4e-5, "stribeck": 3e-3, "stribeck_velocity": 8.0,
        "offset": 2e-4, "dead_zone": 0.5,
    }  # fmt: skip
    effects = ("coulomb_friction", "asymmetric_friction", "viscous_friction", "stribeck_friction",
               "offset", "input_dead_zone")  # fmt: skip
    RigidDrive(effects, params, 0.01, stribeck_shape="gaussian").save(tmp_path / "drive.json")
    drive = load_model(tmp_path / "drive.json")
    ekf = FrictionEKF.from_rig(drive, R=0.04)
    assert ekf.state_names == ("omega", "coulomb", "viscous", "coulomb_neg", "stribeck")
    np.testing.assert_array_equal(ekf.x, [0.0, 5e-3 + 1e-3, 4e-5, 5e-3 - 1e-3, 3e-3])
    assert ekf.stribeck_shape == "gaussian" and ekf.stribeck_decay == 1 / 8.0
    assert ekf.voltage(0.4) == 0.0 and ekf.voltage(1.5) == 1.0  # its dead zone, at unit gain
    # saved with its rigid drive, reloaded the same
    ekf.batch_filter(np.full(20, 3.0), np.linspace(0.0, 5.0, 20))
    ekf.save(tmp_path / "filter.json")
    back = load_model(tmp_path / "filter.json")
    assert back.rig == drive
    np.testing.assert_array_equal(back.x, ekf.x)
    np.testing.assert_array_equal(back.P, ekf.P)


def test_what_cannot_be_saved_is_refused_and_leaves_the_old_file(tmp_path):
    path = tmp_path / "est.json"
    paper_rig().save(path)
    before = path.read_bytes()
    custom = HammersteinRLS(na=2, nb=2, basis=[np.tanh])
    with pytest.raises(ValueError, match="custom basis function"):
        custom.save(path)
    pending = create("arx-rls", na=2, nb=2)
    pending.predict(1.0)
    with pytest.raises(ValueError, match=r"update\(\) first"):
        pending.save(path)
    ekf = FrictionEKF()
    ekf.predict(1.0)
    with pytest.raises(ValueError, match=r"update\(\) first"):
        ekf.save(path)
    with pytest.raises(ValueError, match="cannot save a dict"):
        save_model({}, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["est.json"]  # no temporary file left behind


# --------------------------------------------------------------------------- bad files
def _rig_file() -> dict:
    return model_to_dict(every_part_rig())


def _drive_file() -> dict:
    params = {
        "inertia": 2e-3,
        "input_gain": 0.05,
        "coulomb": 0.02,
        "stribeck": 0.01,
        "stribeck_velocity": 2.0,
    }
    return model_to_dict(RigidDrive(("coulomb_friction", "stribeck_friction"), params, dt=0.01))


def _ekf_file() -> dict:
    return model_to_dict(FrictionEKF(nis_window=5))


def _arx_file() -> dict:
    return model_to_dict(create("arx-rls", na=2, nb=1))


def _set(data: dict, path: tuple, value) -> dict:
    data = copy.deepcopy(data)
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return data


def _drop(data: dict, path: tuple) -> dict:
    data = copy.deepcopy(data)
    node = data
    for key in path[:-1]:
        node = node[key]
    del node[path[-1]]
    return data


#: A law of a version-1 file that no effect holds: eq. (11) with a Stribeck excess differing each way.
PER_DIRECTION = {"kind": "asymmetric_friction", "alpha0": 1e-3, "alpha1": 1e-3, "alpha2": 1.0, "alpha3": 1e-3,
                 "alpha4": 2e-3, "alpha5": 1.0, "stribeck_shape": "exponential", "side": "load"}  # fmt: skip

BAD_FILES = [
    # (what, file content, the key or words the message must name)
    ("other format", lambda: _set(_rig_file(), ("format",), "other"), 'no "format": "motorid-model"'),
    ("newer version", lambda: _set(_rig_file(), ("version",), VERSION + 1), f"version {VERSION + 1} is newer"),
    ("unknown version", lambda: _set(_rig_file(), ("version",), 0), "unknown model file version 0"),
    ("text version", lambda: _set(_rig_file(), ("version",), "1"), "version must be an integer"),
    ("unknown kind", lambda: _set(_rig_file(), ("kind",), "three-mass-rig"), "kind: unknown model kind"),
    ("missing model", lambda: _drop(_rig_file(), ("model",)), "model: missing"),
    ("missing rig key", lambda: _drop(_rig_file(), ("model", "J_m")), "model.J_m: missing"),
    ("missing nested key", lambda: _drop(_rig_file(), ("model", "amplifier", "gain")), "model.amplifier.gain: missing"),
    ("missing friction parameter", lambda: _drop(_rig_file(), ("model", "friction", 1, "params", "stribeck_velocity")), r"model.friction\[1\].params.stribeck_velocity: missing"),
    ("unknown key", lambda: _set(_rig_file(), ("model", "J_mm"), 1.0), "model.J_mm: unknown key"),
    ("text for a number", lambda: _set(_rig_file(), ("model", "K_m"), "0.04"), 'model.K_m: must be a number, got "0.04"'),
    ("bool for a number", lambda: _set(_rig_file(), ("model", "R_a"), True), "model.R_a: must be a number"),
    ("float for an integer", lambda: _set(_rig_file(), ("model", "substeps"), 2.5), "model.substeps: must be an integer"),
    ("number for a side", lambda: _set(_rig_file(), ("model", "encoder", "side"), 1), "model.encoder.side: must be a string"),
    ("friction not a list", lambda: _set(_rig_file(), ("model", "friction"), {"kind": "coulomb_friction"}), "model.friction: must be a list"),
    ("NaN", lambda: _set(_rig_file(), ("model", "J_l"), math.nan), "model.J_l: must be finite, got nan"),
    ("infinity", lambda: _set(_rig_file(), ("model", "friction", 0, "params", "coulomb"), math.inf), r"model.friction\[0\].params.coulomb: must be finite"),
    ("negative inertia", lambda: _set(_rig_file(), ("model", "J_m"), -2.5e-5), "model: J_m must be > 0, got -2.5e-05"),
    ("negative friction", lambda: _set(_rig_file(), ("model", "friction", 0, "params", "coulomb"), -1.0), r"model.friction\[0\].params.coulomb: coulomb must be"),
    ("unknown effect on a mass", lambda: _set(_rig_file(), ("model", "friction", 2, "effects", 0), "stiction"), r"model.friction\[2\].effects\[0\]: unknown effect 'stiction'"),
    ("effect a mass cannot hold", lambda: _set(_rig_file(), ("model", "friction", 0, "effects", 0), "input_delay"), r"model.friction\[0\].effects: input_delay: a mass of the two-mass rig cannot hold it"),
    ("per-direction Stribeck law of a version-1 file", lambda: _set(_rig_file(), ("model", "friction", 2), PER_DIRECTION), r"model.friction\[2\]: an asymmetric_friction law whose Stribeck excess or rate differs forwards"),
    ("unknown law of a version-1 file", lambda: _set(_rig_file(), ("model", "friction", 2), {"kind": "stiction", "side": "load"}), r"model.friction\[2\].kind: unknown friction law 'stiction'"),
    ("unknown side", lambda: _set(_rig_file(), ("model", "friction", 0, "side"), "shaft"), r"model.friction\[0\]: side must be one of"),
    ("drive: negative inertia", lambda: _set(_drive_file(), ("model", "params", "inertia"), -1.0), "model.params.inertia: inertia must be > 0, got -1.0"),
    ("drive: unknown effect", lambda: _set(_drive_file(), ("model", "effects", 1), "stiction"), r"model.effects\[1\]: unknown effect 'stiction'"),
    ("drive: missing parameter", lambda: _drop(_drive_file(), ("model", "params", "stribeck_velocity")), "model.params.stribeck_velocity: missing"),
    ("drive: parameter of no effect", lambda: _set(_drive_file(), ("model", "params", "offset"), 0.0), "model.params.offset: unknown key"),
    ("drive: NaN", lambda: _set(_drive_file(), ("model", "params", "coulomb"), math.nan), "model.params.coulomb: must be finite"),
    ("drive: text dt", lambda: _set(_drive_file(), ("model", "dt"), "0.01"), "model.dt: must be a number"),
    ("drive: unknown shape", lambda: _set(_drive_file(), ("model", "stribeck_shape"), "cubic"), "model: stribeck_shape must be one of"),
    ("rig: unknown Stribeck shape", lambda: _set(_rig_file(), ("model", "friction", 2, "stribeck_shape"), "cubic"), "stribeck_shape must be one of"),
    ("unknown estimator", lambda: _set(_arx_file(), ("model", "estimator"), "lstm"), "model.estimator: unknown estimator 'lstm'"),
    ("estimator setting type", lambda: _set(_arx_file(), ("model", "settings", "na"), 2.0), "model.settings.na: must be an integer"),
    ("estimator setting range", lambda: _set(_arx_file(), ("model", "settings", "lam"), 1.5), "model.settings: lam must satisfy"),
    ("estimate of the wrong size", lambda: _set(_arx_file(), ("model", "state", "x"), [0.0, 1.0]), r"model.state.x: must have shape \(4,\)"),
    ("NaN in a covariance", lambda: _set(_arx_file(), ("model", "state", "P", 1, 2), math.nan), r"model.state.P\[1\]\[2\]: must be finite, got nan"),
    ("history not numbers", lambda: _set(_arx_file(), ("model", "state", "y_history"), ["a", "b"]), "model.state.y_history: must be an array"),
    ("filter rig", lambda: _set(_ekf_file(), ("model", "settings", "rig"), {"R_a": 2.0}), "model.settings.rig.L_a: missing"),
    ("filter setting", lambda: _set(_ekf_file(), ("model", "settings", "stribeck"), "yes"), "model.settings.stribeck: must be true or false"),
    ("filter side", lambda: _set(_ekf_file(), ("model", "settings", "friction_side"), "shaft"), "model.settings: friction_side must be"),
    ("covariance not positive definite", lambda: _set(_ekf_file(), ("model", "state", "P", 0, 0), -1.0), "model.state.P: P must be positive semi-definite"),
    ("NIS window of another length", lambda: _set(_ekf_file(), ("model", "state", "nis_ring"), [0.0]), r"model.state.nis_ring: must have shape \(5,\)"),
]  # fmt: skip


@pytest.mark.parametrize("what, make, message", BAD_FILES, ids=[b[0] for b in BAD_FILES])
def test_bad_file_gets_one_data_error_naming_the_file_and_key(tmp_path, what, make, message):
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(make()))  # json writes NaN and Infinity tokens as Python reads them
    with pytest.raises(DataError) as info:
        load_model(path)
    text = str(info.value)
    assert text.startswith(f"{path}: "), text
    assert re.search(message, text), text
    assert "\n" not in text


@pytest.mark.parametrize(
    "content, message",
    [(b"{", "invalid JSON at line 1"), (b"\xff\xfe", "not UTF-8"), (b"[1, 2]", "not a motorid model file")],
)
def test_unreadable_files_are_refused_naming_the_file(tmp_path, content, message):
    path = tmp_path / "m.json"
    path.write_bytes(content)
    with pytest.raises(DataError, match=message):
        load_model(path)
    with pytest.raises(DataError, match=r"nowhere\.json: cannot read"):
        load_model(tmp_path / "nowhere.json")


# --------------------------------------------------------------------------- command line
def test_simulate_saves_the_rig_its_options_describe_and_simulates_a_model_file(capsys, tmp_path):
    model = tmp_path / "rig.json"
    code, out, _ = run(capsys, "simulate", "--save-model", str(model), "--stribeck", "0.002", "10",
                       "--dead-zone", "0.3", "--coulomb-load", "0", "--json")  # fmt: skip
    assert code == 0 and out["model"] == str(model)
    motor = Friction(STRIBECK, {"coulomb": 4e-3, "stribeck": 0.002, "stribeck_velocity": 10.0}, side="motor")
    expected = paper_rig(friction=(motor,), amplifier=Amplifier(gain=1.0, dead_zone=0.3, v_max=12.0))
    assert load_model(model) == expected
    rec = tmp_path / "rec.csv"
    code, out, _ = run(
        capsys, "simulate", "--model", str(model), "--out", str(rec), "--duration", "4", "--json"
    )
    assert code == 0 and out["rig"] == expected.to_dict() and out["samples"] == 100
    # without options the flags describe the default rig, as before
    run(capsys, "simulate", "--save-model", str(tmp_path / "default.json"))
    assert load_model(tmp_path / "default.json") == paper_rig()
    # a Gaussian Stribeck decay, written and read back
    gauss = tmp_path / "gauss.json"
    code, _, _ = run(capsys, "simulate", "--save-model", str(gauss), "--stribeck", "0.002", "10",
                     "--stribeck-shape", "gaussian", "--json")  # fmt: skip
    stribeck = [f for f in load_model(gauss).friction if "stribeck_friction" in f.effects]
    assert code == 0 and stribeck == [motor.replace(stribeck_shape="gaussian")]
    code, _, err = run(
        capsys, "simulate", "--save-model", str(tmp_path / "no.json"), "--stribeck", "0.002", "0"
    )
    assert code == 2 and "V_S, the Stribeck velocity [rad/s], must be > 0, got 0" in err
    code, _, err = run(
        capsys, "simulate", "--save-model", str(tmp_path / "no.json"), "--stribeck-shape", "gaussian"
    )
    assert code == 2 and "--stribeck-shape needs --stribeck" in err and not (tmp_path / "no.json").exists()


def test_simulate_friction_sets_each_mass_in_the_effects_parameters(capsys, tmp_path):
    """--friction SIDE PARAM=VALUE ...: the effects are those whose parameters are given, on that mass,
    in place of the default rig's friction (LuGre too, with its decay's shape)."""
    path = tmp_path / "rig.json"
    code, _, err = run(capsys, "simulate", "--save-model", str(path), "--dead-zone", "0.3",
                       "--friction", "motor", "coulomb=0.004", "breakaway_excess=0.002",
                       "--friction", "load", "coulomb=0.003", "stribeck=0.001", "stribeck_velocity=2",
                       "stribeck_shape=gaussian", "bristle_stiffness=2", "bristle_damping=0.003")  # fmt: skip
    assert code == 0, err
    motor = Friction(
        ("coulomb_friction", "static_friction"), {"coulomb": 4e-3, "breakaway_excess": 2e-3}, "motor"
    )
    load = Friction(
        (*STRIBECK, "lugre_friction"),
        {"coulomb": 3e-3, "stribeck": 1e-3, "stribeck_velocity": 2.0, "bristle_stiffness": 2.0,
         "bristle_damping": 3e-3},
        "load", "gaussian",
    )  # fmt: skip
    rig = load_model(path)
    assert rig == paper_rig(friction=(motor, load), amplifier=Amplifier(gain=1.0, dead_zone=0.3, v_max=12.0))
    assert rig.breakaway("motor") == (6e-3, 6e-3) and rig.has_lugre


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--friction", "motor", "colomb=0.004"], "--friction motor: unknown parameter 'colomb'; a mass's effects have coulomb, "),
        (["--friction", "motor", "coulomb"], "--friction motor: 'coulomb' is not PARAM=VALUE"),
        (["--friction", "motor", "coulomb=abc"], "--friction motor: coulomb must be a number, got 'abc'"),
        (["--friction", "motor"], "--friction motor: give the parameters of its effects as PARAM=VALUE"),
        (["--friction", "motor", "coulomb=0.004", "stribeck=0.001"], "--friction motor: params: 'stribeck_velocity' is missing"),
        (["--friction", "shaft", "coulomb=0.004"], "--friction shaft: side must be one of motor, load, both"),
        (["--friction", "motor", "coulomb=-1"], "--friction motor: coulomb must be >= 0, got -1.0"),
        (["--friction", "motor", "input_delay=0.01"], "--friction motor: unknown parameter 'input_delay'"),
        (["--friction", "load", "coulomb=0.004", "--coulomb-motor", "0.001"], "--coulomb-motor cannot be combined with --friction"),
    ],
)  # fmt: skip
def test_simulate_friction_refuses_what_a_mass_cannot_be_by_name(capsys, tmp_path, argv, message):
    code, _, err = run(capsys, "simulate", "--save-model", str(tmp_path / "rig.json"), *argv)
    assert code == 2 and message in err, err
    assert not (tmp_path / "rig.json").exists()


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["--model", "{model}", "--dead-zone", "0.1", "--out", "{out}"],
            "--dead-zone cannot be combined with --model",
        ),
        (["--model", "{est}", "--out", "{out}"], "holds a ARXRLS, not a drive model"),
        (["--duration", "1"], "give --out"),
        (["--save-model", "{model}"], "--save-model .*the file exists"),
    ],
)
def test_simulate_model_options_refuse_what_does_not_fit(capsys, tmp_path, argv, message):
    paths = {"model": tmp_path / "rig.json", "est": tmp_path / "est.json", "out": tmp_path / "rec.csv"}
    paper_rig().save(paths["model"])
    create("arx-rls", na=1, nb=1).save(paths["est"])
    code, _, err = run(capsys, "simulate", *[a.format(**paths) for a in argv])
    assert code == 2 and re.search(message, err), err
    assert not paths["out"].exists()


def test_identify_saves_the_identified_estimator(capsys, tmp_path, record):
    u, y = record
    rec = tmp_path / "rec.csv"
    import pandas as pd

    from motorid.io.records import write_record

    frame = pd.DataFrame({"t": np.arange(len(u)) * 0.04, "u": u, "y": y})
    frame.attrs["dt"] = 0.04
    write_record(frame, rec)
    est_path = tmp_path / "est.json"
    code, out, _ = run(capsys, "identify", str(rec), "--estimator", "hammerstein-rls", "--basis", "u,sign",
                       "--save-model", str(est_path), "--json")  # fmt: skip
    assert code == 0 and out["model"] == str(est_path)
    est = load_model(est_path)
    reference = HammersteinRLS(na=4, nb=4, basis="u,sign")
    reference.batch_filter(u, y)
    np.testing.assert_array_equal(est.x, reference.x)
    assert np.allclose(out["params"]["gamma"], est.params["gamma"], rtol=0, atol=0)
    code, _, err = run(capsys, "identify", str(rec), "--save-model", str(est_path))
    assert code == 2 and "--save-model" in err and "exists" in err


def test_rig_serve_hosts_the_model_file(capsys, tmp_path, monkeypatch):
    from motorid.io import RigServer

    rig = paper_rig(J_l=1e-4, friction=(), amplifier=Amplifier(dead_zone=0.2, v_max=9.0))
    rig.save(tmp_path / "rig.json")
    served = []
    port = str(free_port())  # hosted, not served: its address is checked free all the same

    def serve_forever(self, on_listening=None):  # hosted, not served: the test checks what would be
        served.append(self)
        on_listening()

    monkeypatch.setattr(RigServer, "serve_forever", serve_forever)
    code, _, err = run(capsys, "rig", "serve", "--model", str(tmp_path / "rig.json"), "--port", port)
    assert code == 0 and "rig of" in err
    plant = served[-1].plant
    assert plant.rig == rig and served[-1].u_max == 9.0  # the rating is the model's saturation
    plant.reset(seed=2)
    sim = rig.simulation(seed=2)
    assert [plant.step(3.0) for _ in range(5)] == [sim.step(3.0) for _ in range(5)]
    run(capsys, "rig", "serve", "--model", str(tmp_path / "rig.json"), "--u-max", "6", "--port", port)
    assert served[-1].u_max == 6.0
    run(capsys, "rig", "serve", "--port", port)
    assert served[-1].plant.rig == paper_rig() and served[-1].u_max == paper_rig().amplifier.v_max
    TwoMassRig().save(tmp_path / "unbounded.json")  # an ideal amplifier has no rating to serve with
    code, _, err = run(capsys, "rig", "serve", "--model", str(tmp_path / "unbounded.json"), "--port", port)
    assert code == 2 and "--u-max" in err
    code, _, err = run(capsys, "rig", "serve", "--model", str(tmp_path / "missing.json"), "--port", port)
    assert code == 2 and "missing.json: cannot read" in err


def test_the_model_files_page_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "docs" / "guide" / "models.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    example = next(b for b in blocks if "load_model(" in b)
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(example, "models.md", "exec"), namespace)
    assert namespace["same"] == namespace["rig"]
    assert (tmp_path / "rig.json").exists() and (tmp_path / "ekf.json").exists()


def test_rig_from_dict_is_the_same_strict_reader_as_the_model_files():
    """One reader: TwoMassRig.from_dict (a record's attrs) refuses what load_model refuses."""
    data = every_part_rig().to_dict()
    assert TwoMassRig.from_dict(data) == every_part_rig()
    del data["friction"][1]["params"]["stribeck_velocity"]
    with pytest.raises(DataError, match=r"^friction\[1\]\.params\.stribeck_velocity: missing"):
        TwoMassRig.from_dict(data)
    with pytest.raises(DataError, match=r"^J_m must be > 0, got -1.0"):
        TwoMassRig.from_dict({**TwoMassRig().to_dict(), "J_m": -1.0})


def test_a_rig_file_of_version_1_reads_its_friction_laws_as_effects(tmp_path):
    """Version 1 wrote a rig's friction as eq. (11)'s laws; read, each is its effects, and the rig
    simulates what the laws did (the Stribeck rate α2 is 1/v_s)."""
    rig = paper_rig(friction=(
        Friction(("coulomb_friction",), {"coulomb": 4e-3}, side="motor"),
        Friction(STRIBECK, {"coulomb": 1e-3, "stribeck": 2e-3, "stribeck_velocity": 4.0}, side="load"),
        Friction(("viscous_friction",), {"viscous": 1e-6}, side="both"),
    ))  # fmt: skip
    data = model_to_dict(rig)
    data["version"] = 1
    del data["card"]  # version 3's
    data["model"]["friction"] = [
        {"kind": "coulomb_friction", "alpha": 4e-3, "side": "motor"},
        {"kind": "stribeck_friction", "alpha0": 1e-3, "alpha1": 2e-3, "alpha2": 0.25, "stribeck_shape": "exponential",
         "side": "load"},
        {"kind": "viscous_friction", "B": 1e-6, "side": "both"},
    ]  # fmt: skip
    (tmp_path / "v1.json").write_text(json.dumps(data))
    assert load_model(tmp_path / "v1.json") == rig


# --------------------------------------------------------------------------- files of earlier versions
#: Model files written by motorid before estimators were saved through get_params()/get_state()
#: (commit 73f823e): each estimator after the first 120 samples of tests/data/model_files/record.csv,
#: and again after the 80 samples that follow (``NAME.continued.json``).
FROZEN = ROOT / "tests" / "data" / "model_files"


def as_written_now(data: dict) -> dict:
    """A version-1 file as this motorid writes it: the newest version, no card (nobody said what the
    model is), and a two-mass rig's friction laws (eq. 11's α-form) as the effects they are read as."""
    from motorid.drive import friction_from_dict

    data = copy.deepcopy(data)
    data["version"] = VERSION
    data["card"] = None
    rig = data["model"]["settings"].get("rig") or {}
    if "friction" in rig:
        rig["friction"] = [friction_from_dict(law).to_dict() for law in rig["friction"]]
    return data


@pytest.mark.parametrize(
    "name",
    [
        "arx-rls",
        "arx-rls-no-trace-bound",
        "hammerstein-rls",
        "friction-ekf",
        "friction-ukf",
        "friction-ekf-rigid-drive",
    ],
)
def test_an_estimator_file_written_by_an_earlier_motorid_loads_and_continues_bit_for_bit(name):
    """The file reads back into what writes it again byte for byte (the format unchanged but for
    version 2's friction on a rig's masses), and filtering the next 80 samples reaches the state
    the earlier motorid saved after them, to the last bit (the continued file compared as JSON,
    which keeps every float exactly)."""
    import pandas as pd

    record = pd.read_csv(FROZEN / "record.csv")
    u, y = record["u"].to_numpy(), record["y"].to_numpy()
    saved = json.loads((FROZEN / f"{name}.json").read_text())
    assert saved["version"] == 1
    est = load_model(FROZEN / f"{name}.json")
    assert model_to_dict(est) == as_written_now(saved)
    assert est.sample_index == 120
    est.batch_filter(u[120:], y[120:])
    assert model_to_dict(est) == as_written_now(json.loads((FROZEN / f"{name}.continued.json").read_text()))


# --------------------------------------------------------------------------- a plugin estimator
class GainRLS(Estimator):
    """A plugin's estimator: the gain k of ``y = k u`` by RLS with forgetting (a scalar Kalman
    filter, x = (k,)). Its constructor stores its arguments as given (validated in ``reset``);
    it saves through the base class's get_params() and its own get_state()/set_state()."""

    name = "test-gain-rls"

    def __init__(self, lam: float = 0.98, delta: float = 100.0):
        self.lam = lam
        self.delta = delta
        self.reset()

    def reset(self) -> None:
        if not 0.0 < self.lam <= 1.0 or not self.delta > 0.0:
            raise ValueError(f"lam must be in (0, 1] and delta > 0, got {self.lam!r}, {self.delta!r}")
        self.x, self.P = np.zeros(1), np.array([[self.delta]])
        self.x_prior, self.P_prior, self.x_post, self.P_post = self.x, self.P, self.x, self.P
        self.K, self.y, self.S, self.z, self.sample_index = np.zeros(1), 0.0, 0.0, None, 0
        self._u = 0.0

    def predict(self, u: float) -> float:
        self._u = self.check_input(u)
        self.P = self.P_prior = self.P / self.lam
        self.x_prior = self.x
        self.sample_index += 1
        return float(self.x[0] * self._u)

    def update(self, z: float | None) -> None:
        if z is None:
            return
        self.z = z
        self.S = float(self._u * self.P[0, 0] * self._u + 1.0)
        self.K = self.P[:, 0] * self._u / self.S
        self.y = z - float(self.x[0] * self._u)
        self.x = self.x_post = self.x + self.K * self.y
        self.P = self.P_post = self.P - np.outer(self.K, self.K) * self.S

    @property
    def params(self) -> dict:
        return {"k": float(self.x[0])}

    @property
    def state_names(self) -> tuple[str, ...]:
        return ("k",)

    def simulate(self, u) -> np.ndarray:
        return self.x[0] * np.asarray(u, dtype=float)

    def get_state(self) -> dict:
        return {"x": self.x.copy(), "P": self.P.copy(), "sample_index": self.sample_index}

    def set_state(self, state: dict) -> None:
        from motorid.estimators.base import check_covariance

        if np.shape(state["x"]) != (1,) or not np.all(np.isfinite(state["x"])):
            raise ValueError(f"x must be one finite number, got {state['x']!r}")
        self.P = self.P_prior = self.P_post = check_covariance("P", np.array(state["P"], dtype=float))
        self.x = self.x_prior = self.x_post = np.array(state["x"], dtype=float)
        self.sample_index = state["sample_index"]


class OneOrder(HammersteinRLS):
    """A subclass whose constructor takes other arguments than the ones it inherits get_params() for."""

    name = "one-order"

    def __init__(self, order: int = 2):
        super().__init__(order, order)


def test_a_plugin_estimator_registered_at_run_time_is_saved_loaded_and_continues_bit_for_bit(
    capsys, tmp_path, record
):
    from motorid.estimators import register, unregister

    u, y = record
    register(GainRLS.name, GainRLS)
    try:
        est = create(GainRLS.name, lam=0.95)
        est.batch_filter(u[:200], y[:200])
        est.save(tmp_path / "gain.json")
        data = json.loads((tmp_path / "gain.json").read_text())
        assert data["kind"] == "estimator" and data["model"]["estimator"] == "test-gain-rls"
        assert data["model"]["settings"] == {"lam": 0.95, "delta": 100.0}  # get_params(), as given
        back = motorid.load_model(tmp_path / "gain.json")
        assert type(back) is GainRLS and back.params == est.params and back.sample_index == 200
        a, b = est.batch_filter(u[200:], y[200:]), back.batch_filter(u[200:], y[200:])
        np.testing.assert_array_equal(a.x, b.x)
        np.testing.assert_array_equal(back.P, est.P)
        # its state is checked on the way in, and a setting by its own constructor
        for path, value, message in [
            (("model", "state", "P", 0, 0), -1.0, r"model.state.P: P must be positive semi-definite"),
            (("model", "state", "x"), [1.0, 2.0], r"model.state.x: must have shape \(1,\)"),
            (("model", "settings", "lam"), 1.5, "model.settings: lam must be in"),
            (("model", "settings", "delta2"), 1.0, "model.settings.delta2: unknown key"),
        ]:
            (tmp_path / "bad.json").write_text(json.dumps(_set(data, path, value)))
            with pytest.raises(DataError, match=f"bad.json: {message}"):
                load_model(tmp_path / "bad.json")
        # identify --save-model writes it as well (the README's promise)
        import pandas as pd

        from motorid.io.records import write_record

        frame = pd.DataFrame({"t": np.arange(len(u)) * 0.04, "u": u, "y": y})
        frame.attrs["dt"] = 0.04
        write_record(frame, tmp_path / "rec.csv")
        code, out, _ = run(capsys, "identify", str(tmp_path / "rec.csv"), "--estimator", GainRLS.name,
                           "--lam", "0.95", "--save-model", str(tmp_path / "cli.json"), "--json")  # fmt: skip
        assert code == 0 and out["model"] == str(tmp_path / "cli.json")
        reference = GainRLS(lam=0.95)
        reference.batch_filter(u, y)
        from_cli = load_model(tmp_path / "cli.json")
        assert type(from_cli) is GainRLS and from_cli.params == reference.params
    finally:
        unregister(GainRLS.name)
    # what cannot be read back is refused when saved, and the file is left as it was
    before = (tmp_path / "gain.json").read_bytes()
    with pytest.raises(ValueError, match=r"cannot save a Forgetful: it does not implement get_state\(\)"):
        type("Forgetful", (GainRLS,), {"get_state": Estimator.get_state})().save(tmp_path / "gain.json")
    with pytest.raises(
        ValueError, match=r"cannot save a OneOrder: get_params\(\) gives R, basis, .*, which its constructor"
    ):
        OneOrder().save(tmp_path / "gain.json")
    assert (tmp_path / "gain.json").read_bytes() == before
    with pytest.raises(DataError, match=r"model\.estimator: unknown estimator 'test-gain-rls'"):
        load_model(tmp_path / "gain.json")
