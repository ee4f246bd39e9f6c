"""The Modbus register map of a rig: where each signal lives and how it is encoded.

A map names five registers (holding registers, addresses from 0), and may name a sixth:

=================  ======  =========================================================
name               access  meaning
=================  ======  =========================================================
voltage_command    write   input command [V]
heartbeat          write   counter the client increments each sample (uint16, wraps)
status             read    status/fault word (:data:`STATUS_BITS`); write 0 to clear
sequence           read    sample counter of the rig (uint16, wraps)
speed              read    measured load speed [rad/s]
refused_writes     read    optional: writes the rig refused because another client
                           owns it (uint16, wraps); the built-in map has it at 7
=================  ======  =========================================================

Each value is either ``float32`` (two registers, word order ``ABCD``: high
word first, or ``CDAB``: low word first) or a 16-bit integer (``int16`` or
``uint16``) holding ``value / scale``. The map is read from a small TOML file
(:meth:`RegisterMap.from_toml`) or taken as :meth:`RegisterMap.default`, and
written back as TOML by :meth:`RegisterMap.to_toml` (``motorid rig map``).

Example TOML::

    device_id = 1
    word_order = "CDAB"

    [registers.voltage_command]
    address = 0
    type = "float32"
    unit = "V"

    [registers.speed]
    address = 5
    type = "int16"
    scale = 0.1
    unit = "rad/s"
    min = -3000.0
    max = 3000.0
"""

from __future__ import annotations

import math
import struct
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

from motorid.errors import quoted
from motorid.inputs import read_small_file

__all__ = [
    "OPTIONAL_REGISTER_NAMES",
    "REGISTER_NAMES",
    "STATUS_BITS",
    "STATUS_CLEAR",
    "STATUS_FAULTS",
    "Register",
    "RegisterMap",
]

#: The registers every map must name.
REGISTER_NAMES = ("voltage_command", "heartbeat", "status", "sequence", "speed")
#: The registers a map may name: a map read from TOML has one only where the file names it.
OPTIONAL_REGISTER_NAMES = ("refused_writes",)
_KNOWN_NAMES = REGISTER_NAMES + OPTIONAL_REGISTER_NAMES

#: Bits of the status word.
STATUS_BITS: dict[str, int] = {
    "watchdog": 1 << 0,  # heartbeat stalled: voltage forced to 0 V (latched)
    "clamped": 1 << 1,  # the rig clamped the last command to its rating
    "plant": 1 << 2,  # the plant produced an invalid speed (latched)
    "command": 1 << 3,  # the voltage command was NaN or infinite: 0 V held (latched)
}
#: Status bits that are faults (latched until the client writes 0 to ``status``).
STATUS_FAULTS = STATUS_BITS["watchdog"] | STATUS_BITS["plant"] | STATUS_BITS["command"]
#: Value a client writes to the status register to acknowledge latched faults.
STATUS_CLEAR = 0

#: The largest register map file read [bytes] (the built-in map's TOML is about 1 kB).
MAX_MAP_BYTES = 1 << 20

RegisterType = Literal["float32", "int16", "uint16"]
WordOrder = Literal["ABCD", "CDAB"]
_TYPES: tuple[str, ...] = ("float32", "int16", "uint16")
_ORDERS: tuple[str, ...] = ("ABCD", "CDAB")
_INT_RANGE = {"int16": (-32768, 32767), "uint16": (0, 65535)}


