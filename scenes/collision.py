"""Collision scenes built with code: a sheet dropped on a sphere or a box, a thin bar sweeping
through hanging cloth, a sheet twisted by a full turn, a sheet falling onto a floor.

Used by the collision tests and `weft bench ccd`. Bodies are inline meshes; animated bodies
write their per-frame positions as NPZ files into the given directory (the shot references
them by relative path).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from scenes.builders import grid_sheet, inline_mesh, sheet_shot


def sphere_mesh(radius: float, subdivisions: int = 3, centre=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return np.asarray(m.vertices) + np.asarray(centre), np.asarray(m.faces)


def box_mesh(extents=(0.5, 0.5, 0.5), centre=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    m = trimesh.creation.box(extents=extents)
    return np.asarray(m.vertices) + np.asarray(centre), np.asarray(m.faces)


def bar_mesh(radius: float, length: float, sections: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A closed cylinder along x centred at the origin."""
    import trimesh

    m = trimesh.creation.cylinder(radius=radius, height=length, sections=sections)
    m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    return np.asarray(m.vertices), np.asarray(m.faces)


def tube_mesh(radius: float, length: float, sections: int = 16, segments: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """A closed cylinder along x centred at the origin, its side split into `segments` rings
    along the length (a tessellated limb or bone, unlike `bar_mesh`'s two end rings); outward
    normals (counter-clockwise seen from outside)."""
    xs = np.linspace(-length / 2, length / 2, segments + 1)
    angles = 2 * np.pi * np.arange(sections) / sections
    ring = np.stack([np.zeros(sections), radius * np.cos(angles), radius * np.sin(angles)], axis=1)
    vertices = np.concatenate([ring + [x, 0.0, 0.0] for x in xs] + [[[-length / 2, 0, 0], [length / 2, 0, 0]]])
    faces = []
    for i in range(segments):
        for j in range(sections):
            a, b = i * sections + j, i * sections + (j + 1) % sections
            faces += [[a, b, a + sections], [b, b + sections, a + sections]]
    first_cap, last_cap, last_ring = len(vertices) - 2, len(vertices) - 1, segments * sections
    for j in range(sections):
        faces.append([first_cap, (j + 1) % sections, j])
        faces.append([last_cap, last_ring + j, last_ring + (j + 1) % sections])
    return vertices, np.asarray(faces, dtype=np.int64)


def drop_shot(body: str = "sphere", n: int = 16, frames: int = 36, substeps: int = 4) -> dict[str, Any]:
    """A 1 m horizontal sheet released 0.15 m above a sphere (r 0.3 m) or a cube (0.5 m)."""
    if body == "sphere":
        vertices, faces = sphere_mesh(0.3)
    elif body == "box":
        vertices, faces = box_mesh()
    else:
        raise ValueError(f"unknown body {body!r}")
    doc = sheet_shot(
        f"drop_{body}", n, n, 1.0, 1.0, plane="xz", origin=(-0.5, 0.45, -0.5), frames=frames, substeps=substeps,
        material={"friction": 0.5, "damping": 0.01}, air_drag=0.2,
    )
    doc["bodies"] = [{"name": body, "mesh": inline_mesh(vertices, faces)}]
    return doc


def thin_bar_shot(directory: Path, n: int = 16, frames: int = 7, substeps: int = 4) -> dict[str, Any]:
    """A 0.5 m sheet hanging from its top row; a bar of radius 5 mm moving 0.5 m per frame
    sweeps through it along +z, from z = -0.6 to z = +0.9 (it crosses the sheet in frame 3)."""
    vertices, faces = bar_mesh(0.005, 1.0)
    start = vertices + np.array([0.25, -0.3, -0.6])
    animation = np.stack([start + [0.0, 0.0, min(0.5 * max(f - 1, 0), 1.5)] for f in range(frames)])
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "bar.npz", positions=animation)
    doc = sheet_shot("thin_bar", n, n, 0.5, 0.5, plane="xy", pins=list(range(n)), frames=frames, substeps=substeps)
    doc["bodies"] = [{"name": "bar", "mesh": inline_mesh(start, faces), "animation": {"path": "bar.npz"}}]
    return doc


