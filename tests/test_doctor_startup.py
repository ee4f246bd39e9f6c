"""What a fresh ``motorid doctor`` process loads: the libraries it does not use stay out of its
start-up (benchmarks/bench_doctor_startup.py measures the time; this checks the imports, which a
loaded machine does not make flaky)."""

from __future__ import annotations

import json
import subprocess
import sys

from motorid.diagnose.synthetic import planted_record
from motorid.io.records import write_record

#: The console script's path into the command (motorid.cli.run), its report to a string; then
#: which of the modules the doctor should not need were loaded.
PROBE = """
import contextlib, io, json, sys
from motorid.cli import run
sys.argv = ["motorid", "doctor", sys.argv[1], "--json"]
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        run()
    except SystemExit as done:
        code = done.code
print(json.dumps({"code": code, "loaded": sorted(m for m in sys.argv[2:] if m in sys.modules)}))
"""


def test_the_doctor_loads_neither_scipy_signal_nor_scipy_stats(tmp_path):
    """``scipy.signal`` imports ``scipy.stats`` and ``scipy.interpolate`` with it (some 0.35 s of
    CPU time): the doctor's filters are :mod:`motorid.iir`'s."""
    path = tmp_path / "rec.csv"
    write_record(planted_record("coulomb_friction", 3).record, path)
    unwanted = ["scipy.signal", "scipy.stats", "scipy.interpolate"]
    done = subprocess.run([sys.executable, "-c", PROBE, str(path), *unwanted],
                          capture_output=True, text=True, check=True)  # fmt: skip
    assert json.loads(done.stdout) == {"code": 0, "loaded": []}
