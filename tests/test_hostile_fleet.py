"""A fleet in a hostile world: a frozen worker, the scheduler's address, a script without a main guard."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from motorid.fleet.results import load_results
from motorid.fleet.runner import fleet_client, run_fleet


def freezing_task(path: str, given: dict) -> dict:
    """A record's task; the record named ``frozen`` stops its worker process (SIGSTOP) for good."""
    if "frozen" in Path(path).name:
        os.kill(os.getpid(), signal.SIGSTOP)
    return {"record": path, "drive": Path(path).stem, "status": "ok", "value": float(len(path))}


def test_a_frozen_worker_times_out_its_record_and_the_run_goes_on(tmp_path):
    records = []
    for name in ["a", "b", "frozen", "c", "d", "e", "f", "g"]:
        path = tmp_path / "records" / f"{name}.csv"
        path.parent.mkdir(exist_ok=True)
        path.write_text("t,u,y\n")
        records.append(str(path))
    out = tmp_path / "results"
    with fleet_client(workers=2) as client:
        assert client.scheduler.address.startswith("tcp://127.0.0.1:")  # loopback only
        assert not client.scheduler.address.endswith(":8786")  # a random port, not Dask's default
        fleet = run_fleet(records, freezing_task, out, client, task_timeout=5.0)
    assert (fleet.done, fleet.failed) == (7, 1)
    rows = load_results(out).set_index("drive")
    assert len(rows) == 8
    assert rows.loc["frozen", "status"] == "failed"
    assert (
        "TimeoutError: the task ran longer than 5 s on worker tcp://127.0.0.1:" in rows.loc["frozen", "error"]
    )
    assert (rows.drop(index="frozen")["status"] == "ok").all()


SCRIPT = """
from motorid.fleet import IdentifyJob, run
from motorid.fleet.synthetic import make_fleet, write_fleet

def main():
    write_fleet("fleet", make_fleet(1, seed=0), days=1, duration=10.0)
    counts = run("fleet", "results", IdentifyJob(estimator="arx-rls"), workers=1, figures=False)
    print("done", counts.done, counts.failed)
"""


@pytest.mark.parametrize("guarded", [False, True])
def test_a_fleet_script_runs_under_a_main_guard_and_without_one_is_told_what_to_add(tmp_path, guarded):
    body = SCRIPT + ('\nif __name__ == "__main__":\n    main()\n' if guarded else "\nmain()\n")
    script = tmp_path / "fleet_example.py"
    script.write_text(textwrap.dedent(body))
    proc = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    if guarded:
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.strip().splitlines()[-1] == "done 1 0"
        return
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    assert last == (
        f"motorid.errors.DataError: the Dask worker processes did not start: each imports {script} again, "
        'which runs the fleet at import; put the code that runs it under if __name__ == "__main__":'
    )
