"""Every public function and class of motorid documents its parameters in numpydoc form.

In the manner of python-control's ``control/tests/docstrings_test.py``: for each name
in the ``__all__`` of each module, every parameter of the function (of a class: of its
constructor, documented in the class's or ``__init__``'s docstring) must appear as
``name : type`` at the start of a line (``a, b : float`` documents both; ``*args`` and
``**kwargs`` as ``*args :`` and ``**kwargs :``). Dataclass fields documented under
``Attributes`` count. Protocols (no constructor of their own) and exceptions that keep
the built-in constructor are left out. There are no exceptions: every public name passes.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import motorid

PACKAGE = Path(motorid.__file__).parent


def module_names() -> list[str]:
    """Every module of motorid by its dotted name (``__main__`` left out: importing it runs the CLI)."""
    names = ["motorid"]
    for info in pkgutil.walk_packages([str(PACKAGE)], prefix="motorid."):
        if not info.name.endswith(".__main__"):
            names.append(info.name)
    return sorted(names)


def is_documented(name: str, docstring: str) -> bool:
    """Whether ``docstring`` has a numpydoc entry ``name : ...`` (alone or in a list ``a, name : ...``)."""
    item = r"(\*{0,2}\w+|\.{3})"
    pattern = rf"^\s*({item}, )*{re.escape(name)}(, {item})* :"
    return re.search(pattern, docstring, flags=re.MULTILINE) is not None


def undocumented_parameters(obj: Callable[..., Any], docstring: str) -> list[str]:
    """The parameters of ``obj``'s signature that ``docstring`` does not document."""
    missing = []
    for name, parameter in inspect.signature(obj).parameters.items():
        if name in ("self", "cls") or name.startswith("_"):
            continue
        stars = {parameter.VAR_POSITIONAL: "*", parameter.VAR_KEYWORD: "**"}.get(parameter.kind, "")
        if not is_documented(stars + name, docstring) and not is_documented(name, docstring):
            missing.append(stars + name)
    return missing


def public_objects() -> dict[str, Any]:
    """Each public function and class of motorid (in some module's ``__all__``) by its home's name."""
    found: dict[str, Any] = {}
    for module_name in module_names():
        module = importlib.import_module(module_name)
        for attr in getattr(module, "__all__", []):
            obj = getattr(module, attr)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            if not obj.__module__.startswith("motorid"):
                continue
            found.setdefault(f"{obj.__module__}.{obj.__qualname__}", obj)
    return found


def docstring_problems() -> dict[str, list[str]]:
    """Each public function or class with undocumented parameters, and those parameters."""
    problems = {}
    for name, obj in public_objects().items():
        if inspect.isclass(obj):
            if getattr(obj, "_is_protocol", False):
                continue  # a Protocol describes what others provide: no constructor of its own
            if issubclass(obj, BaseException) and "__init__" not in vars(obj):
                continue  # the built-in constructor: a message
            docstring = inspect.getdoc(obj) or ""
            if "__init__" in vars(obj):
                docstring += "\n" + (inspect.getdoc(obj.__init__) or "")
        else:
            docstring = inspect.getdoc(obj) or ""
        missing = undocumented_parameters(obj, docstring)
        if missing:
            problems[name] = missing
    return problems


def test_the_check_reads_numpydoc_entries():
    doc = "Summary.\n\nParameters\n----------\nt, u : ndarray\n    Time [s], input [V].\n**kwargs : dict\n"
    assert is_documented("u", doc) and is_documented("t", doc) and is_documented("**kwargs", doc)
    assert not is_documented("y", doc)
    assert not is_documented("u", "Summary with u : in the middle of a line.")


def test_public_functions_and_classes_document_their_parameters():
    problems = [f"{name}: {', '.join(missing)}" for name, missing in sorted(docstring_problems().items())]
    assert problems == [], "public functions or classes whose docstrings miss parameters"
