"""The fast linear system: bitwise determinism run to run and across thread counts, agreement
with the reference path on the demo shot, transient springs, and the CLI switch."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from scenes.builders import demo_flag_files, sheet_shot
from weft import _solver
from weft.runner import ShotRunner
from weft.shot import load_shot_file
from weft.simulate import new_simulation
from weft.solver_setup import build_setup, resolve_scene

from tests.helpers import final_positions, make_scene


def windy_sheet(frames: int = 3) -> dict:
    # 96 x 96 = 9216 vertices: several fixed-size reduction chunks, and above the size at which
    # the fast solve goes parallel, so the thread split matters.
    return sheet_shot(
        "determinism", 96, 96, 2.4, 2.4, pins=[0, 95], frames=frames, substeps=2, air_drag=0.4,
        wind={"velocity": [1.0, 0.0, 2.5], "gust_amplitude": 0.5, "gust_frequency": 0.7},
        material={"density": 0.2, "stretch_warp": 3000.0, "stretch_weft": 2000.0, "shear": 150.0, "bend": 2e-5,
                  "damping": 0.001},
        solver={"linear_system": "fast", "matrix_precision": "float32"},
    )


def cache_arrays(path: Path) -> dict[str, bytes]:
    with h5py.File(path, "r") as f:
        return {name: f[name][()].tobytes() for name in
                ("frames/positions", "frames/velocities", "state/positions", "state/velocities", "state/warm_start")}


def test_fast_path_is_bitwise_deterministic_across_runs_and_threads(tmp_path: Path) -> None:
    scene = make_scene(windy_sheet())
    results = {}
    for run, threads in enumerate((1, 2, 1, 2)):
        cache = tmp_path / f"run{run}.h5"
        ShotRunner(scene, cache, threads=threads).run()
        results[(run, threads)] = cache_arrays(cache)
    first = results[(0, 1)]
    for key, arrays in results.items():
        for name, data in arrays.items():
            assert data == first[name], f"{name} differs for run/threads {key}"


def test_frame_energies_and_strain_are_the_same_for_any_thread_count() -> None:
    # The frame-end figures are summed in fixed chunks (9216 vertices, 18k faces: several
    # chunks), so they are bitwise the same on 1 and 3 threads, and they agree with the sums
    # taken here from the state.
    from weft.simulate import advance

    scene = make_scene(windy_sheet(frames=3))
    rows = {}
    for threads in (1, 3):
        sim = new_simulation(scene, threads)
        telemetry = [advance(sim, scene, index) for index in (1, 2)]
        rows[threads] = [(t.kinetic_energy, t.potential_energy, t.max_edge_strain) for t in telemetry]
    assert rows[1] == rows[3]
    x, v, mass = np.array(sim.positions), np.array(sim.velocities), np.array(sim.vertex_mass)
    kinetic, potential, strain = rows[3][-1]
    assert kinetic == pytest.approx(0.5 * float(np.sum(mass * np.sum(v * v, axis=1))), rel=1e-12)
    assert kinetic > 0.0
    assert potential == pytest.approx(sim.gravity_energy(x) + sim.elastic_energy(x), rel=1e-12)
    faces = scene.faces
    lengths = np.linalg.norm(x[np.roll(faces, -1, axis=1)] - x[faces], axis=2)
    rest = scene.positions
    rest_lengths = np.linalg.norm(rest[np.roll(faces, -1, axis=1)] - rest[faces], axis=2)
    assert strain == pytest.approx(float(np.max(lengths / rest_lengths)), rel=1e-9)
    assert strain > 1.0


def demo_positions(scene, path: str, frames: int, threads: int) -> np.ndarray:
    return final_positions(scene, sim=new_simulation(scene, threads, path), stop=frames + 1)


def test_fast_and_reference_paths_agree_on_the_demo(tmp_path: Path) -> None:
    shot_path = demo_flag_files(tmp_path)
    scene = resolve_scene(load_shot_file(shot_path), shot_path.parent)
    assert scene.vertex_count == 864
    fast = demo_positions(scene, "fast", 48, 1)  # thread independence is tested above
    reference = demo_positions(scene, "reference", 48, 1)
    size = float(np.linalg.norm(scene.positions.max(axis=0) - scene.positions.min(axis=0)))
    deviation = float(np.linalg.norm(fast - reference, axis=1).max())
    assert deviation < 1e-4 * size, f"max vertex deviation {deviation:.3e} m, cloth size {size:.3f} m"
    assert np.linalg.norm(fast - scene.positions, axis=1).max() > 0.05  # the flag did move


def test_linear_system_info_reports_aggregation_and_rcm() -> None:
    scene = make_scene(windy_sheet(frames=2))
    sim = _solver.Simulation(build_setup(scene, 2))
    info = _solver.linear_system_info(sim)
    assert info.path == "fast" and info.precision == "float32"
    assert info.force_elements < info.per_force_elements
    assert info.narrow_columns and info.bandwidth <= info.bandwidth_natural
    ref = _solver.linear_system_info(_solver.Simulation(build_setup(scene, 2, "reference")))
    assert ref.path == "reference" and ref.precision == "float64"


def test_transient_springs_pull_vertices_together() -> None:
    doc = sheet_shot("springs", 12, 12, 0.5, 0.5, plane="xz", gravity=(0.0, 0.0, 0.0), frames=3)
    scene = make_scene(doc)
    sim = _solver.Simulation(build_setup(scene, 2))
    a, b = 0, 143  # opposite corners: outside the fixed pattern
    gap = scene.positions[b] - scene.positions[a]
    k = 50.0 * np.eye(3)
    sim.advance_frame(0.0, 1 / 24, 1)  # no springs: nothing moves without gravity
    assert np.allclose(sim.positions, scene.positions)
    _solver.add_transient_spring(sim, a, b, k @ gap, k, 0.1 * np.eye(3))
    sim.advance_frame(1 / 24, 1 / 24, 1)
    assert _solver.linear_system_info(sim).transient_blocks == 2
    new_gap = np.asarray(sim.positions[b] - sim.positions[a])
    assert np.linalg.norm(new_gap) < np.linalg.norm(gap)
    _solver.clear_transient(sim)


@pytest.mark.parametrize("path", ["fast", "reference"])
def test_cli_run_accepts_linear_system(tmp_path: Path, path: str) -> None:
    from typer.testing import CliRunner

    from weft.cli import app

    shot_path = demo_flag_files(tmp_path)
    out = tmp_path / f"{path}.h5"
    result = CliRunner().invoke(app, ["run", str(shot_path), "-o", str(out), "--frames", "3", "-q",
                                      "--linear-system", path])
    assert result.exit_code == 0, result.output
    with h5py.File(out, "r") as f:
        assert f["frames/positions"].shape[0] == 3
