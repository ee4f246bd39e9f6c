"""JSON from outside motorid (model files, record attributes), parsed within bounds.

Python's ``json.loads`` takes any nesting until the interpreter's recursion limit
(then ``RecursionError``) and integers of any size (``10**400``, which no float
holds: ``OverflowError`` where it is used as a number). :func:`parse_json` refuses
both with one :class:`~motorid.errors.DataError` naming the file and the key:

- nesting deeper than :data:`MAX_DEPTH` levels (motorid's deepest file, a friction
  filter's rig's friction law, is 5 deep; attributes hold a rig or a model, 6 deep);
- an integer beyond :data:`MAX_INTEGER` = 2**53 in magnitude, the integers a
  float64 holds exactly and every JSON reader reads alike (I-JSON, RFC 7493,
  section 2.2): no count, index or order motorid reads comes near it.

``NaN`` and ``Infinity`` tokens are read as floats (the reader of each value
refuses them where a finite number is needed, naming the key).

The readers of one value (:func:`number`, :func:`integer`, :func:`boolean`,
:func:`text`, :func:`float_array`) and of an object (:func:`object_keys`,
:func:`scalars`) raise :class:`~motorid.errors.ModelFileError` naming the key; the
drive models and the model files read their JSON with them.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np

from motorid.errors import DataError, ModelFileError

__all__ = [
    "LONGEST_TEXT",
    "MAX_DEPTH",
    "MAX_INTEGER",
    "boolean",
    "build",
    "float_array",
    "integer",
    "key_path",
    "number",
    "object_keys",
    "parse_json",
    "scalars",
    "shown",
    "text",
]

#: Deepest nesting of objects and arrays accepted.
MAX_DEPTH = 32
#: Largest magnitude of an integer accepted (2**53).
MAX_INTEGER = 2**53
# Longer digit strings are not even converted (Python refuses over 4300 digits with a ValueError).
_DIGITS = len(str(MAX_INTEGER)) + 1
#: Longest text a value may hold (names, sides, basis specs are far shorter).
LONGEST_TEXT = 500


class _HugeInteger:
    """An integer token too long to convert, kept as its digit count for the message."""

    def __init__(self, text: str):
        self.digits = len(text.lstrip("-"))


def _integer(text: str) -> int | _HugeInteger:
    return int(text) if len(text) <= _DIGITS else _HugeInteger(text)


def key_path(where: str, key: str | int) -> str:
    """The path of ``key`` inside ``where``: ``where.key``, ``where[index]``, ``key`` at the top.

    Parameters
    ----------
    where : str
        The path of the enclosing object or array (``""`` for the top level).
    key : str or int
        A key of an object, or an index of an array.
    """
    if isinstance(key, int):
        return f"{where}[{key}]"
    return f"{where}.{key}" if where else key


def parse_json(text: str, source: str, where: str = "", invalid: str = "invalid JSON") -> Any:
    """The JSON value of ``text``, bounded in depth and integer size.

    Parameters
    ----------
    text : str
        The JSON text.
    source : str
        What the text is, for the messages: the file's name and, for text inside a
        file, where in it (``"rec.csv: line 1"``).
    where : str
        A prefix for the keys named in the messages (``"attrs"``: ``attrs.units``).
    invalid : str
        What text that is not JSON is called in the message (a model file: ``"not a
        model file: invalid JSON"``).

    Raises
    ------
    DataError
        ``{source}: invalid JSON at line 1 ...``, ``{source}: {key}: nested deeper than 32 ...``
        or ``{source}: {key}: the integer of 401 digits is beyond ...``.
    """
    try:
        value = json.loads(text, parse_int=_integer, parse_constant=float)
    except json.JSONDecodeError as exc:
        raise DataError(f"{source}: {invalid} at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
    except RecursionError:
        raise DataError(f"{source}: the JSON is nested deeper than {MAX_DEPTH} levels") from None
    # walked without recursion, containers only on the stack: (container, key, depth)
    if isinstance(value, dict | list):
        stack: list[tuple[Any, str, int]] = [(value, where, 0)]
    else:
        stack = [([value], where, -1)]  # a lone scalar: checked as the one item of a list
    while stack:
        container, key, depth = stack.pop()
        if depth >= MAX_DEPTH:  # the container at depth d is level d + 1
            raise DataError(
                f"{source}: {key or 'the top level'}: the JSON is nested deeper than {MAX_DEPTH} levels"
            )
        pairs = container.items() if isinstance(container, dict) else enumerate(container)
        for name, item in pairs:
            if isinstance(item, dict | list):
                stack.append((item, key_path(key, name), depth + 1))
            elif isinstance(item, _HugeInteger) or (type(item) is int and abs(item) > MAX_INTEGER):
                digits = item.digits if isinstance(item, _HugeInteger) else len(str(abs(item)))
                at = key if depth < 0 else key_path(key, name)
                raise DataError(
                    f"{source}: {at or 'the top level'}: an integer of {digits} digits is beyond "
                    f"±2**53 = {MAX_INTEGER}, the largest a file may hold"
                )
    return value


def object_keys(data: Any, names: tuple[str, ...] | list[str], where: str) -> dict[str, Any]:
    """``data`` as a dict with exactly the keys ``names``.

    Parameters
    ----------
    data : Any
        A JSON value.
    names : sequence of str
        The keys the object must have, every one and no other.
    where : str
        The object's path in its file (``""`` for the top level).

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    label = where or "the top level"
    if not isinstance(data, dict):
        raise ModelFileError(where or "file", f"must be a JSON object, got {type(data).__name__}")
    missing = [n for n in names if n not in data]
    if missing:
        raise ModelFileError(key_path(where, missing[0]), f"missing in {label}")
    unknown = [k for k in data if k not in names]
    if unknown:
        raise ModelFileError(
            key_path(where, unknown[0]), f"unknown key in {label} (known: {', '.join(names)})"
        )
    return data


def shown(value: Any) -> str:
    """``value`` as JSON for a message, cut to 60 characters (a file may hold a 50 MB string).

    Parameters
    ----------
    value : Any
        A JSON value (or anything: what ``json.dumps`` refuses is shown by its type's name).
    """
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):  # an integer of more digits than Python converts to text
        text = type(value).__name__
    return text if len(text) <= 60 else f"{text[:57]}..."


