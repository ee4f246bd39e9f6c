"""The house's rules that a walk over the package can check: every exception lives in
motorid.errors."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

import motorid
import motorid.errors

PACKAGE = Path(motorid.__file__).parent


def module_names() -> list[str]:
    """Every module of motorid by its dotted name (``__main__`` left out: importing it runs the CLI)."""
    names = ["motorid"]
    for info in pkgutil.walk_packages([str(PACKAGE)], prefix="motorid."):
        if not info.name.endswith(".__main__"):
            names.append(info.name)
    return sorted(names)


def test_every_exception_of_the_package_is_defined_in_motorid_errors():
    """A public exception class defined anywhere but motorid.errors is named here; a private one
    that never leaves its module (caught there and turned into a DataError) may stay."""
    elsewhere = []
    for name in module_names():
        module = importlib.import_module(name)
        for attr, obj in vars(module).items():
            if inspect.isclass(obj) and issubclass(obj, BaseException) and obj.__module__ == name:
                if name != "motorid.errors" and not attr.startswith("_"):
                    elsewhere.append(f"{name}.{attr}")
    assert elsewhere == []
    defined = [
        n
        for n, o in vars(motorid.errors).items()
        if inspect.isclass(o) and issubclass(o, BaseException) and o.__module__ == "motorid.errors"
    ]
    assert sorted(motorid.errors.__all__) == sorted(defined)
