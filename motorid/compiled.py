"""Kernels compiled ahead of time, so a short command runs them without numba.

The hot loops of :mod:`motorid.plants.physics` are numba functions, compiled at their first
call and cached on disk. A command that runs once pays numba's start before any work: importing numba, setting up LLVM and loading each cached
kernel cost about 0.8 s and 130 MB, more than ``motorid doctor`` spends on a 16,000-sample
record. So the kernels of a rigid drive and of the doctor (:data:`KERNELS`) are also compiled
ahead of time, from the same source, into one extension module next to this file::

    python -m motorid.compiled        # make runs this before every target; it builds when needed

:func:`load` gives a module's kernels: the extension's when it was built from the module's
source as it is now (the digest of the source files, :func:`source_digest`, is recorded with
the build), else the module itself, compiled by numba at first call. So the result of a
kernel never depends on whether the extension is built, and an edited kernel never runs
stale. ``MOTORID_JIT_ONLY=1`` turns the extension off, and so does ``NUMBA_DISABLE_JIT=1``
(numba's switch to run kernels as plain Python, for debugging).

The extension's functions do not check their arguments (a numba function compiled ahead of
time reads any array as the type it was declared with). Each one is therefore called through
a check of its declared :data:`KINDS`: an input array is converted to a contiguous array of
the declared type (copied only when it is not one already); an array the kernel writes into
must already be one, or a TypeError names it, since a converted copy would lose the writes.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.machinery
import json
import logging
import operator
import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

logger = logging.getLogger(__name__)

#: The extension module's name, in this package.
EXTENSION = "_kernels"
#: The record of the build beside it: the source digest, each module's constants, each
#: kernel's parameter names and defaults.
BUILD_RECORD = Path(__file__).with_name(f"{EXTENSION}.json")

#: The kinds of argument and numba's type of each (for the build); :func:`checked` checks them at a call.
KINDS: dict[str, str] = {
    "float": "f8",
    "int": "i8",
    "float[]": "f8[::1]",
    "int[]": "i8[::1]",
    "float[,]": "f8[:, ::1]",
}


@dataclass(frozen=True)
class Kernel:
    """One kernel compiled ahead of time.

    Attributes
    ----------
    module : str
        The module that defines it (a numba function there).
    name : str
        Its name in that module.
    args : tuple of str
        The kind (:data:`KINDS`) of each parameter.
    result : str
        numba's type of its result.
    written : tuple of int
        The parameters it writes into (arrays updated in place).
    """

    module: str
    name: str
    args: tuple[str, ...]
    result: str
    written: tuple[int, ...] = ()


_PHYSICS = "motorid.plants.physics"
#: The kernels in the extension: what a rigid drive (simulated whole or a sample at a time)
#: and ``motorid doctor`` run.
KERNELS: tuple[Kernel, ...] = (
    Kernel(_PHYSICS, "armature_voltages", ("float[]", "float", "float", "float"), "f8[::1]"),
    Kernel(_PHYSICS, "rigid_columns", ("int[]", "float[]", "float", "int"), "f8[:, ::1]"),
    Kernel(_PHYSICS, "rigid_delay_samples", ("float", "float"), "Tuple((i8, f8))"),
    Kernel(
        _PHYSICS, "rigid_input_dynamics",
        ("float[]", "float", "float", "float", "float[]", "float[]"), "f8[::1]", written=(4, 5),
    ),
    Kernel(_PHYSICS, "reversal_clock", ("float[]", "float", "float", "float[]"), "f8[::1]", written=(3,)),
    Kernel(_PHYSICS, "backlash_dwell", ("float[]", "float", "float", "float[]"), "f8[::1]", written=(3,)),
    Kernel(
        _PHYSICS, "rigid_free_run",
        ("float[]", "float", "int", "float", "float[]", "float", "int", "float", "float"), "f8[::1]",
    ),
)  # fmt: skip

_PACKAGE = Path(__file__).parent


def module_file(module: str) -> Path:
    """The source file of a module of this package (found without importing it)."""
    parts = module.split(".")
    if parts[0] != _PACKAGE.name:
        raise ValueError(f"{module} is not a module of {_PACKAGE.name}")
    return _PACKAGE.joinpath(*parts[1:]).with_suffix(".py")


def source_digest() -> str:
    """SHA-256 of the source files the extension is built from: this file and each kernel's module."""
    digest = hashlib.sha256()
    for path in [Path(__file__), *sorted({module_file(k.module) for k in KERNELS})]:
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _array(dtype: type, ndim: int, written: bool, where: str) -> Callable[[Any], np.ndarray]:
    """The check of an array argument: converted to a contiguous ``dtype`` array of ``ndim``
    dimensions, or (``written``) required to be one already."""

    def check(value: Any) -> np.ndarray:
        if written:
            ok = (
                isinstance(value, np.ndarray) and value.dtype == dtype and value.ndim == ndim
                and value.flags.c_contiguous and value.flags.writeable
            )  # fmt: skip
            if not ok:
                raise TypeError(
                    f"{where}: the kernel writes into it, so it must be a writable C-contiguous "
                    f"{np.dtype(dtype).name} array of {ndim} dimension(s), got {_describe(value)}"
                )
            return value
        array = np.ascontiguousarray(value, dtype=dtype)
        if array.ndim != ndim:
            raise TypeError(f"{where}: expected {ndim} dimension(s), got {array.ndim}")
        return array

    return check


