"""The columns of the binary formats (Parquet, MATLAB, HDF5, TDMS, Excel): which of the file's
arrays are the record's (:func:`column_chooser`, checked before anything is loaded) and
each array checked and converted as a CSV's cells are (:func:`binary_column`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from motorid.errors import DataError
from motorid.io.records.options import check_row_limit, column_hint, quoted, quoted_names

# A reader of a binary format: (file name, choose) -> (arrays by column name, attrs). ``choose`` is
# given the shape of every column the file holds and returns the names to load (it raises on a
# missing, ambiguous, misshapen or too long column), so nothing is loaded before it is checked.
Choose = Callable[[dict[str, tuple[int, ...]]], list[str]]


def _find_column(name: str, column: str, present: list[str]) -> str | None:
    """The name in the file of ``column``: itself, or the one ``group/column`` of a TDMS or HDF5 file."""
    if column in present:
        return column
    nested = [key for key in present if key.rsplit("/", 1)[-1] == column]
    if len(nested) > 1:
        raise DataError(
            f"column {quoted(column)} is ambiguous in {name}: {quoted_names(nested)}; name one of them"
        )
    return nested[0] if nested else None


def samples_of(shape: tuple[int, ...]) -> int | None:
    """Number of samples of an array that is one column (at most one axis longer than 1), else None."""
    return math.prod(shape) if sum(n > 1 for n in shape) <= 1 else None


def column_chooser(
    name: str, mapping: dict[str, str], other_columns: bool, max_samples: int | None, found: dict[str, str],
    optional: set[str] = frozenset(),  # type: ignore[assignment]
) -> Choose:  # fmt: skip
    """The ``choose`` of a binary reader: it checks the columns of ``mapping`` against the shapes the
    file holds (``optional`` ones may be absent), records each one's key in ``found`` (key in the
    file -> canonical name) and returns the keys to load (with the other columns of the same
    length when ``other_columns``)."""

    def choose(shapes: dict[str, tuple[int, ...]]) -> list[str]:
        present = list(shapes)
        for canonical, column in mapping.items():
            key = _find_column(name, column, present)
            if key is None and canonical in optional:
                continue
            if key is None:
                raise DataError(
                    f"column {quoted(column)} is missing from {name}"
                    + (f" (needed as {canonical!r})" if column != canonical else "")
                    + f"; columns are {quoted_names(present)}{column_hint(canonical)}"
                )
            if samples_of(shapes[key]) is None:
                raise DataError(
                    f"column {quoted(column)} of {name} is not one column of samples (shape {shapes[key]})"
                )
            found[key] = canonical
        first = next(iter(found))
        rows = samples_of(shapes[first])
        for key in found:
            if samples_of(shapes[key]) != rows:
                raise DataError(
                    f"column {quoted(key)} of {name} has {samples_of(shapes[key])} samples, column {quoted(first)} has {rows}"
                )
        if not rows:
            raise DataError(f"{name} has columns but no samples")
        check_row_limit(name, rows, max_samples)
        replaced = {k for k, v in mapping.items() if v != k}  # a canonical name that a named column takes
        others = [
            k for k in present
            if k not in found and samples_of(shapes[k]) == rows and short_name(k, present) not in replaced
        ] if other_columns else []  # fmt: skip
        return [k for k in present if k in found or k in others]

    return choose


def binary_column(name: str, key: str, values: np.ndarray, time: bool, first_row: int = 0) -> np.ndarray:
    """Column ``key`` of the binary record ``name`` as float64 (a time column of integers as int64,
    exactly: nanoseconds since 1970 exceed float64's digits), or a DataError naming it when it is
    not numeric, or its first NaN or infinite value by row (``first_row`` is the row of
    ``values[0]`` in the file: one place for the whole-record read and the read in blocks)."""
    if time and values.dtype.kind in "mM":  # datetime64 or timedelta64: int64 ns, exactly
        if np.isnat(values).any():
            raise DataError(f"column {quoted(key)} has a missing time at row {first_row + int(np.isnat(values).argmax())} "
                            f"of {name}")  # fmt: skip
        return values.astype("datetime64[ns]" if values.dtype.kind == "M" else "timedelta64[ns]").astype(
            np.int64
        )
    if values.dtype.kind not in "fiub":
        raise DataError(f"column {quoted(key)} of {name} is not numeric (its values are {values.dtype})")
    if time and values.dtype.kind in "iu":
        return values.astype(np.int64)
    values = values.astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        kind_of = "a NaN" if np.isnan(values[bad[0]]) else "an infinite"
        raise DataError(
            f"column {quoted(key)} has {kind_of} value {values[bad[0]]!r} at row {first_row + int(bad[0])} of {name}"
        )
    return values


def short_name(key: str, keys: list[str]) -> str:
    """``group/name`` as ``name`` when no other of ``keys`` ends in that name."""
    last = key.rsplit("/", 1)[-1]
    return last if sum(k.rsplit("/", 1)[-1] == last for k in keys) == 1 else key


# A source of blocks: a generator that yields the record's attrs, then the line number of a CSV's
# header (None in the other formats), then each block as {canonical name: array} (a time column
# of integers as int64, the rest float64).
Blocks = Iterator[Any]
