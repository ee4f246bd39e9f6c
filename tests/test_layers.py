"""The house's rules that a walk over the package can check: data flows one way through
the layers, no two modules import each other, and every exception lives in motorid.errors.

The imports are read from the source with :mod:`ast`, at module level and inside
functions and methods alike (a function-level import is a dependency all the same), and
the modules a package's :func:`~motorid.exports.lazy_exports` names;
relative imports are resolved against the importing module's package, and
``from package import name`` counts as importing ``package.name`` when that is a
module. Imports under ``if TYPE_CHECKING:`` are left out: they are never run, and a
type named in an annotation is not code the module runs.

Each module is mapped to a layer (:data:`LAYERS`, bottom first). An import may go to
its own layer or one below; an import that goes up a layer, and a pair of modules that
import each other, fail the test, unless named in :data:`UPWARD` or :data:`MUTUAL` with
the reason it is still there. Those lists only shrink: an entry that no longer occurs
fails the test too, so it is taken out when the import goes.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil
from pathlib import Path

import motorid
import motorid.errors

PACKAGE = Path(motorid.__file__).parent

#: The layers today, bottom first: each module (or package, with everything in it) and the
#: layer it is in; the longest matching prefix decides. The design's layers are drive <-
#: estimators, io <- diagnose, validation <- app <- cli, fleet.
LAYERS: dict[str, int] = {
    # 0: imports nothing of motorid
    "motorid.errors": 0,
    "motorid.exports": 0,
    # 1: the common ground: units, checked JSON, writing files, progress bars, figure layout
    "motorid.units": 1,
    "motorid.json_input": 1,
    "motorid.inputs": 1,
    "motorid.outputs": 1,
    "motorid.progress": 1,
    "motorid.figures": 1,
    # 2: the physics, the excitation signals and the digital low-pass filters
    "motorid.drive": 2,
    "motorid.signals": 2,
    "motorid.iir": 2,
    # 3: what measures and estimates a drive, and the records it writes
    "motorid.estimators": 3,
    "motorid.io": 3,
    "motorid.datasets": 3,
    # 5: metrics and residual tests
    "motorid.validation": 5,
    # 6: the work done on records and models
    "motorid.diagnose": 6,
    "motorid.comparison": 6,
    "motorid.experiment": 6,
    "motorid.compensation": 6,
    "motorid.control_design": 6,
    "motorid.speed_control": 6,
    "motorid.controller_c": 6,
    "motorid.testing": 6,
    # 7: the per-record work of the commands, with typed options (the design's app)
    "motorid.app": 7,
    # 8: many records at once
    "motorid.fleet": 8,
    # 9: the command line
    "motorid.cli": 9,
    # 10: the package's own face (load_model, save_model)
    "motorid": 10,
}

#: Imports that go up a layer today: (importer, imported) and why it is still there.
UPWARD: dict[tuple[str, str], str] = {}

#: Pairs of modules that import each other today, and why.
MUTUAL: dict[frozenset[str], str] = {}


def module_names() -> list[str]:
    """Every module of motorid by its dotted name (``__main__`` left out: importing it runs the CLI)."""
    names = ["motorid"]
    for info in pkgutil.walk_packages([str(PACKAGE)], prefix="motorid."):
        if not info.name.endswith(".__main__"):
            names.append(info.name)
    return sorted(names)


def source_files() -> dict[str, tuple[Path, bool]]:
    """Each module's dotted name: its file and whether it is a package's ``__init__``."""
    files = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        files[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return files


def is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def imported_modules(path: Path, module: str, is_package: bool, files: dict) -> dict[str, int]:
    """The motorid modules ``module`` imports, module and function level, with the first line.

    ``from a import b`` imports the module ``a.b`` when that is one, else the module ``a``.
    """
    package = module if is_package else module.rpartition(".")[0]
    found: dict[str, int] = {}

    def add(name: str, line: int) -> None:
        if name.split(".")[0] == "motorid" and name != module:
            found.setdefault(name, line)

    def walk(node: ast.AST) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and is_type_checking(child):
                for other in child.orelse:
                    walk(other)
                continue
            if isinstance(child, ast.Import):
                for alias in child.names:
                    add(alias.name, child.lineno)
            elif isinstance(child, ast.Call) and getattr(child.func, "id", None) == "lazy_exports":
                # a package's names imported on first use (motorid.exports): their modules are imports
                for value in getattr(child.args[1], "values", []) if len(child.args) > 1 else []:
                    if isinstance(value, ast.Constant) and isinstance(value.value, str):
                        relative = value.value.startswith(".")
                        add(f"{package}{value.value}" if relative else value.value, child.lineno)
            elif isinstance(child, ast.ImportFrom):
                base = package.rsplit(".", child.level - 1)[0] if child.level > 1 else package
                if not child.level:
                    source = child.module or ""
                else:
                    source = f"{base}.{child.module}" if child.module else base
                submodules = [f"{source}.{a.name}" for a in child.names if f"{source}.{a.name}" in files]
                for name in submodules or [source]:
                    add(name, child.lineno)
            walk(child)

    walk(ast.parse(path.read_text(encoding="utf-8")))
    return found


def motorid_imports() -> dict[str, dict[str, int]]:
    """For each module: the motorid modules it imports, with the first line that does."""
    files = source_files()
    return {module: imported_modules(path, module, is_pkg, files) for module, (path, is_pkg) in files.items()}


def layer(module: str) -> int:
    prefix = max((p for p in LAYERS if module == p or module.startswith(p + ".")), key=len)
    return LAYERS[prefix]


GRAPH = motorid_imports()


def test_every_module_has_a_layer_and_the_walk_sees_the_imports():
    """The walk finds the package's imports (a check that it reads anything at all)."""
    assert set(GRAPH) == set(module_names()) | {"motorid.cli.__main__"}
    assert (
        "motorid.drive.files" in GRAPH["motorid.estimators.registry"]
    )  # from motorid.drive.files import ...
    assert "motorid.io.base" in GRAPH["motorid.io.modbus"]  # from .base import DAQ, Sample
    assert "motorid.estimators" in GRAPH["motorid"]  # lazy_exports(__name__, {...: "motorid.estimators"})
    assert "motorid.io.rig_server" in GRAPH["motorid.io"]  # lazy_exports(__name__, {...: ".rig_server"})
    assert "motorid.diagnose.workflow" not in GRAPH["motorid.diagnose.figures"]  # only for annotations
    for module in GRAPH:
        layer(module)  # every module falls under some prefix


