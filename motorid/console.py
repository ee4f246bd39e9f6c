"""The ``motorid`` console script: :func:`motorid.cli.run`, the command line's modules loaded with
Python's collector off.

Loading :mod:`motorid.cli` loads numpy, pandas, SciPy, numba and the commands' modules: some
150,000 objects that live as long as the process and leave no garbage. With the collector on, it
passes over them while they load (on ``motorid doctor``'s path 334 young, 31 middle and 2 full
collections, 0.1 s of CPU time; ``benchmarks/bench_doctor_startup.py``), to free nothing. So the
collector is off while they load, and they are moved out of its sight (:func:`gc.freeze`) before
it is switched back on; :func:`motorid.cli.run` then runs the command as before. This lives
outside :mod:`motorid.cli` because importing any module of that package loads it whole.
"""

from __future__ import annotations

import gc
from typing import NoReturn


def run() -> NoReturn:
    """The ``motorid`` command: :func:`motorid.cli.run`, its modules loaded with the collector off
    (module docstring); exits with the command's status."""
    gc.disable()
    try:
        from motorid.cli import run as command
    finally:
        gc.freeze()  # the loaded modules live as long as the process: no collection passes over them
        gc.enable()
    command()


__all__ = ["run"]
