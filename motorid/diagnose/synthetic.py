"""Records with hidden effects, for testing the workflow and calibrating its threshold.

Most effects are planted in the two-mass rig (:mod:`motorid.drive`) with what
it already has: Coulomb and Stribeck friction on its masses, the amplifier's dead zone
and saturation, a constant load torque for an offset, and the back-EMF and
bearing losses as viscous friction. The rig is drawn at random around the
paper's (inertias, motor constant, resistance, bearing losses, excitation)
with a stiff shaft, since the grey-box model is rigid.

The others are planted with the rigid drive's simulator at a finer step
(:meth:`RigidDrive.free_run <motorid.drive.rigid.RigidDrive.free_run>` with 20 sub-steps) plus white measurement
noise: ``quadratic_drag``, ``asymmetric_friction`` (the viscous asymmetry,
which is what tells it from an offset) and ``backlash`` (the rig's backlash is
a gap in a two-mass shaft whose signature in the load speed is an impact, not
the lost-motion dwell the library models), and the base structure ``input_delay``
and ``input_lag`` and the stiction of ``static_friction``. The rig's masses carry the drag,
the asymmetry and the stiction too; the calibration's figures were measured on these records,
so they stay planted as they were.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from motorid.drive.rigid import RigidDrive

#: Effects planted in the rig.
RIG_EFFECTS = (
    "coulomb_friction",
    "stribeck_friction",
    "viscous_friction",
    "input_dead_zone",
    "input_saturation",
    "offset",
)
#: Effects planted with the grey-box simulator.
MODEL_EFFECTS = (
    "quadratic_drag", "asymmetric_friction", "backlash", "input_delay", "input_lag", "static_friction",
)  # fmt: skip

#: The model each single-effect test starts from: every other effect the record holds.
BASE_FOR = {
    "coulomb_friction": ("viscous_friction", "offset"),
    "stribeck_friction": ("viscous_friction", "coulomb_friction", "offset"),
    "viscous_friction": ("coulomb_friction", "offset"),
    "input_dead_zone": ("viscous_friction", "offset"),
    "input_saturation": ("viscous_friction", "coulomb_friction", "offset"),
    "offset": ("viscous_friction", "coulomb_friction"),
    "quadratic_drag": ("viscous_friction", "coulomb_friction", "offset"),
    "asymmetric_friction": ("viscous_friction", "coulomb_friction", "offset"),
    "backlash": ("viscous_friction", "coulomb_friction", "offset"),
    "input_delay": ("viscous_friction", "coulomb_friction", "offset"),
    "input_lag": ("viscous_friction", "coulomb_friction", "offset"),
    "static_friction": ("viscous_friction", "coulomb_friction", "offset"),
}


@dataclass
class Planted:
    """A simulated record and what is hidden in it.

    Attributes
    ----------
    record : DataFrame
        Columns ``t`` [s], ``u`` [V], ``y`` [rad/s]; ``attrs["dt"]``.
    input_gain : float
        Torque per volt at the drive [N m/V] (K_m G / R_a for the rig).
    effects : dict
        Planted effect -> its parameters [SI] (torques in N m).
    base : tuple of str
        The model a test starts from.
    notes : dict
        Other true values: ``inertia`` [kg m^2] (the drive's total), ``viscous`` [N m s/rad]
        (back EMF included), ``coulomb`` [N m] (the kinetic friction level, when the record has
        one) and, with an encoder sensor, its ``quantisation_step`` [rad/s].
    """

    record: pd.DataFrame
    input_gain: float
    effects: dict[str, dict[str, float]]
    base: tuple[str, ...]
    notes: dict[str, float] = field(default_factory=dict)


def _record(u: np.ndarray, y: np.ndarray, dt: float) -> pd.DataFrame:
    df = pd.DataFrame({"t": np.arange(u.size) * dt, "u": u, "y": y})
    df.attrs["dt"] = dt
    df.attrs["units"] = {"t": "s", "u": "V", "y": "rad/s"}
    return df


def planted_record(
    effects: str | Sequence[str] | None,
    seed: int,
    duration: float = 30.0,
    dt: float = 0.01,
    sizes: dict[str, float] | None = None,
    excitation_seed: int | None = None,
    sensor: str = "white",
) -> Planted:
    """Simulate a record with ``effects`` hidden in it (None or () for none).

    Parameters
    ----------
    effects : str, sequence of str or None
        Effects to plant (names of the library). A record with rig effects
        and model effects at once is not supported.
    seed : int
        Draws the rig, the excitation, the effect sizes and the noise.
    duration, dt : float
        Record length and sample time [s].
    sizes : dict, optional
        Fix the main parameter of an effect instead of drawing it: ``coulomb``,
        ``stribeck``, ``stribeck_velocity``, ``dead_zone`` [V], ``saturation``
        (share of max |u|), ``offset`` [N m], ``quadratic_drag``,
        ``viscous_asymmetry``, ``backlash_time``, ``input_delay`` [s],
        ``lag_time_constant`` [s], ``breakaway_excess`` [N m].
    excitation_seed : int, optional
        Draw the excitation and the noise from this seed instead: a second
        record of the same drive (for a held-out check).
    sensor : {"white", "encoder"}
        ``white``: the rig's own sensor (or white noise for the effects planted with the
        grey-box simulator); ``encoder``: in addition, the speed an encoder gives
        (:func:`encoder_speed`): noise that grows with speed, quantised in counts per sample.
    """
    if sensor not in SENSORS:
        raise ValueError(f"sensor must be one of {', '.join(SENSORS)}, got {sensor!r}")
    names = (effects,) if isinstance(effects, str) else tuple(effects or ())
    rng = np.random.default_rng(seed)
    sizes = dict(sizes or {})
    if any(n in MODEL_EFFECTS for n in names):
        if any(n in RIG_EFFECTS and n != "coulomb_friction" for n in names):
            raise ValueError(f"cannot plant {names} together: rig and model effects do not mix")
        planted = _model_record(names, rng, duration, dt, sizes, excitation_seed)
    else:
        planted = _rig_record(names, rng, duration, dt, sizes, excitation_seed)
    if sensor == "encoder":
        sensor_rng = np.random.default_rng([seed if excitation_seed is None else excitation_seed, 3])
        y = planted.record["y"].to_numpy()
        planted.record["y"] = encoder_speed(y, sensor_rng)
        planted.notes["quantisation_step"] = ENCODER_STEP * float(np.max(np.abs(y)))
    return planted


#: The sensors :func:`planted_record` simulates.
SENSORS = ("white", "encoder")
#: The simulated encoder: its count per sample, its noise at rest and its noise per unit speed,
#: as shares of the largest |w| and of |w|: those of the kit motor in ``realmotors/`` (a count of
#: 0.767 rad/s, 0.2-0.3 rad/s of filtered noise near rest and 0.45 at speed, at 1 kHz, on speeds
#: up to about 250 rad/s).
ENCODER_STEP = 0.003
ENCODER_REST_NOISE = 0.001
ENCODER_SPEED_NOISE = 0.01


def encoder_speed(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The speed an encoder reports for the speed ``w``.

    Noise of standard deviation ``σ(w) = (ENCODER_REST_NOISE max|w| + ENCODER_SPEED_NOISE |w|)``
    is added, then the speed is rounded to counts of ``q = ENCODER_STEP max|w|``::

        y = q round((w + σ(w) ε) / q),    ε ~ N(0, 1)

    Parameters
    ----------
    w : ndarray
        The true speed, one sample per entry, in the record's output unit (e.g. [rad/s]);
        ``y`` is in the same unit. All zero: returned as it is.
    rng : numpy.random.Generator
        The source of the noise ε.
    """
    w = np.asarray(w, dtype=float)
    top = float(np.max(np.abs(w)))
    if top == 0.0:
        return w.copy()
    sigma = ENCODER_REST_NOISE * top + ENCODER_SPEED_NOISE * np.abs(w)
    step = ENCODER_STEP * top
    return step * np.round((w + sigma * rng.standard_normal(w.size)) / step)


