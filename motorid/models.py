"""Model files: one versioned JSON format for drive models and identified estimators.

A model file is one JSON object::

    {
      "format": "motorid-model",
      "version": 1,
      "kind": "two-mass-rig" | "rigid-drive" | "estimator",
      "model": {...}
    }

- ``two-mass-rig``: ``model`` is :meth:`TwoMassRig.to_dict
  <motorid.plants.rig.TwoMassRig.to_dict>`, every parameter in SI units (the
  table of :class:`~motorid.plants.rig.TwoMassRig`), its friction laws as
  ``{"kind": ..., <parameters>}``, amplifier, tachogenerator, A/D converter and
  encoder; ``null`` for an infinite amplifier saturation.
- ``rigid-drive``: ``model`` is :meth:`RigidDrive.to_dict
  <motorid.plants.rigid.RigidDrive.to_dict>`: ``effects`` (names), ``params`` (inertia,
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
parameter within its physical range (:mod:`motorid.plants.ranges`), every size an
array is allocated with bounded (NIS window, delay line, orders, basis) before the
array is made, and a covariance symmetric positive semi-definite within 1e-9
relative (:func:`~motorid.estimators.base.check_covariance`).

This module sits at the top of the package, beside :mod:`motorid.records`, because
a model file holds either a drive model (:mod:`motorid.plants`) or an estimator
(:mod:`motorid.estimators`), and the plants must not import the estimators.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.json_input import MAX_INTEGER, parse_json
from motorid.plants.amplifier import Amplifier
from motorid.plants.friction import FRICTION_KINDS
from motorid.plants.rig import TwoMassRig
from motorid.plants.rigid import RigidDrive
from motorid.plants.sensors import ADConverter, Encoder, Tachogenerator

logger = logging.getLogger(__name__)

#: The ``format`` name of a model file.
FORMAT = "motorid-model"
#: The newest ``version`` this motorid writes and reads.
VERSION = 1
#: The ``kind`` of a model file for each kind of model.
KIND_RIG = "two-mass-rig"
KIND_RIGID = "rigid-drive"
KIND_ESTIMATOR = "estimator"

__all__ = [
    "FORMAT",
    "VERSION",
    "friction_from_dict",
    "load_model",
    "model_from_dict",
    "model_to_dict",
    "rig_from_dict",
    "rigid_drive_from_dict",
    "save_model",
]


#: Largest model file [bytes]: an estimator of the most parameters (1000) writes a covariance of
#: 10**6 numbers, about 25 MB.
LARGEST_FILE = 64 * 2**20
#: Longest text a model file's value may hold (names, sides, basis specs are far shorter).
_LONGEST_TEXT = 500


class _BadKeyError(Exception):
    """A problem at ``key`` of the file; :func:`model_from_dict` adds the file's name."""

    def __init__(self, key: str, message: str):
        super().__init__(f"{key}: {message}" if key else message)


# --------------------------------------------------------------------------- writing
def model_to_dict(model: Any) -> dict[str, Any]:
    """The JSON object of a model file for ``model`` (a rig or a saved estimator).

    Raises
    ------
    ValueError
        For an object that has no model file form (another type, an estimator with
        a custom basis function, a filter between ``predict`` and ``update``).
    """
    if isinstance(model, TwoMassRig):
        return {"format": FORMAT, "version": VERSION, "kind": KIND_RIG, "model": model.to_dict()}
    if isinstance(model, RigidDrive):
        model.check_physical()
        return {"format": FORMAT, "version": VERSION, "kind": KIND_RIGID, "model": model.to_dict()}
    from motorid.estimators.base import Estimator

    if isinstance(model, Estimator):
        body = _estimator_to_dict(model)
        return {"format": FORMAT, "version": VERSION, "kind": KIND_ESTIMATOR, "model": body}
    raise ValueError(
        f"cannot save a {type(model).__name__} as a model file: give a TwoMassRig, a RigidDrive "
        "or an estimator"
    )