@dataclass(frozen=True)
class Register:
    """One value in the register map.

    Parameters
    ----------
    name : str
        Signal name (one of :data:`REGISTER_NAMES` or :data:`OPTIONAL_REGISTER_NAMES`).
    address : int
        First holding register (0-based, as on the wire).
    type : {"float32", "int16", "uint16"}
        Encoding.
    scale : float
        For integer types, engineering value = raw * scale. Ignored for float32.
    word_order : {"ABCD", "CDAB"}
        For float32: ``ABCD`` sends the high word first, ``CDAB`` the low word.
    unit : str
        Unit of the engineering value (documentation only).
    min, max : float
        Valid range of the engineering value; a read outside it is an error.
    """

    name: str
    address: int
    type: RegisterType = "float32"
    scale: float = 1.0
    word_order: WordOrder = "ABCD"
    unit: str = ""
    min: float = -math.inf
    max: float = math.inf

    def __post_init__(self) -> None:
        where = f"register {self.name!r}"
        if not isinstance(self.address, int) or not 0 <= self.address <= 65535:
            raise ValueError(f"{where}: address must be an integer in 0..65535, got {quoted(self.address)}")
        if self.type not in _TYPES:
            raise ValueError(f"{where}: type must be one of {_TYPES}, got {quoted(self.type)}")
        if self.word_order not in _ORDERS:
            raise ValueError(f"{where}: word_order must be one of {_ORDERS}, got {quoted(self.word_order)}")
        if not (math.isfinite(self.scale) and self.scale != 0):
            raise ValueError(f"{where}: scale must be finite and non-zero, got {quoted(self.scale)}")
        if not self.min <= self.max:
            raise ValueError(f"{where}: min {quoted(self.min)} must not exceed max {quoted(self.max)}")
        if self.address + self.count - 1 > 65535:
            raise ValueError(f"{where}: address {self.address} + size runs past 65535")
        if self.type != "float32":  # one word: the order is meaningless, keep maps comparable
            object.__setattr__(self, "word_order", "ABCD")

    @property
    def count(self) -> int:
        """Number of 16-bit registers the value occupies."""
        return 2 if self.type == "float32" else 1

    def encode(self, value: float) -> list[int]:
        """Engineering value -> list of 16-bit register words.

        Raises
        ------
        ValueError
            The value is NaN, or does not fit the integer type at this scale.
        """
        if self.type == "float32":
            hi, lo = struct.unpack(">HH", struct.pack(">f", float(value)))
            return [hi, lo] if self.word_order == "ABCD" else [lo, hi]
        if not math.isfinite(value):
            raise ValueError(f"register {self.name!r}: cannot encode {value!r} as {self.type}")
        raw = round(float(value) / self.scale)
        lo_raw, hi_raw = _INT_RANGE[self.type]
        if not lo_raw <= raw <= hi_raw:
            raise ValueError(
                f"register {self.name!r}: {value!r} {self.unit} does not fit {self.type} "
                f"at scale {quoted(self.scale)} (raw {raw} outside {lo_raw}..{hi_raw})"
            )
        return [raw & 0xFFFF]

    def decode(self, words: Sequence[int]) -> float:
        """List of 16-bit register words -> engineering value (not range-checked)."""
        if len(words) != self.count:
            raise ValueError(f"register {self.name!r}: expected {self.count} words, got {len(words)}")
        if self.type == "float32":
            a, b = int(words[0]), int(words[1])
            hi, lo = (a, b) if self.word_order == "ABCD" else (b, a)
            return struct.unpack(">f", struct.pack(">HH", hi, lo))[0]
        raw = int(words[0]) & 0xFFFF
        if self.type == "int16" and raw >= 0x8000:
            raw -= 0x10000
        return raw * self.scale

    def check(self, value: float, where: str = "") -> float:
        """Return ``value`` if it is a valid reading, else raise ValueError naming the register."""
        if math.isnan(value) or not self.min <= value <= self.max:
            raise ValueError(
                f"{where}register {self.name!r} at address {self.address}: "
                f"value {value!r} {self.unit} is not a valid reading "
                f"(valid range {quoted(self.min)}..{quoted(self.max)})"
            )
        return value


def _default_registers(word_order: WordOrder) -> dict[str, Register]:
    return {
        "voltage_command": Register(
            "voltage_command", 0, "float32", word_order=word_order, unit="V", min=-1000.0, max=1000.0
        ),
        "heartbeat": Register("heartbeat", 2, "uint16"),
        "status": Register("status", 3, "uint16"),
        "sequence": Register("sequence", 4, "uint16"),
        "speed": Register(
            "speed", 5, "float32", word_order=word_order, unit="rad/s", min=-5000.0, max=5000.0
        ),
        "refused_writes": Register("refused_writes", 7, "uint16"),
    }


