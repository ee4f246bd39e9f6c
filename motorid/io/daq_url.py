"""Choose a DAQ backend from a short text, as given on the command line (``--daq``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .base import DAQ, Plant
from .modbus import ModbusDAQ
from .registers import RegisterMap
from .simulated import SimulatedDAQ

__all__ = ["daq_from_url"]


def daq_from_url(
    url: str,
    *,
    plant: Plant | None = None,
    seed: int | None = None,
    dt: float | None = None,
    realtime: bool = False,
    register_map: RegisterMap | str | Path | None = None,
    u_max: float = 12.0,
    timeout: float | None = None,
) -> DAQ:
    """Build the DAQ named by ``url`` (not opened yet).

    Parameters
    ----------
    url : str
        ``sim`` (the simulated rig, in process), ``modbus://HOST:PORT`` (Modbus
        TCP) or ``modbus-rtu:///dev/DEVICE?baudrate=N`` (Modbus RTU).
    plant : Plant, optional
        Simulated rig for ``sim`` (default ``motorid.drive.paper_rig()``).
    seed : int, optional
        Noise seed of the simulated rig (``sim`` only).
    dt : float, optional
        Sample time [s]. ``sim``: default the plant's; Modbus: default 0.04 s.
    realtime : bool
        ``sim`` only: pace samples at the wall clock.
    register_map : RegisterMap or path, optional
        Modbus register map (TOML file or object); default the built-in map.
    u_max : float
        Rating of the drive [V].
    timeout : float, optional
        Modbus answer timeout [s]; default suited to ``dt``.

    Returns
    -------
    DAQ
    """
    text = url.strip()
    if text in ("sim", "sim://", "simulated"):
        if register_map is not None or timeout is not None:
            raise ValueError(f"url={url!r}: register_map and timeout apply to a Modbus DAQ only")
        return SimulatedDAQ(plant, dt=dt, realtime=realtime, seed=seed, u_max=u_max)
    if text.startswith(("modbus://", "modbus-tcp://", "modbus-rtu://")):
        if plant is not None or seed is not None or realtime:
            raise ValueError(
                f"url={url!r}: plant, seed and realtime apply to the simulated DAQ (url='sim') only (the rig server "
                "owns them)"
            )
        kw: dict[str, Any] = {"u_max": u_max, "register_map": register_map}
        if dt is not None:
            kw["dt"] = dt
        if timeout is not None:
            kw["timeout"] = timeout
        return ModbusDAQ.from_url(text, **kw)
    raise ValueError(f"url={url!r}: expected 'sim', 'modbus://HOST:PORT' or 'modbus-rtu:///dev/DEVICE'")