def save_model(model: Any, path: str | os.PathLike[str], *, overwrite: bool = True) -> None:
    """Write ``model`` as a model file at ``path``, whole (:func:`motorid.outputs.write_file`).

    ``overwrite=False`` refuses an existing file, also one another process created
    meanwhile (:class:`~motorid.errors.OutputError`, as for a full disk; ``path``
    is then as it was).
    """
    from motorid.outputs import write_file

    text = json.dumps(model_to_dict(model), indent=2, allow_nan=False) + "\n"
    write_file(path, lambda fh: fh.write(text), overwrite=overwrite)
    logger.info("wrote model file %s (%s)", path, type(model).__name__)


def _estimator_to_dict(est: Any) -> dict[str, Any]:
    from motorid.estimators import ARXRLS, FrictionEKF, FrictionUKF, HammersteinRLS

    if type(est) in (ARXRLS, HammersteinRLS):
        if est._pending is not None:
            raise ValueError(f"{est.name} is between predict() and update(): call update() first")
        settings: dict[str, Any] = {
            "na": est.na,
            "nb": est.nb,
            "lam": est.lam,
            "delta": est.delta,
            "direct_term": est.direct_term,
            "max_trace": None if math.isinf(est.max_trace) else est.max_trace,
            "R": est.R,
            "x0": est.x0.tolist(),
        }
        if type(est) is HammersteinRLS:
            settings["basis"] = _basis_spec(est.basis)
            settings["gamma_method"] = est.gamma_method
        state = {
            "x": est.x.tolist(),
            "P": est.P.tolist(),
            "y_history": est.y_history.tolist(),
            "g_history": est.g_history.tolist(),
            "sample_index": est.sample_index,
        }
    elif type(est) in (FrictionEKF, FrictionUKF):
        settings = est.get_params()
        settings["rig"] = None if settings["rig"] is None else settings["rig"].to_dict()
        state = est.get_state()
        state = {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in state.items()}
        state["nis_mean"] = None if math.isnan(state["nis_mean"]) else state["nis_mean"]
    else:
        raise ValueError(
            f"cannot save a {type(est).__name__}: model files hold arx-rls, hammerstein-rls, "
            "friction-ekf and friction-ukf"
        )
    return {"estimator": est.name, "settings": settings, "state": state}


def _basis_spec(basis: Any) -> str:
    """The basis as the text :func:`~motorid.estimators.basis.basis_from_spec` reads back."""
    from motorid.estimators.basis import DEAD_ZONE, POWER, SIGN

    items = []
    for f in basis:
        if f.builtin is None:
            raise ValueError(
                f"cannot save the custom basis function {f.name!r}: only built-in ones are saved"
            )
        kind, parameter = f.builtin
        if kind == POWER:
            items.append(f"u^{int(parameter)}")
        elif kind == SIGN:
            items.append("sign")
        elif kind == DEAD_ZONE:
            items.append(f"dead_zone:{float(parameter)!r}")
    return ",".join(items)