def _excitation(
    rng: np.random.Generator, duration: float, dt: float, excitation_seed: int | None
) -> np.ndarray:
    from motorid.signals import two_sine_signal

    amp = float(rng.uniform(3.0, 6.0))
    if excitation_seed is not None:  # the draws above are made anyway, so the drive stays the same
        rng.integers(2**31)
        rng = np.random.default_rng([excitation_seed, 1])
        amp = float(rng.uniform(3.0, 6.0))
    return two_sine_signal(
        duration, dt, seed=int(rng.integers(2**31)), amplitudes=(amp, 0.625 * amp),
        active_seconds=(3.0, 6.0), low_seconds=(2.0, 4.0),
    )[1]  # fmt: skip


def _rig_record(
    names: tuple[str, ...],
    rng: np.random.Generator,
    duration: float,
    dt: float,
    sizes: dict[str, float],
    excitation_seed: int | None,
) -> Planted:
    from motorid.drive import Amplifier, Friction, paper_rig

    J_m = float(rng.uniform(1.5e-5, 4e-5))
    J_l = float(rng.uniform(4e-5, 1.2e-4))
    K_m = float(rng.uniform(0.035, 0.055))
    R_a = float(rng.uniform(1.5, 3.0))
    u = _excitation(rng, duration, dt, excitation_seed)
    gain = K_m / R_a
    planted: dict[str, dict[str, float]] = {}
    friction = []
    coulomb = float(sizes.get("coulomb", rng.uniform(3e-3, 1.2e-2)))
    has_coulomb = "coulomb_friction" in names or any(
        n in names for n in ("stribeck_friction", "viscous_friction", "input_saturation", "offset")
    )
    if not names:
        has_coulomb = True  # the no-effect record: viscous + Coulomb, and the base model holds both
    if has_coulomb:
        share = float(rng.uniform(0.3, 0.7))
        friction += [
            Friction(("coulomb_friction",), {"coulomb": share * coulomb}, side="motor"),
            Friction(("coulomb_friction",), {"coulomb": (1.0 - share) * coulomb}, side="load"),
        ]
        if "coulomb_friction" in names:
            planted["coulomb_friction"] = {"coulomb": coulomb}
    if "stribeck_friction" in names:
        fs = float(sizes.get("stribeck", rng.uniform(4e-3, 9e-3)))
        vs = float(sizes.get("stribeck_velocity", rng.uniform(6.0, 12.0)))
        friction.append(
            Friction(("stribeck_friction",), {"stribeck": fs, "stribeck_velocity": vs}, side="motor")
        )
        planted["stribeck_friction"] = {"stribeck": fs, "stribeck_velocity": vs}
    dead_zone = 0.0
    if "input_dead_zone" in names:
        dead_zone = float(sizes.get("dead_zone", rng.uniform(0.3, 1.0)))
        planted["input_dead_zone"] = {"dead_zone": dead_zone}
    v_max = math.inf
    if "input_saturation" in names:
        share = float(sizes.get("saturation", rng.uniform(0.5, 0.75)))
        v_max = share * float(np.max(np.abs(u)))
        planted["input_saturation"] = {"saturation": v_max}
    load_torque = None
    if "offset" in names:
        t_d = float(sizes.get("offset", rng.choice([-1.0, 1.0]) * rng.uniform(3e-3, 8e-3)))
        load_torque = np.full(u.size, t_d)
        planted["offset"] = {"offset": t_d}
    B_m = float(rng.uniform(5e-6, 3e-5))
    B_l = float(rng.uniform(5e-6, 3e-5))
    rig = paper_rig(
        J_m=J_m, J_l=J_l, K_m=K_m, R_a=R_a, B_m=B_m, B_l=B_l, k_s=20.0, B_s=0.02, dt=dt,
        substeps=max(1, round(dt / 5e-4)), friction=tuple(friction),
        amplifier=Amplifier(gain=1.0, dead_zone=dead_zone, v_max=v_max),
    )  # fmt: skip
    if "viscous_friction" in names:
        planted["viscous_friction"] = {"viscous": K_m**2 / R_a + B_m + B_l}
    noise_seed = int(rng.integers(2**31))
    if excitation_seed is not None:
        noise_seed = excitation_seed + 7919
    rec = rig.simulate(u, seed=noise_seed, load_torque=load_torque)
    record = _record(u, rec["y"].to_numpy(), dt)
    base = BASE_FOR[names[0]] if len(names) == 1 else ("viscous_friction",)
    if not names:
        base = ("viscous_friction", "coulomb_friction", "offset")
    notes = {"inertia": J_m + J_l, "viscous": K_m**2 / R_a + B_m + B_l}
    if has_coulomb:
        notes["coulomb"] = coulomb
    return Planted(record, gain, planted, base, notes)


