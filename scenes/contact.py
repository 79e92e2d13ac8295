"""Procedural contact scenes for the contact benchmark (`python -m bench.contact`, issue 12 item 7).

Each scene is a function of a directory (where its asset files go: body animations as NPZ, rest
shapes) and its size parameters, returning a shot document (dict) whose asset paths are relative
to that directory. The same documents are run by weft and, with `--peer blender`, by Blender
cloth (`bench/blender_peer.py`), so every body here moves rigidly (per-frame vertex positions of
a rigid motion: the Blender side recovers the transforms from them).

Scenes (`SCENES` maps names to builders):

- `drape_sphere` / `drape_sphere_16k`: an n x n sheet (64 x 64 = 4,096 vertices, 128 x 128 =
  16,384) 1 m wide released 0.15 m above a sphere of radius 0.3 m; thickness 5 mm, self-collision on.
- `table_cloth`: a 64 x 64 sheet 1.2 m wide released 0.1 m above a 0.6 m square box table (12
  triangles): cloth resting on a flat face and hanging over sharp edges and corners.
- `spinning_sphere`: a 48 x 48 sheet dropped on a sphere turning about the vertical at 2 rad/s.
- `fast_drop`: the drape at 48 x 48 released 1.2 m above the sphere (it lands at about 5 m/s).
- `towel_bar`: a 48 x 48 towel dropped over a 2 cm bar.
- `curtain_box`: a 40 x 40 curtain pinned along its top, a box pushed through its lower half at
  2 m/s (the stretch between the pins and the box is forced).
- `sleeve_swing`: a cloth sleeve pinned to a thin limb swung at several m/s
  (`weft.collision_scenes.sleeve_shot`).
- `box_pinch`: a sheet pinched between two closing boxes (`weft.collision_scenes.box_pinch_shot`).
- `thin_limb`: a tessellated limb (radius 1.5 cm) moving at 3 m/s through a sheet hanging from
  its top row.
- `articulated_dress` / `articulated_dress_merged`: a character of 14 closed parts (capsules,
  an icosphere head, box feet) overlapping at the joints, arms and legs swinging, wearing a tube
  dress whose rest shape is 0.9 of its starting girth; the parts are separate bodies, or one
  merged body (the same overlapping parts concatenated).
- `walking_dress`: the articulated dress on the same character also walking forward at 1.2 m/s
  (eased in with the swing): cloth riding a body whose absolute motion is large.
- `layered_dress`: the articulated dress with a second piece over it, a skirt from the hips to
  above the knees that starts 12 mm outside the dress's starting surface with a rest girth 0.9
  of that: two garments pressed on each other (cloth/cloth contact between pieces).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from scenes.builders import inline_mesh, sheet_shot
from scenes.collision import (box_mesh, box_pinch_shot, capsule_mesh, sleeve_mesh, sleeve_shot, sphere_mesh,
                              tube_mesh)


def drape_sphere(directory: Path, n: int = 64, frames: int = 48, width: float = 1.0, radius: float = 0.3,
                 drop: float = 0.15, thickness: float = 0.005, substeps: int = 4,
                 air_drag: float = 0.2) -> dict[str, Any]:
    """An n x n horizontal sheet, `width` wide, `drop` above a sphere of `radius` at the origin."""
    vertices, faces = sphere_mesh(radius, subdivisions=4)
    doc = sheet_shot(f"drape_sphere_{n}", n, n, width, width, plane="xz",
                     origin=(-width / 2, radius + drop, -width / 2), frames=frames, substeps=substeps,
                     material={"thickness": thickness, "friction": 0.5, "damping": 0.01}, air_drag=air_drag)
    doc["bodies"] = [{"name": "sphere", "mesh": inline_mesh(vertices, faces)}]
    doc["features"] = {"self_collision": True}
    return doc


def table_cloth(directory: Path, n: int = 64, frames: int = 48, width: float = 1.2, table: float = 0.6,
                height: float = 0.4, drop: float = 0.1, thickness: float = 0.005, substeps: int = 4) -> dict[str, Any]:
    """An n x n horizontal sheet, `width` wide, `drop` above a box table (`table` square, `height`
    tall, its top at y = 0): the everyday first scene, cloth resting flat on a face and hanging over
    four sharp edges and corners into folds."""
    vertices, faces = box_mesh(extents=(table, height, table), centre=(0.0, -height / 2, 0.0))
    doc = sheet_shot(f"table_cloth_{n}", n, n, width, width, plane="xz", origin=(-width / 2, drop, -width / 2),
                     frames=frames, substeps=substeps,
                     material={"thickness": thickness, "friction": 0.5, "damping": 0.01}, air_drag=0.2)
    doc["bodies"] = [{"name": "table", "mesh": inline_mesh(vertices, faces)}]
    doc["features"] = {"self_collision": True}
    return doc


def spinning_sphere(directory: Path, n: int = 48, frames: int = 48, spin: float = 2.0) -> dict[str, Any]:
    """An n x n sheet 1 m wide released 0.1 m above a sphere of radius 0.3 m that turns about the
    vertical at `spin` rad/s (0.6 m/s at its equator): resting contact on a moving body, friction
    carrying the cloth round, and no translation for a sweep frame to take out."""
    vertices, faces = sphere_mesh(0.3, subdivisions=4)
    fps = 24.0
    turns = [spin * k / fps for k in range(frames)]
    animation = np.stack([vertices @ np.array([[np.cos(a), 0.0, -np.sin(a)], [0.0, 1.0, 0.0],
                                               [np.sin(a), 0.0, np.cos(a)]]) for a in turns])
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "sphere.npz", positions=animation)
    doc = sheet_shot(f"spinning_sphere_{n}", n, n, 1.0, 1.0, plane="xz", origin=(-0.5, 0.4, -0.5), frames=frames,
                     substeps=4, fps=fps, material={"thickness": 0.005, "friction": 0.5, "damping": 0.01},
                     air_drag=0.2)
    doc["bodies"] = [{"name": "sphere", "mesh": inline_mesh(vertices, faces), "animation": {"path": "sphere.npz"}}]
    doc["features"] = {"self_collision": True}
    return doc


def fast_drop(directory: Path, n: int = 48, frames: int = 36) -> dict[str, Any]:
    """`drape_sphere` at n x n released 1.2 m above the sphere, without air drag: the sheet meets
    it at about 5 m/s (0.05 m per substep, ten thicknesses)."""
    doc = drape_sphere(directory, n=n, frames=frames, drop=1.2, air_drag=0.0)
    doc["name"] = f"fast_drop_{n}"
    return doc


def towel_bar(directory: Path, n: int = 48, frames: int = 48) -> dict[str, Any]:
    """An n x n towel 0.8 m wide released 0.1 m above a horizontal bar of radius 2 cm (a closed
    tube 1.2 m long): a body thinner than the cloth is wide, both halves falling onto each other."""
    vertices, faces = tube_mesh(0.02, 1.2, sections=16, segments=24)
    doc = sheet_shot(f"towel_bar_{n}", n, n, 0.8, 0.8, plane="xz", origin=(-0.4, 0.1, -0.4), frames=frames,
                     substeps=4, material={"thickness": 0.004, "friction": 0.5, "damping": 0.01}, air_drag=0.2)
    doc["bodies"] = [{"name": "bar", "mesh": inline_mesh(vertices, faces)}]
    doc["features"] = {"self_collision": True}
    return doc


def curtain_box(directory: Path, n: int = 40, frames: int = 36, speed: float = 2.0) -> dict[str, Any]:
    """A 0.5 m curtain pinned along its top (vertical, in the xy plane); a 0.2 m box 0.3 m below the
    top starts 0.4 m behind it and moves through its lower half at `speed` m/s for 0.9 m: the
    pins and the box stretch the cloth between them (strain forced)."""
    vertices, faces = box_mesh(extents=(0.2, 0.2, 0.2), centre=(0.25, -0.3, -0.4))
    fps = 24.0
    animation = np.stack([vertices + [0.0, 0.0, min(speed * k / fps, 0.9)] for k in range(frames)])
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "box.npz", positions=animation)
    doc = sheet_shot("curtain_box", n, n, 0.5, 0.5, plane="xy", pins=list(range(n)), frames=frames, substeps=4,
                     fps=fps, material={"thickness": 0.004, "friction": 0.3, "damping": 0.01}, air_drag=0.2)
    doc["bodies"] = [{"name": "box", "mesh": inline_mesh(vertices, faces), "animation": {"path": "box.npz"}}]
    doc["features"] = {"self_collision": True}
    return doc


def drape_sphere_16k(directory: Path, n: int = 128, frames: int = 48) -> dict[str, Any]:
    return drape_sphere(directory, n=n, frames=frames)


def sleeve_swing(directory: Path, frames: int = 24, swing_frames: int = 4) -> dict[str, Any]:
    """`sleeve_shot`: tip speed about 5 m/s at the fastest (quarter turn in 4 frames)."""
    doc = sleeve_shot(directory, frames=frames, swing_frames=swing_frames)
    doc["name"] = "sleeve_swing"
    return doc


def box_pinch(directory: Path, n: int = 24, after: int = 8) -> dict[str, Any]:
    """`box_pinch_shot` with an n x n sheet: 2 * 5 + 6 + 1 + `after` frames."""
    return box_pinch_shot(directory, n=n, after=after)


def thin_limb(directory: Path, n: int = 32, frames: int = 16, speed: float = 3.0, limb_radius: float = 0.015,
              width: float = 0.5, substeps: int = 4, friction: float = 0.3) -> dict[str, Any]:
    """A `width` sheet hanging from its top row (vertical, in the xy plane, top at y = 0); a limb
    along x (closed tube, `limb_radius`, 1 m long, 12 x 20 tessellated) 0.3 m below the top
    starts 0.25 m behind the sheet and moves along +z at `speed` m/s until 0.5 m in front of it,
    then stays."""
    limb_v, limb_f = tube_mesh(limb_radius, 1.0, sections=12, segments=20)
    start = limb_v + [width / 2, -0.6 * width, -0.25]
    fps = 24.0
    offsets = np.minimum(speed * np.arange(frames) / fps, 0.75)
    animation = np.stack([start + [0.0, 0.0, dz] for dz in offsets])
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "limb.npz", positions=animation)
    doc = sheet_shot("thin_limb", n, n, width, width, plane="xy", pins=list(range(n)), frames=frames,
                     substeps=substeps, fps=fps, material={"friction": friction, "damping": 0.01}, air_drag=0.2)
    doc["bodies"] = [{"name": "limb", "mesh": inline_mesh(start, limb_f), "animation": {"path": "limb.npz"}}]
    return doc


# -- the articulated character ---------------------------------------------------------------------

@dataclass
class Part:
    name: str
    vertices: np.ndarray  # rest (frame 0) positions
    faces: np.ndarray
    chain: tuple[str, ...]  # joints from the body outwards; the part follows their rotations
    dress_support: tuple[float, float, float, float] | None = None  # vertical capsule: y0, y1, radius, axis distance


# Joint pivots (rest positions) and the rotation axis of every joint (all about x: swings
# forward and back).
JOINTS = {
    "shoulder_l": (0.17, 1.42, 0.0), "elbow_l": (0.22, 1.14, 0.0),
    "shoulder_r": (-0.17, 1.42, 0.0), "elbow_r": (-0.22, 1.14, 0.0),
    "hip_l": (0.09, 0.92, 0.0), "knee_l": (0.09, 0.50, 0.0),
    "hip_r": (-0.09, 0.92, 0.0), "knee_r": (-0.09, 0.50, 0.0),
}


def character_parts() -> list[Part]:
    """A 1.8 m character standing at the origin (y up, facing +z): head, neck, torso, hips,
    upper and lower arms and legs (capsules), feet (boxes): 14 closed parts, each overlapping its
    neighbours at the joints."""
    head_v, head_f = sphere_mesh(0.1, subdivisions=2, centre=(0.0, 1.72, 0.0))
    parts = [
        Part("head", head_v, head_f, ()),
        Part("neck", *capsule_mesh((0, 1.48, 0), (0, 1.64, 0), 0.05), ()),
        Part("torso", *capsule_mesh((0, 1.15, 0), (0, 1.40, 0), 0.14), (), (1.15, 1.40, 0.14, 0.0)),
        Part("hips", *capsule_mesh((0, 0.86, 0), (0, 1.02, 0), 0.155), (), (0.86, 1.02, 0.155, 0.0)),
    ]
    for side, s in (("l", 1.0), ("r", -1.0)):
        shoulder, elbow = np.array(JOINTS[f"shoulder_{side}"]), np.array(JOINTS[f"elbow_{side}"])
        hip, knee = np.array(JOINTS[f"hip_{side}"]), np.array(JOINTS[f"knee_{side}"])
        wrist, ankle = (s * 0.24, 0.86, 0.0), (s * 0.09, 0.10, 0.0)
        parts += [
            Part(f"upper_arm_{side}", *capsule_mesh(shoulder, elbow, 0.045), (f"shoulder_{side}",)),
            Part(f"lower_arm_{side}", *capsule_mesh(elbow, wrist, 0.038), (f"shoulder_{side}", f"elbow_{side}")),
            Part(f"upper_leg_{side}", *capsule_mesh(hip, knee, 0.07), (f"hip_{side}",), (knee[1], hip[1], 0.07, 0.09)),
            Part(f"lower_leg_{side}", *capsule_mesh(knee, ankle, 0.05), (f"hip_{side}", f"knee_{side}")),
            Part(f"foot_{side}", *box_mesh((0.09, 0.06, 0.22), (s * 0.09, 0.05, 0.05)), (f"hip_{side}", f"knee_{side}")),
        ]
    return parts


def joint_angles(frames: int, fps: float = 24.0, still: int = 4, ramp: int = 6, period: float = 1.0,
                 arm: float = np.radians(35.0), leg: float = np.radians(25.0)) -> dict[str, np.ndarray]:
    """Per-frame joint angles (radians): still for `still` frames, then a walk-like swing (arms
    and legs in opposite phase, elbows and knees bending) whose amplitude ramps up over `ramp`
    frames."""
    k = np.arange(frames, dtype=np.float64)
    t = np.maximum(k - still, 0.0) / fps
    weight = np.clip((k - still) / ramp, 0.0, 1.0)
    weight = weight * weight * (3.0 - 2.0 * weight)  # smoothstep
    swing = weight * np.sin(2 * np.pi * t / period)
    bend = weight * 0.5 * (1.0 - np.cos(2 * np.pi * t / period))
    return {
        "shoulder_l": -arm * swing, "shoulder_r": arm * swing,
        "elbow_l": -np.radians(25.0) * bend, "elbow_r": -np.radians(25.0) * bend,
        "hip_l": leg * swing, "hip_r": -leg * swing,
        "knee_l": np.radians(30.0) * bend, "knee_r": np.radians(30.0) * bend,
    }


def walk_offsets(frames: int, speed: float, fps: float = 24.0, still: int = 4, ramp: int = 6) -> np.ndarray:
    """Per-frame forward (+z) offsets (m) of a character walking at `speed` m/s, eased in over
    the frames `joint_angles` ramps its swing over (still, then smoothstep)."""
    k = np.arange(frames, dtype=np.float64)
    weight = np.clip((k - still) / ramp, 0.0, 1.0)
    weight = weight * weight * (3.0 - 2.0 * weight)
    return np.concatenate([[0.0], np.cumsum(speed * weight[1:] / fps)])


def rotation_about(pivot, angle: float) -> np.ndarray:
    """4 x 4 rotation by `angle` about the x axis through `pivot`."""
    c, s = np.cos(angle), np.sin(angle)
    m = np.eye(4)
    m[1:3, 1:3] = [[c, -s], [s, c]]
    p = np.asarray(pivot, dtype=np.float64)
    m[:3, 3] = p - m[:3, :3] @ p
    return m


def part_animation(part: Part, angles: dict[str, np.ndarray]) -> np.ndarray:
    """(frames, V, 3) positions of a part moved by its joint chain (proximal joint outermost)."""
    frames = len(next(iter(angles.values())))
    out = np.empty((frames, *part.vertices.shape))
    for k in range(frames):
        m = np.eye(4)
        for joint in part.chain:
            m = m @ rotation_about(JOINTS[joint], angles[joint][k])
        out[k] = part.vertices @ m[:3, :3].T + m[:3, 3]
    return out


def dress_mesh(parts: list[Part], around: int, along: int, top: float = 1.25, bottom: float = 0.55,
               offset: float = 0.005) -> tuple[np.ndarray, np.ndarray]:
    """An open tube around the vertical axis from y = `top` down to `bottom` (`along` rings of
    `around` vertices), each ring `offset` outside the widest of the supporting parts (torso,
    hips, upper legs: vertical capsules, their tessellations lie inside them) at its height."""
    unit_v, faces = sleeve_mesh(1.0, 1.0, around=around, along=along)
    ys = top - unit_v[:, 0] * (top - bottom)
    radius = np.zeros(len(ys))
    for part in parts:
        if part.dress_support is None:
            continue
        y0, y1, r, axis = part.dress_support
        dy = np.maximum(np.maximum(y0 - ys, ys - y1), 0.0)
        extent = np.where(dy < r, axis + np.sqrt(np.maximum(r * r - dy * dy, 0.0)), 0.0)
        radius = np.maximum(radius, extent)
    radius += offset
    vertices = np.stack([radius * unit_v[:, 1], ys, radius * unit_v[:, 2]], axis=1)
    return vertices, faces


def articulated_dress(directory: Path, frames: int = 24, around: int = 64, along: int = 48, shrink: float = 0.9,
                      offset: float = 0.005, thickness: float = 0.003, merged: bool = False,
                      substeps: int = 4, walk: float = 0.0) -> dict[str, Any]:
    """The character (`character_parts`) animated by `joint_angles`, wearing a dress
    (`dress_mesh`, around x along vertices) that starts `offset` outside the body and whose rest
    shape is `shrink` times its starting girth (positions scaled toward the vertical axis).
    Bodies: one per part (`articulated_dress`), or all parts as one mesh (`merged`). `walk`
    (m/s): the whole character also moves forward at that speed (`walk_offsets`)."""
    parts = character_parts()
    angles = joint_angles(frames)
    animations = [part_animation(p, angles) for p in parts]
    if walk:
        forward = walk_offsets(frames, walk)
        for animation in animations:
            animation[:, :, 2] += forward[:, None]
    dress_v, dress_f = dress_mesh(parts, around, along, offset=offset)
    rest = dress_v * [shrink, 1.0, shrink]
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "dress_rest.npz", positions=rest)
    if merged:
        offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
        faces = np.concatenate([p.faces + o for p, o in zip(parts, offsets)])
        bodies = [("body", np.concatenate(animations, axis=1), faces)]
    else:
        bodies = [(p.name, a, p.faces) for p, a in zip(parts, animations)]
    name = "walking_dress" if walk else "articulated_dress_merged" if merged else "articulated_dress"
    doc = sheet_shot(name, 2, 2, 1.0, 1.0,
                     frames=frames, substeps=substeps, air_drag=0.2,
                     material={"thickness": thickness, "friction": 0.4, "damping": 0.01})
    doc["cloth"][0].update({"name": "dress", "mesh": inline_mesh(dress_v, dress_f),
                            "rest": {"kind": "positions", "positions": {"path": "dress_rest.npz"}}})
    doc["bodies"] = []
    for name, animation, faces in bodies:
        np.savez(directory / f"{name}.npz", positions=animation)
        doc["bodies"].append({"name": name, "mesh": inline_mesh(animation[0], faces),
                              "animation": {"path": f"{name}.npz"}})
    doc["features"] = {"self_collision": True}
    return doc


def articulated_dress_merged(directory: Path, frames: int = 24, **kwargs: Any) -> dict[str, Any]:
    return articulated_dress(directory, frames=frames, merged=True, **kwargs)


def walking_dress(directory: Path, frames: int = 24, speed: float = 1.2, **kwargs: Any) -> dict[str, Any]:
    """`articulated_dress` on a character that walks forward at `speed` m/s as it swings."""
    return articulated_dress(directory, frames=frames, walk=speed, **kwargs)


def layered_dress(directory: Path, frames: int = 24, around: int = 64, along: int = 48, skirt_around: int = 72,
                  skirt_along: int = 24, skirt_offset: float = 0.012, skirt_shrink: float = 0.9,
                  **kwargs: Any) -> dict[str, Any]:
    """`articulated_dress` with a skirt over the dress: an open tube from y = 1.0 down to 0.62
    (`skirt_around` x `skirt_along` vertices), `skirt_offset` outside the supporting parts (the
    dress starts 5 mm outside them), rest girth `skirt_shrink` times its starting one, the
    dress's material."""
    doc = articulated_dress(directory, frames=frames, around=around, along=along, **kwargs)
    skirt_v, skirt_f = dress_mesh(character_parts(), skirt_around, skirt_along, top=1.0, bottom=0.62,
                                  offset=skirt_offset)
    np.savez(directory / "skirt_rest.npz", positions=skirt_v * [skirt_shrink, 1.0, skirt_shrink])
    skirt = {**doc["cloth"][0], "name": "skirt", "mesh": inline_mesh(skirt_v, skirt_f),
             "rest": {"kind": "positions", "positions": {"path": "skirt_rest.npz"}}}
    doc["cloth"].append(skirt)
    doc["name"] = "layered_dress"
    return doc


