"""Helpers the tests share: scenes and simulations built from shot documents in memory, the
frame loop over a document (weft.simulate), a depth test against convex bodies. (OpenMP's wait
policy is set once, by importing weft: weft/__init__.py.)"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from weft import simulate as frame_loop
from weft.shot import parse_shot
from weft.solver_setup import Scene, resolve_scene


def make_scene(document: dict[str, Any], base_dir: Path | None = None) -> Scene:
    return resolve_scene(parse_shot(document), base_dir or Path.cwd())


def make_sim(document: dict[str, Any], threads: int = 1) -> tuple[Scene, Any]:
    scene = make_scene(document)
    return scene, frame_loop.new_simulation(scene, threads)


def simulate(document: dict[str, Any], base_dir: Path | None = None, threads: int = 2) -> Iterator[tuple[int, Any, Any]]:
    """Yields (frame index, simulation, solver telemetry) for every simulated frame of a shot
    document (weft.simulate's frame loop)."""
    return frame_loop.simulate(make_scene(document, base_dir), threads=threads)


def final_positions(scene: Scene, threads: int = 1, sim: Any = None, stop: int | None = None) -> np.ndarray:
    """Positions after the frame loop ran over the whole shot (or frames 1 .. stop - 1), from a
    new Simulation with `threads` unless `sim` is given."""
    sim = frame_loop.new_simulation(scene, threads) if sim is None else sim
    for _ in frame_loop.simulate(scene, sim, stop=stop):
        pass
    return np.array(sim.positions)


def convex_depth(x: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed distance-like depth of points to a convex closed mesh: > 0 outside, < 0 inside."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return np.max(np.einsum("vfk,fk->vf", x[:, None, :] - a[None], n), axis=1)