# --------------------------------------------------------------------------- reading
def load_model(path: str | os.PathLike[str]) -> Any:
    """Read a model file: a :class:`~motorid.plants.rig.TwoMassRig`, a
    :class:`~motorid.plants.rigid.RigidDrive` or an estimator.

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
        text = source.read_text(encoding="utf-8")
    except OSError as exc:
        raise DataError(f"{source}: cannot read the model file: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise DataError(f"{source}: not a model file (not UTF-8 text)") from None
    data = parse_json(text, str(source), invalid="not a model file: invalid JSON")
    return model_from_dict(data, source=str(source))


def model_from_dict(data: Any, source: str = "model") -> Any:
    """Build the model a model file's JSON object describes (see :func:`load_model`).

    ``source`` names the file in the error messages.
    """
    try:
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise DataError(f'{source}: not a motorid model file (no "format": "{FORMAT}")')
        version = data.get("version")
        if isinstance(version, bool) or not isinstance(version, int):
            raise DataError(f"{source}: version must be an integer, got {_shown(version)}")
        if version > VERSION:
            raise DataError(
                f"{source}: model file version {version} is newer than this motorid reads "
                f"(up to {VERSION}); upgrade motorid to read it"
            )
        if version < 1:
            raise DataError(f"{source}: unknown model file version {version} (known: 1 to {VERSION})")
        _keys(data, ("format", "version", "kind", "model"), "")
        kind = _text(data["kind"], "kind")
        if kind == KIND_RIG:
            return _rig(data["model"], "model")
        if kind == KIND_RIGID:
            return _rigid_drive(data["model"], "model")
        if kind == KIND_ESTIMATOR:
            return _estimator(data["model"], "model")
        raise _BadKeyError(
            "kind", f"unknown model kind {kind!r} (known: {KIND_RIG}, {KIND_RIGID}, {KIND_ESTIMATOR})"
        )
    except _BadKeyError as exc:
        raise DataError(f"{source}: {exc}") from None


def rig_from_dict(data: Any) -> TwoMassRig:
    """A :class:`~motorid.plants.rig.TwoMassRig` from its description (``model`` of a rig file).

    Raises
    ------
    DataError
        Naming the key: ``friction[1].alpha1: missing``, ``J_m: J_m must be > 0, got -1.0``.
    """
    try:
        return _rig(data, "")
    except _BadKeyError as exc:
        raise DataError(str(exc)) from None


def rigid_drive_from_dict(data: Any) -> RigidDrive:
    """A physical :class:`~motorid.plants.rigid.RigidDrive` from its description (``model`` of a
    rigid-drive file); DataError naming the key, e.g. ``params.inertia: inertia must be > 0``."""
    try:
        return _rigid_drive(data, "")
    except _BadKeyError as exc:
        raise DataError(str(exc)) from None


def friction_from_dict(data: Any) -> Any:
    """A friction law from its description ``{"kind": ..., <parameters>}`` (DataError naming the key)."""
    try:
        return _friction(data, "")
    except _BadKeyError as exc:
        raise DataError(str(exc)) from None


def _keys(data: Any, names: tuple[str, ...] | list[str], where: str) -> dict[str, Any]:
    """``data`` as a dict with exactly the keys ``names``."""
    label = where or "the top level"
    if not isinstance(data, dict):
        raise _BadKeyError(where or "file", f"must be a JSON object, got {type(data).__name__}")
    missing = [n for n in names if n not in data]
    if missing:
        raise _BadKeyError(_join(where, missing[0]), f"missing in {label}")
    unknown = [k for k in data if k not in names]
    if unknown:
        raise _BadKeyError(_join(where, unknown[0]), f"unknown key in {label} (known: {', '.join(names)})")
    return data


def _join(where: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{where}[{key}]"
    return f"{where}.{key}" if where else key


def _shown(value: Any) -> str:
    """``value`` as JSON for a message, cut to 60 characters (a file may hold a 50 MB string)."""
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):  # an integer of more digits than Python converts to text
        text = type(value).__name__
    return text if len(text) <= 60 else f"{text[:57]}..."


def _number(value: Any, key: str, *, none_is: float | None = None) -> float:
    if value is None and none_is is not None:
        return none_is
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _BadKeyError(key, f"must be a number, got {_shown(value)}")
    if isinstance(value, int) and abs(value) > MAX_INTEGER:
        raise _BadKeyError(
            key, f"must be a number within ±2**53, got an integer of {len(str(abs(value)))} digits"
        )
    if not math.isfinite(value):
        raise _BadKeyError(key, f"must be finite, got {value!r}")
    return float(value)


def _integer(value: Any, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _BadKeyError(key, f"must be an integer, got {_shown(value)}")
    if abs(value) > MAX_INTEGER:
        raise _BadKeyError(key, f"must be an integer within ±2**53, got one of {len(str(abs(value)))} digits")
    return value


def _boolean(value: Any, key: str) -> bool:
    if not isinstance(value, bool):
        raise _BadKeyError(key, f"must be true or false, got {_shown(value)}")
    return value


def _text(value: Any, key: str) -> str:
    if not isinstance(value, str):
        raise _BadKeyError(key, f"must be a string, got {_shown(value)}")
    if len(value) > _LONGEST_TEXT:
        raise _BadKeyError(key, f"must be a name of at most {_LONGEST_TEXT} characters, got {len(value)}")
    return value


def _array(value: Any, key: str, shape: tuple[int, ...], largest: float = math.inf) -> np.ndarray:
    """A finite float array of ``shape`` from nested lists, entries within ±``largest``."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise _BadKeyError(key, f"must be an array of numbers of shape {shape}") from None
    if arr.shape != shape or (arr.size and not isinstance(value, list)):
        raise _BadKeyError(key, f"must have shape {shape}, got {arr.shape}")
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        where = "".join(f"[{int(i)}]" for i in bad[0])
        raise _BadKeyError(key + where, f"must be finite, got {float(arr[tuple(bad[0])])!r}")
    big = np.argwhere(np.abs(arr) > largest)
    if big.size:
        where = "".join(f"[{int(i)}]" for i in big[0])
        raise _BadKeyError(key + where, f"must be within ±{largest:g}, got {float(arr[tuple(big[0])])!r}")
    if not all(
        isinstance(v, int | float) and not isinstance(v, bool)
        for v in np.array(value, dtype=object).reshape(-1)
    ):
        raise _BadKeyError(key, "must hold numbers, not text or true/false")
    return arr


