"""Hard GIA scenes built with code (docs/intersection-analysis.md): a sheet over a thin "bone"
with a patch pushed into it or wholly through it. Used by the GIA tests and `weft bench gia`."""

from __future__ import annotations

import numpy as np

from weft.collision_scenes import bar_mesh, tube_mesh
from weft.scene_builders import grid_sheet, inline_mesh, sheet_shot

RADIUS = 0.01  # the "bone"'s radius, m


def bone_shot(n: int = 21, frames: int = 16, patch: bool = True, gia: bool | None = None, depth: float = 0.003,
              half_width: float = 0.0) -> dict:
    """A 0.3 m sheet 2 mm above a horizontal closed cylinder (radius 1 cm, along x, 0.5 m
    long) at the origin; with `patch`, the sheet's middle row over |x| <= 6 cm is pushed down
    through the cylinder's top to height `depth` (inside the cylinder; their triangles cut it),
    with the rows within `half_width` of it. The two edges parallel to the cylinder are pinned at their start height (an
    unpinned sheet slides off a 1 cm bar), so gravity and the sheet's tension press it onto
    the cylinder."""
    y0 = RADIUS + 0.002
    vertices, faces = grid_sheet(n, n, 0.3, 0.3, "xz", origin=(-0.15, y0, -0.15))
    if patch:
        pushed = (np.abs(vertices[:, 2]) <= half_width + 1e-9) & (np.abs(vertices[:, 0]) <= 0.06 + 1e-9)
        vertices[pushed, 1] = depth
    pins = list(range(n)) + list(range(n * (n - 1), n * n))  # the rows at z = -0.15 and z = +0.15
    doc = sheet_shot("bone", n, n, 0.3, 0.3, plane="xz", frames=frames, substeps=4, pins=pins,
                     material={"friction": 0.5, "damping": 0.01}, air_drag=0.2)
    doc["cloth"][0]["mesh"] = inline_mesh(vertices, faces)
    bar_v, bar_f = bar_mesh(RADIUS, 0.5, sections=16)
    doc["bodies"] = [{"name": "bone", "mesh": inline_mesh(bar_v, bar_f)}]
    if gia is not None:
        doc["features"] = {"gia": gia}
    return doc


def through_shot(height: float = 0.02, depth: float = -0.02, frames: int = 12, gia: bool | None = None,
                 n: int = 21) -> dict:
    """A patch pushed wholly through the bone: a 0.3 m sheet (n x n, flat rest shape) pinned
    along its two edges parallel to a tessellated bone (radius 1 cm, 20 rings along its 0.5 m)
    at `height`, so it drapes onto the bone; the three middle rows over |x| <= 6 cm start at
    `depth`, below the bone. No cloth vertex is inside the bone: the bone passes through the
    sheet's two steep walls at x = +-6.75 cm, and its segment between them is on the wrong side."""
    vertices, faces = grid_sheet(n, n, 0.3, 0.3, "xz", origin=(-0.15, height, -0.15))
    rest = vertices.copy()
    pushed = (np.abs(vertices[:, 2]) <= 0.015 + 1e-9) & (np.abs(vertices[:, 0]) <= 0.06 + 1e-9)
    vertices[pushed, 1] = depth
    pins = list(range(n)) + list(range(n * (n - 1), n * n))
    doc = sheet_shot("bone_through", n, n, 0.3, 0.3, plane="xz", frames=frames, substeps=4, pins=pins,
                     material={"friction": 0.5, "damping": 0.01}, air_drag=0.2)
    doc["cloth"][0]["mesh"] = inline_mesh(vertices, faces)
    doc["cloth"][0]["rest"] = {"kind": "positions", "positions": rest.tolist()}
    tube_v, tube_f = tube_mesh(RADIUS, 0.5, sections=16, segments=20)
    doc["bodies"] = [{"name": "bone", "mesh": inline_mesh(tube_v, tube_f)}]
    if gia is not None:
        doc["features"] = {"gia": gia}
    return doc
