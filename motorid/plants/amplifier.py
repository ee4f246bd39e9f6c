"""The power amplifier between the command u and the armature voltage v_a.

    v_s  = clip(G u, -V_max, V_max)                    (input saturation at the rating)
    v_a  = 0                    if |v_s| <= d
         = v_s - d sgn(v_s)     otherwise              (ideal dead zone, paper Fig. 4)  [V]

The saturation is the ±12 V input range of the rig (commands beyond it change
nothing); the dead zone models the amplifier's output stage (and any offset
band of the drive electronics) at low command, so the largest armature voltage
is V_max - d.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from motorid.plants.physics import armature_voltages
from motorid.plants.ranges import check_parameter


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
