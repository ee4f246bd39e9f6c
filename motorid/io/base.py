"""The DAQ contract shared by every backend: simulated, Modbus TCP and Modbus RTU.

A DAQ (data acquisition) backend is opened, commanded and sampled the same way
whatever sits behind it::

    with SimulatedDAQ(paper_rig(), seed=1) as daq:
        daq.write(2.0)          # input command [V], held for one sample
        sample = daq.read()     # Sample(t, seq, y, u, clamped, status)

The commanded voltage is clamped to the rig's rating (``u_max``, 12 V by
default). A clamp is never silent: it is logged as a warning, counted in
:attr:`DAQ.clamp_count` and flagged on the sample it produced
(:attr:`Sample.clamped`).
"""

from __future__ import annotations

import logging
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from motorid.errors import DAQError

logger = logging.getLogger(__name__)

__all__ = [
    "DAQ",
    "Plant",
    "Sample",
]


@runtime_checkable
class Plant(Protocol):
    """What a DAQ needs from a simulated rig (``motorid.drive.paper_rig()`` fits).

    Attributes
    ----------
    dt : float
        Sample time [s].
    """

    dt: float

    def reset(self, seed: int | None = None) -> object:
        """Return the rig to rest and reseed its noise."""
        ...

    def step(self, u: float) -> float:
        """Apply ``u`` [V] for one sample; return the measured speed [rad/s] at its end."""
        ...


@dataclass(frozen=True, slots=True)
class Sample:
    """One measurement taken from a DAQ.

    Attributes
    ----------
    t : float
        Time stamp of the measurement [s] (sequence number times ``dt``).
    seq : int
        Sequence number of the measurement: the number of samples the rig
        has advanced since it was opened (monotonic, never wraps).
    y : float
        Measured output, the load speed [rad/s].
    u : float
        Input command in force during the sample that ended at ``t`` [V],
        after clamping.
    clamped : bool
        True when that command was clamped to the rig's rating.
    status : int
        Status word of the rig (0: healthy). Bit meanings are backend
        specific; see :data:`motorid.io.registers.STATUS_BITS`.
    """

    t: float
    seq: int
    y: float
    u: float = 0.0
    clamped: bool = False
    status: int = 0


class DAQ(ABC):
    """Abstract DAQ backend: open/close, ``write(u)``, ``read()``, ``dt``.

    Subclasses implement :meth:`_open`, :meth:`_close`, :meth:`_write` and
    :meth:`read`; clamping and its reporting live here so every backend
    behaves the same.

    Parameters
    ----------
    u_max : float
        Rating of the drive [V]; commands are clamped to ``[-u_max, u_max]``.
    """

    def __init__(self, *, u_max: float = 12.0) -> None:
        if not (math.isfinite(u_max) and u_max > 0):
            raise ValueError(f"u_max must be a finite positive voltage [V], got {u_max!r}")
        self.u_max = float(u_max)
        #: Number of commands clamped since the DAQ was created.
        self.clamp_count = 0
        self._clamps_open = 0  # clamp_count when the DAQ opened
        self._clamps_said: int | None = None  # clamp_count at the warning of the first clamp while open
        self._last_clamped = False
        self._u = 0.0
        self._is_open = False

    # -- to implement --------------------------------------------------------
    @property
    @abstractmethod
    def dt(self) -> float:
        """Sample time [s]."""

    @abstractmethod
    def _open(self) -> None:
        """Connect to the rig."""

    @abstractmethod
    def _close(self) -> None:
        """Release the rig (the command is already 0 V where it could be sent)."""

    @abstractmethod
    def _write(self, u: float) -> None:
        """Send the (already clamped, finite) command ``u`` [V]."""

    @abstractmethod
    def read(self) -> Sample:
        """Return the latest measurement.

        Raises
        ------
        DAQConnectionError
            The rig did not answer within the timeout.
        DAQValueError
            The rig returned a value that is not a valid measurement.
        RigFaultError
            The rig reports a fault.
        """

    # -- shared behaviour ----------------------------------------------------
    @property
    def is_open(self) -> bool:
        """True between :meth:`open` and :meth:`close`."""
        return self._is_open

    @property
    def u(self) -> float:
        """The last command sent [V], after clamping."""
        return self._u

    def open(self) -> DAQ:
        """Connect to the rig; returns ``self`` so ``daq = X(...).open()`` works."""
        if not self._is_open:
            self._open()
            self._is_open = True
            self._clamps_open, self._clamps_said = self.clamp_count, None
        return self

    def close(self) -> None:
        """Command 0 V (best effort) and release the rig. Safe to call twice."""
        if not self._is_open:
            return
        try:
            self._write(0.0)
            self._u = 0.0
        except Exception as exc:  # the link may be what failed; closing must go on
            logger.warning("could not command 0 V while closing: %s", exc)  # exc names the link
        finally:
            self._is_open = False
            if self._clamps_said is not None and self.clamp_count > self._clamps_said:
                logger.warning(
                    "%d command(s) clamped to the rating +/-%.4g V while the DAQ was open",
                    self.clamp_count - self._clamps_open,
                    self.u_max,
                )
            self._clamps_said = None
            self._close()

    def __enter__(self) -> DAQ:
        return self.open()

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def clamp(self, u: float) -> tuple[float, bool]:
        """Clamp a command to the rating.

        Parameters
        ----------
        u : float
            Requested command [V].

        Returns
        -------
        u_clamped : float
            The command that will be sent [V].
        clamped : bool
            True when ``u`` was outside ``[-u_max, u_max]``.

        Raises
        ------
        ValueError
            ``u`` is NaN or infinite.
        """
        u = float(u)
        if not math.isfinite(u):
            raise ValueError(f"{type(self).__name__}.write: command u must be finite [V], got {u!r}")
        if -self.u_max <= u <= self.u_max:
            return u, False
        return math.copysign(self.u_max, u), True

    def write(self, u: float) -> float:
        """Command the input voltage for the next sample.

        Parameters
        ----------
        u : float
            Input command [V]. Clamped to ``[-u_max, u_max]``; a clamp is
            logged (once per run of consecutive clamped commands), counted in
            :attr:`clamp_count` and flagged on the next :class:`Sample`.

        Returns
        -------
        float
            The command actually sent [V].

        Raises
        ------
        ValueError
            ``u`` is NaN or infinite (nothing is sent).
        DAQError
            The DAQ is not open, or the rig could not be reached.
        """
        if not self._is_open:
            raise DAQError(f"{type(self).__name__}.write: the DAQ is not open (call open() first)")
        u_sent, clamped = self.clamp(u)
        if clamped:
            self.clamp_count += 1
            if self._clamps_said is None:  # said once while open; the total when it closes
                self._clamps_said = self.clamp_count
                logger.warning(
                    "command %.4g V clamped to %.4g V (rating +/-%.4g V); the clamps that follow are counted and "
                    "said when the DAQ closes",
                    float(u),
                    u_sent,
                    self.u_max,
                )
        self._last_clamped = clamped
        self._write(u_sent)
        self._u = u_sent
        return u_sent
