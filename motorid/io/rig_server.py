"""A Modbus rig server: the simulated rig behind real Modbus (pymodbus server).

The server's holding registers are the rig (see :mod:`motorid.io.registers`
for the map). In lock-step mode (the default) a client's write that changes
the heartbeat advances the plant one sample with the voltage command then in
the register, so a client that writes command and heartbeat each sample gets
exactly the run a :class:`~motorid.io.SimulatedDAQ` would give. In real-time
mode the plant advances once per ``dt`` of wall-clock time whatever the
client does.

The rig has one owner: the first client (TCP connection) that writes to it
(a command, a heartbeat, a fault acknowledgement). It owns the rig until its
heartbeat stalls for the watchdog's time or it disconnects; meanwhile every
write of another client is refused with Modbus exception 6 (device busy),
changes nothing and is counted (:attr:`RigServer.refused_writes`, and the
``refused_writes`` register where the map has one). Reads are free to all.

Like a PLC, the server has a watchdog that follows one rule: a command holds
only while its own client heart-beats. Re-writing the command is not a
heartbeat, and no other client's heartbeat counts. What it counts depends on
what keeps the plant's time:

- Real time (the plant advances with the clock): the watchdog is armed by the
  first voltage command or heartbeat; when the owner's heartbeat has not
  changed for more than ``watchdog_periods`` sample periods of wall-clock time
  since its last heartbeat (or since the command that armed it), the server
  forces the voltage to 0 V, latches the ``watchdog`` bit of the status word
  and lets the owner go. When the owner disconnects, the voltage goes to 0 V at
  once and the rig is free; the watchdog still trips once the periods have
  passed and latches its fault (the next client acknowledges it).
- Lock-step (the plant advances one sample per heartbeat: the client is the
  clock): the plant stands still while the client computes, however long, so
  wall-clock time is no fault. The watchdog counts the owner's commands
  instead: more than ``watchdog_periods`` commands in a row without a heartbeat
  force 0 V, latch the fault and let the owner go. The owner keeps the rig,
  however long it is silent, until then or until it disconnects: the voltage
  then goes to 0 V and the rig is free (a client that froze with its
  connection open is stopped, not waited out).

A client acknowledges latched faults by writing 0 to ``status``.

The register image is fixed: the server answers function codes 3, 6, 16 and
23 (read, write one, write many, read/write holding registers) on the map's
device id. Any other function code is answered with exception 1 (illegal
function), an address outside the map or a write to a read-only register with
exception 2, a request to another device id with exception 11 (no response
from the target; over RTU, no answer, as a bus does): one line at debug level
each, and nothing changes.

Run it in a background thread (tests, notebooks)::

    with RigServer(paper_rig(), port=5020, seed=1) as rig:
        ...                           # talk to 127.0.0.1:5020

or in the foreground (the ``motorid rig serve`` command)::

    RigServer(paper_rig(), port=5020).serve_forever()
"""

from __future__ import annotations

import asyncio
import contextvars
import gc
import logging
import math
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .base import Plant
from .registers import STATUS_BITS, STATUS_CLEAR, STATUS_FAULTS, RegisterMap, WordOrder
from .simulated import plant_to_step

logger = logging.getLogger(__name__)

__all__ = ["REALTIME_WATCHDOG", "RigServer", "rig_map_toml"]

_READONLY = ("sequence", "speed", "refused_writes")
#: Function codes the rig answers: read holding registers, write one, write many, read/write many.
SUPPORTED_FUNCTION_CODES = frozenset({3, 6, 16, 23})
#: Default watchdog of a real-time rig served on a shared computer (``motorid rig serve --realtime``) [s]:
#: on 2 cores with 7 busy processes (load average 6-13) a process went without a core for up to 1.02 s
#: in 10,000 samples at 40 ms (the client's heartbeats 0.16-0.2 s apart at p99.9;
#: benchmarks/bench_modbus_long_run.py); twice that. A PLC, with a core of its own, keeps 3 periods.
REALTIME_WATCHDOG = 2.0
#: Time the real-time watchdog lets requests already received be served before it trips [s].
_SERVE_PENDING = 0.002
#: The connection (request handler) whose request is being served, for the rig's owner rule.
_CLIENT: contextvars.ContextVar[object | None] = contextvars.ContextVar("rig_client", default=None)