def _build(cls: Any, values: dict[str, Any], where: str) -> Any:
    """``cls(**values)``, its ValueError (which names the parameter) turned into a _BadKeyError at ``where``."""
    try:
        return cls(**values)
    except ValueError as exc:
        raise _BadKeyError(where, str(exc)) from None


def _scalars(cls: Any, data: Any, where: str) -> Any:
    """A dataclass of scalar fields, every field required, each checked for its type."""
    fields = [f for f in dataclasses.fields(cls) if f.init]
    _keys(data, [f.name for f in fields], where)
    values: dict[str, Any] = {}
    for f in fields:
        key = _join(where, f.name)
        value = data[f.name]
        if f.type == "float":
            infinite = f.default if isinstance(f.default, float) and math.isinf(f.default) else None
            values[f.name] = _number(value, key, none_is=infinite)
        elif f.type == "int":
            values[f.name] = _integer(value, key)
        else:  # str and Literal aliases such as Side
            values[f.name] = _text(value, key)
    return _build(cls, values, where)


def _friction(data: Any, where: str) -> Any:
    if not isinstance(data, dict):
        raise _BadKeyError(where, f"must be a JSON object, got {type(data).__name__}")
    kind = _text(data.get("kind"), _join(where, "kind"))
    if kind not in FRICTION_KINDS:
        raise _BadKeyError(
            _join(where, "kind"), f"unknown friction law {kind!r} (known: {', '.join(FRICTION_KINDS)})"
        )
    return _scalars(FRICTION_KINDS[kind], {k: v for k, v in data.items() if k != "kind"}, where)


def _rig(data: Any, where: str) -> TwoMassRig:
    fields = [f for f in dataclasses.fields(TwoMassRig) if f.init]
    _keys(data, [f.name for f in fields], where)
    parts = {"amplifier": Amplifier, "tacho": Tachogenerator, "adc": ADConverter}
    values: dict[str, Any] = {}
    for f in fields:
        key = _join(where, f.name)
        value = data[f.name]
        if f.name == "friction":
            if not isinstance(value, list):
                raise _BadKeyError(key, f"must be a list of friction laws, got {_shown(value)}")
            values[f.name] = tuple(_friction(item, _join(key, k)) for k, item in enumerate(value))
        elif f.name in parts:
            values[f.name] = _scalars(parts[f.name], value, key)
        elif f.name == "encoder":
            values[f.name] = None if value is None else _scalars(Encoder, value, key)
        elif f.type == "int":
            values[f.name] = _integer(value, key)
        else:
            values[f.name] = _number(value, key)
    return _build(TwoMassRig, values, where)


