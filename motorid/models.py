"""Model files: one versioned JSON format for drive models and identified estimators.

A model file is one JSON object::

    {
      "format": "motorid-model",
      "version": 1,
      "kind": "two-mass-rig" | "rigid-drive" | "estimator",
      "model": {...}
    }

- ``two-mass-rig``: ``model`` is :meth:`TwoMassRig.to_dict
  <motorid.drive.two_mass.TwoMassRig.to_dict>`, every parameter in SI units (the
  table of :class:`~motorid.drive.two_mass.TwoMassRig`), its friction laws as
  ``{"kind": ..., <parameters>}``, amplifier, tachogenerator, A/D converter and
  encoder; ``null`` for an infinite amplifier saturation.
- ``rigid-drive``: ``model`` is :meth:`RigidDrive.to_dict
  <motorid.drive.rigid.RigidDrive.to_dict>`: ``effects`` (names), ``params`` (inertia,
  input gain and each effect's parameters, SI units), ``dt`` and ``stribeck_shape``;
  what ``motorid doctor --save-model`` writes.
- ``estimator``: ``model`` is ``{"estimator": NAME, "settings": {...}, "state":
  {...}}``: the registered name, the constructor arguments and what the filter has
  learnt (``x``, ``P`` and what the next sample needs), so the reloaded estimator
  has the same ``params``, gives the same ``simulate(u)`` bit for bit and continues
  filtering as the saved one would. Saved: ``arx-rls``, ``hammerstein-rls`` (built-in
  basis functions), ``friction-ekf`` and ``friction-ukf`` (with their rig).

Every key is required and no other is allowed. :func:`load_model` checks the whole
file before it builds anything, and a bad file (not JSON, another format, a newer or
unknown version, a missing or unknown key, a wrong type, NaN, a value out of range
such as a negative inertia, an unknown friction law) raises one
:class:`~motorid.errors.DataError` naming the file and the key, e.g.
``rig.json: model.J_m: J_m must be > 0, got -1.0``. Nothing a file says is trusted
with memory or time: the file is at most :data:`LARGEST_FILE` bytes, its JSON at most
32 levels deep with integers within ±2**53 (:mod:`motorid.json_input`), every drive
parameter within its physical range (:mod:`motorid.drive.ranges`), every size an
array is allocated with bounded (NIS window, delay line, orders, basis) before the
array is made, and a covariance symmetric positive semi-definite within 1e-9
relative (:func:`~motorid.estimators.base.check_covariance`).

This module sits above the drive models and the estimators, because a model file holds
either a drive model (:mod:`motorid.drive`) or an estimator
(:mod:`motorid.estimators`), and the drive must not import the estimators. A drive
model reads and writes its own description (``TwoMassRig.from_dict``,
``RigidDrive.save``; the envelope in :mod:`motorid.drive.files`, the checked values
in :mod:`motorid.json_input`) and an estimator writes its own (``Estimator.to_dict``,
``Estimator.save``), so neither imports this module; reading an estimator back is
done here.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from motorid.drive.files import (
    FORMAT,
    KIND_ESTIMATOR,
    KIND_RIG,
    KIND_RIGID,
    VERSION,
    model_file,
    write_model_file,
)
from motorid.drive.rigid import RigidDrive
from motorid.drive.two_mass import TwoMassRig
from motorid.errors import DataError, ModelFileError
from motorid.json_input import (
    boolean,
    build,
    float_array,
    integer,
    key_path,
    number,
    object_keys,
    parse_json,
    shown,
    text,
)

__all__ = [
    "FORMAT",
    "VERSION",
    "load_model",
    "model_from_dict",
    "model_to_dict",
    "save_model",
]


#: Largest model file [bytes]: an estimator of the most parameters (1000) writes a covariance of
#: 10**6 numbers, about 25 MB.
LARGEST_FILE = 64 * 2**20


# --------------------------------------------------------------------------- writing
def model_to_dict(model: Any) -> dict[str, Any]:
    """The JSON object of a model file for ``model`` (a rig or a saved estimator).

    Parameters
    ----------
    model : TwoMassRig, RigidDrive or Estimator
        What to save.

    Raises
    ------
    ValueError
        For an object that has no model file form (another type, an estimator with
        a custom basis function, a filter between ``predict`` and ``update``).
    """
    if isinstance(model, TwoMassRig):
        return model_file(KIND_RIG, model.to_dict())
    if isinstance(model, RigidDrive):
        model.check_physical()
        return model_file(KIND_RIGID, model.to_dict())
    from motorid.estimators.base import Estimator

    if isinstance(model, Estimator):
        return model_file(KIND_ESTIMATOR, model.to_dict())
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
        if kind == KIND_RIG:
            return TwoMassRig.from_dict(data["model"], "model")
        if kind == KIND_RIGID:
            return RigidDrive.from_dict(data["model"], "model")
        if kind == KIND_ESTIMATOR:
            return _estimator(data["model"], "model")
        raise ModelFileError(
            "kind", f"unknown model kind {kind!r} (known: {KIND_RIG}, {KIND_RIGID}, {KIND_ESTIMATOR})"
        )
    except ModelFileError as exc:
        raise DataError(f"{source}: {exc}") from None


def _estimator(data: Any, where: str) -> Any:
    from motorid.estimators import ARXRLS, FrictionEKF, FrictionUKF, HammersteinRLS

    object_keys(data, ("estimator", "settings", "state"), where)
    classes = {cls.name: cls for cls in (ARXRLS, HammersteinRLS, FrictionEKF, FrictionUKF)}
    name = text(data["estimator"], key_path(where, "estimator"))
    if name not in classes:
        raise ModelFileError(
            key_path(where, "estimator"), f"unknown estimator {name!r} (known: {', '.join(classes)})"
        )
    cls = classes[name]
    if cls in (ARXRLS, HammersteinRLS):
        return _rls(cls, data["settings"], data["state"], where)
    return _friction_filter(cls, data["settings"], data["state"], where)


def _rls(cls: Any, settings: Any, state: Any, where: str) -> Any:
    from motorid.estimators import HammersteinRLS
    from motorid.estimators.base import LARGEST_VALUE, check_covariance

    s_where, x_where = key_path(where, "settings"), key_path(where, "state")
    names = ["na", "nb", "lam", "delta", "direct_term", "max_trace", "R", "x0"]
    if cls is HammersteinRLS:
        names += ["basis", "gamma_method"]
    object_keys(settings, names, s_where)
    kw: dict[str, Any] = {
        "na": integer(settings["na"], key_path(s_where, "na")),
        "nb": integer(settings["nb"], key_path(s_where, "nb")),
        "lam": number(settings["lam"], key_path(s_where, "lam")),
        "delta": number(settings["delta"], key_path(s_where, "delta")),
        "direct_term": boolean(settings["direct_term"], key_path(s_where, "direct_term")),
        "max_trace": number(settings["max_trace"], key_path(s_where, "max_trace"), none_is=math.inf),
        "R": number(settings["R"], key_path(s_where, "R")),
    }
    if cls is HammersteinRLS:
        kw["basis"] = text(settings["basis"], key_path(s_where, "basis"))
        kw["gamma_method"] = text(settings["gamma_method"], key_path(s_where, "gamma_method"))
    x0 = settings["x0"]
    if not isinstance(x0, list):
        raise ModelFileError(key_path(s_where, "x0"), f"must be a list of numbers, got {shown(x0)}")
    kw["x0"] = float_array(x0, key_path(s_where, "x0"), (len(x0),), LARGEST_VALUE)
    est = build(cls, kw, s_where)
    n = est.dim_x
    object_keys(state, ("x", "P", "y_history", "g_history", "sample_index"), x_where)
    x = float_array(state["x"], key_path(x_where, "x"), (n,), LARGEST_VALUE)
    P = float_array(state["P"], key_path(x_where, "P"), (n, n))
    try:
        P = check_covariance("P", P)
    except ValueError as exc:
        raise ModelFileError(key_path(x_where, "P"), str(exc)) from None
    y_history = float_array(
        state["y_history"], key_path(x_where, "y_history"), est.y_history.shape, LARGEST_VALUE
    )
    g_history = float_array(
        state["g_history"], key_path(x_where, "g_history"), est.g_history.shape, LARGEST_VALUE
    )
    sample_index = integer(state["sample_index"], key_path(x_where, "sample_index"))
    if sample_index < 0:
        raise ModelFileError(key_path(x_where, "sample_index"), f"must be >= 0, got {sample_index}")
    est.x = est.x_prior = est.x_post = x
    est.P = est.P_prior = est.P_post = P
    est.y_history, est.g_history = y_history, g_history
    est.sample_index = sample_index
    return est


def _friction_filter(cls: Any, settings: Any, state: Any, where: str) -> Any:
    s_where, x_where = key_path(where, "settings"), key_path(where, "state")
    annotations = cls.parameter_annotations()
    object_keys(settings, list(annotations), s_where)
    kw: dict[str, Any] = {}
    for name, annotation in annotations.items():
        key, value = key_path(s_where, name), settings[name]
        if name == "rig":
            # a filter's rig is a two-mass rig or a rigid drive (whose description has ``effects``)
            if value is None:
                kw[name] = None
            elif isinstance(value, dict) and "effects" in value:
                kw[name] = RigidDrive.from_dict(value, key)
            else:
                kw[name] = TwoMassRig.from_dict(value, key)
        elif value is None and "None" in annotation:
            kw[name] = None
        elif annotation.startswith("bool"):
            kw[name] = boolean(value, key)
        elif annotation.startswith("int"):
            kw[name] = integer(value, key)
        elif annotation.startswith("float"):
            kw[name] = number(value, key)
        else:  # a Literal of names
            kw[name] = text(value, key)
    est = build(cls, kw, s_where)
    n, window = est.dim_x, est.nis_window
    fixed = ("x", "P", "sample_index", "nis_ring", "nis_count", "nis_mean", "diverged")
    fresh = est.get_state()  # a rigid drive with a delay or lag adds its input path's memory
    memory = {k: np.shape(v) for k, v in fresh.items() if k not in fixed}
    object_keys(state, (*fixed, *memory), x_where)
    values = {
        "x": float_array(state["x"], key_path(x_where, "x"), (n,)),
        "P": float_array(state["P"], key_path(x_where, "P"), (n, n)),
        "nis_ring": float_array(state["nis_ring"], key_path(x_where, "nis_ring"), (window,)),
        "sample_index": integer(state["sample_index"], key_path(x_where, "sample_index")),
        "nis_count": integer(state["nis_count"], key_path(x_where, "nis_count")),
        "nis_mean": number(state["nis_mean"], key_path(x_where, "nis_mean"), none_is=math.nan),
        "diverged": boolean(state["diverged"], key_path(x_where, "diverged")),
        **{k: float_array(state[k], key_path(x_where, k), shape) for k, shape in memory.items()},
    }
    try:
        est.set_state(values)
    except ValueError as exc:
        raise ModelFileError(x_where, str(exc)) from None
    return est
