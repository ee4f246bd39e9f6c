"""A synthetic fleet: drives of one design with spread constants, some wearing, one growing a dead zone.

Each drive is the paper's rig (:func:`~motorid.drive.two_mass.paper_rig`) without the
amplifier dead zone, its constants (R_a, K_m, J_m, J_L, the Coulomb levels and the
viscous coefficients) each scaled by a factor drawn uniformly in ``1 ± spread``.
A drive records one record a day on the paper's test signal (a new seed per
record). On day ``d`` a wearing drive has its Coulomb levels and viscous
coefficients multiplied by

    1 + growth d                                                        (growth per day, e.g. 0.02)

and a drive with a dead zone day ``d0`` has an amplifier dead zone of
``dead_zone`` [V] from that day on. The records carry ``attrs["drive"]`` and
``attrs["time"]`` (ISO 8601), which ``motorid fleet`` reads.

>>> from motorid.fleet.synthetic import make_fleet
>>> fleet = make_fleet(n_drives=4, seed=0)
>>> [d.name for d in fleet]
['drive-00', 'drive-01', 'drive-02', 'drive-03']
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pandas as pd

from motorid.drive.components import Amplifier
from motorid.drive.friction import Friction
from motorid.drive.two_mass import TwoMassRig, paper_rig
from motorid.io.records import DRIVE_ATTR, TIME_ATTR, write_record
from motorid.signals import two_sine_signal

logger = logging.getLogger(__name__)

#: The first day of a generated fleet's records.
FLEET_START = datetime(2026, 1, 5, 8, 0, 0)


def _coulomb_times(friction: Friction, factor: float) -> Friction:
    """``friction`` with its Coulomb level (if it has one) times ``factor``."""
    if "coulomb" not in friction.params:
        return friction
    return friction.replace(params={**friction.params, "coulomb": friction.params["coulomb"] * factor})


@dataclass(frozen=True)
class FleetDrive:
    """One drive of a fleet.

    Attributes
    ----------
    name : str
        Drive id, e.g. ``drive-03``.
    rig : TwoMassRig
        The drive on day 0 (no dead zone).
    friction_growth : float
        Relative growth of its Coulomb levels and viscous coefficients per day [1/day]; 0 for a
        healthy drive.
    dead_zone_day : int or None
        Day from which its amplifier has a dead zone of ``dead_zone`` [V]; None: never.
    dead_zone : float
        That dead zone [V].
    """

    name: str
    rig: TwoMassRig
    friction_growth: float = 0.0
    dead_zone_day: int | None = None
    dead_zone: float = 0.8

    @property
    def healthy(self) -> bool:
        """True for a drive whose friction stays and that never grows a dead zone."""
        return self.friction_growth == 0.0 and self.dead_zone_day is None

    def rig_on(self, day: int) -> TwoMassRig:
        """The drive as it is on ``day`` (0-based): friction grown, dead zone there or not."""
        scale = 1.0 + self.friction_growth * day
        friction = tuple(_coulomb_times(f, scale) for f in self.rig.friction)
        amplifier = self.rig.amplifier
        if self.dead_zone_day is not None and day >= self.dead_zone_day:
            amplifier = dataclasses.replace(amplifier, dead_zone=self.dead_zone)
        return dataclasses.replace(
            self.rig,
            friction=friction,
            B_m=self.rig.B_m * scale,
            B_l=self.rig.B_l * scale,
            amplifier=amplifier,
        )

    def record(
        self, day: int, duration: float = 60.0, start: datetime = FLEET_START, seed: int = 0
    ) -> pd.DataFrame:
        """The drive's record of ``day``: the paper's test signal for ``duration`` [s] at 40 ms.

        The signal and the sensor noise take seeds drawn from ``seed``, the drive and the day, so
        every record differs and the same arguments give the same record.
        """
        index = int(self.name.rsplit("-", 1)[-1]) if self.name.rsplit("-", 1)[-1].isdigit() else 0
        signal_seed, noise_seed = np.random.SeedSequence([seed, index, day]).generate_state(2)
        rig = self.rig_on(day)
        _, u = two_sine_signal(duration=duration, dt=rig.dt, seed=int(signal_seed))
        record = rig.simulate(u, seed=int(noise_seed))
        record.attrs[DRIVE_ATTR] = self.name
        record.attrs[TIME_ATTR] = (start + timedelta(days=day)).isoformat()
        return record


def make_fleet(
    n_drives: int,
    seed: int = 0,
    spread: float = 0.05,
    wearing: tuple[int, ...] = (1, 2),
    friction_growth: float = 0.02,
    dead_zone_drive: int | None = 3,
    dead_zone_day: int = 5,
    dead_zone: float = 0.8,
) -> list[FleetDrive]:
    """``n_drives`` drives of the paper's design with constants spread by ``± spread``.

    Parameters
    ----------
    n_drives : int
        Number of drives, >= 1; named ``drive-00``, ``drive-01`` ...
    seed : int
        Seed of the spread.
    spread : float
        Half-width of the uniform spread of each constant, relative (0.05: ± 5 %), in [0, 0.5].
    wearing : tuple of int
        Indices of the drives whose friction grows by ``friction_growth`` per day (those
        < ``n_drives``).
    friction_growth : float
        Relative growth per day [1/day], >= 0 (0.02: +20 % in 10 days).
    dead_zone_drive : int or None
        Index of the drive whose amplifier grows a dead zone of ``dead_zone`` [V] on day
        ``dead_zone_day``; None, or an index >= ``n_drives``: no such drive.
    dead_zone_day : int
        The day [days from day 0] the dead zone appears.
    dead_zone : float
        That dead zone (the amplifier's) [V].

    Raises
    ------
    ValueError
        Naming the argument out of range, or a drive both wearing and growing the dead zone.
    """
    if not isinstance(n_drives, int) or n_drives < 1:
        raise ValueError(f"n_drives must be an integer >= 1, got {n_drives!r}")
    if not 0.0 <= spread <= 0.5:
        raise ValueError(f"spread must be in [0, 0.5], got {spread!r}")
    if not friction_growth >= 0.0:
        raise ValueError(f"friction_growth must be >= 0, got {friction_growth!r}")
    if dead_zone_drive is not None and dead_zone_drive in wearing:
        raise ValueError(f"drive {dead_zone_drive} cannot be both wearing and growing the dead zone")
    if not dead_zone > 0.0 or dead_zone_day < 0:
        raise ValueError(
            f"dead_zone must be > 0 and dead_zone_day >= 0, got {dead_zone!r}, {dead_zone_day!r}"
        )
    rng = np.random.default_rng(seed)
    base = paper_rig(amplifier=Amplifier(gain=1.0, dead_zone=0.0, v_max=12.0))
    drives = []
    for i in range(n_drives):
        factor = rng.uniform(1.0 - spread, 1.0 + spread, size=8)
        friction = tuple(_coulomb_times(f, k) for f, k in zip(base.friction, factor[6:], strict=True))
        rig = dataclasses.replace(
            base, R_a=base.R_a * factor[0], K_m=base.K_m * factor[1], J_m=base.J_m * factor[2],
            J_l=base.J_l * factor[3], B_m=base.B_m * factor[4], B_l=base.B_l * factor[5], friction=friction,
        )  # fmt: skip
        drives.append(
            FleetDrive(
                name=f"drive-{i:02d}",
                rig=rig,
                friction_growth=friction_growth if i in wearing else 0.0,
                dead_zone_day=dead_zone_day if i == dead_zone_drive else None,
                dead_zone=dead_zone,
            )
        )
    return drives


def write_fleet(
    folder: str | os.PathLike[str],
    drives: Sequence[FleetDrive],
    days: int | Sequence[int],
    duration: float = 60.0,
    seed: int = 0,
    start: datetime = FLEET_START,
) -> list[Path]:
    """Write each drive's record of each day as ``folder/<drive>_<YYYYMMDD>.csv``; the paths.

    ``days`` is a number of days (0, 1, ... ``days - 1``) or the days themselves (e.g. every third).
    The file names follow the pattern ``{drive}_{date:%Y%m%d}.csv`` (``motorid fleet
    --pattern``); the records' attrs say the same.

    Parameters
    ----------
    folder : str or os.PathLike
        Where to write (made if missing).
    drives : sequence of FleetDrive
        The drives (:func:`make_fleet`).
    days : int or sequence of int
        A number of days, or the days [days from ``start``].
    duration : float
        Length of each record [s].
    seed : int
        Seed of the records' noise and signals (a new one per record from it).
    start : datetime
        The date and time of day 0.
    """
    day_list = list(range(days)) if isinstance(days, int) else [int(d) for d in days]
    if not day_list or min(day_list) < 0:
        raise ValueError(f"days must be a number >= 1 or days >= 0, got {days!r}")
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for drive in drives:
        for day in day_list:
            path = out / f"{drive.name}_{(start + timedelta(days=day)):%Y%m%d}.csv"
            write_record(drive.record(day, duration=duration, start=start, seed=seed), path)
            paths.append(path)
    logger.info("wrote %d records of %d drives in %s", len(paths), len(drives), out)
    return paths


__all__ = ["FLEET_START", "FleetDrive", "make_fleet", "write_fleet"]
