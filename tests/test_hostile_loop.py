"""A loop that keeps time: no garbage collection inside a sample, the largest interval reported."""

from __future__ import annotations

import gc
import math

from cli_fixtures import run

from motorid.io import SimulatedDAQ
from motorid.io.online import CollectorBetweenSamples, RunRecorder, sample_loop


class Cycle:
    """An object in a reference cycle: only the garbage collector frees it."""

    alive = 0

    def __init__(self) -> None:
        Cycle.alive += 1
        self.me = self
        self.payload = [float(i) for i in range(20)]

    def __del__(self) -> None:
        Cycle.alive -= 1


def test_no_collection_starts_inside_a_sample_and_cycles_are_still_freed():
    daq = SimulatedDAQ(seed=0)
    inside = False
    started_inside: list[int] = []
    started_between: list[int] = []

    def watch(phase: str, info: dict) -> None:
        if phase == "start":
            (started_inside if inside else started_between).append(info["generation"])

    def sample(k: int) -> dict[str, float | int]:
        nonlocal inside
        inside = True
        for _ in range(300):  # 300 cyclic objects a sample: the collector would start every few samples
            Cycle()
        daq.write(0.0)
        taken = daq.read()
        inside = False
        return {"t": taken.t, "y": taken.y}

    recorder = RunRecorder(None, keep=10)
    was_enabled = gc.isenabled()
    gc.callbacks.append(watch)
    try:
        sample_loop(daq, 2500, sample, recorder, "test")
    finally:
        gc.callbacks.remove(watch)
    assert started_inside == []
    assert 2 in started_between  # the collections of everything since the start (every 1000 samples)
    assert len(started_between) >= 2500 * 300 // CollectorBetweenSamples.YOUNG_LIMIT // 2
    gc.collect()
    assert Cycle.alive == 0
    assert gc.isenabled() == was_enabled and gc.get_freeze_count() == 0
    assert math.isfinite(recorder.largest_interval) and recorder.largest_interval > 0
    assert 1 <= recorder.largest_interval_sample < 2500


def test_the_collector_is_restored_after_a_loop_that_failed():
    daq = SimulatedDAQ(seed=0)
    was_enabled = gc.isenabled()

    def sample(k: int) -> dict[str, float | int]:
        if k == 3:
            raise RuntimeError("sample 3 failed")
        daq.write(0.0)
        return {"y": daq.read().y}

    recorder = RunRecorder(None)
    try:
        sample_loop(daq, 10, sample, recorder, "test")
    except RuntimeError as exc:
        assert "test stopped after 3 of 10 samples" in exc.__notes__[0]
    assert gc.isenabled() == was_enabled and gc.get_freeze_count() == 0


def test_run_reports_the_largest_time_between_two_samples(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code, result, err = run(
        capsys, "run", "--estimator", "arx-rls", "--duration", "2", "--out", str(out), "--json"
    )
    assert code == 0, err
    assert 0 < result["largest_interval"] < 2.0
    assert "largest time between two samples" in err