def _rigid_drive(data: Any, where: str) -> RigidDrive:
    from motorid.plants.rigid import DRIVE_PARAMETERS, RIGID_EFFECTS

    _keys(data, ("effects", "params", "dt", "stribeck_shape"), where)
    e_where = _join(where, "effects")
    if not isinstance(data["effects"], list):
        raise _BadKeyError(e_where, f"must be a list of effect names, got {_shown(data['effects'])}")
    effects = []
    for k, name in enumerate(data["effects"]):
        if _text(name, _join(e_where, k)) not in RIGID_EFFECTS:
            raise _BadKeyError(
                _join(e_where, k), f"unknown effect {name!r} (known: {', '.join(RIGID_EFFECTS)})"
            )
        effects.append(name)
    p_where = _join(where, "params")
    names = [*DRIVE_PARAMETERS, *(p for e in dict.fromkeys(effects) for p in RIGID_EFFECTS[e])]
    params = _keys(data["params"], names, p_where)
    values = {n: _number(params[n], _join(p_where, n)) for n in names}
    dt = _number(data["dt"], _join(where, "dt"))
    shape = _text(data["stribeck_shape"], _join(where, "stribeck_shape"))
    drive = _build(RigidDrive, {"effects": tuple(effects), "params": values, "dt": dt,
                                "stribeck_shape": shape}, where)  # fmt: skip
    try:
        return drive.check_physical()
    except ValueError as exc:
        name = str(exc).split(" ", 1)[0]
        raise _BadKeyError(_join(p_where, name), str(exc)) from None


def _estimator(data: Any, where: str) -> Any:
    from motorid.estimators import ARXRLS, FrictionEKF, FrictionUKF, HammersteinRLS

    _keys(data, ("estimator", "settings", "state"), where)
    classes = {cls.name: cls for cls in (ARXRLS, HammersteinRLS, FrictionEKF, FrictionUKF)}
    name = _text(data["estimator"], _join(where, "estimator"))
    if name not in classes:
        raise _BadKeyError(
            _join(where, "estimator"), f"unknown estimator {name!r} (known: {', '.join(classes)})"
        )
    cls = classes[name]
    if cls in (ARXRLS, HammersteinRLS):
        return _rls(cls, data["settings"], data["state"], where)
    return _friction_filter(cls, data["settings"], data["state"], where)


