"""Solver threads that give way to other processes (weft/thread_governor.py): changing the thread
count between frames never changes a trajectory, the governor's decisions, and a real run beside
processes that keep every core busy."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.omp_wait import busy_processes
from scenes.collision import drop_shot
from weft import simulate as frame_loop
from weft.cache import describe_cache
from weft.runner import ShotRunner
from weft.thread_governor import (CONTENDED_FRAMES, CONTENDED_SHARE, FIRST_PROBE, LONGEST_PROBE, ThreadGovernor,
                                  cpu_wait_seconds)
from tests.helpers import make_scene

needs_schedstat = pytest.mark.skipif(cpu_wait_seconds() is None,
                                     reason="the kernel reports no run delay (/proc/self/task/*/schedstat)")


def draping_sheet(frames: int) -> object:
    """48 x 48 vertices with self-collision on a sphere: every parallel part of the step splits its
    work at this size (the solve's threads start at 2048 vertices). Runs beside busy processes
    start one more of them than there are CPUs, so the solver's threads wait on any machine."""
    doc = drop_shot("sphere", n=48, frames=frames, substeps=2)
    doc["features"] = {"self_collision": True}
    return make_scene(doc)


def test_threads_changed_between_frames_move_the_cloth_bitwise_as_one_count() -> None:
    scene = draping_sheet(frames=8)
    steady = frame_loop.new_simulation(scene, 2)
    changing = frame_loop.new_simulation(scene, 2)
    counts = [1, 3, 2, 1, 2, 3, 1]
    reached = 0
    for index, threads in zip(range(1, scene.frame_count), counts, strict=True):
        frame_loop.advance(steady, scene, index)
        changing.threads = threads
        t = frame_loop.advance(changing, scene, index)
        assert t.threads == threads  # the frame ran on what was set
        assert np.array_equal(steady.positions, changing.positions), f"frame {index} on {threads} threads"
        assert np.array_equal(steady.velocities, changing.velocities)
        reached += t.proximity_pairs
    assert reached > 0  # the sheet did reach the sphere


def test_fewer_than_one_thread_is_refused() -> None:
    sim = frame_loop.new_simulation(draping_sheet(frames=2), 2)
    with pytest.raises(ValueError, match="threads must be at least 1"):
        sim.threads = 0
    assert sim.threads == 2
    with pytest.raises(ValueError, match="threads: must be at least 1, got 0"):
        ThreadGovernor(sim, 0)


def test_contended_frames_halve_the_threads_and_probes_wait_longer_each_time_they_fail() -> None:
    sim = frame_loop.new_simulation(draping_sheet(frames=2), 4)
    governor = ThreadGovernor(sim, 4, enabled=True)
    governor.adapting = True  # the decisions alone, also where the kernel does not report the wait
    busy, idle = 2 * CONTENDED_SHARE, 0.5 * CONTENDED_SHARE

    assert CONTENDED_FRAMES == 2
    governor.choose(4, idle)
    assert sim.threads == 4  # uncontended at the requested count: nothing to do
    governor.choose(4, busy)
    governor.choose(4, idle)
    assert sim.threads == 4  # one crowded frame alone (the machine's services waking) changes nothing
    governor.choose(4, busy)
    governor.choose(4, busy)
    assert sim.threads == 2
    governor.choose(2, busy)
    assert sim.threads == 2
    governor.choose(2, busy)
    assert sim.threads == 1
    for _ in range(FIRST_PROBE - 1):
        governor.choose(1, 0.0)  # one thread waits for nothing: no sign either way
        assert sim.threads == 1
    governor.choose(1, 0.0)
    assert sim.threads == 2  # the probe
    governor.choose(2, busy)  # failed: back, and the next probe waits twice as long
    assert sim.threads == 1 and governor.probe_interval == 2 * FIRST_PROBE
    for _ in range(2 * FIRST_PROBE - 1):
        governor.choose(1, 0.0)
    assert sim.threads == 1
    governor.choose(1, 0.0)
    assert sim.threads == 2
    governor.choose(2, idle)  # the probe found the cores free: the next one comes soon
    assert sim.threads == 2 and governor.probe_interval == FIRST_PROBE
    for _ in range(FIRST_PROBE):
        governor.choose(2, idle)
    assert sim.threads == 4

    for _ in range(20):  # probes that keep failing wait at most LONGEST_PROBE frames
        while sim.threads > 1:
            governor.choose(sim.threads, busy)
        while sim.threads == 1:
            governor.choose(1, 0.0)
    assert governor.probe_interval == LONGEST_PROBE


def test_one_thread_or_the_switch_keeps_the_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    sim = frame_loop.new_simulation(draping_sheet(frames=2), 1)
    assert not ThreadGovernor(sim, 1).adapting
    monkeypatch.setenv("WEFT_THREAD_GOVERNOR", "off")
    sim.threads = 2
    assert not ThreadGovernor(sim, 2).adapting


@needs_schedstat
def test_beside_processes_that_keep_every_core_busy_a_run_gives_way_and_its_probe_too() -> None:
    scene = draping_sheet(frames=FIRST_PROBE + 6)
    sim = frame_loop.new_simulation(scene, 2)
    governor = ThreadGovernor(sim, 2, enabled=True)
    rows = []
    with busy_processes(frame_loop.usable_cpus() + 1):
        for index in range(1, scene.frame_count):
            t = frame_loop.advance(sim, scene, index, governor)
            rows.append(frame_loop.telemetry_row(index, t, governor))
    threads = [row.threads for row in rows]
    assert threads[:2] == [2, 2] and all(row.cpu_wait_share > CONTENDED_SHARE for row in rows[:2]), rows[:2]
    # Then one thread until the try at two, which finds the cores still taken.
    assert threads[2:FIRST_PROBE + 2] == [1] * FIRST_PROBE, threads
    assert threads[FIRST_PROBE + 2] == 2 and rows[FIRST_PROBE + 2].cpu_wait_share > CONTENDED_SHARE, threads
    assert threads[FIRST_PROBE + 3:] == [1] * len(threads[FIRST_PROBE + 3:]), threads
    assert governor.probe_interval == 2 * FIRST_PROBE


@needs_schedstat
@pytest.mark.skipif(frame_loop.usable_cpus() < 2, reason="a run on one CPU has one thread: nothing to give way")
def test_a_crowded_run_records_its_threads_in_the_cache_and_weft_info(tmp_path: Path) -> None:
    scene = draping_sheet(frames=5)
    with busy_processes(frame_loop.usable_cpus() + 1):
        summary = ShotRunner(scene, tmp_path / "c.h5", threads=2).run()
    threads = [row.threads for row in summary.telemetry[1:]]
    assert threads == [2, 2, 1, 1], threads
    assert summary.telemetry[1].cpu_wait_share > CONTENDED_SHARE
    info = describe_cache(tmp_path / "c.h5")
    assert info["solver_threads"]["fewest"] == 1 and info["solver_threads"]["most"] == 2
    assert info["solver_threads"]["max_cpu_wait_share"] == max(row.cpu_wait_share for row in summary.telemetry)


@needs_schedstat
@pytest.mark.skipif(frame_loop.usable_cpus() < 2, reason="a run on one CPU has one thread: nothing to give way")
def test_weft_run_says_when_it_ran_on_fewer_threads(tmp_path: Path) -> None:
    doc = drop_shot("sphere", n=48, frames=5, substeps=2)
    doc["features"] = {"self_collision": True}
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps(doc))
    with busy_processes(frame_loop.usable_cpus() + 1):
        done = subprocess.run([sys.executable, "-m", "weft.cli", "run", str(shot), "-o", str(tmp_path / "c.h5"),
                               "--threads", "2"], capture_output=True, text=True, timeout=300,
                              env={**os.environ, "COLUMNS": "200"})
    assert done.returncode == 0, done.stderr
    assert "1-2: fewer while other processes wanted the cores" in done.stdout, done.stdout
