"""Names of a package imported at their first use.

A package that re-exports its modules' names imports every module when any one of them is
imported. ``motorid.plants`` and ``motorid.estimators`` re-export theirs lazily instead, so
that a command needing one module (the doctor needs the rigid drive, not the two-mass rig or
the filters) does not load the others and their compiled kernels.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def lazy_names(package: str, homes: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package`` (PEP 562) for the names of ``homes``.

    Parameters
    ----------
    package : str
        The package's name.
    homes : dict
        Each public name and the module of ``package`` that defines it.
    """
    namespace = importlib.import_module(package).__dict__

    def getattr_(name: str) -> Any:
        if name not in homes:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{homes[name]}"), name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted({*namespace, *homes})

    return getattr_, dir_
