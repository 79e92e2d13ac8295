"""Cost of the pin-room check when a shot is read (docs/collisions.md, "Offsets that leave no
room"): `python -m bench.pin_room` resolves a 240-frame shot whose 208 fixed pins ring a turning
sphere of 5,120 faces (every pin within reach of the sphere's box at every keyframe), once with
the check's pruned distances (`weft.geometry.distances_within`, as `weft.pin_room` calls it)
and once with every pin against every face (`weft.geometry.surface_distance`), and prints both
times."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import weft.pin_room as pin_room
from scenes.builders import grid_sheet, inline_mesh, sheet_shot
from scenes.collision import sphere_mesh
from weft.geometry import surface_distance
from weft.shot import parse_shot
from weft.solver_setup import resolve_scene


def ringed_sphere_shot(directory: Path, frames: int = 240) -> dict[str, Any]:
    """A 30 x 30 sheet through a sphere's equator band, held at the vertices of a ring just
    outside the sphere (inside its box); the sphere turns half a radian over the shot."""
    vertices, faces = sphere_mesh(0.3, subdivisions=4)
    origin = (-0.4, 0.2, -0.4)
    grid, _ = grid_sheet(30, 30, 0.8, 0.8, "xz", origin)
    radius = np.hypot(grid[:, 0], grid[:, 2])
    pins = np.flatnonzero((radius > 0.26) & (np.abs(grid[:, 0]) < 0.3) & (np.abs(grid[:, 2]) < 0.3))
    shot = sheet_shot("pin_room", 30, 30, 0.8, 0.8, plane="xz", origin=origin, pins=pins.tolist(), frames=frames)
    turns = [np.array([[np.cos(a), 0.0, -np.sin(a)], [0.0, 1.0, 0.0], [np.sin(a), 0.0, np.cos(a)]])
             for a in np.linspace(0.0, 0.5, frames)]
    np.save(directory / "turn.npy", np.stack([vertices @ r for r in turns]))
    shot["bodies"] = [{"name": "ball", "mesh": inline_mesh(vertices, faces), "animation": {"path": "turn.npy"}}]
    shot["cloth"][0]["material"] = {"thickness": 0.005}
    return shot


def every_face(points: np.ndarray, x: np.ndarray, faces: np.ndarray, reach: float) -> np.ndarray:
    return surface_distance(points, x, faces)


def timed(shot: dict[str, Any], directory: Path, distances: Callable[..., np.ndarray]) -> float:
    original = pin_room.distances_within
    pin_room.distances_within = distances
    try:
        start = time.perf_counter()
        resolve_scene(parse_shot(shot), directory)
        return time.perf_counter() - start
    finally:
        pin_room.distances_within = original


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        shot = ringed_sphere_shot(directory)
        pins = len(shot["cloth"][0]["pins"][0]["vertices"])
        pruned = timed(shot, directory, pin_room.distances_within)
        full = timed(shot, directory, every_face)
    print(f"pin-room check, 240 keyframes, {pins} fixed pins, sphere of 5,120 faces turning beside them")
    print(f"| distances | resolve_scene s |\n|---|---|\n| pruned (distances_within) | {pruned:.2f} |\n"
          f"| every pin against every face | {full:.2f} |\n| ratio | {full / pruned:.1f} |")


if __name__ == "__main__":  # pragma: no cover
    main()
