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
"""

from __future__ import annotations

import json
from typing import Any

from motorid.errors import DataError

__all__ = ["MAX_DEPTH", "MAX_INTEGER", "parse_json"]

#: Deepest nesting of objects and arrays accepted.
MAX_DEPTH = 32
#: Largest magnitude of an integer accepted (2**53).
MAX_INTEGER = 2**53
# Longer digit strings are not even converted (Python refuses over 4300 digits with a ValueError).
_DIGITS = len(str(MAX_INTEGER)) + 1


class _HugeInteger:
    """An integer token too long to convert, kept as its digit count for the message."""

    def __init__(self, text: str):
        self.digits = len(text.lstrip("-"))


def _integer(text: str) -> int | _HugeInteger:
    return int(text) if len(text) <= _DIGITS else _HugeInteger(text)


def _key(where: str, key: str | int) -> str:
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
                stack.append((item, _key(key, name), depth + 1))
            elif isinstance(item, _HugeInteger) or (type(item) is int and abs(item) > MAX_INTEGER):
                digits = item.digits if isinstance(item, _HugeInteger) else len(str(abs(item)))
                at = key if depth < 0 else _key(key, name)
                raise DataError(
                    f"{source}: {at or 'the top level'}: an integer of {digits} digits is beyond "
                    f"±2**53 = {MAX_INTEGER}, the largest a file may hold"
                )
    return value
