"""The garment demo (issue 18): a flared skirt cut from one sewing-pattern panel, on the walking
articulated character of ``scenes.contact`` (14 closed parts overlapping at the joints).

- The skirt is an OBJ whose ``vt`` are the flat pattern in metres: a cone frustum developed
  into an annulus sector, the back seam a vertex column with different ``vt`` on each side.
  The shot's rest shape is that pattern (``rest: {kind: uv}``); the skirt starts exactly in it,
  flared out like a lampshade, clear of the arms.
- Its waistband is pinned to the hips (a body pin: it follows the walk); its hem is held in
  space while the character stands still, then released (``pins[].release``), so the skirt
  drapes and swings with the walk.
- 5 mm cloth thickness, the waistband 5 mm outside the hips, self-collision on.

    python -m scenes.garment OUT_DIR     # writes OUT_DIR/skirt_walk.yaml and its assets
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from scenes.contact import character_parts, joint_angles, part_animation

WAIST_Y, HEM_Y = 0.98, 0.58
WAIST_RADIUS = 0.155 + 0.005  # the hips capsule's radius plus the offset
HEM_RADIUS = 0.21  # clear of the hanging forearms (x 0.18-0.28 above 0.86 m)


AROUND, ALONG = 72, 20


def skirt_pattern(around: int = AROUND, along: int = ALONG) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The skirt as a cone frustum around the vertical axis (vertex j of ring i is
    i * around + j, ring 0 the waist) and its pattern: (vertices, faces, vt, face_vt). The vt
    are the frustum developed flat, in metres, with `around + 1` columns: the back seam (j = 0)
    appears twice, at both ends of the sector."""
    drop, flare = WAIST_Y - HEM_Y, HEM_RADIUS - WAIST_RADIUS
    slant = float(np.hypot(drop, flare))
    inner = WAIST_RADIUS * slant / flare  # the developed sector's radii and angle
    sector = 2 * np.pi * WAIST_RADIUS / inner
    t = np.linspace(0.0, 1.0, along)
    angles = 2 * np.pi * np.arange(around) / around
    radius, height = WAIST_RADIUS + t * flare, WAIST_Y - t * drop
    vertices = np.array([[r * np.sin(a), y, r * np.cos(a)] for r, y in zip(radius, height) for a in angles])
    columns = np.arange(around + 1) / around
    vt = np.array([[(inner + s * slant) * np.sin(sector * c), (inner + s * slant) * np.cos(sector * c)]
                   for s in t for c in columns])
    faces, face_vt = [], []
    for i in range(along - 1):
        for j in range(around):
            a, b = i * around + j, i * around + (j + 1) % around
            ta, tb = i * (around + 1) + j, i * (around + 1) + j + 1
            faces += [[a, a + around, b], [b, a + around, b + around]]
            face_vt += [[ta, ta + around + 1, tb], [tb, ta + around + 1, tb + around + 1]]
    return vertices, np.asarray(faces), vt, np.asarray(face_vt)


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray, vt: np.ndarray | None = None,
              face_vt: np.ndarray | None = None) -> None:
    lines = [f"# weft garment demo: {path.stem}" + ("; vt = the sewing pattern in metres" if vt is not None else "") + "\n"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in vertices]
    if vt is None or face_vt is None:
        lines += [f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces]
    else:
        lines += [f"vt {u:.9g} {v:.9g}\n" for u, v in vt]
        lines += [f"f {a + 1}/{ta + 1} {b + 1}/{tb + 1} {c + 1}/{tc + 1}\n"
                  for (a, b, c), (ta, tb, tc) in zip(faces, face_vt)]
    path.write_text("".join(lines))


def skirt_walk(directory: Path, frames: int = 72, settle_seconds: float = 0.25, substeps: int = 4) -> Path:
    """Write the demo shot (skirt_walk.yaml) and its assets into `directory`; its path."""
    directory.mkdir(parents=True, exist_ok=True)
    vertices, faces, vt, face_vt = skirt_pattern()
    write_obj(directory / "skirt.obj", vertices, faces, vt, face_vt)
    around = AROUND
    parts = character_parts()
    angles = joint_angles(frames, still=8, ramp=8)
    bodies = []
    for part in parts:
        animation = part_animation(part, angles)
        np.save(directory / f"{part.name}.npy", animation)
        mesh_file = f"{part.name}.obj"
        write_obj(directory / mesh_file, part.vertices, part.faces)
        bodies.append({"name": part.name, "mesh": {"path": mesh_file}, "animation": {"path": f"{part.name}.npy"},
                       "group": "character"})
    waist = list(range(around))
    hem = list(range(len(vertices) - around, len(vertices)))
    shot: dict[str, Any] = {
        "name": "skirt_walk",
        "fps": 24.0,
        "frame_range": [1, frames],
        "substeps": substeps,
        "environment": {"gravity": [0.0, -9.81, 0.0], "air_drag": 0.3},
        "cloth": [{
            "name": "skirt",
            "mesh": {"path": "skirt.obj"},
            "rest": {"kind": "uv"},
            "material": {"density": 0.15, "stretch_warp": 2000.0, "stretch_weft": 2000.0, "shear": 100.0,
                         "bend": 2.0e-5, "damping": 0.005, "thickness": 0.005, "friction": 0.4},
            "pins": [{"vertices": waist, "body": "hips"}, {"vertices": hem, "release": settle_seconds}],
        }],
        "bodies": bodies,
        "features": {"self_collision": True},
    }
    path = directory / "skirt_walk.yaml"
    path.write_text(yaml.safe_dump(shot, sort_keys=False))
    return path


if __name__ == "__main__":
    print(skirt_walk(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "generated" / "garment"))
