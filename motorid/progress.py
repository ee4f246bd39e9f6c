"""Progress bars: every bar motorid shows is made here.

A function with long work takes ``progress: bool`` and builds its bar with
:func:`progress_bar`; the caller decides (the command line shows bars only when
stderr is a terminal and ``--quiet`` is not given). The ``TQDM_DISABLE``
environment variable, which tqdm itself reads only as the default of its
``disable`` argument (ignored once a caller passes one), turns every bar off
here, whatever the caller asked for.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from tqdm import tqdm

__all__ = ["bars_disabled_by_environment", "progress_bar"]

#: Values of ``TQDM_DISABLE`` that leave bars on (unset is the same as these).
_ENABLING = ("", "0", "false", "no", "off")


def bars_disabled_by_environment() -> bool:
    """True when the environment variable ``TQDM_DISABLE`` is set to anything but
    empty, ``0``, ``false``, ``no`` or ``off`` (in any case)."""
    return os.environ.get("TQDM_DISABLE", "").strip().lower() not in _ENABLING


def progress_bar(
    iterable: Iterable[Any] | None = None,
    *,
    show: bool,
    desc: str,
    total: int | None = None,
    unit: str = "it",
    leave: bool = True,
) -> tqdm:
    """A tqdm bar on stderr, drawn only when ``show`` is true and ``TQDM_DISABLE`` is not set.

    Parameters
    ----------
    iterable : iterable, optional
        What the bar counts, as ``tqdm(iterable)``; without it, call ``update(n)``.
    show : bool
        The caller's choice (a library function's ``progress`` argument).
    desc, unit : str
        The bar's label and the name of what it counts.
    total : int, optional
        How many there are (taken from ``len(iterable)`` when it has one).
    leave : bool
        Keep the finished bar on the terminal (False for an inner bar).

    Returns
    -------
    tqdm.tqdm
        A disabled bar (no output at all, the iterable passed through) when not shown.
    """
    from tqdm import tqdm

    return tqdm(
        iterable,
        total=total,
        desc=desc,
        unit=unit,
        leave=leave,
        file=sys.stderr,
        dynamic_ncols=True,
        disable=not show or bars_disabled_by_environment(),
    )