def twist_shot(directory: Path, n: int = 12, frames: int = 121, substeps: int = 2, width: float = 0.5) -> dict[str, Any]:
    """A square sheet held at two opposite edges (pinned to two thin handle bodies that do not
    collide); the handles turn half a turn each in opposite directions about the sheet's axis
    (a full relative turn over the shot) while coming 0.2 m closer. Self-collision on."""
    doc = sheet_shot("twist", n, n, width, width, plane="xz", origin=(0.0, 0.0, -width / 2), frames=frames,
                     substeps=substeps)
    left = [j * n for j in range(n)]
    right = [j * n + n - 1 for j in range(n)]
    z = np.linspace(-width / 2, width / 2, n)
    strip = [(k, k + 1, n + k) for k in range(n - 1)] + [(k + 1, n + k + 1, n + k) for k in range(n - 1)]
    directory.mkdir(parents=True, exist_ok=True)
    bodies = []
    for name, x, sign in (("left", 0.0, -1.0), ("right", width, 1.0)):
        edge = np.stack([np.full(n, x), np.zeros(n), z], axis=1)
        handle = np.concatenate([edge, edge + [sign * 0.01, 0.0, 0.0]])
        frames_v = []
        for k in range(frames):
            s = k / (frames - 1)
            angle = sign * np.pi * s
            c, si = np.cos(angle), np.sin(angle)
            moved = handle.copy()
            moved[:, 1] = c * handle[:, 1] - si * handle[:, 2]
            moved[:, 2] = si * handle[:, 1] + c * handle[:, 2]
            moved[:, 0] -= sign * 0.1 * s
            frames_v.append(moved)
        np.savez(directory / f"{name}.npz", positions=np.asarray(frames_v))
        bodies.append({"name": name, "mesh": inline_mesh(handle, np.asarray(strip)),
                       "animation": {"path": f"{name}.npz"}, "collide": False})
    doc["bodies"] = bodies
    doc["cloth"][0]["pins"] = [{"vertices": left, "body": "left"}, {"vertices": right, "body": "right"}]
    doc["features"] = {"self_collision": True}
    return doc


def floor_fold_shot(n: int = 14, frames: int = 36, substeps: int = 4) -> dict[str, Any]:
    """A vertical 0.6 m sheet, slightly tilted, released just above a floor: it lands on its
    lower edge, buckles and folds onto itself."""
    vertices, faces = grid_sheet(n, n, 0.6, 0.6, "xy", origin=(-0.3, 0.62, 0.0))
    vertices[:, 2] += 0.08 * (vertices[:, 1] - 0.02)  # lean forward so it folds one way
    doc = sheet_shot("floor_fold", n, n, 0.6, 0.6, frames=frames, substeps=substeps,
                     material={"bend": 1e-6, "friction": 0.6, "damping": 0.01}, air_drag=0.2)
    doc["cloth"][0]["mesh"] = inline_mesh(vertices, faces)
    floor = np.array([[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]])
    doc["bodies"] = [{"name": "floor", "mesh": inline_mesh(floor, np.array([[0, 2, 1], [0, 3, 2]]))}]
    doc["features"] = {"self_collision": True}
    return doc


