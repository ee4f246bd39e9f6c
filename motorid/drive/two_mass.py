"""The two-mass DC motor rig: parameters, online stepping and record simulation.

Model (paper, section 2 and 2.1), SI units throughout::

    v_a = R_a i_a + L_a di_a/dt + e_a,    e_a = K_m ω_m,    T_m = K_m i_a        (1)-(3)
    J_m dω_m/dt = T_m - T_s - B_m ω_m - T_f,m(ω_m) - T_cog(θ_m)                 (12)
    J_L dω_L/dt = T_s - B_L ω_L - T_d - T_f,L(ω_L)                              (13)
    T_s = k_s (θ_m - θ_L) + B_s (ω_m - ω_L)                                     (6)
    dθ_m/dt = ω_m,   dθ_L/dt = ω_L                                              (7)

with T_f the sum of the friction objects on each side (:mod:`.friction`), an
amplifier with dead zone and saturation in front of the armature
(:mod:`.amplifier`), the motor's cogging ripple
T_cog(θ_m) = A_s sin(p θ_m) + A_c cos(p θ_m) (``cogging_sin``, ``cogging_cos`` [N m],
``cogging_periods`` p [1/rad]: the ripple's periods per revolution; the rigid drive's
``cogging`` effect, one spelling), optional backlash of half-width b in the shaft (T_s = 0 for
|δ| < b, δ = θ_m - θ_L, else k_s (δ - b sgn δ) + B_s (ω_m - ω_L): the
"dead-zone" backlash model, whose contact damping can briefly pull while the
teeth separate) and the tachogenerator + A/D chain on the load speed
(:mod:`.sensors`).

Timing convention of a sample k (also of a record row): the command u[k] is held
over ``[k dt, (k+1) dt)`` (zero-order hold) and ``y[k]`` and the true states are
those at the end of that interval, as returned by :meth:`TwoMassRig.step`. The
``t`` column of a record is the start of the interval, ``t[k] = k dt``.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
import pandas as pd

from motorid.drive import effects as registry
from motorid.drive import kernels
from motorid.drive.components import ADConverter, Amplifier, Encoder, Tachogenerator, measure_speed
from motorid.drive.effects.cogging import Cogging
from motorid.drive.files import KIND_RIG, register_kind, save_model
from motorid.drive.friction import RIG_UNITS, Friction, friction_from_dict, pack_lugre, pack_rows
from motorid.drive.ranges import MOST_SUBSTEPS, check_count, check_parameter
from motorid.drive.rigid import RigidDrive, check_input, check_sample_time
from motorid.errors import ModelFileError
from motorid.json_input import build, integer, key_path, number, object_keys, scalars, shown

logger = logging.getLogger(__name__)

#: Units of the record columns.
RECORD_UNITS: dict[str, str] = {
    "t": "s",
    "u": "V",
    "y": "rad/s",
    "v_a": "V",
    "i_a": "A",
    "omega_m": "rad/s",
    "omega_l": "rad/s",
    "theta_m": "rad",
    "theta_l": "rad",
    "z_m": "rad",
    "z_l": "rad",
    "theta_enc": "rad",
    "T_d": "N m",
}

_POSITIVE = ("R_a", "L_a", "K_m", "J_m", "J_l", "k_s")
#: The motor's cogging ripple: the ``cogging`` effect's parameters, one spelling.
COGGING = tuple(p.name for p in Cogging.parameters)
_NONNEGATIVE = ("B_m", "B_l", "B_s", "backlash")
_NOISE_BLOCK = 1024


def _about(unit: str, meaning: str) -> dict[str, str]:
    """Field metadata of a physical parameter: its unit and what it is (for the tables)."""
    return {"unit": unit, "meaning": meaning}


#: The rigid drive's effects the rig holds outside its masses' friction: in its amplifier, its load
#: torque and its motor's ripple.
RIG_PARTS = ("input_dead_zone", "input_saturation", "offset", "cogging")


@dataclass(frozen=True)
class TwoMassRig:
    """Two-mass DC motor drive with friction, amplifier, backlash and sensors.

    Parameters
    ----------
    R_a : float
        Armature resistance [Ω], > 0.
    L_a : float
        Armature inductance [H], > 0.
    K_m : float
        Torque and back-EMF constant [N m/A = V s/rad], > 0.
    J_m, J_l : float
        Motor and load moments of inertia [kg m²], > 0.
    B_m, B_l : float
        Motor and load viscous friction [N m s/rad], >= 0.
    k_s : float
        Shaft stiffness [N m/rad], > 0.
    B_s : float
        Shaft inner damping [N m s/rad], >= 0.
    backlash : float
        Half-width b of the backlash gap in the shaft [rad], >= 0 (total play 2b).
    T_d : float
        Constant load disturbance torque [N m] (a per-sample profile can be
        passed to :meth:`simulate` and :meth:`step`).
    dt : float
        Sample time [s], > 0.
    substeps : int
        Internal steps per sample of the fast integrator (h = dt/substeps), >= 1.
    friction : tuple of Friction
        The friction on the masses: effects with their parameters
        (:class:`~motorid.drive.friction.Friction`), each on the motor side, the load side or
        both.
    amplifier : Amplifier
        Gain, dead zone and saturation between command u and armature voltage.
    tacho : Tachogenerator
        Load speed sensor.
    adc : ADConverter
        A/D converter reading the tacho voltage.
    encoder : Encoder or None
        Optional incremental encoder (adds a ``theta_enc`` column to records).
    cogging_sin, cogging_cos : float
        The motor's cogging ripple A_s sin(p θ_m) + A_c cos(p θ_m) [N m] (0: none; amplitude
        sqrt(A_s² + A_c²), phase atan2(A_c, A_s)).
    cogging_periods : float
        p [1/rad], its periods per revolution, > 0 with a ripple (>= 0 without).

    Notes
    -----
    The defaults of the thirteen physical parameters (R_a ... substeps) are the
    paper's rig, written here once (:data:`PHYSICAL_DEFAULTS` lists them with
    units); without friction and with an ideal amplifier they make the linear
    rig, and :func:`paper_rig` adds its friction and amplifier. A rig is a
    description: immutable (make variants with :meth:`replace`), comparable,
    saved and loaded as a model file (:meth:`save`, :func:`motorid.load_model`).
    A running simulation (state, noise stream) is a :class:`RigSimulation`, made
    by :meth:`simulation`; :meth:`simulate` runs a whole record from rest.
    """

    R_a: float = field(default=2.0, metadata=_about("Ω", "armature resistance"))
    L_a: float = field(
        default=1.0e-3, metadata=_about("H", "armature inductance (electrical time constant 0.5 ms)")
    )
    K_m: float = field(
        default=0.04284, metadata=_about("V s/rad", "torque/back-EMF constant, set for 2400 rpm at 12 V")
    )
    J_m: float = field(default=2.5e-5, metadata=_about("kg m²", "rotor"))
    J_l: float = field(
        default=7.5e-5, metadata=_about("kg m²", "disks, tachogenerator and brake disk on the shaft")
    )
    B_m: float = field(default=1.0e-5, metadata=_about("N m s/rad", "motor bearing and brush viscous losses"))
    B_l: float = field(default=2.0e-5, metadata=_about("N m s/rad", "load bearing viscous losses"))
    k_s: float = field(default=0.5, metadata=_about("N m/rad", "flexible coupling; shaft mode near 30 Hz"))
    B_s: float = field(default=1.0e-3, metadata=_about("N m s/rad", "inner damping of the coupling"))
    backlash: float = field(default=0.0, metadata=_about("rad", "half-width of the shaft's backlash gap"))
    T_d: float = field(default=0.0, metadata=_about("N m", "constant load disturbance torque"))
    dt: float = field(default=0.04, metadata=_about("s", "sampling interval (section 5)"))
    substeps: int = field(default=40, metadata=_about("", "internal steps per sample (1 kHz)"))
    friction: tuple[Friction, ...] = ()
    amplifier: Amplifier = field(default_factory=Amplifier)
    tacho: Tachogenerator = field(default_factory=Tachogenerator)
    adc: ADConverter = field(default_factory=ADConverter)
    encoder: Encoder | None = None
    cogging_sin: float = 0.0
    cogging_cos: float = 0.0
    cogging_periods: float = 0.0

    # ------------------------------------------------------------------ setup
    def __post_init__(self) -> None:
        units = {f.name: f.metadata.get("unit", "") for f in dataclasses.fields(self)}
        check_sample_time(self.dt)
        for name, sign in (
            *((n, "> 0") for n in _POSITIVE),
            *((n, ">= 0") for n in _NONNEGATIVE),
            ("T_d", "any"),
        ):
            check_parameter(name, getattr(self, name), units[name], sign=sign)
        check_count("substeps", self.substeps, 1, MOST_SUBSTEPS)
        check_parameter("cogging_sin", self.cogging_sin, "N m", sign="any")
        check_parameter("cogging_cos", self.cogging_cos, "N m", sign="any")
        ripple = self.cogging_sin != 0.0 or self.cogging_cos != 0.0
        check_parameter("cogging_periods", self.cogging_periods, "1/rad", sign="> 0" if ripple else ">= 0")
        friction = tuple(self.friction)
        for f in friction:
            if not isinstance(f, Friction):
                raise ValueError(f"friction must hold Friction objects (motorid.drive.Friction), got {f!r}")
        object.__setattr__(self, "friction", friction)
        for name, cls in (
            ("amplifier", Amplifier),
            ("tacho", Tachogenerator),
            ("adc", ADConverter),
        ):
            if not isinstance(getattr(self, name), cls):
                raise ValueError(f"{name} must be a {cls.__name__}, got {getattr(self, name)!r}")
        if self.encoder is not None and not isinstance(self.encoder, Encoder):
            raise ValueError(f"encoder must be an Encoder or None, got {self.encoder!r}")

        lugre = pack_lugre(friction)  # raises on two LuGre laws on one mass
        h = self.h
        for k, (side, J) in enumerate((("motor", self.J_m), ("load", self.J_l))):
            if lugre[k, 0] and h * math.sqrt(lugre[k, 1] / J) > 0.5:
                logger.warning(
                    "LuGre on the %s side: h*sqrt(sigma0/J) = %.3g > 0.5; "
                    "raise substeps for a stable bristle integration",
                    side,
                    h * math.sqrt(lugre[k, 1] / J),
                )
        phi, gam = self._discretise(h)
        # derived at construction, never changed: the compiled model
        object.__setattr__(
            self,
            "_compiled",
            (phi, gam, self._packed_parameters(), pack_rows(friction), lugre),
        )

    @property
    def h(self) -> float:
        """Internal step of the fast integrator [s]."""
        return self.dt / int(self.substeps)

    @property
    def has_lugre(self) -> bool:
        """Whether a mass has ``lugre_friction`` (an internal bristle state)."""
        return any(f.lugre for f in self.friction)

    def replace(self, **changes: Any) -> TwoMassRig:
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def viscous(self, side: str) -> float:
        """Total viscous coefficient on ``side`` [N m s/rad]: B_m or B_L plus its friction's."""
        base = self.B_m if side == "motor" else self.B_l
        return base + sum(f.viscous for f in self.friction if side in f.sides())

    def breakaway(self, side: str) -> tuple[float, float]:
        """Breakaway torques (forwards, backwards magnitude) [N m] on ``side``
        (:attr:`Friction.breakaway <motorid.drive.friction.Friction.breakaway>`, summed)."""
        pairs = [f.breakaway for f in self.friction if side in f.sides()]
        return sum(p[0] for p in pairs), sum(p[1] for p in pairs)

    def linear_system(
        self, stuck_m: bool = False, stuck_l: bool = False, gap: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """Continuous ``(A, B)`` of the linear part for one mode.

        State ``[i_a, ω_m, ω_L, δ, θ_L]``, input ``[v_a, τ_m, τ_L]`` (extra torques
        on the masses [N m]). A stuck mass has its speed row and column removed;
        ``gap`` removes the shaft coupling (inside the backlash).
        """
        R, L, K = self.R_a, self.L_a, self.K_m
        Jm, Jl = self.J_m, self.J_l
        Bm, Bl = self.viscous("motor"), self.viscous("load")
        ks, bs = (0.0, 0.0) if gap else (self.k_s, self.B_s)
        A = np.array(
            [
                [-R / L, -K / L, 0.0, 0.0, 0.0],
                [K / Jm, -(Bm + bs) / Jm, bs / Jm, -ks / Jm, 0.0],
                [0.0, bs / Jl, -(Bl + bs) / Jl, ks / Jl, 0.0],
                [0.0, 1.0, -1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0, 0.0],
            ]
        )
        B = np.array(
            [
                [1.0 / L, 0.0, 0.0],
                [0.0, 1.0 / Jm, 0.0],
                [0.0, 0.0, 1.0 / Jl],
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
            ]
        )
        for k, stuck in ((1, stuck_m), (2, stuck_l)):
            if stuck:
                A[k, :] = 0.0
                A[:, k] = 0.0
                B[k, :] = 0.0
        return A, B

    def _discretise(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        import scipy.linalg  # here, not at the top: the rigid-drive users (the doctor) never need it

        n, m = kernels.N_LINEAR, 3
        phi = np.zeros((8, n, n))
        gam = np.zeros((8, n, m))
        for mode in range(8):
            A, B = self.linear_system(bool(mode & 1), bool(mode & 2), bool(mode & 4))
            M = np.zeros((n + m, n + m))
            M[:n, :n] = A
            M[:n, n:] = B
            E = scipy.linalg.expm(M * h)
            phi[mode] = E[:n, :n]
            gam[mode] = E[:n, n:]
            # frozen states (zero rows of A and B) keep their value bit for bit
            for r in range(n):
                if not A[r].any() and not B[r].any():
                    phi[mode, r, :] = 0.0
                    phi[mode, r, r] = 1.0
                    gam[mode, r, :] = 0.0
        return np.ascontiguousarray(phi), np.ascontiguousarray(gam)

    def _packed_parameters(self) -> np.ndarray:
        p = np.zeros(kernels.N_PARAMS)
        p[kernels.P_K] = self.K_m
        p[kernels.P_KS] = self.k_s
        p[kernels.P_BS] = self.B_s
        p[kernels.P_BACKLASH] = self.backlash
        p[kernels.P_H] = self.h
        p[kernels.P_NSUB] = int(self.substeps)
        p[kernels.P_AMP_GAIN] = self.amplifier.gain
        p[kernels.P_DEAD_ZONE] = self.amplifier.dead_zone
        p[kernels.P_VMAX] = self.amplifier.v_max
        p[kernels.P_TACHO_GAIN] = self.tacho.gain
        p[kernels.P_TACHO_NOISE] = self.tacho.noise_std
        p[kernels.P_ADC_BITS] = self.adc.bits
        p[kernels.P_ADC_VMIN] = self.adc.v_min
        p[kernels.P_ADC_VMAX] = self.adc.v_max
        p[kernels.P_BREAK_POS_M], p[kernels.P_BREAK_NEG_M] = self.breakaway("motor")
        p[kernels.P_BREAK_POS_L], p[kernels.P_BREAK_NEG_L] = self.breakaway("load")
        p[kernels.P_RIPPLE_SIN] = self.cogging_sin
        p[kernels.P_RIPPLE_COS] = self.cogging_cos
        p[kernels.P_RIPPLE_PERIODS] = self.cogging_periods
        return p

    # ----------------------------------------------------------- online use
    def simulation(self, seed: int | None = None) -> RigSimulation:
        """A new running simulation of this rig, at rest, noise seeded with ``seed``."""
        return RigSimulation(self, seed)

    # -------------------------------------------------------------- records
    def simulate(
        self,
        u: npt.ArrayLike,
        seed: int | None = None,
        integrator: Literal["fast", "reference"] = "fast",
        load_torque: npt.ArrayLike | None = None,
        **reference_options: Any,
    ) -> pd.DataFrame:
        """Simulate a record from rest for the command sequence ``u``.

        Independent of every :class:`RigSimulation` of the rig.

        Parameters
        ----------
        u : array_like, shape (N,)
            Command voltage [V], one value per sample, held over the sample.
        seed : int or None
            Seed of the sensor noise.
        integrator : {"fast", "reference"}
            The compiled fixed-step integrator or the ``solve_ivp`` reference
            (:class:`~motorid.drive.reference_integrator.ReferenceIntegrator`,
            which takes ``reference_options``).
        load_torque : array_like, shape (N,), optional
            Load disturbance T_d [N m] per sample; default the constant ``self.T_d``
            (a ``T_d`` column is added when given).

        Returns
        -------
        pandas.DataFrame
            Columns ``t`` [s], ``u`` [V], ``y`` [rad/s] (measured load speed),
            ``v_a`` [V], ``i_a`` [A], ``omega_m``, ``omega_l`` [rad/s], ``theta_m``,
            ``theta_l`` [rad], plus ``z_m``, ``z_l`` with LuGre friction,
            ``theta_enc`` with an encoder and ``T_d`` when given. ``attrs``:
            ``dt``, ``units`` (column -> unit), ``rig`` (:meth:`to_dict`),
            ``integrator``, ``seed`` and ``timing``.
        """
        u_arr = check_input("u", u)
        n = u_arr.size
        if load_torque is None:
            t_d = np.full(n, float(self.T_d))
        else:
            t_d = check_input("load_torque", load_torque)
            if t_d.size != n:
                raise ValueError(f"load_torque must have {n} samples like u, got {t_d.size}")
        noise = np.random.default_rng(seed).standard_normal(n)
        phi, gam, p, fric, lug = self._compiled
        if integrator == "fast":
            rows = kernels.simulate_kernel(
                np.zeros(kernels.N_STATE), u_arr, t_d, noise, phi, gam, p, fric, lug
            )
            v_a = rows[:, 1]
            states = rows[:, 2:]
            y = rows[:, 0]
        elif integrator == "reference":
            from motorid.drive.reference_integrator import ReferenceIntegrator

            ref = ReferenceIntegrator(self, **reference_options)
            v_a, states = ref.run(u_arr, t_d)
            y = measure_speed(states[:, 2], noise, self.tacho, self.adc)
        else:
            raise ValueError(f"integrator must be 'fast' or 'reference', got {integrator!r}")

        data: dict[str, np.ndarray] = {
            "t": np.arange(n) * self.dt,
            "u": u_arr,
            "y": y,
            "v_a": v_a,
            "i_a": states[:, 0],
            "omega_m": states[:, 1],
            "omega_l": states[:, 2],
            "theta_m": states[:, 4] + states[:, 3],
            "theta_l": states[:, 4],
        }
        if self.has_lugre:
            data["z_m"] = states[:, 5]
            data["z_l"] = states[:, 6]
        if self.encoder is not None:
            theta = data["theta_m"] if self.encoder.side == "motor" else data["theta_l"]
            data["theta_enc"] = self.encoder.measure(theta)
        if load_torque is not None:
            data["T_d"] = t_d
        df = pd.DataFrame(data)
        df.attrs["dt"] = float(self.dt)
        df.attrs["units"] = {c: RECORD_UNITS[c] for c in df.columns}
        df.attrs["rig"] = self.to_dict()
        df.attrs["integrator"] = integrator
        df.attrs["seed"] = seed
        # a keyword of motorid.io.records.TIMINGS; the true states are at t[k]+dt too
        df.attrs["timing"] = "hold"
        return df

    # ---------------------------------------------------------- description
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description of every parameter (inverse: :meth:`from_dict`); the cogging keys
        only for a rig with a cogging parameter other than 0 (a file without them has none)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in COGGING and all(getattr(self, n) == 0.0 for n in COGGING):
                continue
            if f.name == "friction":
                out[f.name] = [fr.to_dict() for fr in value]
            elif value is None:
                out[f.name] = None
            elif hasattr(value, "to_dict"):
                out[f.name] = value.to_dict()
            else:
                out[f.name] = value.item() if isinstance(value, np.generic) else value
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "") -> TwoMassRig:
        """Rebuild a rig from :meth:`to_dict` output, every key checked.

        The one reader of a rig description, shared with the model files.

        Parameters
        ----------
        data : dict
            :meth:`to_dict` output: every parameter in SI units.
        where : str
            Where ``data`` sits in its file (``"model"``), put in front of the key an
            error names.

        Raises
        ------
        motorid.errors.ModelFileError
            A DataError naming the missing, unknown, mistyped or out-of-range key.
        """
        fields = [f for f in dataclasses.fields(cls) if f.init]
        if isinstance(data, dict) and not any(n in data for n in COGGING):
            fields = [f for f in fields if f.name not in COGGING]  # a rig without cogging (older files)
        object_keys(data, [f.name for f in fields], where)
        parts = {"amplifier": Amplifier, "tacho": Tachogenerator, "adc": ADConverter}
        values: dict[str, Any] = {}
        for f in fields:
            key = key_path(where, f.name)
            value = data[f.name]
            if f.name == "friction":
                if not isinstance(value, list):
                    raise ModelFileError(key, f"must be a list of frictions, got {shown(value)}")
                values[f.name] = tuple(
                    friction_from_dict(item, key_path(key, k)) for k, item in enumerate(value)
                )
            elif f.name in parts:
                values[f.name] = scalars(parts[f.name], value, key)
            elif f.name == "encoder":
                values[f.name] = None if value is None else scalars(Encoder, value, key)
            elif f.type == "int":
                values[f.name] = integer(value, key)
            else:
                values[f.name] = number(value, key)
        return build(cls, values, where)

    def save(self, path: str | Path, *, overwrite: bool = True) -> None:
        """Write the rig as a model file; :func:`motorid.load_model` reads it.

        Written whole; ``overwrite=False`` refuses an existing file
        (:func:`motorid.drive.files.write_model_file`).

        Parameters
        ----------
        path : str or Path
            The file to write.
        overwrite : bool
            False refuses an existing file.
        """
        save_model(self, path, overwrite=overwrite)

    # ------------------------------------------------------ rigid equivalent
    def rigid_equivalent(self, dt: float | None = None) -> RigidDrive:
        """The rigid drive that the measured load speed sees when the shaft is stiff.

        With the shaft mode well above the band a record excites (ω_L = ω_m = ω) and the
        electrical time constant L_a/R_a short beside a sample (i_a = (v_a - K_m ω)/R_a),
        eqs. (1)-(13) add up to one mass::

            (J_m + J_L) dω/dt = (K_m/R_a) v_a - (B_m + B_L + K_m²/R_a) ω - T_f,m(ω) - T_f,L(ω) - T_d
            v_a = D_d(clip(G u, ±V_max)) = G D_{d/G}(clip(u, ±V_max/G))

        so the rigid drive (:class:`~motorid.drive.rigid.RigidDrive`, input in the command's
        unit [V]) has

        ======================= ===============================================================
        inertia                 J_m + J_L [kg m²]                                        exact
        input_gain              g = G K_m/R_a [N m/V]                                     exact
        viscous                 B_m + B_L + K_m²/R_a + the masses' ``viscous``            exact
        offset                  T_d [N m]                                                 exact
        dead_zone, saturation   d/G and V_max/G [V] (when the amplifier has them)        exact
        every other parameter   the sum over the masses (``coulomb``,                     exact
        of the masses' effects  ``coulomb_asymmetry``, ``stribeck``, ``quadratic_drag``,
                                ``breakaway_excess``, ...)
        stribeck_velocity       1/r̄, r̄ the excess-weighted mean of the masses' decay      approximate
                                rates 1/v_s
        cogging_sin, _cos,      the motor's ripple A_s, A_c [N m] and p [1/rad]          exact
        cogging_periods         (θ_m = θ_L = θ on a stiff shaft)
        ======================= ===============================================================

        A :class:`~motorid.drive.friction.Friction` on ``side="both"`` counts once per mass.
        Approximated: the electrical lag L_a/R_a, the shaft's compliance and damping (k_s, B_s),
        LuGre's pre-sliding (its steady state, the mass's Coulomb and Stribeck levels, is kept;
        ``lugre_friction`` itself is left out) and, with Stribeck friction on both masses, their
        decay rates (one mean rate). Both masses break away together on a stiff shaft, so their
        breakaway excesses add. The tachogenerator, the A/D converter and an encoder are
        sensors, not dynamics: left out.

        Parameters
        ----------
        dt : float, optional
            Sample time [s] of the rigid drive; default the rig's.

        Returns
        -------
        RigidDrive
            Effects ``viscous_friction`` and ``offset`` always (the back-EMF is a viscous term,
            T_d an offset), every effect of the masses' friction but LuGre, ``input_dead_zone``,
            ``input_saturation`` and ``cogging`` when the rig has them.

        Raises
        ------
        ValueError
            For what has no rigid equivalent, named: a backlash gap in the shaft, or Stribeck
            friction of both decay shapes.
        """
        if self.backlash > 0.0:
            raise ValueError(
                f"backlash: the rig's shaft has a gap of ±{self.backlash:g} rad; a rigid drive has no "
                "shaft to carry it (its backlash is a dwell time), so the rig has no rigid equivalent"
            )
        K, R, G = self.K_m, self.R_a, self.amplifier.gain
        effects = ["viscous_friction", "offset"]
        params = {
            "inertia": self.J_m + self.J_l,
            "input_gain": G * K / R,
            "viscous": self.viscous("motor") + self.viscous("load") + K * K / R,
            "offset": float(self.T_d),
        }
        masses = [f for f in self.friction for _ in f.sides()]  # one entry per mass it acts on
        for f in masses:
            for name in f.effects:
                if name in ("viscous_friction", "lugre_friction"):
                    continue
                effects.append(name)
                for p in registry.get(name).parameters:
                    if p.name != "stribeck_velocity":
                        params[p.name] = params.get(p.name, 0.0) + f.params[p.name]
        shape = "exponential"
        stribeck = [f for f in masses if "stribeck_friction" in f.effects]
        if stribeck:
            shapes = sorted({f.stribeck_shape for f in stribeck if f.params["stribeck"] > 0.0})
            if len(shapes) > 1:
                raise ValueError(
                    "stribeck_friction: the rig's masses have Stribeck friction of both decay shapes "
                    "(exponential and gaussian); its rigid equivalent has one"
                )
            shape = shapes[0] if shapes else stribeck[0].stribeck_shape
            excess = sum(f.params["stribeck"] for f in stribeck)
            rate = (
                sum(f.params["stribeck"] * f.rate for f in stribeck) / excess if excess else stribeck[0].rate
            )
            params["stribeck_velocity"] = 1.0 / rate
        if self.amplifier.dead_zone > 0.0:
            effects.append("input_dead_zone")
            params["dead_zone"] = self.amplifier.dead_zone / G
        if math.isfinite(self.amplifier.v_max):
            effects.append("input_saturation")
            params["saturation"] = self.amplifier.v_max / G
        if self.cogging_sin != 0.0 or self.cogging_cos != 0.0:
            effects.append("cogging")
            params.update({name: float(getattr(self, name)) for name in COGGING})
        return RigidDrive(tuple(effects), params, self.dt if dt is None else dt, stribeck_shape=shape)

    def with_rigid_equivalent(self, drive: RigidDrive) -> TwoMassRig:
        """This rig changed so that its :meth:`rigid_equivalent` is ``drive`` (e.g. the model the
        doctor fitted on the rig's rigid equivalent): the effects found put back on the rig.

        Each rigid parameter goes back where :meth:`rigid_equivalent` took it from; a value
        equal to the rig's own equivalent leaves the rig's parameters as they are (so
        ``rig.with_rigid_equivalent(rig.rigid_equivalent()) == rig``), a changed one maps back
        proportionally:

        - inertia J: J_m and J_L both times J / (J_m + J_L) (their ratio, and so the shape of
          the shaft mode, kept);
        - input gain g: the amplifier gain G times g / (G K_m/R_a) (the motor constants K_m,
          R_a kept, and with them the back-EMF K_m²/R_a);
        - viscous B: the mechanical part B - K_m²/R_a shared by B_m, B_L and the masses'
          ``viscous`` in their proportions (all on B_m if they are all 0);
        - offset T_0: the load torque T_d = T_0;
        - dead zone and saturation [V of the command]: d = G dead_zone, V_max = G saturation
          (none when ``drive`` has no such effect);
        - every other parameter of the masses' effects (``coulomb``, ``coulomb_asymmetry``,
          ``stribeck``, ``breakaway_excess``, ...): its value on each mass scaled so that their
          sum is the drive's; one the rig's masses have none of (a sum of 0) goes to the motor,
          with its effect; an effect the drive lacks leaves the masses (LuGre stays, on the
          levels it holds);
        - ``stribeck_velocity`` and the Stribeck shape: a changed one is every mass's;
        - cogging: the motor's ripple ``cogging_sin``, ``cogging_cos`` [N m] and
          ``cogging_periods`` [1/rad] are the drive's (none when ``drive`` has no cogging).

        ``drive.dt`` is not taken: the rig keeps its own sample time and substeps.

        Parameters
        ----------
        drive : RigidDrive
            The rigid drive to put back, its input in the rig's command unit [V] and its forces
            in N m.

        Returns
        -------
        TwoMassRig

        Raises
        ------
        ValueError
            Naming the effect the rig cannot carry (``backlash``, ``input_delay``, ``input_lag``,
            ``position_friction``: :attr:`~motorid.drive.effects.Effect.not_on_a_mass`), or a
            level it cannot hold (negative, a viscous coefficient below the back-EMF's K_m²/R_a,
            an asymmetry where the Coulomb level is LuGre's).
        """
        if not isinstance(drive, RigidDrive):
            raise ValueError(f"drive must be a RigidDrive, got {type(drive).__name__}")
        for effect in drive.effects:
            reason = registry.get(effect).not_on_a_mass
            if reason and effect not in RIG_PARTS:
                raise ValueError(f"{effect}: a two-mass rig cannot carry it ({reason})")
        p = dict(drive.params)
        here = self.rigid_equivalent(drive.dt)
        q = here.params
        changes: dict[str, Any] = {}

        # inertia and gain, proportionally
        if p["inertia"] != q["inertia"]:
            ratio = p["inertia"] / q["inertia"]
            changes.update(J_m=self.J_m * ratio, J_l=self.J_l * ratio)
        gain_changed = p["input_gain"] != q["input_gain"]
        gain = (
            self.amplifier.gain * (p["input_gain"] / q["input_gain"]) if gain_changed else self.amplifier.gain
        )

        def in_volts(name: str, own: float, none: float) -> float:
            """The amplifier's ``own`` value [V], or the drive's ``name`` [V of the command] times the gain."""
            value = p.get(name, none)
            return own if not gain_changed and value == q.get(name, none) else gain * value

        amplifier = Amplifier(
            gain=gain,
            dead_zone=in_volts("dead_zone", self.amplifier.dead_zone, 0.0),
            v_max=in_volts("saturation", self.amplifier.v_max, math.inf),
        )
        if amplifier != self.amplifier:
            changes["amplifier"] = amplifier
        changes["T_d"] = p.get("offset", 0.0)

        # viscous: the mechanical part, in the rig's proportions
        viscous_ratio = 1.0
        if p["viscous"] != q["viscous"]:
            back_emf = self.K_m**2 / self.R_a
            mechanical = p["viscous"] - back_emf
            if mechanical < 0.0:
                raise ValueError(
                    f"viscous_friction: viscous = {p['viscous']:.4g} N m s/rad is below the back-EMF's "
                    f"K_m²/R_a = {back_emf:.4g} N m s/rad; the rig's motor constants cannot carry it"
                )
            old = self.viscous("motor") + self.viscous("load")
            if old > 0.0:
                viscous_ratio = mechanical / old
                changes.update(B_m=self.B_m * viscous_ratio, B_l=self.B_l * viscous_ratio)
            else:
                changes["B_m"] = mechanical
        changes["friction"] = self._friction_for(drive, here, viscous_ratio)
        if "cogging" in drive.effects:
            changes.update({name: p[name] for name in COGGING})
        elif "cogging" in here.effects:
            changes.update(dict.fromkeys(COGGING, 0.0))
        return self.replace(**changes)

    def _friction_for(
        self, drive: RigidDrive, here: RigidDrive, viscous_ratio: float
    ) -> tuple[Friction, ...]:
        """The masses' friction carrying ``drive``'s levels (see :meth:`with_rigid_equivalent`);
        ``here`` is the rig's own rigid equivalent."""
        p, q = drive.params, here.params
        for name, value in p.items():
            effect = registry.parameter_owner(name) if name not in ("inertia", "input_gain") else ""
            if effect and effect not in RIG_PARTS and registry.parameter(name).sign != "any" and value < 0.0:
                unit = registry.param_unit(name, RIG_UNITS)
                raise ValueError(
                    f"{effect}: {name} = {value:.4g} {unit} < 0 is not physical; the rig cannot carry it"
                )
        kept = {*drive.effects, "viscous_friction", "lugre_friction"}
        velocity = p.get("stribeck_velocity")
        new_velocity = velocity is not None and velocity != q.get("stribeck_velocity")
        new_shape = drive.stribeck_shape != here.stribeck_shape

        def value(name: str, own: float) -> float:
            if name == "viscous":
                return own * viscous_ratio
            if name == "stribeck_velocity":
                return velocity if new_velocity else own
            if name not in p or p[name] == q.get(name) or not q.get(name):
                return own
            return own * p[name] / q[name]

        out = []
        for f in self.friction:
            effects = tuple(e for e in f.effects if e in kept)
            params = {n: value(n, v) for n, v in f.params.items() if registry.parameter_owner(n) in effects}
            shape = drive.stribeck_shape if new_shape and "stribeck_friction" in effects else f.stribeck_shape
            if effects:  # an entry left with no effect goes
                out.append(f.replace(effects=effects, params=params, stribeck_shape=shape))
        # what the masses have none of (a sum of 0): on the motor
        added = {
            n: p[n] for e in drive.effects if e not in RIG_PARTS and e != "viscous_friction"
            for n in registry.get(e).linear + registry.get(e).nonlinear
            if n != "stribeck_velocity" and not q.get(n) and p[n]
        }  # fmt: skip
        if added:
            motor = next((k for k, f in enumerate(out) if f.side == "motor" and not f.lugre), None)
            entry = out[motor] if motor is not None else Friction((), {}, "motor", drive.stribeck_shape)
            effects = tuple(dict.fromkeys((*entry.effects, *map(registry.parameter_owner, added))))
            params = dict(entry.params)
            for e in effects:
                for n in (*registry.get(e).linear, *registry.get(e).nonlinear):
                    default = p.get(n, 0.0) if n == "stribeck_velocity" else 0.0
                    params[n] = params.get(n, default) + added.get(n, 0.0)
            shape = drive.stribeck_shape if "stribeck" in added else entry.stribeck_shape
            entry = entry.replace(effects=effects, params=params, stribeck_shape=shape)
            if motor is None:
                out.append(entry)
            else:
                out[motor] = entry
        return tuple(out)


register_kind(KIND_RIG, TwoMassRig, TwoMassRig.from_dict)


class RigSimulation:
    """A running simulation of a :class:`TwoMassRig`: its state and noise stream.

    The rig is the description; this object is what changes as samples are
    applied. Several simulations of one rig run independently.

    Parameters
    ----------
    rig : TwoMassRig
        The rig simulated (read only).
    seed : int or None
        Seed of the sensor noise (``numpy.random.default_rng``).

    Attributes
    ----------
    rig : TwoMassRig
    sample_index : int
        Samples applied since the last :meth:`reset`.
    """

    def __init__(self, rig: TwoMassRig, seed: int | None = None) -> None:
        self.rig = rig
        self.reset(seed)

    @property
    def dt(self) -> float:
        """Sample time [s] (the rig's)."""
        return self.rig.dt

    def reset(self, seed: int | None = None) -> None:
        """Return to rest (all states zero) and re-seed the sensor noise.

        Parameters
        ----------
        seed : int or None
            Seed of the noise generator; the measurements after ``reset(seed)``
            equal the ``y`` column of ``rig.simulate(u, seed=seed)`` for the same inputs.
        """
        self._x = np.zeros(kernels.N_STATE)
        self._out = np.zeros(kernels.N_OUT)
        self._rng = np.random.default_rng(seed)
        self._noise = np.empty(0)
        self._noise_pos = 0
        self.sample_index = 0

    def step(self, u: float, load_torque: float | None = None) -> float:
        """Apply ``u`` [V] for one sample (zero-order hold) and measure.

        Parameters
        ----------
        u : float
            Command voltage [V] (before the amplifier).
        load_torque : float, optional
            Load disturbance torque T_d [N m] for this sample; default the rig's ``T_d``.

        Returns
        -------
        float
            Measured load speed y [rad/s] at the end of the sample.
        """
        u = float(u)
        if not math.isfinite(u):
            raise ValueError(f"u must be finite, got {u!r} at sample {self.sample_index}")
        t_d = self.rig.T_d if load_torque is None else float(load_torque)
        if not math.isfinite(t_d):
            raise ValueError(f"load_torque must be finite, got {t_d!r} at sample {self.sample_index}")
        if self._noise_pos >= self._noise.size:
            self._noise = self._rng.standard_normal(_NOISE_BLOCK)
            self._noise_pos = 0
        noise = self._noise[self._noise_pos]
        self._noise_pos += 1
        self.sample_index += 1
        phi, gam, p, fric, lug = self.rig._compiled
        return kernels.advance_sample(self._x, u, t_d, noise, phi, gam, p, fric, lug, self._out)

    def run(self, u: npt.ArrayLike) -> np.ndarray:
        """Apply the commands ``u`` [V] one sample each (zero-order hold, the rig's ``T_d``) and
        measure: :meth:`step` over a block, in one compiled call. Consecutive blocks continue one
        record: after ``reset(seed)`` they give the ``y`` column of ``rig.simulate(u, seed=seed)``
        for the whole input, to the last bit (the same kernel, state and noise stream).

        Parameters
        ----------
        u : array_like, shape (N,)
            The next commands [V] (finite).

        Returns
        -------
        ndarray, shape (N,)
            Measured load speed y [rad/s] at the end of each sample.
        """
        u_arr = check_input("u", u)
        n = u_arr.size
        noise = np.empty(n)
        taken = 0
        while taken < n:
            if self._noise_pos >= self._noise.size:
                self._noise = self._rng.standard_normal(max(_NOISE_BLOCK, n - taken))
                self._noise_pos = 0
            part = min(n - taken, self._noise.size - self._noise_pos)
            noise[taken : taken + part] = self._noise[self._noise_pos : self._noise_pos + part]
            self._noise_pos += part
            taken += part
        phi, gam, p, fric, lug = self.rig._compiled
        rows = kernels.simulate_kernel(
            self._x, u_arr, np.full(n, float(self.rig.T_d)), noise, phi, gam, p, fric, lug
        )
        if n:
            self._out[:] = rows[-1]
        self.sample_index += n
        return rows[:, 0].copy()

    @property
    def state(self) -> dict[str, float]:
        """True state [SI] after the last :meth:`step`.

        Keys: ``t`` [s], ``v_a`` [V] (last armature voltage), ``i_a`` [A],
        ``omega_m``, ``omega_l`` [rad/s], ``theta_m``, ``theta_l``, ``twist``
        [rad], ``z_m``, ``z_l`` [rad] (LuGre bristles; 0 without LuGre).
        """
        x = self._x
        return {
            "t": self.sample_index * self.rig.dt,
            "v_a": float(self._out[1]),
            "i_a": float(x[0]),
            "omega_m": float(x[1]),
            "omega_l": float(x[2]),
            "theta_m": float(x[4] + x[3]),
            "theta_l": float(x[4]),
            "twist": float(x[3]),
            "z_m": float(x[5]),
            "z_l": float(x[6]),
        }


#: What :func:`paper_rig` adds to the defaults of :class:`TwoMassRig`.
PAPER_NONLINEARITIES: dict[str, Any] = {
    "friction": (
        Friction(("coulomb_friction",), {"coulomb": 4.0e-3}, side="motor"),
        Friction(("coulomb_friction",), {"coulomb": 2.0e-3}, side="load"),
    ),
    "amplifier": Amplifier(gain=1.0, dead_zone=0.6, v_max=12.0),
}


def paper_rig(**overrides: Any) -> TwoMassRig:
    """The default rig, sized to behave like the paper's (sections 4 and 5).

    What the paper gives, and how it is met:

    - ±12 V rating (section 4): the amplifier saturates the command at
      ``v_max = 12 V``.
    - about 2400 rpm at 12 V (section 4, "maximum output shaft speed of
      2400 rev/min"): the steady state at u = 12 V (and beyond, saturated) is
      2400 rpm within 0.012 % (2400.2 rpm), as close as K_m, set for it to four
      digits, can hold it (tests/test_drive.py).
    - settling time about 400 ms (section 5, pretest step response): the
      mechanical time constant J R / (K² + R B) is ≈ 0.1 s; the 2 % settling
      time of the 12 V step response is 0.41 s (0.409 s at 1 ms resolution;
      tests/test_drive.py).
    - sampling interval 40 ms (section 5): ``dt = 0.04``, with 40 internal
      steps (1 kHz) for the fast integrator.
    - Coulomb friction on both masses and a dead zone (section 2.1, eqs. 12-13,
      Fig. 4): breakaway and dead zone together keep the drive from turning steadily for
      |u| up to 0.88 V (0.6 V dead zone + 0.28 V to drive the 6 mN m of both
      Coulomb levels through R_a); the motor alone breaks away from 0.79 V and
      winds the shaft up by a few mrad, and the load stays at rest below
      0.85 V. This is what makes a linear model fail near zero speed.

    Values from the datasheet class of small 12 V permanent-magnet DC motors
    (20-40 W servo-trainer motors of the kind on the paper's rig): the physical
    parameters are the defaults of :class:`TwoMassRig` (this table is made from
    them), and :data:`PAPER_NONLINEARITIES` adds

    - Coulomb friction 4 mN m on the motor (brushes), 2 mN m on the load
      (bearings, tacho brushes);
    - a 0.6 V dead zone in the amplifier output stage and its ±12 V rating;
    - the default tachogenerator (2.5 V/1000 rpm, 10 mV noise) and A/D
      converter (12 bit, ±10 V, as the PCL-1800).

    {table}

    Parameters
    ----------
    **overrides : Any
        Any :class:`TwoMassRig` field, e.g. ``paper_rig(friction=(), dt=0.01)``.
    """
    names = {f.name for f in dataclasses.fields(TwoMassRig)}
    unknown = set(overrides) - names
    if unknown:
        raise ValueError(f"unknown rig parameter(s): {sorted(unknown)}")
    return TwoMassRig(**{**PAPER_NONLINEARITIES, **overrides})


#: The physical parameters of :class:`TwoMassRig` with their defaults: ``name -> (value, unit, meaning)``.
PHYSICAL_DEFAULTS: dict[str, tuple[float, str, str]] = {
    f.name: (f.default, f.metadata["unit"], f.metadata["meaning"])
    for f in dataclasses.fields(TwoMassRig)
    if "unit" in f.metadata
}


def _defaults_table() -> str:
    """The reStructuredText table of :data:`PHYSICAL_DEFAULTS` for :func:`paper_rig`'s docstring."""
    rows = [
        (name, f"{value:g} {unit}".strip(), meaning)
        for name, (value, unit, meaning) in PHYSICAL_DEFAULTS.items()
    ]
    widths = [max(len(r[k]) for r in rows) for k in range(3)]
    rule = " ".join("=" * w for w in widths)
    lines = [
        rule,
        *(" ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows),
        rule,
    ]
    return "\n    ".join(lines)


if paper_rig.__doc__:  # None under python -OO
    paper_rig.__doc__ = paper_rig.__doc__.replace("{table}", _defaults_table())


def steady_state_speed(rig: TwoMassRig, u: float) -> float:
    """Steady load speed [rad/s] for a constant command ``u`` [V] (static balance).

    Solves K_m (v_a - K_m ω)/R_a = (B_m + B_L) ω + T_c(ω) + T_d with the
    masses' friction at speed ω (both masses turn at ω in steady state); 0 when the
    drive cannot break away.

    Parameters
    ----------
    rig : TwoMassRig
        The rig.
    u : float
        The constant command [V].
    """
    v = float(rig.amplifier(u))
    K, R = rig.K_m, rig.R_a
    B = rig.viscous("motor") + rig.viscous("load")

    def friction_at(w: float) -> float:  # the terms beside the viscous ones (in B)
        return sum((float(f.torque(w)) - f.viscous * w) * len(f.sides()) for f in rig.friction)

    def balance(w: float) -> float:
        return K * (v - K * w) / R - B * w - friction_at(w) - rig.T_d

    if v == 0.0 or balance(math.copysign(1e-12, v)) * math.copysign(1.0, v) <= 0.0:
        return 0.0
    hi = v / K
    import scipy.optimize  # here, not at the top: the rigid-drive users (the doctor) never need it

    return float(scipy.optimize.brentq(balance, math.copysign(1e-12, v), hi))


__all__ = [
    "PAPER_NONLINEARITIES",
    "PHYSICAL_DEFAULTS",
    "RECORD_UNITS",
    "RIG_PARTS",
    "RigSimulation",
    "TwoMassRig",
    "paper_rig",
    "steady_state_speed",
]
