"""Model files: one versioned JSON format for drive models and identified estimators.

A model file is one JSON object::

    {
      "format": "motorid-model",
      "version": 2,
      "kind": "two-mass-rig" | "rigid-drive" | "estimator",
      "model": {...}
    }

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
with memory or time: the file is at most :data:`LARGEST_FILE` bytes, its JSON at most
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

import json
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motorid.errors import DataError, ModelFileError
from motorid.json_input import object_keys, parse_json, shown, text
from motorid.outputs import write_file

logger = logging.getLogger(__name__)

__all__ = [
    "FORMAT",
    "KIND_ESTIMATOR",
    "KIND_RIG",
    "KIND_RIGID",
    "LARGEST_FILE",
    "VERSION",
    "ModelKind",
    "load_model",
    "model_file",
    "model_from_dict",
    "model_to_dict",
    "register_kind",
    "save_model",
    "write_model_file",
]

#: The ``format`` name of a model file.
FORMAT = "motorid-model"
#: The newest ``version`` this motorid writes and reads (2: a rig's friction as effects).
VERSION = 2
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


def model_file(kind: str, body: dict[str, Any]) -> dict[str, Any]:
    """The JSON object of a model file of ``kind`` holding ``body``.

    Parameters
    ----------
    kind : str
        :data:`KIND_RIG`, :data:`KIND_RIGID` or :data:`KIND_ESTIMATOR`.
    body : dict
        The model's description (its ``to_dict()``), the file's ``model``.

    Returns
    -------
    dict
        ``{"format": FORMAT, "version": VERSION, "kind": kind, "model": body}``.
    """
    return {"format": FORMAT, "version": VERSION, "kind": kind, "model": body}


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
def model_to_dict(model: Any) -> dict[str, Any]:
    """The JSON object of a model file for ``model`` (a drive model or a saved estimator).

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or Estimator
        What to save: an object of a registered kind's class.

    Raises
    ------
    ValueError
        For an object that has no model file form (another type, an estimator with
        a custom basis function, a filter between ``predict`` and ``update``).
    """
    for entry in _KINDS.values():
        if isinstance(model, entry.cls):
            return model_file(entry.kind, entry.to_dict(model))
    raise ValueError(
        f"cannot save a {type(model).__name__} as a model file: give a TwoMassRig, a RigidDrive "
        "or an estimator"
    )


def save_model(model: Any, path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
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
    """
    write_model_file(model_to_dict(model), path, overwrite=overwrite)


# --------------------------------------------------------------------------- reading
def load_model(path: str | os.PathLike[str]) -> Any:
    """Read a model file: a :class:`~motorid.drive.two_mass.TwoMassRig`, a
    :class:`~motorid.drive.rigid.RigidDrive` or an estimator.

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
    try:
        size = source.stat().st_size
        if not source.is_file():  # a FIFO or a device would block or never end
            raise DataError(f"{source}: cannot read the model file: not a regular file")
        if size > LARGEST_FILE:
            raise DataError(
                f"{source}: not a model file: {size} bytes, more than the {LARGEST_FILE} a model file takes"
            )
        content = source.read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"{source}: cannot read the model file: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise DataError(f"{source}: not a model file (not UTF-8 text)") from None
    data = parse_json(content, str(source), invalid="not a model file: invalid JSON")
    return model_from_dict(data, source=str(source))


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
        object_keys(data, ("format", "version", "kind", "model"), "")
        kind = text(data["kind"], "kind")
        if kind not in _KINDS:
            raise ModelFileError("kind", f"unknown model kind {kind!r} (known: {', '.join(_KINDS)})")
        return _KINDS[kind].from_dict(data["model"], "model")
    except ModelFileError as exc:
        raise DataError(f"{source}: {exc}") from None
