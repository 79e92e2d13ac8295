"""The stability map's scene (`weft report stability`, issue 14): a 0.5 m sheet of 10 x 10
vertices, pinned at two corners that may be dragged sideways by a handle body, and a sphere that
may be driven up through its middle. Every driver moves at a constant speed from the first
frame, so a cell of the map is one (stiffness, time step, density, pin speed, body speed)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from scenes.builders import inline_mesh, sheet_shot
from scenes.collision import sphere_mesh

N = 10
WIDTH = 0.5


def stability_shot(directory: Path, stretch: float = 2000.0, substeps: int = 4, density: float = 0.1,
                   pin_speed: float = 0.0, body_speed: float = 0.0, frames: int = 12, fps: float = 24.0) -> dict[str, Any]:
    """stretch: N/m (warp and weft; shear a tenth of it); density: kg/m^2; speeds: m/s."""
    doc = sheet_shot("stability", N, N, WIDTH, WIDTH, plane="xz", origin=(-WIDTH / 2, 0.0, -WIDTH / 2), frames=frames,
                     substeps=substeps, fps=fps,
                     material={"stretch_warp": stretch, "stretch_weft": stretch, "shear": stretch / 10,
                               "density": density, "damping": 0.01})
    corners = [0, N - 1]
    directory.mkdir(parents=True, exist_ok=True)
    t = np.arange(frames) / fps
    doc["bodies"] = []
    if pin_speed > 0.0:
        handle = np.array([[-WIDTH / 2, 0.0, -WIDTH / 2], [WIDTH / 2, 0.0, -WIDTH / 2], [0.0, 0.01, -WIDTH / 2]])
        np.savez(directory / "handle.npz", positions=handle[None] + t[:, None, None] * [pin_speed, 0.0, 0.0])
        doc["bodies"].append({"name": "handle", "mesh": inline_mesh(handle, np.array([[0, 1, 2]])),
                              "animation": {"path": "handle.npz"}, "collide": False})
        doc["cloth"][0]["pins"] = [{"vertices": corners, "body": "handle"}]
    else:
        doc["cloth"][0]["pins"] = [{"vertices": corners}]
    if body_speed > 0.0:
        v, f = sphere_mesh(0.08, subdivisions=2, centre=(0.0, -0.15, 0.0))
        np.savez(directory / "ball.npz", positions=v[None] + t[:, None, None] * [0.0, body_speed, 0.0])
        doc["bodies"].append({"name": "ball", "mesh": inline_mesh(v, f), "animation": {"path": "ball.npz"}})
    return doc
