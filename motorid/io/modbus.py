"""DAQ backend for a rig behind a Modbus device (a PLC, or :class:`motorid.io.RigServer`).

Each sample the client writes the voltage command and an incremented
heartbeat in one request, and reads status, sequence counter and speed in
one request (with the default map; a map with gaps costs one request per
contiguous run). The heartbeat counts on from the value the rig holds when the
link opens, so its first write always changes it. A rig owned by another
client refuses the writes (Modbus exception 6): :class:`~motorid.errors.RigBusyError`.

A late answer is not a lost rig: each request waits up to ``timeout``
(:data:`LATE_ANSWER` by default, 2 s, longer than the longest answer measured
on a busy machine), with no retries (a request that is re-sent on TCP only
arrives again behind the first). A closed connection raises
:class:`~motorid.errors.DAQConnectionError` at once, a silent one within one
timeout, and the next call tries to reconnect. Keeping the rig safe while the
client is late is the rig's watchdog's work, not the client's timeout.
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlparse

from motorid.errors import DAQConnectionError, DAQError, DAQValueError, RigBusyError, RigFaultError

from .base import DAQ, Sample
from .registers import STATUS_BITS, STATUS_CLEAR, STATUS_FAULTS, Register, RegisterMap, WordOrder

logger = logging.getLogger(__name__)

#: Default wait for one answer [s]: on a 2-core machine with 7 busy processes (load average 10-13)
#: the rig server went without a core for up to 0.95 s and answers on 127.0.0.1 came up to 0.91 s late
#: (benchmarks/bench_modbus_long_run.py); twice that. A lost link that closes its connection is said at
#: once, a silent one after this wait.
LATE_ANSWER = 2.0
#: Modbus exception code of a rig owned by another client (server device busy).
_DEVICE_BUSY = 6
#: A read on a rig that keeps its own time sleeps until this share of a period before the next sample is
#: due, then polls: a few requests a sample instead of one every 2 ms (less work for a loaded machine).
_WAKE_EARLY = 0.25

__all__ = ["LATE_ANSWER", "ModbusDAQ", "contiguous_runs", "describe_status"]


def describe_status(status: int) -> str:
    """Names of the bits set in a status word, e.g. ``"watchdog|clamped"`` (``"ok"`` for 0).

    Parameters
    ----------
    status : int
        The rig's status word (:data:`~motorid.io.registers.STATUS_BITS`).
    """
    names = [name for name, bit in STATUS_BITS.items() if status & bit]
    unknown = status & ~sum(STATUS_BITS.values())
    if unknown:
        names.append(f"0x{unknown:04x}")
    return "|".join(names) if names else "ok"


def contiguous_runs(registers: list[Register]) -> list[tuple[int, list[Register]]]:
    """Group registers into runs of adjacent addresses, each readable in one request.

    Parameters
    ----------
    registers : list of Register
        The registers to read, in any order.

    Returns
    -------
    list of (address, registers)
        Start address of each run and the registers in it, in address order.
    """
    runs: list[tuple[int, list[Register]]] = []
    end = -1
    for reg in sorted(registers, key=lambda r: r.address):
        if runs and reg.address == end:
            runs[-1][1].append(reg)
        else:
            runs.append((reg.address, [reg]))
        end = reg.address + reg.count
    return runs


class ModbusDAQ(DAQ):
    """DAQ backend speaking Modbus TCP or Modbus RTU (pymodbus client).

    Parameters
    ----------
    host : str
        Host name or address of a Modbus TCP server (ignored with ``serial_port``).
    port : int
        TCP port.
    serial_port : str, optional
        Serial device (e.g. ``/dev/ttyUSB0``) for Modbus RTU instead of TCP.
        Needs ``pyserial``.
    baudrate, parity, stopbits, bytesize :
        Serial line settings (RTU only).
    register_map : RegisterMap or path, optional
        Where the signals live; a path is read as TOML. Default:
        :meth:`RegisterMap.default` with ``word_order``.
    word_order : {"ABCD", "CDAB"}
        Word order of float32 values in the default map.
    dt : float
        Sample time of the rig [s].
    timeout : float, optional
        Time to wait for each answer [s]. Default: ``max(LATE_ANSWER, 2.5 * dt)``
        (:data:`LATE_ANSWER` = 2 s): an answer a busy machine delays is
        waited for, not taken for a lost link. No retries.
    u_max : float
        Rating of the drive [V]; commands are clamped to ``[-u_max, u_max]``.
    clear_faults_on_open : bool
        On :meth:`open`, acknowledge faults latched before this connection
        (they are logged as a warning). Faults raised while open are never
        acknowledged silently: :meth:`read` raises :class:`RigFaultError`.
    wait_new_sample : bool
        :meth:`read` waits until the rig's sequence counter has moved on, so
        a loop is paced by a real-time rig and never sees a sample twice: after
        a read that had to wait, the next sleeps until a quarter period before
        its sample is due, then polls every ``dt / 20`` (at most 2 ms). A
        lock-step rig advances on each :meth:`write`, so there is no wait.

    Examples
    --------
    >>> with ModbusDAQ("127.0.0.1", 5020, dt=0.04) as daq:   # doctest: +SKIP
    ...     daq.write(2.0)
    ...     s = daq.read()
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 502,
        *,
        serial_port: str | None = None,
        baudrate: int = 115200,
        parity: str = "N",
        stopbits: int = 1,
        bytesize: int = 8,
        register_map: RegisterMap | str | Path | None = None,
        word_order: WordOrder = "ABCD",
        dt: float = 0.04,
        timeout: float | None = None,
        u_max: float = 12.0,
        clear_faults_on_open: bool = True,
        wait_new_sample: bool = True,
    ) -> None:
        super().__init__(u_max=u_max)
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"ModbusDAQ: dt must be a positive sample time [s], got {dt!r}")
        if timeout is None:
            timeout = max(LATE_ANSWER, 2.5 * dt)
        if not (math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"ModbusDAQ: timeout must be a positive time [s], got {timeout!r}")
        if register_map is None:
            register_map = RegisterMap.default(word_order)
        elif not isinstance(register_map, RegisterMap):
            register_map = RegisterMap.from_toml(register_map)
        self.register_map = register_map
        self.host = host
        self.port = int(port)
        self.serial_port = serial_port
        self.serial_settings = {
            "baudrate": int(baudrate),
            "parity": parity,
            "stopbits": int(stopbits),
            "bytesize": int(bytesize),
        }
        self._dt = float(dt)
        self.timeout = float(timeout)
        self.clear_faults_on_open = clear_faults_on_open
        self.wait_new_sample = wait_new_sample
        #: Samples the rig took that this client never read (real-time rigs).
        self.missed_samples = 0
        #: Number of times the link was re-established after a loss.
        self.reconnect_count = 0
        self._client: Any = None
        self._link_lost = False
        self._heartbeat = 0
        self._seq = 0
        self._seq_raw: int | None = None
        self._missed_open = 0  # missed_samples when the link opened
        self._missed_said: int | None = None  # missed_samples at the warning of this link's first miss
        self._seen_at: float | None = None  # time.monotonic() when the last new sample was read
        self._waited = False  # the last read waited for its sample: the rig keeps its own time
        self._clamped_for_next = False
        m = register_map
        self._read_runs = contiguous_runs([m["status"], m["sequence"], m["speed"]])
        self._write_runs = contiguous_runs([m["voltage_command"], m["heartbeat"]])

    # -- construction from a URL ---------------------------------------------
    @classmethod
    def from_url(cls, url: str, **kwargs: Any) -> ModbusDAQ:
        """Build from ``modbus://HOST:PORT`` or ``modbus-rtu:///dev/ttyX?baudrate=N``.

        Keyword arguments are passed on (``dt``, ``register_map``, ...). Query
        parameters of the URL (``baudrate``, ``parity``, ``word_order``,
        ``timeout``, ``dt``) fill in those not given.
        """
        parsed = urlparse(url)
        query = {k: v[-1] for k, v in parse_qs(parsed.query).items()}
        for key, conv in (
            ("baudrate", int),
            ("timeout", float),
            ("dt", float),
            ("parity", str),
            ("word_order", str),
        ):
            if key in query and key not in kwargs:
                kwargs[key] = conv(query.pop(key))
        if query:
            raise ValueError(f"{url!r}: unknown query parameter(s) {sorted(query)}")
        if parsed.scheme in ("modbus", "modbus-tcp"):
            if not parsed.hostname:
                raise ValueError(f"{url!r}: expected modbus://HOST:PORT")
            return cls(parsed.hostname, parsed.port or 502, **kwargs)
        if parsed.scheme == "modbus-rtu":
            if not parsed.path:
                raise ValueError(f"{url!r}: expected modbus-rtu:///dev/DEVICE")
            return cls(serial_port=parsed.path, **kwargs)
        raise ValueError(f"{url!r}: scheme must be modbus://, modbus-tcp:// or modbus-rtu://")

    @property
    def endpoint(self) -> str:
        """Human-readable description of the link, used in messages."""
        if self.serial_port:
            return f"Modbus RTU {self.serial_port} (device {self.register_map.device_id})"
        return f"Modbus TCP {self.host}:{self.port}"

    def __repr__(self) -> str:
        return f"ModbusDAQ({self.endpoint}, dt={self._dt!r}, timeout={self.timeout!r})"

    @property
    def dt(self) -> float:
        """Sample time [s]."""
        return self._dt

    # -- link ------------------------------------------------------------------
    def _make_client(self) -> Any:
        if self.serial_port:
            try:
                import serial  # noqa: F401  (pymodbus needs pyserial for RTU)
            except ImportError:
                raise DAQError(f"{self.endpoint}: Modbus RTU needs pyserial (pip install pyserial)") from None
            from pymodbus.client import ModbusSerialClient

            return ModbusSerialClient(
                self.serial_port, timeout=self.timeout, retries=0, **self.serial_settings
            )
        from pymodbus.client import ModbusTcpClient

        return ModbusTcpClient(self.host, port=self.port, timeout=self.timeout, retries=0)

    def _open(self) -> None:
        self._client = self._make_client()
        if not self._client.connect():
            self._client.close()
            raise DAQConnectionError(f"{self.endpoint}: cannot connect (is the rig server running?)")
        self._link_lost = False
        self._missed_open, self._missed_said = self.missed_samples, None
        try:
            status, seq_raw, _ = self._read_words()
        except Exception:
            self._client.close()
            raise
        # sequence numbers count from this connection: the first sample is seq 1
        self._seq, self._seq_raw = 0, seq_raw
        try:  # the heartbeat counts on from the rig's: the first write is a change whatever came before
            self._heartbeat = int(self._read_register("heartbeat"))
        except Exception:
            self._client.close()
            raise
        if status & STATUS_FAULTS and self.clear_faults_on_open:
            logger.warning(
                "%s: rig reported latched fault(s) %s from before this connection; acknowledged",
                self.endpoint,
                describe_status(status),
            )
            self.reset_faults()

    def _close(self) -> None:
        if self._client is not None:
            self._client.close()
        if self._missed_said is not None and self.missed_samples > self._missed_said:
            logger.warning(
                "%s: %d sample(s) of the rig were not read while the link was open (client too slow for "
                "dt = %g s)",
                self.endpoint,
                self.missed_samples - self._missed_open,
                self._dt,
            )
        self._missed_said = None

    def _say_missed(self, missed: int) -> None:
        """Samples the rig took that this client did not read: a warning the first time while the link is
        open, the total when it closes (:meth:`_close`), so a slow client is said twice, not each sample."""
        if self._missed_said is None:
            self._missed_said = self.missed_samples
            logger.warning(
                "%s: %d sample(s) of the rig were not read (client too slow for dt = %g s); those that follow "
                "are counted and said when the link closes",
                self.endpoint,
                missed,
                self._dt,
            )
        else:
            logger.debug(
                "%s: %d more sample(s) not read, %d in all", self.endpoint, missed, self.missed_samples
            )

    def _execute(self, what: str, call: Any, *args: Any, **kwargs: Any) -> Any:
        """Run one pymodbus request; turn every failure into a clear DAQ error."""
        from pymodbus.exceptions import ModbusException

        if self._client is None:
            raise DAQError(f"{self.endpoint}: the DAQ is not open (call open() first)")
        reconnecting = self._link_lost
        try:
            response = call(*args, device_id=self.register_map.device_id, **kwargs)
        except (ModbusException, OSError) as exc:
            self._client.close()  # drop any late answer; the next call reconnects
            self._link_lost = True
            raise DAQConnectionError(
                f"{self.endpoint}: link lost while {what} (no answer within "
                f"{self.timeout:g} s or connection refused): {exc}"
            ) from exc
        if reconnecting:
            self._link_lost = False
            self.reconnect_count += 1
            self._seq_raw = None
            logger.warning("%s: link re-established (reconnect #%d)", self.endpoint, self.reconnect_count)
        if response.isError() and getattr(response, "exception_code", None) == _DEVICE_BUSY:
            raise RigBusyError(
                f"{self.endpoint}: the rig refused {what}: another client owns it (Modbus exception 6, "
                "device busy); it takes commands again once that client disconnects or its heartbeat "
                "stops for the rig's watchdog time"
            )
        if response.isError():
            raise DAQError(
                f"{self.endpoint}: device refused {what}: {response} "
                "(does the register map match the device?)"
            )
        return response

    def _read_register(self, name: str) -> float:
        """One register of the map, read on its own (engineering value)."""
        reg = self.register_map[name]
        rr = self._execute(
            f"reading register {name!r} at {reg.address}",
            self._client.read_holding_registers,
            reg.address,
            count=reg.count,
        )
        words = list(rr.registers)
        if len(words) != reg.count:
            raise DAQValueError(
                f"{self.endpoint}: asked for {reg.count} registers at {reg.address}, got {len(words)}"
            )
        return reg.decode(words)

    def _read_words(self) -> tuple[int, int, float]:
        values: dict[str, float] = {}
        for address, regs in self._read_runs:
            count = sum(r.count for r in regs)
            rr = self._execute(
                f"reading registers {address}..{address + count - 1}",
                self._client.read_holding_registers,
                address,
                count=count,
            )
            words = list(rr.registers)
            if len(words) != count:
                raise DAQValueError(
                    f"{self.endpoint}: asked for {count} registers at {address}, got {len(words)}"
                )
            offset = 0
            for reg in regs:
                values[reg.name] = reg.decode(words[offset : offset + reg.count])
                offset += reg.count
        return int(values["status"]), int(values["sequence"]), values["speed"]

    def reset_faults(self) -> None:
        """Acknowledge latched faults of the rig (writes 0 to the status register)."""
        reg = self.register_map["status"]
        self._execute(
            "clearing the status word", self._client.write_registers, reg.address, reg.encode(STATUS_CLEAR)
        )

    # -- samples ---------------------------------------------------------------
    def _write(self, u: float) -> None:
        m = self.register_map
        heartbeat = (self._heartbeat + 1) & 0xFFFF
        words = {
            "voltage_command": m["voltage_command"].encode(u),
            "heartbeat": m["heartbeat"].encode(heartbeat),
        }
        for address, regs in self._write_runs:  # voltage before heartbeat when split
            payload = [w for reg in regs for w in words[reg.name]]
            self._execute(f"writing the command {u:.4g} V", self._client.write_registers, address, payload)
        self._heartbeat = heartbeat
        self._clamped_for_next = self._last_clamped

    def read(self) -> Sample:
        """Read status, sequence counter and speed from the rig.

        Returns
        -------
        Sample
            ``t = seq * dt`` [s], ``seq`` unwrapped from the 16-bit counter,
            ``y`` the measured speed [rad/s], ``u`` the last command sent [V].

        Raises
        ------
        DAQConnectionError
            No answer within :attr:`timeout`, or the connection was refused.
        DAQValueError
            The speed register holds NaN/inf or a value outside its range.
        RigFaultError
            The rig's status word has a fault bit set (e.g. the watchdog tripped).
        """
        if not self._is_open:
            raise DAQError(f"{self.endpoint}: the DAQ is not open (call open() first)")
        deadline = None
        if self._waited and self._seen_at is not None and self._seq_raw is not None:
            pause = self._seen_at + (1.0 - _WAKE_EARLY) * self._dt - time.monotonic()
            if pause > 0:
                time.sleep(pause)
        self._waited = False
        while True:
            status, seq_raw, y = self._read_words()
            if status & STATUS_FAULTS:
                raise RigFaultError(
                    f"{self.endpoint}: rig reports fault {describe_status(status)} "
                    f"(status word 0x{status:04x}); the rig holds 0 V until the fault is acknowledged "
                    "(a new connection acknowledges it, or ModbusDAQ.reset_faults()) once the cause is fixed",
                    status,
                )
            if not self.wait_new_sample or self._seq_raw is None or seq_raw != self._seq_raw:
                break
            self._waited = True
            now = time.monotonic()
            if deadline is None:
                deadline = now + max(self.timeout, 2.0 * self._dt)
            elif now > deadline:
                raise DAQError(
                    f"{self.endpoint}: the rig's sequence counter stayed at {seq_raw} for "
                    f"{max(self.timeout, 2.0 * self._dt):g} s: no new sample (a lock-step "
                    "rig advances only when a command is written)"
                )
            time.sleep(min(self._dt / 20.0, 0.002))
        try:
            self.register_map["speed"].check(y, where=f"{self.endpoint}: ")
        except ValueError as exc:
            raise DAQValueError(str(exc)) from None
        if self._seq_raw is None:
            # first read after a reconnect: the rig's counter may have restarted;
            # keep ours monotonic
            self._seq += 1
        else:
            step = (seq_raw - self._seq_raw) & 0xFFFF
            if step > 1:
                self.missed_samples += step - 1
                self._say_missed(step - 1)
            self._seq += step
        self._seq_raw = seq_raw
        self._seen_at = time.monotonic()
        return Sample(
            t=self._seq * self._dt,
            seq=self._seq,
            y=float(y),
            u=self._u,
            clamped=self._clamped_for_next or bool(status & STATUS_BITS["clamped"]),
            status=status,
        )
