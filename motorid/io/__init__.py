"""DAQ backends, the online identification loop, and the records wing.

- :class:`SimulatedDAQ`: the simulated rig in process (the default backend).
- :class:`ModbusDAQ`: a rig behind Modbus TCP or RTU (a PLC, or our rig server).
- :class:`RigServer`: the simulated rig served over real Modbus (pymodbus).
- :class:`RegisterMap`: where the rig's signals live in the Modbus registers.
- :func:`run_online`: excite, measure, feed estimators, record to CSV as it goes.
- :func:`daq_from_url`: ``sim``, ``modbus://HOST:PORT`` or ``modbus-rtu:///dev/X``.
- :mod:`motorid.io.records`: records read, checked and written, whatever file they come in, with
  one :class:`~motorid.io.records.RecordOptions`.
"""

from typing import TYPE_CHECKING

from motorid.exports import lazy_exports

if TYPE_CHECKING:  # for type checkers; when run, each name's module is imported on first use
    from .base import DAQ, Plant, Sample
    from .daq_url import daq_from_url
    from .modbus import ModbusDAQ
    from .online import RunRecorder, run_online
    from .registers import STATUS_BITS, Register, RegisterMap
    from .rig_server import RigServer, rig_map_toml
    from .simulated import SimulatedDAQ

# The records wing (motorid.io.records) is what the doctor and the other record commands use: it
# does not load the DAQ backends, the Modbus rig's server or asyncio.
__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "DAQ": ".base", "Plant": ".base", "Sample": ".base", "daq_from_url": ".daq_url",
        "ModbusDAQ": ".modbus", "RunRecorder": ".online", "run_online": ".online",
        "STATUS_BITS": ".registers", "Register": ".registers", "RegisterMap": ".registers",
        "RigServer": ".rig_server", "rig_map_toml": ".rig_server", "SimulatedDAQ": ".simulated",
    },
)  # fmt: skip

__all__ = [
    "DAQ",
    "STATUS_BITS",
    "ModbusDAQ",
    "Plant",
    "Register",
    "RegisterMap",
    "RigServer",
    "RunRecorder",
    "Sample",
    "SimulatedDAQ",
    "daq_from_url",
    "rig_map_toml",
    "run_online",
]
