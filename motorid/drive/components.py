"""The rig's components around the motor: the power amplifier between the command u and
the armature voltage, and the sensors (tachogenerator, A/D converter, incremental encoder).

The amplifier::

    v_s  = clip(G u, -V_max, V_max)                    (input saturation at the rating)
    v_a  = 0                    if |v_s| <= d
         = v_s - d sgn(v_s)     otherwise              (ideal dead zone, paper Fig. 4)  [V]

The saturation is the ±12 V input range of the rig (commands beyond it change
nothing); the dead zone models the amplifier's output stage (and any offset
band of the drive electronics) at low command, so the largest armature voltage
is V_max - d.

The sensors. The measured output of the paper's rig is the load speed from a
tachogenerator, read through the 12-bit A/D converter of the data acquisition
card (ADVANTECH PCL-1800: 12 bit, bipolar ±10 V input range)::

    v_t   = G_t ω_L + n,       n ~ N(0, σ_t²)                         [V]
    code  = clip(round((v_t - V_min) / q), 0, 2^bits - 1),  q = (V_max - V_min) / 2^bits
    y     = (V_min + q code) / G_t                                    [rad/s]

so a speed of exactly zero with no noise reads exactly zero, and readings
saturate at the converter's range. The optional encoder on the motor shaft
counts ``counts_per_rev`` edges per revolution: θ_enc = 2π/N floor(N θ / 2π).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from motorid.drive.kernels import armature_voltages, tacho_readings
from motorid.drive.ranges import check_count, check_parameter


@dataclass(frozen=True)
class Amplifier:
    """Voltage amplifier with dead zone and saturation.

    Parameters
    ----------
    gain : float
        Voltage gain G [V/V], > 0.
    dead_zone : float
        Half-width d [V] of the input dead zone, >= 0 (0 switches it off).
    v_max : float
        Input saturation level V_max [V], > 0 (``math.inf`` switches it off).
    """

    gain: float = 1.0
    dead_zone: float = 0.0
    v_max: float = math.inf

    def __post_init__(self) -> None:
        if not math.isfinite(self.gain) or self.gain <= 0.0:
            raise ValueError(f"gain must be finite and > 0, got {self.gain!r}")
        if not math.isfinite(self.dead_zone) or self.dead_zone < 0.0:
            raise ValueError(f"dead_zone must be finite and >= 0, got {self.dead_zone!r}")
        if math.isnan(self.v_max) or self.v_max <= 0.0:
            raise ValueError(f"v_max must be > 0, got {self.v_max!r}")
        check_parameter("gain", self.gain, "V/V", sign="> 0")
        check_parameter("dead_zone", self.dead_zone, "V")
        check_parameter("v_max", self.v_max, "V", sign="> 0", allow_inf=True)

    def __call__(self, u: npt.ArrayLike) -> np.ndarray:
        """Armature voltage v_a [V] for command ``u`` [V]."""
        arr = np.asarray(u, dtype=float)
        flat = np.ascontiguousarray(arr.reshape(-1))
        out = armature_voltages(flat, self.gain, self.dead_zone, self.v_max)
        return out.reshape(arr.shape)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        if math.isinf(self.v_max):
            d["v_max"] = None  # JSON has no infinity
        return d


def measure_speed(
    omega: npt.ArrayLike, noise: npt.ArrayLike, tacho: Tachogenerator, adc: ADConverter
) -> np.ndarray:
    """Measured load speed [rad/s] for true speeds ``omega`` and standard normal ``noise``.

    Parameters
    ----------
    omega : array_like
        True load speeds [rad/s].
    noise : array_like
        Standard normal draws, one per speed (scaled by the tacho's noise).
    tacho : Tachogenerator
        The speed sensor [V s/rad].
    adc : ADConverter
        The converter its voltage is read through.
    """
    w = np.ascontiguousarray(np.asarray(omega, dtype=float).reshape(-1))
    n = np.ascontiguousarray(np.broadcast_to(np.asarray(noise, dtype=float), w.shape))
    return tacho_readings(w, n, tacho.gain, tacho.noise_std, int(adc.bits), adc.v_min, adc.v_max)


def _finite(name: str, value: float) -> None:
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    check_parameter(name, value, "(SI units)", sign="any")


@dataclass(frozen=True)
class Tachogenerator:
    """Tachogenerator on the load shaft.

    Parameters
    ----------
    gain : float
        Output constant G_t [V s/rad], > 0. Default 2.5 V per 1000 rpm
        (0.02387 V s/rad), the class of tachos on small servo trainers: 2400 rpm
        gives 6 V, inside the ±10 V converter range.
    noise_std : float
        Standard deviation σ_t [V] of the white voltage noise (ripple and
        pick-up), >= 0. Default 10 mV (about 4 rpm).
    """

    gain: float = 2.5 / (1000.0 * 2.0 * math.pi / 60.0)
    noise_std: float = 0.01

    def __post_init__(self) -> None:
        _finite("gain", self.gain)
        _finite("noise_std", self.noise_std)
        if self.gain <= 0.0:
            raise ValueError(f"gain must be > 0, got {self.gain!r}")
        if self.noise_std < 0.0:
            raise ValueError(f"noise_std must be >= 0, got {self.noise_std!r}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class ADConverter:
    """Bipolar A/D converter with ``bits`` resolution over ``[v_min, v_max]`` [V].

    ``bits=0`` switches quantisation and clipping off (an ideal reading).

    Attributes
    ----------
    bits : int
        Resolution, 0 to 32 bits.
    v_min, v_max : float
        The input range [V].
    """

    bits: int = 12
    v_min: float = -10.0
    v_max: float = 10.0

    def __post_init__(self) -> None:
        if not isinstance(self.bits, int | np.integer) or not 0 <= self.bits <= 32:
            raise ValueError(f"bits must be an integer in [0, 32], got {self.bits!r}")
        _finite("v_min", self.v_min)
        _finite("v_max", self.v_max)
        if self.v_max <= self.v_min:
            raise ValueError(f"v_max must be > v_min, got v_min={self.v_min!r}, v_max={self.v_max!r}")

    @property
    def lsb(self) -> float:
        """Quantisation step q [V] (0 when quantisation is off)."""
        return 0.0 if self.bits == 0 else (self.v_max - self.v_min) / 2.0**self.bits

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Encoder:
    """Incremental encoder: ``counts_per_rev`` counts per revolution on ``side``.

    Parameters
    ----------
    counts_per_rev : int
        Counts N per revolution (after quadrature decoding), > 0.
    side : {"motor", "load"}
        Shaft the disk is on (the paper's slotted opto sensor is on the motor).
    """

    counts_per_rev: int = 512
    side: str = "motor"

    def __post_init__(self) -> None:
        if not isinstance(self.counts_per_rev, int | np.integer) or self.counts_per_rev <= 0:
            raise ValueError(f"counts_per_rev must be a positive integer, got {self.counts_per_rev!r}")
        check_count("counts_per_rev", self.counts_per_rev, 1, 2**32)  # 32-bit encoder counters
        if self.side not in ("motor", "load"):
            raise ValueError(f"side must be 'motor' or 'load', got {self.side!r}")

    def measure(self, theta: npt.ArrayLike) -> np.ndarray:
        """Encoder reading [rad] of the true angle ``theta`` [rad]."""
        step = 2.0 * math.pi / self.counts_per_rev
        return np.floor(np.asarray(theta, dtype=float) / step) * step

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)