def number(value: Any, key: str, *, none_is: float | None = None) -> float:
    """``value`` as a finite float; ``None`` is ``none_is`` where that is given (an infinite default).

    Parameters
    ----------
    value : Any
        A JSON value.
    key : str
        The value's path in its file (:func:`key_path`), named in the error.
    none_is : float or None
        What ``null`` reads as (a parameter whose default is infinite); None refuses ``null``.

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    if value is None and none_is is not None:
        return none_is
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ModelFileError(key, f"must be a number, got {shown(value)}")
    if isinstance(value, int) and abs(value) > MAX_INTEGER:
        raise ModelFileError(
            key, f"must be a number within ±2**53, got an integer of {len(str(abs(value)))} digits"
        )
    if not math.isfinite(value):
        raise ModelFileError(key, f"must be finite, got {value!r}")
    return float(value)


def integer(value: Any, key: str) -> int:
    """``value`` as an integer within ±2**53 (true and false refused).

    Parameters
    ----------
    value : Any
        A JSON value.
    key : str
        The value's path in its file (:func:`key_path`), named in the error.

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    if isinstance(value, bool) or not isinstance(value, int):
        raise ModelFileError(key, f"must be an integer, got {shown(value)}")
    if abs(value) > MAX_INTEGER:
        raise ModelFileError(
            key, f"must be an integer within ±2**53, got one of {len(str(abs(value)))} digits"
        )
    return value


def boolean(value: Any, key: str) -> bool:
    """``value`` as true or false.

    Parameters
    ----------
    value : Any
        A JSON value.
    key : str
        The value's path in its file (:func:`key_path`), named in the error.

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    if not isinstance(value, bool):
        raise ModelFileError(key, f"must be true or false, got {shown(value)}")
    return value


def text(value: Any, key: str) -> str:
    """``value`` as a string of at most :data:`LONGEST_TEXT` characters.

    Parameters
    ----------
    value : Any
        A JSON value.
    key : str
        The value's path in its file (:func:`key_path`), named in the error.

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    if not isinstance(value, str):
        raise ModelFileError(key, f"must be a string, got {shown(value)}")
    if len(value) > LONGEST_TEXT:
        raise ModelFileError(key, f"must be a name of at most {LONGEST_TEXT} characters, got {len(value)}")
    return value


def float_array(value: Any, key: str, shape: tuple[int, ...], largest: float = math.inf) -> np.ndarray:
    """A finite float array of ``shape`` from nested lists, entries within ±``largest``.

    Parameters
    ----------
    value : Any
        A JSON value: nested lists of numbers.
    key : str
        The value's path in its file (:func:`key_path`), named in the error.
    shape : tuple of int
        The array's shape.
    largest : float
        Largest magnitude of an entry, in the entry's own unit.

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelFileError(key, f"must be an array of numbers of shape {shape}") from None
    if arr.shape != shape or (arr.size and not isinstance(value, list)):
        raise ModelFileError(key, f"must have shape {shape}, got {arr.shape}")
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        where = "".join(f"[{int(i)}]" for i in bad[0])
        raise ModelFileError(key + where, f"must be finite, got {float(arr[tuple(bad[0])])!r}")
    big = np.argwhere(np.abs(arr) > largest)
    if big.size:
        where = "".join(f"[{int(i)}]" for i in big[0])
        raise ModelFileError(key + where, f"must be within ±{largest:g}, got {float(arr[tuple(big[0])])!r}")
    if not all(
        isinstance(v, int | float) and not isinstance(v, bool)
        for v in np.array(value, dtype=object).reshape(-1)
    ):
        raise ModelFileError(key, "must hold numbers, not text or true/false")
    return arr


def build(cls: Any, values: dict[str, Any], where: str) -> Any:
    """``cls(**values)``, its ValueError (which names the parameter) turned into a ModelFileError at ``where``.

    Parameters
    ----------
    cls : type
        The class to build.
    values : dict
        Its constructor's arguments, already read from the file.
    where : str
        The object's path in its file.
    """
    try:
        return cls(**values)
    except ValueError as exc:
        raise ModelFileError(where, str(exc)) from None


def scalars(cls: Any, data: Any, where: str) -> Any:
    """A dataclass of scalar fields, every field required, each checked for its type.

    Parameters
    ----------
    cls : type
        The dataclass; its fields' annotations (``float``, ``int``, else text) say how each is read.
    data : Any
        A JSON value: an object with one key per field.
    where : str
        The object's path in its file.

    Raises
    ------
    ModelFileError
        Naming ``key`` and what is wrong.
    """
    fields = [f for f in dataclasses.fields(cls) if f.init]
    object_keys(data, [f.name for f in fields], where)
    values: dict[str, Any] = {}
    for f in fields:
        key = key_path(where, f.name)
        value = data[f.name]
        if f.type == "float":
            infinite = f.default if isinstance(f.default, float) and math.isinf(f.default) else None
            values[f.name] = number(value, key, none_is=infinite)
        elif f.type == "int":
            values[f.name] = integer(value, key)
        else:  # str and Literal aliases such as Side
            values[f.name] = text(value, key)
    return build(cls, values, where)