def _describe(value: Any) -> str:
    if isinstance(value, np.ndarray):
        layout = "C-contiguous" if value.flags.c_contiguous else "strided"
        access = "" if value.flags.writeable else "read-only "
        return f"a {access}{layout} {value.dtype} array of shape {value.shape}"
    return type(value).__name__


def _checker(kind: str, written: bool, where: str) -> Callable[[Any], Any]:
    """The check of an ``int`` or array argument (a ``float`` one needs none: the extension
    converts it as ``float()`` does, with a TypeError for what ``float()`` refuses)."""
    if kind == "int":
        return operator.index  # an int parameter refuses a float rather than truncate it
    dtype = np.float64 if kind.startswith("float") else np.int64
    return _array(dtype, kind.count(",") + 1, written, where)


def checked(
    kernel: Kernel, function: Callable[..., Any], params: list[str], defaults: list[Any]
) -> Callable[..., Any]:
    """``function`` (the extension's ``kernel``) called with its arguments checked against
    the kernel's kinds; ``params`` are its parameter names, ``defaults`` the values of the
    last ones (as in the module)."""
    where = [f"{kernel.name}() argument {name!r}" for name in params]
    checks = [
        (i, _checker(kind, i in kernel.written, where[i]))
        for i, kind in enumerate(kernel.args)
        if kind != "float"
    ]
    first_default = len(params) - len(defaults)

    def bind(args: tuple[Any, ...], kwargs: dict[str, Any]) -> list[Any]:
        """All arguments in order, from positions, keywords and defaults (as Python binds them)."""
        if len(args) > len(params):
            raise TypeError(f"{kernel.name}() takes {len(params)} arguments, got {len(args)}")
        values = list(args) + [None] * (len(params) - len(args))
        for name, value in kwargs.items():
            if name not in params or params.index(name) < len(args):
                raise TypeError(f"{kernel.name}() got an unexpected or repeated argument {name!r}")
            values[params.index(name)] = value
        for i in range(len(args), len(params)):
            if params[i] not in kwargs:
                if i < first_default:
                    raise TypeError(f"{kernel.name}() missing argument {params[i]!r}")
                values[i] = defaults[i - first_default]
        return values

    def call(*args: Any, **kwargs: Any) -> Any:
        values = list(args) if len(args) == len(params) and not kwargs else bind(args, kwargs)
        for i, check in checks:
            values[i] = check(values[i])
        return function(*values)

    call.__name__ = call.__qualname__ = kernel.name
    call.__doc__ = f"{kernel.module}.{kernel.name}, compiled ahead of time (arguments checked)."
    return call


class BuiltModule:
    """A module's kernels from the extension and its constants from the build record; any
    other name is the module's own (imported, and so compiled by numba, at first use)."""

    def __init__(self, module: str, names: dict[str, Any]) -> None:
        self.__name__ = module
        self.__dict__.update(names)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(importlib.import_module(self.__name__), name)


_loaded: dict[str, ModuleType | BuiltModule] = {}


def status(folder: Path = _PACKAGE) -> str:
    """Whether the extension in ``folder`` is used: ``"built"``, or why not: ``"not built"``
    (no build record, or no extension for this Python, as when another Python version built
    it), ``"stale"`` (built from other source), ``"off"`` (``MOTORID_JIT_ONLY=1``: every
    kernel through numba's JIT) or ``"off: NUMBA_DISABLE_JIT"`` (numba's switch to run kernels
    as plain Python, for debugging)."""
    if os.environ.get("MOTORID_JIT_ONLY", "0") not in ("", "0"):
        return "off"
    if os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"):
        return "off: NUMBA_DISABLE_JIT"
    try:
        record = json.loads((folder / BUILD_RECORD.name).read_text())
    except (OSError, ValueError):
        return "not built"
    if not any(
        (folder / f"{EXTENSION}{suffix}").exists() for suffix in importlib.machinery.EXTENSION_SUFFIXES
    ):
        return "not built"
    return "built" if record.get("digest") == source_digest() else "stale"


