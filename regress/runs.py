"""A regression scene as files and as a run: its shot written next to its assets, its resolved
weft scene, and the frames of a run (cloth positions and telemetry columns) from this process
or from an HDF5 cache."""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from scenes.regression import SCENES


@dataclass
class Run:
    """Cloth positions of every frame (index 0 the initial state) and per-frame telemetry columns
    of the simulated frames (1..); `failure` names the frame and reason of a run that stopped."""

    positions: np.ndarray
    telemetry: dict[str, np.ndarray]
    wall_seconds: float
    failure: str | None = None
    energy: np.ndarray | None = None  # kinetic + gravitational + elastic (J) at every frame, index 0 included


def unknown_scenes(names: list[str]) -> list[str]:
    return [n for n in names if n not in SCENES]


def write_shot(name: str, directory: Path, overrides: dict[str, Any] | None = None) -> Path:
    """The scene's shot document (with `overrides` merged into its top-level sections) as
    `shot.json` in `directory`, beside the assets its builder wrote there."""
    directory.mkdir(parents=True, exist_ok=True)
    document = SCENES[name](directory)
    for key, value in (overrides or {}).items():
        document[key] = {**document.get(key, {}), **value} if isinstance(value, dict) else value
    path = directory / "shot.json"
    path.write_text(json.dumps(document))
    return path


def resolve(shot_path: Path) -> Any:
    from weft.shot import load_shot_file
    from weft.solver_setup import resolve_scene

    return resolve_scene(load_shot_file(shot_path), shot_path.parent)


def run_here(scene: Any, threads: int = 2) -> Run:
    """Simulates the whole shot in this process."""
    from weft.simulate import SolverFailure, advance, initial_telemetry, new_simulation, telemetry_row
    from weft.thread_governor import ThreadGovernor

    start = time.perf_counter()
    sim = new_simulation(scene, threads)
    governor = ThreadGovernor(sim, threads)
    first = initial_telemetry(scene.shot.frame_range[0], sim)
    energy = [first.kinetic_energy + first.potential_energy]
    positions, rows, failure = [np.array(sim.positions)], [], None
    for index in range(1, scene.shot.frame_count):
        try:
            t = advance(sim, scene, index, governor)
        except SolverFailure as exc:
            failure = f"frame {exc.frame}: {exc.reason}"
            break
        rows.append(telemetry_row(scene.shot.frame_range[0] + index, t, governor).model_dump())
        energy.append(rows[-1]["kinetic_energy"] + rows[-1]["potential_energy"])
        positions.append(np.array(sim.positions))
    columns = {k: np.array([r[k] for r in rows]) for k in (rows[0] if rows else {})}
    return Run(np.stack(positions), columns, time.perf_counter() - start, failure, np.asarray(energy))


def read_cache(path: Path) -> Run:
    from weft.cache import open_cache_reader

    with open_cache_reader(path) as f:
        positions = f["frames/positions"][()].astype(np.float64)
        table = f["telemetry"][()]
        status, error = str(f.attrs["status"]), str(f.attrs["error"])
    simulated = table[table["substeps"] > 0]
    columns = {name: np.asarray(simulated[name]) for name in table.dtype.names}
    failure = None if status == "complete" else f"cache status {status}: {error}"
    energy = np.asarray(table["kinetic_energy"] + table["potential_energy"], dtype=np.float64)
    return Run(positions, columns, float(np.sum(columns.get("total_seconds", 0.0))), failure, energy)
