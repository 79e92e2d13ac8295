"""Hard GIA scenes built with code (docs/intersection-analysis.md): a sheet over a thin "bone"
with a patch pushed into it or wholly through it; a sheet folded over itself with the flap pushed
through its own lower layer; a small sheet pushed partly through a larger one. Used by the GIA
tests and `weft bench gia`."""

from __future__ import annotations

import numpy as np

from scenes.builders import grid_sheet, inline_mesh, sheet_shot
from scenes.collision import bar_mesh, box_mesh, tube_mesh

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


def corner_cut_shot(depth: float = 0.003, frames: int = 8, gia: bool | None = None) -> dict:
    """A flat strip (2 x 6 vertices, 10 cm long, 4 cm across) across the top front edge of a
    0.2 m box (the edge along x at y = z = 0.1), in the plane at 45 degrees to both faces, its
    middle line `depth` inside the corner: one row in front of the front face, one above the
    top, so every cross edge goes in through one face and out through the other with no vertex
    inside (docs/intersection-analysis.md, point 5). No gravity, no drag: nothing but the
    collision stage moves it."""
    box_v, box_f = box_mesh((0.2, 0.2, 0.2), (0.0, 0.0, 0.0))
    across = np.array([0.0, 1.0, -1.0]) / np.sqrt(2.0)
    middle = np.array([0.0, 0.1, 0.1]) - depth * np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)
    xs = np.linspace(-0.05, 0.05, 6)
    vertices = np.array([middle + [x, 0.0, 0.0] + side * 0.02 * across for side in (-1.0, 1.0) for x in xs])
    n = len(xs)
    faces = np.array([f for i in range(n - 1) for f in ([i, i + 1, n + i + 1], [i, n + i + 1, n + i])])
    doc = {"name": "corner_cut", "fps": 24.0, "frame_range": [1, frames], "substeps": 4,
           "environment": {"gravity": [0.0, 0.0, 0.0], "air_drag": 0.0},
           "cloth": [{"name": "strip", "mesh": inline_mesh(vertices, faces)}],
           "bodies": [{"name": "box", "mesh": inline_mesh(box_v, box_f)}]}
    if gia is not None:
        doc["features"] = {"gia": gia}
    return doc


R = 0.012  # fold radius: the flap lies 2R above the lower layer


def folded_sheet(dip: float, k: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 0.3 x 0.2 m sheet (31 x 21, 1 cm; k times finer with k > 1) folded back over itself along the line x = 0.16
    (a half cylinder of radius R); the flap returns 2R above the lower layer. Its outer part
    (from 4 cm along the flap to its free edge) bends down by up to `dip` at the middle of the
    free edge (cos^2 profile across, zero at the sides), so with dip > 2R the middle of the
    flap's tip is pushed through the lower layer. Returns (positions, faces, rest positions:
    the fold with a flat flap)."""
    nx, nz = 30 * k + 1, 20 * k + 1
    flat, faces = grid_sheet(nx, nz, 0.3, 0.2, "xz")
    a = 0.16
    u, z = flat[:, 0], flat[:, 2]
    x, y = u.copy(), np.zeros_like(u)
    bend = (u > a) & (u <= a + np.pi * R)
    theta = (u[bend] - a) / R
    x[bend], y[bend] = a + R * np.sin(theta), R * (1 - np.cos(theta))
    flap = u > a + np.pi * R
    s = u - a - np.pi * R
    x[flap], y[flap] = a - s[flap], 2 * R
    rest = np.stack([x, y, z], axis=1)
    s0, s_max = 0.04, s.max()
    ramp = np.clip((s - s0) / (s_max - s0), 0.0, None) * flap
    profile = np.cos(np.pi * (z - 0.1) / 0.2) ** 2
    start = rest.copy()
    start[:, 1] -= dip * ramp * profile
    return start, faces, rest


def fold_shot(dip: float = 4 * R, gia: bool | None = None, frames: int = 12, k: int = 1) -> dict:
    start, faces, rest = folded_sheet(dip, k)
    doc = sheet_shot("fold", 30 * k + 1, 20 * k + 1, 0.3, 0.2, plane="xz", frames=frames, substeps=4,
                     gravity=(0.0, 0.0, 0.0), material={"damping": 0.02})
    doc["cloth"][0]["mesh"] = inline_mesh(start, faces)
    doc["cloth"][0]["rest"] = {"kind": "positions", "positions": rest.tolist()}
    doc["features"] = {"self_collision": True}
    if gia is not None:
        doc["features"]["gia"] = gia
    return doc


def two_sheets_shot(pushed: bool = True, gia: bool | None = None, frames: int = 12, gravity: float = 0.0) -> dict:
    """A 0.3 m sheet A (16 x 16) at y = 0 and above it a 10 x 14 cm sheet B (11 x 15) at
    y = 1 cm, offset off A's grid lines; with `pushed`, B's end beyond x = 2 cm bends down
    linearly to -1 cm at its edge, i.e. partly through A (B's sides stay inside A). Rest
    shapes are flat."""
    a_v, a_f = grid_sheet(16, 16, 0.3, 0.3, "xz", origin=(-0.15, 0.0, -0.15))
    b_rest, b_f = grid_sheet(11, 15, 0.1, 0.14, "xz", origin=(-0.0463, 0.01, -0.0659))
    b_v = b_rest.copy()
    if pushed:
        b_v[:, 1] -= 0.02 * np.clip((b_v[:, 0] - 0.02) / (b_v[:, 0].max() - 0.02), 0.0, None)
    doc = sheet_shot("two", 16, 16, 0.3, 0.3, plane="xz", frames=frames, substeps=4, gravity=(0.0, -gravity, 0.0),
                     material={"damping": 0.02})
    corners = [0, 15, 240, 255]
    doc["cloth"][0]["mesh"] = inline_mesh(a_v, a_f)
    doc["cloth"][0]["pins"] = [{"vertices": corners}]
    doc["cloth"].append({
        "name": "b",
        "mesh": inline_mesh(b_v, b_f),
        "rest": {"kind": "positions", "positions": b_rest.tolist()},
        "material": {"damping": 0.02},
    })
    if gia is not None:
        doc["features"] = {"gia": gia}
    return doc