def test_no_import_goes_up_a_layer():
    upward = {
        (
            module,
            target,
        ): f"{module} (layer {layer(module)}) imports {target} (layer {layer(target)}), line {line}"
        for module, targets in GRAPH.items()
        for target, line in targets.items()
        if layer(target) > layer(module)
    }
    new = [text for pair, text in sorted(upward.items()) if pair not in UPWARD]
    gone = [f"{a} -> {b}" for a, b in UPWARD if (a, b) not in upward]
    assert new == [], "imports that go up a layer"
    assert gone == [], "listed in UPWARD but no longer there: take them out of the list"


#: What the drive package may import of motorid besides itself: the design's errors and units, and
#: the checked reading and whole writing of files its model files need (json_input, inputs, outputs). The
#: physics of a drive stands on nothing else of the package.
DRIVE_MAY_IMPORT = (
    "motorid.errors",
    "motorid.units",
    "motorid.json_input",
    "motorid.inputs",
    "motorid.outputs",
)


def test_the_drive_imports_nothing_of_motorid_but_errors_units_and_file_io():
    found = {
        f"{module} imports {target} (line {line})"
        for module, targets in GRAPH.items()
        if module == "motorid.drive" or module.startswith("motorid.drive.")
        for target, line in targets.items()
        if not (target == "motorid.drive" or target.startswith("motorid.drive."))
        and target not in DRIVE_MAY_IMPORT
    }
    assert sorted(found) == []


def test_no_two_modules_import_each_other():
    mutual = {
        frozenset({module, target})
        for module, targets in GRAPH.items()
        for target in targets
        if module in GRAPH.get(target, {})
    }
    new = sorted(" <-> ".join(sorted(pair)) for pair in mutual - set(MUTUAL))
    gone = sorted(" <-> ".join(sorted(pair)) for pair in set(MUTUAL) - mutual)
    assert new == [], "modules that import each other"
    assert gone == [], "listed in MUTUAL but no longer there: take them out of the list"


def test_every_exception_of_the_package_is_defined_in_motorid_errors():
    """A public exception class defined anywhere but motorid.errors is named here; a private one
    that never leaves its module may stay."""
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