def sleeve_mesh(radius: float, length: float, around: int = 16, along: int = 17, x0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """An open cloth tube along x from x0 to x0 + length: `along` rings of `around` vertices
    (vertex j of ring i is i * around + j)."""
    angles = 2 * np.pi * np.arange(around) / around
    xs = x0 + np.linspace(0.0, length, along)
    vertices = np.array([[x, radius * np.cos(a), radius * np.sin(a)] for x in xs for a in angles])
    faces = []
    for i in range(along - 1):
        for j in range(around):
            a, b = i * around + j, i * around + (j + 1) % around
            faces += [[a, a + around, b], [b, a + around, b + around]]
    return vertices, np.asarray(faces, dtype=np.int64)


def swing_angles(frames: int, swing_frames: int, amplitude: float) -> np.ndarray:
    """Per-frame limb angle: down by `amplitude` in `swing_frames` frames, back up as fast, and
    again, a smooth (cosine) swing repeated over the shot."""
    k = np.arange(frames)
    return -amplitude * 0.5 * (1.0 - np.cos(np.pi * k / swing_frames))


def capsule_mesh(a, b, radius: float, sections: int = 16, caps: int = 4,
                 spacing: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """A closed capsule (cylinder with hemispherical ends) from point a to point b: rings of
    `sections` vertices, `caps` rings per hemisphere, cylinder rings at most `spacing` apart, a
    pole at each end; outward normals."""
    import trimesh

    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    length = float(np.linalg.norm(b - a))
    cap = np.linspace(-np.pi / 2, 0.0, caps + 1)[1:]
    along = np.linspace(0.0, length, max(2, int(np.ceil(length / spacing)) + 1))
    profile = ([(radius * np.sin(t), radius * np.cos(t)) for t in cap] + [(z, radius) for z in along[1:-1]]
               + [(length - radius * np.sin(t), radius * np.cos(t)) for t in cap[::-1]])
    angles = 2 * np.pi * np.arange(sections) / sections
    rings = [np.stack([r * np.cos(angles), r * np.sin(angles), np.full(sections, z)], axis=1) for z, r in profile]
    vertices = np.concatenate(rings + [[[0.0, 0.0, -radius], [0.0, 0.0, length + radius]]])
    faces = []
    for i in range(len(rings) - 1):
        for j in range(sections):
            p, q = i * sections + j, i * sections + (j + 1) % sections
            faces += [[p, q, q + sections], [p, q + sections, p + sections]]
    bottom, top, last = len(vertices) - 2, len(vertices) - 1, (len(rings) - 1) * sections
    for j in range(sections):
        faces += [[bottom, (j + 1) % sections, j], [top, last + j, last + (j + 1) % sections]]
    rotation = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], (b - a) / length)[:3, :3]
    return vertices @ rotation.T + a, np.asarray(faces, dtype=np.int64)


def sleeve_shot(directory: Path, frames: int = 24, swing_frames: int = 4, amplitude: float = np.pi / 2,
                limb_radius: float = 0.015, sleeve_radius: float = 0.03, substeps: int = 4) -> dict[str, Any]:
    """A sleeve on a thin limb swung fast (a skeleton-like arm): a limb (closed tessellated tube,
    radius 1.5 cm, 0.5 m from the shoulder at the origin along +x) turns about the z axis at the
    shoulder, down by `amplitude` in `swing_frames` frames and back, repeatedly (tip speed about
    |amplitude| * 0.5 m / (swing_frames / 24 s) * pi / 2 at the fastest); a cloth sleeve
    (radius 3 cm, 0.4 m long, open) is pinned by its shoulder ring to the limb."""
    limb_v, limb_f = tube_mesh(limb_radius, 0.5, sections=12, segments=16)
    limb_v = limb_v + [0.25, 0.0, 0.0]
    angles = swing_angles(frames, swing_frames, amplitude)
    keyframes = []
    for angle in angles:
        c, s = np.cos(angle), np.sin(angle)
        rotated = limb_v.copy()
        rotated[:, 0] = c * limb_v[:, 0] - s * limb_v[:, 1]
        rotated[:, 1] = s * limb_v[:, 0] + c * limb_v[:, 1]
        keyframes.append(rotated)
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "limb.npz", positions=np.asarray(keyframes))
    around = 16
    sleeve_v, sleeve_f = sleeve_mesh(sleeve_radius, 0.4, around=around, along=17, x0=0.03)
    doc = sheet_shot("sleeve", 2, 2, 1.0, 1.0, frames=frames, substeps=substeps,
                     material={"friction": 0.3, "damping": 0.02}, air_drag=0.2)
    doc["cloth"][0]["name"] = "sleeve"
    doc["cloth"][0]["mesh"] = inline_mesh(sleeve_v, sleeve_f)
    doc["cloth"][0]["pins"] = [{"vertices": list(range(around)), "body": "limb"}]
    doc["bodies"] = [{"name": "limb", "mesh": inline_mesh(limb_v, limb_f), "animation": {"path": "limb.npz"}}]
    return doc