def loose_skirt(directory: Path, frames: int = 24, **kwargs: Any) -> dict[str, Any]:
    """`layered_dress` on the walking character with a skirt too loose to hold on the hips:
    2 cm outside the parts, rest girth 0.95 of its starting one. It slides down the dress over
    the first two seconds and bunches around the swinging legs: cloth/cloth contact in folds
    that the legs keep stirring (the hardest of these scenes for the collision stage)."""
    options = {"skirt_offset": 0.02, "skirt_shrink": 0.95, "walk": 1.2, **kwargs}
    doc = layered_dress(directory, frames=frames, **options)
    doc["name"] = "loose_skirt"
    return doc


def leg_girth(y: np.ndarray, upper: float = 0.07, lower: float = 0.05) -> np.ndarray:
    """Radius of the union of a leg's parts (`character_parts`: upper leg capsule down to the
    knee, its cap below it, the lower leg down to the ankle) at heights y, about the leg's axis."""
    knee, ankle = JOINTS["knee_l"][1], 0.10
    thigh = np.where(y >= knee, upper, np.sqrt(np.maximum(upper ** 2 - (knee - y) ** 2, 0.0)))
    shin = np.where((y <= knee) & (y >= ankle), lower, 0.0)
    return np.maximum(thigh, shin)