def _model_record(
    names: tuple[str, ...],
    rng: np.random.Generator,
    duration: float,
    dt: float,
    sizes: dict[str, float],
    excitation_seed: int | None,
) -> Planted:
    gain = float(rng.uniform(0.015, 0.03))
    params = {
        "inertia": float(rng.uniform(5e-5, 2e-4)),
        "input_gain": gain,
        "viscous": float(rng.uniform(5e-4, 1.2e-3)),
        "coulomb": float(sizes.get("coulomb", rng.uniform(3e-3, 8e-3))),
        "offset": 0.0,
    }
    effects = ["viscous_friction", "coulomb_friction", "offset"]
    planted: dict[str, dict[str, float]] = {}
    if "quadratic_drag" in names:
        c = float(sizes.get("quadratic_drag", rng.uniform(1.5e-6, 5e-6)))
        params["quadratic_drag"] = c
        planted["quadratic_drag"] = {"quadratic_drag": c}
    if "asymmetric_friction" in names:
        dfv = float(sizes.get("viscous_asymmetry", rng.choice([-1.0, 1.0]) * rng.uniform(0.25, 0.5)))
        dfv *= params["viscous"]
        params["viscous_asymmetry"] = dfv
        params["coulomb_asymmetry"] = 0.0
        planted["asymmetric_friction"] = {"viscous_asymmetry": dfv}
    if "backlash" in names:
        tau = float(sizes.get("backlash_time", rng.uniform(0.06, 0.15)))
        params["backlash_time"] = tau
        planted["backlash"] = {"backlash_time": tau}
    if "input_delay" in names:
        delay = float(sizes.get("input_delay", rng.uniform(1.2, 3.5) * dt))
        params["input_delay"] = delay
        planted["input_delay"] = {"input_delay": delay}
    if "input_lag" in names:
        lag = float(sizes.get("lag_time_constant", rng.uniform(1.5, 4.0) * dt))
        params["lag_time_constant"] = lag
        planted["input_lag"] = {"lag_time_constant": lag}
    if "static_friction" in names:
        excess = float(sizes.get("breakaway_excess", rng.uniform(1e-2, 1.4e-2)))
        params["breakaway_excess"] = excess
        planted["static_friction"] = {"breakaway_excess": excess}
    if "coulomb_friction" in names:
        planted["coulomb_friction"] = {"coulomb": params["coulomb"]}
    model = RigidDrive((*effects, *names), params, dt)
    u = _excitation(rng, duration, dt, excitation_seed)
    w = model.free_run(u, substeps=20)
    noise_rng = rng if excitation_seed is None else np.random.default_rng([excitation_seed, 2])
    noise = 0.002 * float(np.max(np.abs(w))) * noise_rng.standard_normal(u.size)
    record = _record(u, w + noise, dt)
    base = BASE_FOR[names[0]] if len(names) == 1 else ("viscous_friction", "offset")
    notes = {"inertia": params["inertia"], "viscous": params["viscous"], "coulomb": params["coulomb"]}
    return Planted(record, gain, planted, base, notes)


__all__ = [
    "BASE_FOR",
    "MODEL_EFFECTS",
    "RIG_EFFECTS",
    "SENSORS",
    "Planted",
    "encoder_speed",
    "planted_record",
]
