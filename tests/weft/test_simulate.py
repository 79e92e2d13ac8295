"""The frame loop (weft.simulate) and the telemetry schema: the runner, the tests and the
benchmarks step through the same loop; every schema field is read from the solver's record and
survives the cache's table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from api_schemas import FrameTelemetry
from scenes.builders import sheet_shot
from scenes.collision import twist_shot
from weft.cache import open_cache_reader
from weft.runner import ShotRunner
from weft.simulate import (SolverFailure, advance, initial_telemetry, new_simulation, simulate, solver_threads,
                           telemetry_row, usable_cpus)

from tests.helpers import make_scene


def test_runner_and_frame_loop_give_the_same_state(tmp_path: Path) -> None:
    # Animated bodies with pinned cloth: body keyframes and substeps go through the same loop.
    scene = make_scene(twist_shot(tmp_path, n=6, frames=4), tmp_path)
    ShotRunner(scene, tmp_path / "c.h5").run()
    for index, sim, t in simulate(scene):
        assert t.substeps >= scene.shot.substeps  # more where a substep was halved
    assert index == scene.frame_count - 1
    with open_cache_reader(tmp_path / "c.h5") as f:
        assert np.array_equal(f["state/positions"][()], sim.positions)
        assert np.array_equal(f["state/velocities"][()], sim.velocities)


def test_telemetry_rows_read_every_field_and_survive_the_cache(tmp_path: Path) -> None:
    scene = make_scene(sheet_shot("t", 6, 6, 0.3, 0.3, pins=[0, 5], frames=3, substeps=2))
    summary = ShotRunner(scene, tmp_path / "c.h5").run()
    first, *simulated = summary.telemetry
    assert first.substeps == 0 and first.total_seconds == 0.0
    assert first.intersections == FrameTelemetry.model_fields["intersections"].default
    assert all(row.substeps == 2 and row.cg_iterations > 0 for row in simulated)
    with open_cache_reader(tmp_path / "c.h5") as f:
        table = f["telemetry"][()]
    assert list(table.dtype.names) == list(FrameTelemetry.model_fields)
    assert [FrameTelemetry(**{k: row[k].item() for k in table.dtype.names}) for row in table] == summary.telemetry

    sim = new_simulation(scene)
    e = sim.energies()
    row = initial_telemetry(1, sim)
    assert (row.kinetic_energy, row.potential_energy) == (e.kinetic, e.gravity + e.elastic)
    t = advance(sim, scene, 1)
    row = telemetry_row(2, t)
    assert row.frame == 2
    assert all(getattr(row, k) == getattr(t, k) for k in FrameTelemetry.model_fields
               if k not in {"frame", "cpu_wait_share"})
    assert row.threads == 1 and row.cpu_wait_share == 0.0  # the CPU wait is a governor's


def test_a_diverging_frame_is_a_solver_failure_at_that_frame() -> None:
    scene = make_scene(sheet_shot("overflow", 4, 4, 0.2, 0.2, frames=5, gravity=(0.0, -1e300, 0.0)))
    with pytest.raises(SolverFailure) as failure:
        for _ in simulate(scene):
            pass
    assert failure.value.frame == 2 and "non-finite" in failure.value.reason


def test_a_run_uses_at_most_the_cpus_it_may_run_on(tmp_path: Path) -> None:
    cpus = usable_cpus()
    assert solver_threads(1) == 1 and solver_threads(cpus) == cpus and solver_threads(cpus + 7) == cpus
    scene = make_scene(sheet_shot("t", 6, 6, 0.3, 0.3, pins=[0, 5], frames=3))
    asked = ShotRunner(scene, tmp_path / "many.h5", threads=cpus + 7)
    assert asked.threads == cpus + 7 and asked.threads_used == cpus
    asked.run()
    ShotRunner(scene, tmp_path / "one.h5", threads=1).run()
    with open_cache_reader(tmp_path / "many.h5") as many, open_cache_reader(tmp_path / "one.h5") as one:
        assert many.attrs["threads"] == cpus  # the cache records the threads the run used
        assert np.array_equal(many["state/positions"][()], one["state/positions"][()])


def test_weft_run_says_when_it_uses_fewer_threads_than_asked(tmp_path: Path) -> None:
    import json
    import subprocess
    import sys

    asked = usable_cpus() + 1
    if asked > 256:  # --threads allows at most 256
        pytest.skip("this machine has more usable CPUs than --threads allows")
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps(sheet_shot("t", 4, 4, 0.2, 0.2, pins=[0], frames=2)))
    done = subprocess.run([sys.executable, "-m", "weft.cli", "run", str(shot), "-o", str(tmp_path / "c.h5"),
                           "--threads", str(asked), "-q"], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert f"--threads {asked}: this process may run on {usable_cpus()} CPU(s)" in " ".join(done.stderr.split())
