"""Names a package exports from its modules, each module imported when one of its names is first read
(PEP 562: a module's ``__getattr__`` and ``__dir__``).

A package whose ``__init__`` imports every module it re-exports makes whoever imports one of them
pay for all of them: ``import motorid.io.records`` (the doctor reads its record with it) would load
the DAQ backends, the Modbus rig's server and ``asyncio``; ``import motorid`` would load the drive
models and numba. :func:`lazy_exports` is the one way a package of motorid defers them.

>>> __getattr__, __dir__ = lazy_exports(__name__, {"RigServer": ".rig_server"})  # doctest: +SKIP
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, modules: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package that exports ``modules``' names on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    modules : mapping of str to str
        Each exported name -> the module that defines it, relative to the package (``".base"``)
        or absolute (``"motorid.estimators"``).

    Returns
    -------
    tuple of callable
        ``(__getattr__, __dir__)`` to assign at the package's module level. ``__getattr__(name)``
        imports ``name``'s module, keeps the value in the package (later reads do not come back)
        and returns it; AttributeError naming the package for any other name. ``__dir__()`` lists
        the package's attributes and the names not read yet.
    """

    def first_read(name: str) -> Any:
        if name not in modules:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(modules[name], package), name)
        setattr(sys.modules[package], name, value)
        return value

    def names() -> list[str]:
        return sorted({*vars(sys.modules[package]), *modules})

    return first_read, names
