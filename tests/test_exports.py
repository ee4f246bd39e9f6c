"""A package's names imported on first use (:func:`motorid.exports.lazy_exports`): importing the
records wing loads no DAQ backend, ``import motorid`` no drive model; each name is its module's
object once read; an unknown name fails as an attribute of the package does."""

from __future__ import annotations

import subprocess
import sys

import pytest

import motorid
import motorid.io

LOADED = """
import sys
import {module}
print(" ".join(sorted(m for m in {watched!r} if m in sys.modules)))
"""


@pytest.mark.parametrize(
    ("module", "unloaded"),
    [
        (
            "motorid.io.records",
            ("asyncio", "motorid.io.rig_server", "motorid.io.modbus", "motorid.io.online"),
        ),
        ("motorid", ("numba", "motorid.estimators", "motorid.drive")),
    ],
)
def test_importing_a_package_loads_no_module_of_its_names_until_one_is_read(module, unloaded):
    """In a fresh process (this one has loaded everything already)."""
    code = LOADED.format(module=module, watched=unloaded)
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    assert done.stdout.split() == []


def test_a_name_read_is_its_modules_object_and_stays_in_the_package():
    from motorid.estimators import load_model
    from motorid.io.rig_server import RigServer

    assert motorid.io.RigServer is RigServer and "RigServer" in vars(motorid.io)
    assert motorid.load_model is load_model
    assert "SimulatedDAQ" in dir(motorid.io) and "save_model" in dir(motorid)


def test_an_unknown_name_is_an_attribute_error_naming_the_package():
    with pytest.raises(AttributeError, match=r"module 'motorid.io' has no attribute 'RigServr'"):
        motorid.io.RigServr  # noqa: B018
    with pytest.raises(ImportError, match="RigServr"):
        from motorid.io import RigServr  # noqa: F401