def built_module(module: str, extension: ModuleType, record: dict[str, Any]) -> BuiltModule:
    """The kernels of ``module`` in the built ``extension``, with the constants, parameter names
    and defaults of its build ``record``."""
    names = {k: tuple(v) if isinstance(v, list) else v for k, v in record["constants"][module].items()}
    for kernel in KERNELS:
        if kernel.module == module:
            params, defaults = record["parameters"][kernel.name]
            names[kernel.name] = checked(kernel, getattr(extension, kernel.name), params, defaults)
    return BuiltModule(module, names)


def load(module: str) -> ModuleType | BuiltModule:
    """The kernels of ``module``: the extension's when it is built from the current source
    (:func:`status`), else the module itself (compiled by numba at first call)."""
    if module not in _loaded:
        state = status()
        kernels: ModuleType | BuiltModule | None = None
        if state == "built":
            try:
                extension = importlib.import_module(f"{__package__}.{EXTENSION}")
            except ImportError as exc:  # e.g. built against another numpy: the JIT gives the same numbers
                logger.warning(
                    "the kernels compiled ahead of time do not load (%s); numba compiles them instead "
                    "(python -m motorid.compiled --force rebuilds them)",
                    exc,
                )
                state = "does not load"
            else:
                kernels = built_module(module, extension, json.loads(BUILD_RECORD.read_text()))
        _loaded[module] = kernels if kernels is not None else importlib.import_module(module)
        logger.debug(
            "%s: kernels %s", module, "compiled ahead of time" if state == "built" else f"by numba ({state})"
        )
    return _loaded[module]


def _constants(module: ModuleType) -> dict[str, Any]:
    """The module-level constants of ``module``: upper-case names of numbers, strings and
    tuples of them."""

    def constant(value: Any) -> bool:
        if isinstance(value, tuple):
            return all(constant(v) for v in value)
        return isinstance(value, (int, float, str)) and not isinstance(value, bool)

    return {k: v for k, v in vars(module).items() if k.isupper() and constant(v)}


def build(folder: Path = _PACKAGE) -> Path:
    """Compile :data:`KERNELS` ahead of time into ``folder``; the path of the extension.

    The extension is compiled in a temporary folder and moved into place in one rename, and
    the build record (:data:`BUILD_RECORD`'s name, in ``folder``) is written after it: a
    process never loads a half-written extension, and a build that fails leaves it unused.
    Takes 10-30 s.
    """
    import inspect
    import tempfile
    import warnings

    with warnings.catch_warnings():  # numba marks pycc as pending deprecation, with no replacement yet
        warnings.simplefilter("ignore")
        from numba.pycc import CC

    digest = source_digest()
    record_path = folder / BUILD_RECORD.name
    record_path.unlink(missing_ok=True)
    compiler = CC(EXTENSION)
    compiler.verbose = False
    parameters: dict[str, Any] = {}
    constants: dict[str, Any] = {}
    for kernel in KERNELS:
        module = importlib.import_module(kernel.module)
        constants.setdefault(kernel.module, _constants(module))
        function = getattr(module, kernel.name).py_func
        signature = f"{kernel.result}({', '.join(KINDS[kind] for kind in kernel.args)})"
        compiler.export(kernel.name, signature)(function)
        params = list(inspect.signature(function).parameters.values())
        if len(params) != len(kernel.args):
            raise ValueError(f"{kernel.name}: {len(params)} parameters, {len(kernel.args)} kinds declared")
        defaults = [p.default for p in params if p.default is not inspect.Parameter.empty]
        parameters[kernel.name] = ([p.name for p in params], defaults)
    with tempfile.TemporaryDirectory(dir=folder) as scratch:
        compiler.output_dir = scratch
        compiler.compile()
        built = next(Path(scratch).glob(f"{EXTENSION}.*"))
        extension = folder / built.name
        os.replace(built, extension)
    record = {"digest": digest, "constants": constants, "parameters": parameters}
    record_path.write_text(json.dumps(record, indent=1) + "\n")
    return extension


def main(argv: list[str] | None = None) -> int:
    """``python -m motorid.compiled [--force]``: build the extension unless it is current."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m motorid.compiled", description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="build even when the build is current")
    args = parser.parse_args(argv)
    state = status()
    if state == "built" and not args.force:
        print(f"motorid kernels compiled ahead of time: current ({BUILD_RECORD})", file=sys.stderr)
        return 0
    print(f"motorid kernels compiled ahead of time: {state}, building (10-30 s)", file=sys.stderr)
    extension = build()
    print(f"motorid kernels compiled ahead of time: {extension}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
