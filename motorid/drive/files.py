"""Model files: one versioned JSON format for drive models and identified estimators.

A model file is one JSON object::

    {
      "format": "motorid-model",
      "version": 3,
      "kind": "two-mass-rig" | "rigid-drive" | "estimator",
      "model": {...},
      "card": {...} | null
    }

The ``card`` (version 3; :class:`ModelCard`) says what the model is: the unit and kind of its
input (``V``; ``%`` PWM duty, with the supply voltage where known; ``counts`` with their full
scale) and of its output (a speed or a position, in SI units), the sample time and timing it
was fitted at, the sensor the records were measured with (quantisation step, noise per speed
band), the records it was fitted on (file name, SHA-256, span) and each parameter's standard
error and whether the records determined it. ``null``: nobody said (a file of version 1 or 2,
or a model made in Python and saved without one). Every command that reads a model checks the
card against what it is given (:mod:`motorid.app.model_cards`), converting % duty and volts with
a supply voltage, refusing in one line otherwise.

- ``two-mass-rig``: ``model`` is :meth:`TwoMassRig.to_dict
  <motorid.drive.two_mass.TwoMassRig.to_dict>`, every parameter in SI units (the
  table of :class:`~motorid.drive.two_mass.TwoMassRig`), the friction on its masses as
  ``{"effects": [...], "params": {...}, "side": ..., "stribeck_shape": ...}``
  (:class:`~motorid.drive.friction.Friction`: the effects' names and parameters, as a
  rigid drive's), amplifier, tachogenerator, A/D converter and encoder; ``null`` for an
  infinite amplifier saturation. Version 1 wrote the friction as eq. (11)'s laws
  ``{"kind": ..., <α parameters>}``; they are read as their effects
  (:func:`~motorid.drive.friction.friction_from_dict`).
- ``rigid-drive``: ``model`` is :meth:`RigidDrive.to_dict
  <motorid.drive.rigid.RigidDrive.to_dict>`: ``effects`` (names), ``params`` (inertia,
  input gain and each effect's parameters, SI units), ``dt`` and ``stribeck_shape``;
  what ``motorid doctor --save-model`` writes.
- ``estimator``: ``model`` is :meth:`Estimator.to_dict
  <motorid.estimators.base.Estimator.to_dict>`, ``{"estimator": NAME, "settings":
  {...}, "state": {...}}``: the registered name, the constructor arguments
  (``get_params()``) and what the filter has learnt (``get_state()``: ``x``, ``P`` and
  what the next sample needs), so the reloaded estimator has the same ``params``,
  gives the same ``simulate(u)`` bit for bit and continues filtering as the saved one
  would. Saved: ``arx-rls``, ``hammerstein-rls`` (built-in basis functions),
  ``friction-ekf`` and ``friction-ukf`` (with their rig), and any registered estimator
  class that implements ``get_state`` and ``set_state``.

Every key is required and no other is allowed. :func:`load_model` checks the whole
file before it builds anything, and a bad file (not JSON, another format, a newer or
unknown version, a missing or unknown key, a wrong type, NaN, a value out of range
such as a negative inertia, an unknown effect) raises one
:class:`~motorid.errors.DataError` naming the file and the key, e.g.
``rig.json: model.J_m: J_m must be > 0, got -1.0``. Nothing a file says is trusted
with memory or time: the file is a regular file (a FIFO or a device such as ``/dev/zero`` is
refused before it is read: :func:`motorid.inputs.read_small_file`, as every small file a command
reads) of at most :data:`LARGEST_FILE` bytes, its JSON at most
32 levels deep with integers within ±2**53 (:mod:`motorid.json_input`), every drive
parameter within its physical range (:mod:`motorid.drive.ranges`), every size an
array is allocated with bounded (NIS window, delay line, orders, basis) before the
array is made, and a covariance symmetric positive semi-definite within 1e-9
relative (:func:`~motorid.estimators.base.check_covariance`).

Each kind is read and written by the class that owns it, through a registry of kinds
(:func:`register_kind`): the drive models register ``two-mass-rig`` and
``rigid-drive`` when :mod:`motorid.drive` is imported (which happens before this
module runs, as it is the package's own), the estimators register ``estimator``
when :mod:`motorid.estimators` is imported; the drive never imports the estimators.
``motorid.load_model`` and ``motorid.save_model`` import both.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motorid.errors import DataError, ModelFileError
from motorid.inputs import read_small_file
from motorid.json_input import boolean, integer, key_path, number, object_keys, parse_json, shown, text
from motorid.outputs import write_file

logger = logging.getLogger(__name__)

__all__ = [
    "FORMAT",
    "KIND_ESTIMATOR",
    "KIND_RIG",
    "KIND_RIGID",
    "LARGEST_FILE",
    "VERSION",
    "ModelCard",
    "ModelFile",
    "ModelKind",
    "file_sha256",
    "load_model",
    "model_file",
    "model_from_dict",
    "model_to_dict",
    "read_model_file",
    "register_kind",
    "save_model",
    "write_model_file",
]

#: The ``format`` name of a model file.
FORMAT = "motorid-model"
#: The newest ``version`` this motorid writes and reads (2: a rig's friction as effects; 3: the
#: model's card, :class:`ModelCard`).
VERSION = 3
#: The ``kind`` of a model file for each kind of model.
KIND_RIG = "two-mass-rig"
KIND_RIGID = "rigid-drive"
KIND_ESTIMATOR = "estimator"
#: Largest model file [bytes]: an estimator of the most parameters (1000) writes a covariance of
#: 10**6 numbers, about 25 MB.
LARGEST_FILE = 64 * 2**20


@dataclass(frozen=True)
class ModelKind:
    """One kind of model file: the class whose objects it holds, and how they are written and read.

    Parameters
    ----------
    kind : str
        The file's ``kind``.
    cls : type
        The class of the models of this kind (subclasses included).
    to_dict : callable
        A model -> its description, the file's ``model`` (a ValueError for a model that
        cannot be saved).
    from_dict : callable
        ``(description, where)`` -> the model; ``where`` is the description's path in its
        file, named with the key in a :class:`~motorid.errors.ModelFileError`.
    """

    kind: str
    cls: type
    to_dict: Callable[[Any], dict[str, Any]]
    from_dict: Callable[[Any, str], Any]


_KINDS: dict[str, ModelKind] = {}

#: Kinds of a model's input by its unit (after reading: :func:`motorid.units.input_factor`).
INPUT_KINDS = {"V": "voltage", "%": "duty", "counts": "duty counts"}
#: Kinds of a model's output by its SI unit.
OUTPUT_KINDS = {"rad/s": "speed", "m/s": "speed", "rad": "position", "m": "position"}
#: Timings of a record (:data:`motorid.io.records.TIMINGS`).
CARD_TIMINGS = ("hold", "sampled")
#: Most records and sensor bands a card lists.
LONGEST_LIST = 10_000


@dataclass(frozen=True)
class ModelCard:
    """What a model is: the units and kinds of its input and output, its timing, the sensor and
    records it was fitted on, its parameters' uncertainty. Every field may be None: unknown.

    Attributes
    ----------
    input_unit : {"V", "%", "counts"} or None
        The unit of the input the model was fitted on: volts, PWM duty [%] or PWM counts.
    supply_voltage : float or None
        The drive's supply voltage [V] where known: ``u_V = u_% V_s / 100``.
    input_full_scale : float or None
        The count of full duty [counts], for an input in counts.
    output_unit : {"rad/s", "m/s", "rad", "m"} or None
        The SI unit of the output: a speed (rad/s, m/s) or a position (rad, m).
    dt : float or None
        The sample time of the records [s].
    timing : {"hold", "sampled"} or None
        Their input/output timing (:data:`motorid.io.records.TIMINGS`).
    quantisation_step : float or None
        The speed sensor's step [output unit, or its speed for a position], e.g. an encoder's
        one count per sample.
    noise_bands : tuple of dict
        The sensor's noise per speed band: ``speed_from``, ``speed_to`` [speed unit], ``std``
        [speed unit] (the doctor's measurement); empty: unknown.
    records : tuple of dict
        The records fitted on: ``file`` (its name), ``sha256`` (of its bytes), ``samples``,
        ``start`` and ``stop`` [s].
    parameters : dict
        Per parameter name: ``standard_error`` [the parameter's unit] (None: none computed) and
        ``determined`` (whether the records determined it).
    """

    input_unit: str | None = None
    supply_voltage: float | None = None
    input_full_scale: float | None = None
    output_unit: str | None = None
    dt: float | None = None
    timing: str | None = None
    quantisation_step: float | None = None
    noise_bands: tuple[dict[str, float], ...] = ()
    records: tuple[dict[str, Any], ...] = ()
    parameters: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def input_kind(self) -> str | None:
        """``voltage``, ``duty`` or ``duty counts`` (None: unknown)."""
        return INPUT_KINDS.get(self.input_unit) if self.input_unit else None

    @property
    def output_kind(self) -> str | None:
        """``speed`` or ``position`` (None: unknown)."""
        return OUTPUT_KINDS.get(self.output_unit) if self.output_unit else None

    def input_words(self) -> str:
        """The input in words, e.g. ``% duty (supply 15 V)``."""
        if self.input_unit is None:
            return "an input in no named unit"
        words = {"V": "V", "%": "% duty", "counts": "PWM counts"}[self.input_unit]
        if self.input_unit == "counts" and self.input_full_scale is not None:
            words += f" (full scale {self.input_full_scale:g})"
        if self.supply_voltage is not None:
            words += f" (supply {self.supply_voltage:g} V)"
        return words

    def to_dict(self) -> dict[str, Any]:
        """The file's ``card``: every field, the kinds beside the units."""
        return {
            "input": {"unit": self.input_unit, "kind": self.input_kind, "supply_voltage": self.supply_voltage,
                      "full_scale": self.input_full_scale},
            "output": {"unit": self.output_unit, "kind": self.output_kind},
            "dt": self.dt,
            "timing": self.timing,
            "sensor": {"quantisation_step": self.quantisation_step,
                       "noise_bands": [dict(band) for band in self.noise_bands]},
            "records": [dict(record) for record in self.records],
            "parameters": {name: dict(entry) for name, entry in self.parameters.items()},
        }  # fmt: skip

    @classmethod
    def from_dict(cls, data: Any, where: str = "card") -> ModelCard:
        """The card of a model file, checked key by key (:class:`~motorid.errors.ModelFileError`
        naming the key)."""
        object_keys(data, ("input", "output", "dt", "timing", "sensor", "records", "parameters"), where)
        given = object_keys(
            data["input"], ("unit", "kind", "supply_voltage", "full_scale"), key_path(where, "input")
        )
        input_unit = _choice(given["unit"], key_path(where, "input.unit"), tuple(INPUT_KINDS))
        if given["kind"] != (INPUT_KINDS.get(input_unit) if input_unit else None):
            raise ModelFileError(key_path(where, "input.kind"),
                                 f"must be {shown(INPUT_KINDS.get(input_unit) if input_unit else None)} for "
                                 f"the unit {shown(input_unit)}, got {shown(given['kind'])}")  # fmt: skip
        output = object_keys(data["output"], ("unit", "kind"), key_path(where, "output"))
        output_unit = _choice(output["unit"], key_path(where, "output.unit"), tuple(OUTPUT_KINDS))
        if output["kind"] != (OUTPUT_KINDS.get(output_unit) if output_unit else None):
            raise ModelFileError(key_path(where, "output.kind"),
                                 f"must be {shown(OUTPUT_KINDS.get(output_unit) if output_unit else None)} "
                                 f"for the unit {shown(output_unit)}, got {shown(output['kind'])}")  # fmt: skip
        sensor = object_keys(data["sensor"], ("quantisation_step", "noise_bands"), key_path(where, "sensor"))
        bands = _items(sensor["noise_bands"], key_path(where, "sensor.noise_bands"))
        noise_bands = tuple(
            {name: _non_negative(object_keys(band, ("speed_from", "speed_to", "std"), key)[name], key_path(key, name))
             for name in ("speed_from", "speed_to", "std")}
            for key, band in bands
        )  # fmt: skip
        records = []
        for key, record in _items(data["records"], key_path(where, "records")):
            entry = object_keys(record, ("file", "sha256", "samples", "start", "stop"), key)
            digest = text(entry["sha256"], key_path(key, "sha256"))
            if len(digest) != 64 or any(c not in "0123456789abcdef" for c in digest):
                raise ModelFileError(
                    key_path(key, "sha256"), f"must be 64 hexadecimal digits, got {shown(digest)}"
                )
            records.append({"file": text(entry["file"], key_path(key, "file")), "sha256": digest,
                            "samples": integer(entry["samples"], key_path(key, "samples")),
                            "start": number(entry["start"], key_path(key, "start")),
                            "stop": number(entry["stop"], key_path(key, "stop"))})  # fmt: skip
        parameters: dict[str, dict[str, Any]] = {}
        table = data["parameters"]
        if not isinstance(table, dict):
            raise ModelFileError(key_path(where, "parameters"), f"must be a JSON object, got {shown(table)}")
        for name, entry in table.items():
            key = key_path(key_path(where, "parameters"), text(name, key_path(where, "parameters")))
            entry = object_keys(entry, ("standard_error", "determined"), key)
            error = entry["standard_error"]
            parameters[name] = {
                "standard_error": None
                if error is None
                else _non_negative(error, key_path(key, "standard_error")),
                "determined": boolean(entry["determined"], key_path(key, "determined")),
            }
        return cls(
            input_unit=input_unit,
            supply_voltage=_optional_positive(given["supply_voltage"], key_path(where, "input.supply_voltage")),
            input_full_scale=_optional_positive(given["full_scale"], key_path(where, "input.full_scale")),
            output_unit=output_unit,
            dt=_optional_positive(data["dt"], key_path(where, "dt")),
            timing=_choice(data["timing"], key_path(where, "timing"), CARD_TIMINGS),
            quantisation_step=_optional_positive(sensor["quantisation_step"], key_path(where, "sensor.quantisation_step")),
            noise_bands=noise_bands,
            records=tuple(records),
            parameters=parameters,
        )  # fmt: skip


def _choice(value: Any, key: str, known: tuple[str, ...]) -> str | None:
    if value is None:
        return None
    if value not in known:
        raise ModelFileError(key, f"must be one of {', '.join(known)} or null, got {shown(value)}")
    return value


def _non_negative(value: Any, key: str) -> float:
    number_ = number(value, key)
    if number_ < 0:
        raise ModelFileError(key, f"must be >= 0, got {shown(value)}")
    return number_


def _optional_positive(value: Any, key: str) -> float | None:
    if value is None:
        return None
    number_ = number(value, key)
    if not number_ > 0:
        raise ModelFileError(key, f"must be > 0 or null, got {shown(value)}")
    return number_


def _items(value: Any, key: str) -> list[tuple[str, Any]]:
    if not isinstance(value, list):
        raise ModelFileError(key, f"must be a JSON list, got {shown(value)}")
    if len(value) > LONGEST_LIST:
        raise ModelFileError(key, f"must hold at most {LONGEST_LIST} entries, got {len(value)}")
    return [(f"{key}[{i}]", item) for i, item in enumerate(value)]


def file_sha256(path: str | os.PathLike[str]) -> str:
    """The SHA-256 of the bytes of the file ``path``, as 64 hexadecimal digits (a record's
    fingerprint in a :class:`ModelCard`).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    """
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


@dataclass(frozen=True)
class ModelFile:
    """A model file read: the model and its card.

    Attributes
    ----------
    model : TwoMassRig, RigidDrive or Estimator
        What :func:`load_model` returns.
    card : ModelCard or None
        What the file says the model is; None for a file of version 1 or 2, or one saved
        without a card.
    version : int
        The file's version.
    source : str
        The file's name, for messages.
    """

    model: Any
    card: ModelCard | None
    version: int
    source: str


def register_kind(
    kind: str,
    cls: type,
    from_dict: Callable[[Any, str], Any],
    to_dict: Callable[[Any], dict[str, Any]] | None = None,
) -> None:
    """Make model files of ``kind`` hold objects of ``cls``: written by ``to_dict``, read by ``from_dict``.

    Registering a kind again replaces it (a module imported twice, e.g. after a reload).

    Parameters
    ----------
    kind : str
        The file's ``kind``.
    cls : type
        The class whose objects (subclasses included) the kind holds.
    from_dict : callable
        ``(description, where)`` -> the model, raising :class:`~motorid.errors.ModelFileError`
        naming the key for a bad description.
    to_dict : callable, optional
        A model -> its description; ``cls.to_dict`` by default.
    """
    _KINDS[kind] = ModelKind(kind, cls, to_dict or cls.to_dict, from_dict)  # type: ignore[attr-defined]


def model_file(kind: str, body: dict[str, Any], card: ModelCard | None = None) -> dict[str, Any]:
    """The JSON object of a model file of ``kind`` holding ``body``.

    Parameters
    ----------
    kind : str
        :data:`KIND_RIG`, :data:`KIND_RIGID` or :data:`KIND_ESTIMATOR`.
    body : dict
        The model's description (its ``to_dict()``), the file's ``model``.
    card : ModelCard, optional
        What the model is (its units, timing, sensor, records); None: unknown.

    Returns
    -------
    dict
        ``{"format": FORMAT, "version": VERSION, "kind": kind, "model": body, "card": ...}``.
    """
    return {"format": FORMAT, "version": VERSION, "kind": kind, "model": body,
            "card": None if card is None else card.to_dict()}  # fmt: skip


def write_model_file(file: dict[str, Any], path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
    """Write the model file ``file`` (:func:`model_file`) at ``path``, whole (:func:`motorid.outputs.write_file`).

    Parameters
    ----------
    file : dict
        The model file's JSON object.
    path : str or os.PathLike
        Where to write it.
    overwrite : bool
        False refuses an existing file, also one another process created meanwhile
        (:class:`~motorid.errors.OutputError`, as for a full disk; ``path`` is then as it
        was).
    """
    content = json.dumps(file, indent=2, allow_nan=False) + "\n"
    write_file(path, lambda fh: fh.write(content), overwrite=overwrite)
    logger.info("wrote model file %s (%s)", path, file["kind"])


# --------------------------------------------------------------------------- writing
def model_to_dict(model: Any, card: ModelCard | None = None) -> dict[str, Any]:
    """The JSON object of a model file for ``model`` (a drive model or a saved estimator).

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or Estimator
        What to save: an object of a registered kind's class.
    card : ModelCard, optional
        What the model is; None: unknown.

    Raises
    ------
    ValueError
        For an object that has no model file form (another type, an estimator with
        a custom basis function, a filter between ``predict`` and ``update``).
    """
    for entry in _KINDS.values():
        if isinstance(model, entry.cls):
            return model_file(entry.kind, entry.to_dict(model), card)
    raise ValueError(
        f"cannot save a {type(model).__name__} as a model file: give a TwoMassRig, a RigidDrive "
        "or an estimator"
    )


def save_model(
    model: Any, path: str | os.PathLike[str], *, overwrite: bool = True, card: ModelCard | None = None
) -> None:
    """Write ``model`` as a model file at ``path``, whole (:func:`motorid.outputs.write_file`).

    ``overwrite=False`` refuses an existing file, also one another process created
    meanwhile (:class:`~motorid.errors.OutputError`, as for a full disk; ``path``
    is then as it was).

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or Estimator
        What to save (:func:`model_to_dict`).
    path : str or os.PathLike
        The file to write.
    overwrite : bool
        False refuses an existing file.
    card : ModelCard, optional
        What the model is (units, timing, sensor, records); None: unknown.
    """
    write_model_file(model_to_dict(model, card), path, overwrite=overwrite)


# --------------------------------------------------------------------------- reading
def load_model(path: str | os.PathLike[str]) -> Any:
    """Read a model file: a :class:`~motorid.drive.two_mass.TwoMassRig`, a
    :class:`~motorid.drive.rigid.RigidDrive` or an estimator (its card: :func:`read_model_file`).

    Parameters
    ----------
    path : str or os.PathLike
        The model file, at most :data:`LARGEST_FILE` bytes of UTF-8 JSON.

    Raises
    ------
    DataError
        Naming the file and the key for an unreadable or bad file (module docstring).
    """
    return read_model_file(path).model


def read_model_file(path: str | os.PathLike[str]) -> ModelFile:
    """Read a model file: the model and its card (:class:`ModelFile`).

    Parameters
    ----------
    path : str or os.PathLike
        The model file, at most :data:`LARGEST_FILE` bytes of UTF-8 JSON.

    Raises
    ------
    DataError
        Naming the file and the key for an unreadable or bad file (module docstring).
    """
    source = Path(path)
    raw = read_small_file(source, "model file", LARGEST_FILE)  # a FIFO or a device is refused unopened
    try:
        content = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise DataError(f"{source}: not a model file (not UTF-8 text)") from None
    data = parse_json(content, str(source), invalid="not a model file: invalid JSON")
    model = model_from_dict(data, source=str(source))
    card = None
    if data["version"] >= 3 and data["card"] is not None:
        try:
            card = ModelCard.from_dict(data["card"])
        except ModelFileError as exc:
            raise DataError(f"{source}: {exc}") from None
    return ModelFile(model, card, data["version"], source.name)


def model_from_dict(data: Any, source: str = "model") -> Any:
    """Build the model a model file's JSON object describes (see :func:`load_model`).

    Parameters
    ----------
    data : Any
        The file's JSON object (``format``, ``version``, ``kind``, ``model``).
    source : str
        Names the file in the error messages.

    Raises
    ------
    DataError
        Naming ``source`` and the key.
    """
    try:
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise DataError(f'{source}: not a motorid model file (no "format": "{FORMAT}")')
        version = data.get("version")
        if isinstance(version, bool) or not isinstance(version, int):
            raise DataError(f"{source}: version must be an integer, got {shown(version)}")
        if version > VERSION:
            raise DataError(
                f"{source}: model file version {version} is newer than this motorid reads "
                f"(up to {VERSION}); upgrade motorid to read it"
            )
        if version < 1:
            raise DataError(f"{source}: unknown model file version {version} (known: 1 to {VERSION})")
        object_keys(data, ("format", "version", "kind", "model", *(("card",) if version >= 3 else ())), "")
        if version >= 3 and data["card"] is not None:
            ModelCard.from_dict(data["card"])  # a bad card is named before the model is built
        kind = text(data["kind"], "kind")
        if kind not in _KINDS:
            raise ModelFileError("kind", f"unknown model kind {kind!r} (known: {', '.join(_KINDS)})")
        return _KINDS[kind].from_dict(data["model"], "model")
    except ModelFileError as exc:
        raise DataError(f"{source}: {exc}") from None
