"""Backlash: lost motion in a rigid drive seen from the measured side.

After the drive force reverses, the driving side crosses the play before it pushes again;
for a velocity record this is a dwell of τ_b during which the measured side coasts under
friction alone (the driving side's momentum, small beside the load's, is not carried over).
τ_b ≈ sqrt(4 b J_m / |F|) for a play 2b and a driving inertia J_m; the effect reports τ_b,
not b.
"""

from __future__ import annotations

import numpy as np

from motorid.drive.effects.base import Effect, Parameter
from motorid.drive.input_path import backlash_dwell


class Backlash(Effect):
    """Lost motion: the drive force is not transmitted for ``τ_b`` after each reversal of its sign.

    Parameter ``backlash_time`` τ_b [s], >= 0. See the module notes for what this models and
    how τ_b relates to the play. Not in the friction filters' model.
    """

    name = "backlash"
    kind = "input"
    not_on_a_mass = (
        "the rigid drive's backlash is a dwell time after reversals, the rig's a gap in the shaft [rad] "
        "(its backlash); one does not give the other"
    )
    parameters = (Parameter("backlash_time", "s", ">= 0"),)
    signature = "right after each reversal of the drive force: the measured side lags, sign follows the force"
    order = 4

    def transform(self, x: np.ndarray, dt: float, shape: dict[str, float]) -> np.ndarray:
        return backlash_dwell(x, dt, shape["backlash_time"])

    def bounds(self, scale: dict[str, float]) -> dict[str, tuple[float, float]]:
        # a dwell shorter than the decimated sample time is below the band the balance resolves
        lo = scale.get("dt_band", scale["dt"])
        return {"backlash_time": (lo, max(2.0 * lo, min(50.0 * scale["dt"], 0.3)))}


__all__ = ["Backlash"]
