"""Test-suite configuration: the hypothesis profiles, the ``cpu_sensitive`` marker, a small disk.

Hypothesis profiles (chosen with the environment variable ``HYPOTHESIS_PROFILE``):

``ci`` (the default, what ``make test`` runs)
    Derandomized: every run tries the same examples, so a red run is reproduced by
    running it again, and a green one does not turn red by chance. No deadline and
    no ``too_slow`` health check (both time the test, which a loaded shared machine
    makes flaky); the blob to reproduce a failure is printed. 100 examples per test
    unless the test sets its own number with :func:`examples`.
``thorough``
    Random examples (a new draw every run, failures replayed from the example
    database), 1000 per test, and ten times the number a test sets with
    :func:`examples`. For a developer hunting bugs: ``HYPOTHESIS_PROFILE=thorough
    .venv/bin/python -m pytest tests/test_rls.py``.

A test that needs its own number of examples (because each one is slow) takes it
from :func:`examples`, which scales it with the profile; a plain ``@settings(...)``
keeps the profile's other values (derandomize, deadline) but fixes the number.

The ``cpu_sensitive`` marker selects the tests that hold two code paths to the
same numbers (``batch_filter`` against the sample loop, the conformance suite, a
plant's step loop against its record simulation). ``make test`` runs them a second
time with ``NUMBA_CPU_NAME=generic``, so the compiled kernels are checked on a
second target: a difference between paths that only one CPU's instructions hide
shows up there.
"""

from __future__ import annotations

import os
import signal
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

#: Factor on the number of examples a test sets with :func:`examples`, per profile.
_SCALE = {"ci": 1, "thorough": 10}

settings.register_profile(
    "ci",
    max_examples=100,
    derandomize=True,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "thorough",
    max_examples=1000,
    derandomize=False,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)
PROFILE = os.environ.get("HYPOTHESIS_PROFILE", "ci")
settings.load_profile(PROFILE)


def examples(n: int, **kwargs) -> settings:
    """Hypothesis settings for a test that sets its own number of examples.

    ``n`` examples under the ``ci`` profile, ten times as many under ``thorough``;
    every other setting from the profile unless given in ``kwargs``.
    """
    return settings(max_examples=n * _SCALE.get(PROFILE, 1), **kwargs)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "cpu_sensitive: holds two code paths to the same numbers; make test runs these again "
        "under NUMBA_CPU_NAME=generic",
    )
    # The tests interrupt the commands they start (rig serve, fleet, run) with SIGINT, as Ctrl-C
    # does. A test run started in the background of a shell (`make test &`, nohup) inherits SIGINT
    # ignored, and so would every command it starts: such a command stays deaf to Ctrl-C, as a
    # background job should. The run takes Python's own handler back, so the commands it starts
    # begin with SIGINT at its default and turn it into KeyboardInterrupt.
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture
def small_disk(tmp_path: Path):
    """A 64 kB tmpfs mounted at a folder of the test; skipped where mounting is not permitted."""
    folder = tmp_path / "disk"
    folder.mkdir()
    if os.name != "posix" or os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root on Linux: no full disk to write to here")
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)], capture_output=True, text=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=False)
