"""Programmatic scenes: grid sheets and the shots built from them.

Used by `scenes/generate.py` (demo and analytic scenes written to disk) and by the tests
(the same scenes built in memory), so every scene comes from code, never hand-typed arrays.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


def grid_sheet(
    nx: int, ny: int, width: float, height: float, plane: str = "xy", origin: tuple[float, float, float] = (0, 0, 0)
) -> tuple[np.ndarray, np.ndarray]:
    """A regular nx-by-ny vertex grid split into triangles with alternating diagonals.

    plane 'xy': a vertical sheet, rows going down from the origin along -y (vertex 0 is the
    top-left corner). plane 'xz': a horizontal sheet at height origin[1].
    Vertex (i, j) (column i, row j) has index j * nx + i.
    """
    if nx < 2 or ny < 2:
        raise ValueError("a grid needs at least 2 x 2 vertices")
    u = np.linspace(0.0, width, nx)
    v = np.linspace(0.0, height, ny)
    uu, vv = np.meshgrid(u, v)
    o = np.asarray(origin, dtype=np.float64)
    if plane == "xy":
        vertices = np.stack([uu.ravel(), -vv.ravel(), np.zeros(uu.size)], axis=1) + o
    elif plane == "xz":
        vertices = np.stack([uu.ravel(), np.zeros(uu.size), vv.ravel()], axis=1) + o
    else:
        raise ValueError(f"unknown plane {plane!r}")
    faces = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            a, b, c, d = j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1
            if (i + j) % 2 == 0:
                faces += [(a, c, b), (b, c, d)]
            else:
                faces += [(a, c, d), (a, d, b)]
    return vertices, np.asarray(faces, dtype=np.int64)


def inline_mesh(vertices: np.ndarray, faces: np.ndarray) -> dict[str, Any]:
    return {"vertices": vertices.tolist(), "faces": faces.tolist()}


def sheet_shot(
    name: str,
    nx: int,
    ny: int,
    width: float,
    height: float,
    *,
    plane: str = "xy",
    pins: list[int] | None = None,
    material: dict[str, float] | None = None,
    fps: float = 24.0,
    frames: int = 24,
    substeps: int = 4,
    gravity: tuple[float, float, float] = (0.0, -9.81, 0.0),
    air_drag: float = 0.0,
    wind: dict[str, Any] | None = None,
    solver: dict[str, Any] | None = None,
    origin: tuple[float, float, float] = (0, 0, 0),
) -> dict[str, Any]:
    """A shot document (dict) with one inline grid sheet."""
    vertices, faces = grid_sheet(nx, ny, width, height, plane, origin)
    piece: dict[str, Any] = {"name": "sheet", "mesh": inline_mesh(vertices, faces)}
    if material:
        piece["material"] = material
    if pins:
        piece["pins"] = [{"vertices": pins}]
    env: dict[str, Any] = {"gravity": list(gravity), "air_drag": air_drag}
    if wind:
        env["wind"] = wind
    shot: dict[str, Any] = {
        "name": name,
        "fps": fps,
        "frame_range": [1, frames],
        "substeps": substeps,
        "environment": env,
        "cloth": [piece],
    }
    if solver:
        shot["solver"] = solver
    return shot


def demo_flag_files(directory: Path) -> Path:
    """The demo: a 1.2 m x 0.8 m flag pinned at its two top corners, in gusty wind.

    Writes flag.obj and demo_flag.yaml into directory; returns the shot path.
    """
    import trimesh
    import yaml

    directory.mkdir(parents=True, exist_ok=True)
    nx, ny = 36, 24
    vertices, faces = grid_sheet(nx, ny, 1.2, 0.8, "xy", origin=(0.0, 2.0, 0.0))
    trimesh.Trimesh(vertices, faces, process=False).export(directory / "flag.obj")
    shot = {
        "name": "demo_flag",
        "fps": 24,
        "frame_range": [1, 96],
        "substeps": 4,
        "environment": {
            "gravity": [0.0, -9.81, 0.0],
            "air_drag": 0.4,
            "wind": {"velocity": [1.5, 0.0, 3.0], "gust_amplitude": 0.5, "gust_frequency": 0.7},
        },
        "cloth": [
            {
                "name": "flag",
                "mesh": {"path": "flag.obj"},
                "material": {
                    "density": 0.2,
                    "stretch_warp": 3000.0,
                    "stretch_weft": 2000.0,
                    "shear": 150.0,
                    "bend": 2e-5,
                    "damping": 0.001,
                },
                "pins": [{"vertices": [0, nx - 1]}],
            }
        ],
        "solver": {"cg_tolerance": 1e-5, "cg_max_iterations": 400},
    }
    path = directory / "demo_flag.yaml"
    path.write_text(yaml.safe_dump(shot, sort_keys=False))
    return path