def _client_name(handler: object) -> str:
    """``HOST:PORT`` of a TCP client, or ``the serial line``."""
    transport = getattr(handler, "transport", None)
    peer = transport.get_extra_info("peername") if transport is not None else None
    return f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) and len(peer) >= 2 else "the serial line"


def rig_map_toml(register_map: RegisterMap | str | Path | None = None, word_order: WordOrder = "ABCD") -> str:
    """The register map a rig server uses, as TOML text (``motorid rig map``).

    Parameters
    ----------
    register_map : RegisterMap or path, optional
        A map, or a TOML file to read one from. Default: the built-in map.
    word_order : {"ABCD", "CDAB"}
        Word order of float32 values in the built-in map.

    Returns
    -------
    str
        TOML text readable by :meth:`RegisterMap.from_toml`.
    """
    if register_map is None:
        register_map = RegisterMap.default(word_order)
    elif not isinstance(register_map, RegisterMap):
        register_map = RegisterMap.from_toml(register_map)
    return register_map.to_toml()


class RigServer:
    """Modbus TCP (or RTU) server hosting a simulated rig.

    Parameters
    ----------
    plant : drive model or Plant, optional
        The simulated rig: a model such as ``motorid.drive.paper_rig()`` (the
        default), run in a simulation of the server's own, or a running
        :class:`Plant` (``dt``, ``reset(seed)``, ``step(u)``).
    host : str
        Address to bind (TCP). ``127.0.0.1`` by default: only this machine
        can reach the rig. Use ``0.0.0.0`` deliberately to expose it.
    port : int
        TCP port; 0 picks a free one (read it back from :attr:`port`).
    serial_port : str, optional
        Serve Modbus RTU on this serial device instead of TCP (needs pyserial).
    baudrate : int
        Serial speed (RTU only).
    register_map : RegisterMap or path, optional
        Register layout; a path is read as TOML. Default: the built-in map.
    word_order : {"ABCD", "CDAB"}
        Word order of float32 values in the built-in map.
    lockstep : bool
        True: each heartbeat change advances the plant one sample. False:
        the plant advances once per ``dt`` of wall-clock time.
    seed : int, optional
        Seed for ``plant.reset`` at start.
    watchdog_periods : float or None
        Real time: time without the owner's heartbeat, in sample periods, since
        its last heartbeat or the command that armed the watchdog, after which
        the voltage is forced to 0 V and the watchdog fault is latched.
        Lock-step: the number of the owner's commands in a row without a
        heartbeat it tolerates (one more trips the watchdog); wall-clock time
        is not counted. None disables the watchdog.
    u_max : float
        Rating of the drive [V]; the rig clamps commands to it and sets the
        ``clamped`` status bit.

    Attributes
    ----------
    voltage : float
        Voltage applied to the plant [V] (after clamping and faults).
    speed : float
        Last measured speed published [rad/s].
    seq : int
        Samples the plant has advanced since start (not wrapped).
    status : int
        Status word (:data:`~motorid.io.registers.STATUS_BITS`).
    watchdog_trips : int
        Number of times the watchdog tripped.
    refused_writes : int
        Writes refused because another client owned the rig (not wrapped).
    """

    def __init__(
        self,
        plant: object | None = None,
        *,
        host: str = "127.0.0.1",
        port: int = 5020,
        serial_port: str | None = None,
        baudrate: int = 115200,
        register_map: RegisterMap | str | Path | None = None,
        word_order: WordOrder = "ABCD",
        lockstep: bool = True,
        seed: int | None = None,
        watchdog_periods: float | None = 3.0,
        u_max: float = 12.0,
    ) -> None:
        if register_map is None:
            register_map = RegisterMap.default(word_order)
        elif not isinstance(register_map, RegisterMap):
            register_map = RegisterMap.from_toml(register_map)
        if watchdog_periods is not None and not watchdog_periods > 0:
            raise ValueError(f"watchdog_periods must be > 0 or None, got {watchdog_periods!r}")
        if not (math.isfinite(u_max) and u_max > 0):
            raise ValueError(f"u_max must be a finite positive voltage [V], got {u_max!r}")
        self.plant: Plant = plant_to_step(plant)
        self.dt = float(self.plant.dt)
        self.host = host
        self.port = int(port)
        self.serial_port = serial_port
        self.baudrate = int(baudrate)
        self.register_map = register_map
        self.lockstep = bool(lockstep)
        self.seed = seed
        self.watchdog_periods = watchdog_periods
        self.u_max = float(u_max)

        self.voltage = 0.0
        self.speed = 0.0
        self.seq = 0
        self.status = 0
        self.watchdog_trips = 0
        self.refused_writes = 0

        self._base, n = register_map.span
        self._words = [0] * n
        self._heartbeat: int | None = None
        self._last_contact = 0.0  # loop time of the owner's last heartbeat or arming command [s]
        self._armed = False
        self._unbeaten_commands = 0  # the owner's commands since its last heartbeat (lock-step watchdog)
        self._owner: object | None = None  # the request handler (connection) that owns the rig
        self._owner_name = ""  # its HOST:PORT, kept for the messages after it disconnected
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop_event: asyncio.Event | None = None
        self._ready = threading.Event()
        self._done = threading.Event()
        self._done.set()
        self._error: BaseException | None = None
        self._server: Any = None

    def __repr__(self) -> str:
        where = f"RTU {self.serial_port}" if self.serial_port else f"{self.host}:{self.port}"
        mode = "lock-step" if self.lockstep else "real-time"
        return f"RigServer({where}, dt={self.dt!r}, {mode})"

    @property
    def url(self) -> str:
        """``modbus://HOST:PORT`` (or ``modbus-rtu://DEVICE``) of the running server."""
        if self.serial_port:
            return f"modbus-rtu://{self.serial_port}"
        return f"modbus://{self.host}:{self.port}"

    # -- register words ----------------------------------------------------------
    def _set(self, name: str, value: float) -> None:
        reg = self.register_map[name]
        i = reg.address - self._base
        self._words[i : i + reg.count] = reg.encode(value)

    def _get(self, name: str, words: list[int] | None = None) -> float:
        reg = self.register_map[name]
        i = reg.address - self._base
        return reg.decode((self._words if words is None else words)[i : i + reg.count])

    def _publish(self) -> None:
        if "refused_writes" in self.register_map.registers:
            self._set("refused_writes", self.refused_writes & 0xFFFF)
        self._set("status", self.status)
        self._set("sequence", self.seq & 0xFFFF)
        reg = self.register_map["speed"]
        try:
            self._set("speed", self.speed)
        except ValueError:  # does not fit a scaled integer: publish the limit, flag it
            raw_limit = 32767 if reg.type == "int16" else 65535
            limit = raw_limit if self.speed > 0 else (-32768 if reg.type == "int16" else 0)
            self._set("speed", limit * reg.scale)
            self.status |= STATUS_BITS["plant"]
            self._set("status", self.status)
        if not math.isfinite(self.speed):
            if not self.status & STATUS_BITS["plant"]:
                logger.error("rig: plant produced speed %r at sample %d", self.speed, self.seq)
            self.status |= STATUS_BITS["plant"]
            self._set("status", self.status)

    def _apply_command(self, u: float) -> float:
        """Voltage the rig applies for command ``u`` [V]: clamped, 0 V when faulted."""
        self.status &= ~STATUS_BITS["clamped"]
        if self.status & STATUS_FAULTS:
            return 0.0
        if not math.isfinite(u):
            logger.error("rig: invalid voltage command %r; holding 0 V", u)
            self.status |= STATUS_BITS["command"]
            return 0.0
        if abs(u) > self.u_max:
            self.status |= STATUS_BITS["clamped"]
            return math.copysign(self.u_max, u)
        return u

    def _advance(self) -> None:
        """Advance the plant one sample with the applied voltage and publish."""
        self.speed = float(self.plant.step(self.voltage))
        self.seq += 1
        self._publish()

    def refusal(self, function_code: int, device_id: int) -> int | None:
        """The Modbus exception code for a request the rig does not serve, or None to serve it.

        Parameters
        ----------
        function_code : int
            The request's function code.
        device_id : int
            The device (unit) id it is addressed to.
        """
        if device_id != self.register_map.device_id:
            logger.debug(
                "rig: request for device id %d refused (the rig is %d)",
                device_id,
                self.register_map.device_id,
            )
            return 0x0B  # gateway target device failed to respond
        if function_code not in SUPPORTED_FUNCTION_CODES:
            logger.debug("rig: function code %d refused (illegal function)", function_code)
            return 0x01
        return None

    def _client_left(self, client: object) -> None:
        """A connection closed: if it owned the rig, 0 V at once and the rig is free (in real time the
        watchdog, armed, still trips and latches its fault: the owner's heartbeat has stopped)."""
        if client is not self._owner:
            return
        self._owner = None
        if self.voltage:
            logger.info(
                "rig: the owning client %s disconnected at %.4g V: voltage set to 0 V",
                self._owner_name,
                self.voltage,
            )
        self.voltage = 0.0
        self._set("voltage_command", 0.0)
        self._publish()

    def _trip(self, what: str) -> None:
        """The watchdog trips: 0 V, the watchdog fault latched, the owner let go."""
        self._armed = False
        self.watchdog_trips += 1
        level = logging.WARNING if self.voltage else logging.INFO
        logger.log(
            level,
            "rig: %s, at %.4g V: voltage forced to 0 V, watchdog fault latched, the rig is free",
            what,
            self.voltage,
        )
        self.voltage = 0.0
        self.status |= STATUS_BITS["watchdog"]
        self._owner = None  # the owner that stopped heart-beating lets the rig go
        self._unbeaten_commands = 0
        self._set("voltage_command", 0.0)
        self._publish()

    async def _on_access(
        self,
        func_code: int,
        start_address: int,
        address: int,
        count: int,
        registers: list[int],
        set_values: list[int] | list[bool] | None,
    ) -> Any:
        """pymodbus SimDevice action: our words are the truth; sync them both ways.

        Returns None, or pymodbus's ``ExcCodes.DEVICE_BUSY`` for a write of a client that does not own the rig.
        """
        offset = self._base - start_address
        if set_values is not None:
            client = _CLIENT.get()
            if self._owner is not None and client is not self._owner:
                self.refused_writes += 1
                self._publish()
                registers[offset : offset + len(self._words)] = self._words
                logger.debug(
                    "rig: write of %s refused: %s owns the rig (%d refused)",
                    _client_name(client),
                    self._owner_name,
                    self.refused_writes,
                )
                from pymodbus.constants import ExcCodes

                return ExcCodes.DEVICE_BUSY
            if self._owner is None:
                self._owner, self._owner_name = client, _client_name(client)
                self._unbeaten_commands = 0
                logger.info("rig: owned by client %s", self._owner_name)
            words = list(self._words)
            first = address - self._base
            words[first : first + count] = [int(v) for v in set_values]
            status_reg = self.register_map["status"]
            si = status_reg.address - self._base
            if first <= si < first + count:
                if words[si] == STATUS_CLEAR and self.status & STATUS_FAULTS:
                    logger.info("rig: faults %d acknowledged by the client", self.status)
                    self.status &= ~STATUS_FAULTS
            hb_reg = self.register_map["heartbeat"]
            hi = hb_reg.address - self._base
            heartbeat = words[hi]
            beat = first <= hi < first + count and heartbeat != self._heartbeat
            vreg = self.register_map["voltage_command"]
            vi = vreg.address - self._base
            commanded = first < vi + vreg.count and vi < first + count
            if commanded:
                self.voltage = self._apply_command(self._get("voltage_command", words))
            elif self.status & STATUS_FAULTS:
                self.voltage = 0.0
            self._words = words
            self._set("voltage_command", self.voltage)
            now = asyncio.get_running_loop().time()
            if beat or (
                commanded and not self._armed
            ):  # a command arms the watchdog; only a heartbeat feeds it
                self._last_contact = now
                self._armed = self.watchdog_periods is not None
            if beat:
                self._heartbeat = heartbeat
                self._unbeaten_commands = 0
                if self.lockstep:
                    self._advance()
            elif commanded and self.lockstep and self.watchdog_periods is not None:
                self._unbeaten_commands += 1
                if self._unbeaten_commands > self.watchdog_periods:
                    self._trip(
                        f"{self._unbeaten_commands} commands in a row without a heartbeat from the owning client "
                        f"(more than {self.watchdog_periods:g})"
                    )
            self._publish()
            set_values[:] = self._words[first : first + count]  # what pymodbus stores
        registers[offset : offset + len(self._words)] = self._words
        return None

    # -- background tasks ---------------------------------------------------------------
    async def _watchdog(self) -> None:
        """Real time: trip when the owner's heartbeat has stalled for the watchdog's periods of wall-clock time."""
        assert self.watchdog_periods is not None
        limit = self.watchdog_periods * self.dt
        loop = asyncio.get_running_loop()
        while True:
            # wake when the last heartbeat would run out, not on a tick: one wake-up per few samples
            # (on a busy machine each wake-up waits its turn for a core)
            due = self._last_contact + limit if self._armed else loop.time() + limit
            await asyncio.sleep(max(0.0, due - loop.time()) + _SERVE_PENDING)
            if not (self._armed and loop.time() - self._last_contact > limit):
                continue
            # a server the machine paused may hold requests that came in time: serve them before judging
            # (a request takes several turns of the loop between its bytes and the register image)
            await asyncio.sleep(_SERVE_PENDING)
            silent = loop.time() - self._last_contact
            if self._armed and silent > limit:
                self._trip(
                    f"no heartbeat from the owning client for {silent:.3g} s, more than {self.watchdog_periods:g} "
                    f"sample periods ({limit:.3g} s)"
                )

    async def _clock(self) -> None:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        k = 0
        while True:
            k += 1
            await asyncio.sleep(max(0.0, t0 + k * self.dt - loop.time()))
            self._advance()

    async def _serve(self) -> None:
        from pymodbus.framer import FramerType
        from pymodbus.server import ModbusSerialServer, ModbusTcpServer
        from pymodbus.simulator import DataType, SimData, SimDevice

        blocks = [
            SimData(
                reg.address,
                count=reg.count,
                values=0,
                datatype=DataType.REGISTERS,
                readonly=name in _READONLY,
            )
            for name, reg in self.register_map.registers.items()
        ]
        device = SimDevice(self.register_map.device_id, simdata=blocks, action=self._on_access)
        if self.serial_port:
            server = _owned_server(ModbusSerialServer, self)(
                device,
                framer=FramerType.RTU,
                port=self.serial_port,
                baudrate=self.baudrate,
                timeout=max(self.dt, 0.05),
            )
        else:
            server = _owned_server(ModbusTcpServer, self)(device, address=(self.host, self.port))
        await server.serve_forever(background=True)  # raises if it cannot listen
        if not self.serial_port:
            self.port = server.transport.sockets[0].getsockname()[1]
        self._server = server
        self._stop_event = asyncio.Event()
        tasks = []
        if not self.lockstep:  # lock-step: the watchdog counts commands (in _on_access), not time
            tasks.append(asyncio.create_task(self._clock()))
            if self.watchdog_periods is not None:
                tasks.append(asyncio.create_task(self._watchdog()))
        logger.info(
            "rig server listening on %s (%s)", self.url, "lock-step" if self.lockstep else "real-time"
        )
        self._ready.set()
        try:
            await self._stop_event.wait()
        finally:
            for task in tasks:
                task.cancel()
            await server.shutdown()
            logger.info("rig server on %s stopped", self.url)

    def _reset_plant(self) -> None:
        self.plant.reset(seed=self.seed)
        self.plant.step(0.0)  # compile/warm up outside the first request's timeout
        self.plant.reset(seed=self.seed)
        self.voltage = self.speed = 0.0
        self.seq = self.status = 0
        self._heartbeat = None
        self._armed = False
        self._unbeaten_commands = 0
        self._owner = None
        self.refused_writes = 0
        self._words = [0] * len(self._words)
        self._publish()

    def _run_thread(self) -> None:
        try:
            asyncio.run(self._run_main())
        except BaseException as exc:  # reported to start() or logged
            self._error = exc
            if self._ready.is_set():
                logger.exception("rig server on %s failed", self.url)
        finally:
            self._ready.set()
            self._done.set()

    async def _run_main(self) -> None:
        self._loop = asyncio.get_running_loop()
        await self._serve()

    # -- public control ------------------------------------------------------------------
    def start(self, timeout: float = 10.0) -> RigServer:
        """Start serving in a background thread; return once the server listens.

        Raises
        ------
        RuntimeError
            Already running, or the server could not start (port in use, ...).
        """
        if self.running:
            raise RuntimeError(f"{self!r} is already running")
        self._reset_plant()
        self._ready.clear()
        self._done.clear()
        self._error = None
        self._thread = threading.Thread(target=self._run_thread, name=f"rig-server-{self.port}", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise RuntimeError(f"{self!r} did not start within {timeout} s")
        if self._error is not None:
            self._done.wait(timeout)
            self._thread = None
            raise RuntimeError(f"{self!r} could not start: {self._error}") from self._error
        return self

    def stop(self, timeout: float = 10.0) -> None:
        """Stop serving: close every connection and the listener, join the thread."""
        thread, loop, event = self._thread, self._loop, self._stop_event
        if thread is None:
            return
        # (our own event, not Thread.is_alive/join: a join interrupted by a signal
        # can leave the thread marked stopped on Python < 3.13)
        if loop is not None and event is not None and not self._done.is_set():
            loop.call_soon_threadsafe(event.set)
        if not self._done.wait(timeout):
            raise RuntimeError(f"{self!r} did not stop within {timeout} s")
        thread.join(timeout)
        self._thread = None
        self._loop = None
        self._stop_event = None

    @property
    def running(self) -> bool:
        """True while the server thread is serving."""
        return self._thread is not None and not self._done.is_set()

    def __enter__(self) -> RigServer:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def serve_forever(self, on_listening: Callable[[], None] | None = None) -> None:
        """Serve in the calling thread until KeyboardInterrupt or SIGTERM.

        SIGTERM is handled like Ctrl-C (when called from the main thread) from
        before the server starts, so the listener is closed cleanly either
        way. Once it listens, the objects alive (modules, the plant, the
        server) are frozen out of Python's garbage collector
        (:func:`gc.freeze`) until it stops: the process serves the rig, and a
        collection of its whole heap would hold every request behind it.
        ``on_listening`` is called once the server listens (the command
        line prints its banner there).

        Raises
        ------
        RuntimeError
            The server could not start (see :meth:`start`) or failed while serving.
        """
        import signal

        previous = None
        if threading.current_thread() is threading.main_thread():

            def _terminate(signum: int, frame: object) -> None:
                raise KeyboardInterrupt

            previous = signal.signal(signal.SIGTERM, _terminate)
        try:
            self.start()
            # this process is the rig: what start-up made (modules, the plant, the server) is frozen, so
            # no collection scans it again while requests wait (a full one took 40-170 ms on a busy machine)
            gc.collect()
            gc.freeze()
            if on_listening is not None:
                on_listening()
            while not self._done.wait(0.5):
                pass
        except KeyboardInterrupt:
            logger.info("rig server on %s: interrupted", self.url)
        finally:
            self.stop()
            gc.unfreeze()
            if previous is not None:
                signal.signal(signal.SIGTERM, previous)
        if self._error is not None:
            raise RuntimeError(f"{self!r} failed: {self._error}") from self._error


def _owned_server(base: type, rig: RigServer) -> type:
    """A pymodbus server class (``base``: TCP or serial) whose connections serve ``rig``'s rules.

    Each request runs with its connection in :data:`_CLIENT` (the owner rule), a request the rig
    does not serve (:meth:`RigServer.refusal`) is answered with its exception before it reaches
    the data (over RTU an unknown device id gets no answer), and a closed connection is reported
    to the rig.
    """
    from pymodbus.pdu import ExceptionResponse
    from pymodbus.server.requesthandler import ServerRequestHandler

    serial = rig.serial_port is not None

    class RigRequestHandler(ServerRequestHandler):
        async def handle_request(self) -> None:
            pdu = self.last_pdu
            if not pdu:
                return
            code = rig.refusal(pdu.function_code, pdu.dev_id)
            if code is not None:
                if serial and code == 0x0B:
                    return  # another device on the bus may answer
                response = ExceptionResponse(pdu.function_code, code)
                response.transaction_id = pdu.transaction_id
                response.dev_id = pdu.dev_id
                self.server_send(response, self.last_addr)
                return
            token = _CLIENT.set(self)
            try:
                await super().handle_request()
            finally:
                _CLIENT.reset(token)

        def callback_disconnected(self, exc: Exception | None) -> None:
            super().callback_disconnected(exc)
            rig._client_left(self)

    class RigModbusServer(base):
        def callback_new_connection(self) -> ServerRequestHandler:
            return RigRequestHandler(self, self.trace_packet, self.trace_pdu, self.trace_connect)

    return RigModbusServer