def sheet_between(name: str, directory: Path, n: int, width: float, substeps: int,
                  fixed: tuple[str, np.ndarray, np.ndarray],
                  moving: tuple[str, np.ndarray, np.ndarray]) -> dict[str, Any]:
    """A `width` sheet (n x n) lying 2.5 mm above y = 0, centred, on a fixed body, with a body
    animated over it: `fixed` (name, vertices, faces) and `moving` (name, per-frame vertices,
    faces; the animation is written to `directory`/<name>.npz). One frame per keyframe."""
    fixed_name, fixed_v, fixed_f = fixed
    moving_name, animation, moving_f = moving
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / f"{moving_name}.npz", positions=animation)
    doc = sheet_shot(name, n, n, width, width, plane="xz", origin=(-width / 2, 0.0025, -width / 2),
                     frames=len(animation), substeps=substeps, material={"friction": 0.5, "damping": 0.01},
                     air_drag=0.2)
    doc["bodies"] = [
        {"name": fixed_name, "mesh": inline_mesh(fixed_v, fixed_f)},
        {"name": moving_name, "mesh": inline_mesh(animation[0], moving_f), "animation": {"path": f"{moving_name}.npz"}},
    ]
    return doc


def box_pinch_shot(directory: Path, n: int = 16, width: float = 0.35, close: int = 5, hold: int = 6,
                   after: int = 8, depth: float = 0.003, travel: float = 0.05, substeps: int = 4,
                   gia: bool | None = None) -> dict[str, Any]:
    """Cloth pinched between two boxes. A `width` sheet lies 2.5 mm above a fixed 0.4 x 0.1 x 0.4 m
    box (top at y = 0); a 0.2 x 0.1 x 0.2 m box, its bottom `travel` above the top, comes down at
    constant speed over `close` frames until the boxes interpenetrate by `depth` (the cloth
    under it squeezed), stays closed `hold` frames, goes back up over `close` frames and stays
    up `after` frames. Frame k (0-based) ends at keyframe k. The upper box's animation is
    written to `directory`/upper.npz."""
    lower_v, lower_f = box_mesh((0.4, 0.1, 0.4), (0.0, -0.05, 0.0))
    upper_v, upper_f = box_mesh((0.2, 0.1, 0.2), (0.0, 0.05, 0.0))  # bottom at y = 0
    step = (travel + depth) / close
    bottoms = ([travel - step * k for k in range(close + 1)] + [-depth] * (hold - 1)
               + [-depth + step * k for k in range(close + 1)] + [travel] * after)
    animation = np.stack([upper_v + [0.0, b, 0.0] for b in bottoms])
    doc = sheet_between("box_pinch", directory, n, width, substeps, ("lower", lower_v, lower_f),
                        ("upper", animation, upper_f))
    if gia is not None:
        doc["features"] = {"gia": gia}
    return doc


def part_sweep_shot(directory: Path, n: int = 16, width: float = 0.3, gap: float = 0.001, sweep: int = 36,
                    after: int = 6, substeps: int = 4, group: bool = True) -> dict[str, Any]:
    """Cloth squeezed between two parts of one character (`group`: both bodies in the group
    "character"; False: two separate bodies). A `width` sheet lies 2.5 mm above a fixed 0.4 x
    0.1 x 0.4 m block (top at y = 0), the "torso"; a capsule of radius 4 cm lying along z, the
    "arm", its lowest line `gap` above the block's top (closer than the cloth can lie between
    them), rolls without turning along x across the whole sheet over `sweep` frames from
    x = -0.35 to 0.35, then stays there `after` frames. The arm's animation is written to
    `directory`/arm.npz."""
    torso_v, torso_f = box_mesh((0.4, 0.1, 0.4), (0.0, -0.05, 0.0))
    radius = 0.04
    arm_v, arm_f = capsule_mesh((0.0, radius + gap, -0.25), (0.0, radius + gap, 0.25), radius, sections=24)
    xs = [-0.35 + 0.7 * k / sweep for k in range(sweep + 1)] + [0.35] * after
    animation = np.stack([arm_v + [x, 0.0, 0.0] for x in xs])
    doc = sheet_between("part_sweep", directory, n, width, substeps, ("torso", torso_v, torso_f),
                        ("arm", animation, arm_f))
    if group:
        for body in doc["bodies"]:
            body["group"] = "character"
    return doc