@dataclass(frozen=True)
class RegisterMap:
    """Where the rig's signals live on the Modbus device.

    Parameters
    ----------
    registers : mapping of str to Register
        One :class:`Register` for each name in :data:`REGISTER_NAMES`, and optionally for
        those in :data:`OPTIONAL_REGISTER_NAMES`.
    device_id : int
        Modbus device (unit/slave) id, 0..247.
    """

    registers: Mapping[str, Register] = field(default_factory=lambda: _default_registers("ABCD"))
    device_id: int = 1

    def __post_init__(self) -> None:
        missing = [n for n in REGISTER_NAMES if n not in self.registers]
        if missing:
            raise ValueError(f"register map: missing register(s) {missing}")
        unknown = [n for n in self.registers if n not in _KNOWN_NAMES]
        if unknown:
            raise ValueError(f"register map: unknown register(s) {unknown}; known: {_KNOWN_NAMES}")
        if not isinstance(self.device_id, int) or not 0 <= self.device_id <= 247:
            raise ValueError(f"register map: device_id must be 0..247, got {quoted(self.device_id)}")
        for name in ("heartbeat", "status", "sequence", *OPTIONAL_REGISTER_NAMES):
            reg = self.registers.get(name)
            if reg is not None and (reg.type != "uint16" or reg.scale != 1):
                raise ValueError(f"register map: {name!r} must be a uint16 with scale 1")
        used: dict[int, str] = {}
        for reg in self.registers.values():
            for a in range(reg.address, reg.address + reg.count):
                if a in used:
                    raise ValueError(f"register map: {reg.name!r} overlaps {used[a]!r} at address {a}")
                used[a] = reg.name

    def __getitem__(self, name: str) -> Register:
        return self.registers[name]

    @classmethod
    def default(cls, word_order: WordOrder = "ABCD", device_id: int = 1) -> RegisterMap:
        """The built-in map: voltage 0-1, heartbeat 2, status 3, sequence 4, speed 5-6, refused writes 7."""
        if word_order not in _ORDERS:
            raise ValueError(f"word_order must be one of {_ORDERS}, got {quoted(word_order)}")
        return cls(_default_registers(word_order), device_id)

    @property
    def span(self) -> tuple[int, int]:
        """First address and number of registers covering the whole map."""
        first = min(r.address for r in self.registers.values())
        last = max(r.address + r.count for r in self.registers.values())
        return first, last - first

    def with_word_order(self, word_order: WordOrder) -> RegisterMap:
        """A copy with every float32 register using ``word_order``."""
        regs = {n: replace(r, word_order=word_order) for n, r in self.registers.items()}
        return RegisterMap(regs, self.device_id)

    # -- TOML ------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "register map") -> RegisterMap:
        """Build a map from parsed TOML; missing registers/fields take the defaults.

        An optional register (:data:`OPTIONAL_REGISTER_NAMES`) is in the map only where ``data``
        names it (its default address could collide with a layout of the user's).
        """
        known_top = {"device_id", "word_order", "registers"}
        unknown = set(data) - known_top
        if unknown:
            raise ValueError(
                f"{source}: unknown key(s) {quoted(', '.join(sorted(unknown)))}; known: {sorted(known_top)}"
            )
        word_order = data.get("word_order", "ABCD")
        if word_order not in _ORDERS:
            raise ValueError(f"{source}: word_order must be one of {_ORDERS}, got {quoted(word_order)}")
        regs = dict(_default_registers(word_order))
        table = data.get("registers", {})
        if not isinstance(table, Mapping):
            raise ValueError(f"{source}: [registers] must be a table")
        for name in OPTIONAL_REGISTER_NAMES:
            if name not in table:
                del regs[name]
        fields = {"address", "type", "scale", "word_order", "unit", "min", "max"}
        for name, spec in table.items():
            if name not in _KNOWN_NAMES:
                raise ValueError(f"{source}: unknown register {quoted(name)}; known: {_KNOWN_NAMES}")
            if not isinstance(spec, Mapping):
                raise ValueError(f"{source}: [registers.{name}] must be a table")
            bad = set(spec) - fields
            if bad:
                raise ValueError(
                    f"{source}: [registers.{name}] unknown field(s) {sorted(bad)}; known: {sorted(fields)}"
                )
            kw = {k: spec[k] for k in spec}
            for k in ("scale", "min", "max"):
                if k in kw:
                    kw[k] = float(kw[k])
            try:
                regs[name] = replace(regs[name], **kw)
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{source}: [registers.{name}]: {exc}") from None
        try:
            return cls(regs, int(data.get("device_id", 1)))
        except ValueError as exc:
            raise ValueError(f"{source}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> RegisterMap:
        """Read a map from a TOML file (see the module docstring for the format).

        The file must be a regular file of at most :data:`MAX_MAP_BYTES` (a FIFO or a device such
        as ``/dev/zero`` is refused at once: :func:`motorid.inputs.read_small_file`).

        Raises
        ------
        motorid.errors.DataError
            The file cannot be read, is not a regular file or is too large.
        ValueError
            The file is not valid TOML, or not a valid map; the message names the file.
        """
        path = Path(path)
        raw = read_small_file(path, "register map", MAX_MAP_BYTES)
        try:
            data = tomllib.loads(raw.decode("utf-8"))
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: not UTF-8 text at byte {exc.start}") from None
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML: {exc}") from None
        return cls.from_dict(data, source=str(path))

    @classmethod
    def from_toml_text(cls, text: str) -> RegisterMap:
        """Parse a map from TOML text."""
        return cls.from_dict(tomllib.loads(text), source="register map TOML")

    def to_toml(self) -> str:
        """The map as TOML text, readable by :meth:`from_toml`."""
        lines = [
            "# motorid rig register map: Modbus holding registers, 0-based addresses",
            "# float32 takes two registers; word_order ABCD = high word first, CDAB = low word first",
            "# integer registers hold value / scale",
            f"# status bits: {', '.join(f'{k}={v}' for k, v in STATUS_BITS.items())}"
            "; write 0 to status to clear latched faults",
            "# heartbeat: the client increments it each sample; the rig zeroes the voltage and raises the",
            "# watchdog bit when it stalls for more than 3 sample periods (real time) or for more than",
            "# 3 commands in a row (lock-step, where the plant waits for the client)",
            "# the first client that writes owns the rig until its heartbeat stalls or it disconnects;",
            "# another client's writes are refused (exception 6, busy) and counted in refused_writes",
            f"device_id = {self.device_id}",
            "",
        ]
        for name in (n for n in _KNOWN_NAMES if n in self.registers):
            r = self.registers[name]
            lines.append(f"[registers.{name}]")
            lines.append(f"address = {r.address}")
            lines.append(f'type = "{r.type}"')
            if r.type == "float32":
                lines.append(f'word_order = "{r.word_order}"')
            else:
                lines.append(f"scale = {r.scale!r}")
            if r.unit:
                lines.append(f'unit = "{r.unit}"')
            if math.isfinite(r.min):
                lines.append(f"min = {r.min!r}")
            if math.isfinite(r.max):
                lines.append(f"max = {r.max!r}")
            lines.append("")
        return "\n".join(lines)