def trousers(directory: Path, frames: int = 24, around: int = 32, along: int = 48, top: float = 0.70,
             bottom: float = 0.20, offset: float = 0.006, shrink: float = 0.95, walk: float = 1.2,
             knee: float = 60.0, thickness: float = 0.003, substeps: int = 4) -> dict[str, Any]:
    """Trouser legs on the walking character: an open tube around each leg from y = `top` (below
    the hips) down to `bottom` (the shin), `offset` outside the leg's parts, rest girth `shrink`
    times the starting one, on legs whose knees bend up to `knee` degrees as they swing (a
    walking knee bends about 60 in swing): cloth in the knee pit, between two parts that close
    on it, and around lower legs that swing fast, the everyday garment of a character of parts."""
    parts = character_parts()
    angles = joint_angles(frames)
    for side in "lr":
        angles[f"knee_{side}"] = angles[f"knee_{side}"] * knee / 30.0
    animations = [part_animation(p, angles) for p in parts]
    forward = walk_offsets(frames, walk)
    for animation in animations:
        animation[:, :, 2] += forward[:, None]
    vertices, faces, rest = [], [], []
    for side in ("l", "r"):
        axis = JOINTS[f"hip_{side}"][0]
        unit_v, unit_f = sleeve_mesh(1.0, 1.0, around=around, along=along)
        ys = top - unit_v[:, 0] * (top - bottom)
        radius = leg_girth(ys) + offset
        leg = np.stack([axis + radius * unit_v[:, 1], ys, radius * unit_v[:, 2]], axis=1)
        faces.append(unit_f + sum(len(v) for v in vertices))
        vertices.append(leg)
        rest.append(leg * [shrink, 1.0, shrink] + [axis * (1.0 - shrink), 0.0, 0.0])
    directory.mkdir(parents=True, exist_ok=True)
    np.savez(directory / "trousers_rest.npz", positions=np.concatenate(rest))
    doc = sheet_shot("trousers", 2, 2, 1.0, 1.0, frames=frames, substeps=substeps, air_drag=0.2,
                     material={"thickness": thickness, "friction": 0.4, "damping": 0.01})
    doc["cloth"][0].update({"name": "trousers", "mesh": inline_mesh(np.concatenate(vertices), np.concatenate(faces)),
                            "rest": {"kind": "positions", "positions": {"path": "trousers_rest.npz"}}})
    doc["bodies"] = []
    for part, animation in zip(parts, animations):
        np.savez(directory / f"{part.name}.npz", positions=animation)
        doc["bodies"].append({"name": part.name, "mesh": inline_mesh(animation[0], part.faces),
                              "animation": {"path": f"{part.name}.npz"}})
    doc["features"] = {"self_collision": True}
    return doc


SCENES: dict[str, Callable[..., dict[str, Any]]] = {
    "drape_sphere": drape_sphere,
    "drape_sphere_16k": drape_sphere_16k,
    "table_cloth": table_cloth,
    "spinning_sphere": spinning_sphere,
    "fast_drop": fast_drop,
    "towel_bar": towel_bar,
    "curtain_box": curtain_box,
    "sleeve_swing": sleeve_swing,
    "box_pinch": box_pinch,
    "thin_limb": thin_limb,
    "articulated_dress": articulated_dress,
    "articulated_dress_merged": articulated_dress_merged,
    "walking_dress": walking_dress,
    "layered_dress": layered_dress,
    "loose_skirt": loose_skirt,
    "trousers": trousers,
}