def _rls(cls: Any, settings: Any, state: Any, where: str) -> Any:
    from motorid.estimators import HammersteinRLS
    from motorid.estimators.base import LARGEST_VALUE, check_covariance

    s_where, x_where = _join(where, "settings"), _join(where, "state")
    names = ["na", "nb", "lam", "delta", "direct_term", "max_trace", "R", "x0"]
    if cls is HammersteinRLS:
        names += ["basis", "gamma_method"]
    _keys(settings, names, s_where)
    kw: dict[str, Any] = {
        "na": _integer(settings["na"], _join(s_where, "na")),
        "nb": _integer(settings["nb"], _join(s_where, "nb")),
        "lam": _number(settings["lam"], _join(s_where, "lam")),
        "delta": _number(settings["delta"], _join(s_where, "delta")),
        "direct_term": _boolean(settings["direct_term"], _join(s_where, "direct_term")),
        "max_trace": _number(settings["max_trace"], _join(s_where, "max_trace"), none_is=math.inf),
        "R": _number(settings["R"], _join(s_where, "R")),
    }
    if cls is HammersteinRLS:
        kw["basis"] = _text(settings["basis"], _join(s_where, "basis"))
        kw["gamma_method"] = _text(settings["gamma_method"], _join(s_where, "gamma_method"))
    x0 = settings["x0"]
    if not isinstance(x0, list):
        raise _BadKeyError(_join(s_where, "x0"), f"must be a list of numbers, got {_shown(x0)}")
    kw["x0"] = _array(x0, _join(s_where, "x0"), (len(x0),), LARGEST_VALUE)
    est = _build(cls, kw, s_where)
    n = est.dim_x
    _keys(state, ("x", "P", "y_history", "g_history", "sample_index"), x_where)
    x = _array(state["x"], _join(x_where, "x"), (n,), LARGEST_VALUE)
    P = _array(state["P"], _join(x_where, "P"), (n, n))
    try:
        P = check_covariance("P", P)
    except ValueError as exc:
        raise _BadKeyError(_join(x_where, "P"), str(exc)) from None
    y_history = _array(state["y_history"], _join(x_where, "y_history"), est.y_history.shape, LARGEST_VALUE)
    g_history = _array(state["g_history"], _join(x_where, "g_history"), est.g_history.shape, LARGEST_VALUE)
    sample_index = _integer(state["sample_index"], _join(x_where, "sample_index"))
    if sample_index < 0:
        raise _BadKeyError(_join(x_where, "sample_index"), f"must be >= 0, got {sample_index}")
    est.x = est.x_prior = est.x_post = x
    est.P = est.P_prior = est.P_post = P
    est.y_history, est.g_history = y_history, g_history
    est.sample_index = sample_index
    return est


def _friction_filter(cls: Any, settings: Any, state: Any, where: str) -> Any:
    s_where, x_where = _join(where, "settings"), _join(where, "state")
    annotations = cls.parameter_annotations()
    _keys(settings, list(annotations), s_where)
    kw: dict[str, Any] = {}
    for name, annotation in annotations.items():
        key, value = _join(s_where, name), settings[name]
        if name == "rig":
            # a filter's rig is a two-mass rig or a rigid drive (whose description has ``effects``)
            if value is None:
                kw[name] = None
            elif isinstance(value, dict) and "effects" in value:
                kw[name] = _rigid_drive(value, key)
            else:
                kw[name] = _rig(value, key)
        elif value is None and "None" in annotation:
            kw[name] = None
        elif annotation.startswith("bool"):
            kw[name] = _boolean(value, key)
        elif annotation.startswith("int"):
            kw[name] = _integer(value, key)
        elif annotation.startswith("float"):
            kw[name] = _number(value, key)
        else:  # a Literal of names
            kw[name] = _text(value, key)
    est = _build(cls, kw, s_where)
    n, window = est.dim_x, est.nis_window
    fixed = ("x", "P", "sample_index", "nis_ring", "nis_count", "nis_mean", "diverged")
    fresh = est.get_state()  # a rigid drive with a delay or lag adds its input path's memory
    memory = {k: np.shape(v) for k, v in fresh.items() if k not in fixed}
    _keys(state, (*fixed, *memory), x_where)
    values = {
        "x": _array(state["x"], _join(x_where, "x"), (n,)),
        "P": _array(state["P"], _join(x_where, "P"), (n, n)),
        "nis_ring": _array(state["nis_ring"], _join(x_where, "nis_ring"), (window,)),
        "sample_index": _integer(state["sample_index"], _join(x_where, "sample_index")),
        "nis_count": _integer(state["nis_count"], _join(x_where, "nis_count")),
        "nis_mean": _number(state["nis_mean"], _join(x_where, "nis_mean"), none_is=math.nan),
        "diverged": _boolean(state["diverged"], _join(x_where, "diverged")),
        **{k: _array(state[k], _join(x_where, k), shape) for k, shape in memory.items()},
    }
    try:
        est.set_state(values)
    except ValueError as exc:
        raise _BadKeyError(x_where, str(exc)) from None
    return est
