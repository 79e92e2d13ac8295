"""Render frames of a weft cache with its bodies to a PNG (matplotlib, no GPU, no display).

    python scripts/render_cache.py SHOT.yaml CACHE.h5 OUT.png [--frames 1,36,72]

The cloth comes from the cache; the bodies from the shot's own assets at the same frames.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from weft.shot import load_shot_file  # noqa: E402
from weft.solver_setup import resolve_scene  # noqa: E402


def shade(normals: np.ndarray, base: tuple[float, float, float]) -> np.ndarray:
    light = np.array([0.4, 0.8, 0.6]) / np.linalg.norm([0.4, 0.8, 0.6])
    n = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    k = 0.35 + 0.65 * np.abs(n @ light)
    return np.clip(np.outer(k, base), 0, 1)


def triangles(x: np.ndarray, faces: np.ndarray, base: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Triangles as matplotlib draws them (y up in our scenes: plotted as (x, z, y), so the figure
    stands upright) and their shaded colours."""
    tris = x[faces][:, :, [0, 2, 1]]
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    return tris, shade(normals, base)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("shot", type=Path)
    parser.add_argument("cache", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--frames", default=None, help="frame numbers, comma separated (default: first, middle, last)")
    args = parser.parse_args()
    scene = resolve_scene(load_shot_file(args.shot), args.shot.parent)
    with h5py.File(args.cache, "r") as f:
        numbers = f["frames/frame"][()]
        positions = f["frames/positions"][()]
        faces = f["cloth/faces"][()]
    picks = [int(n) for n in args.frames.split(",")] if args.frames else [int(numbers[0]), int(numbers[len(numbers) // 2]),
                                                                          int(numbers[-1])]
    fig = plt.figure(figsize=(4.2 * len(picks), 6.0), dpi=110)
    for column, number in enumerate(picks, start=1):
        row = int(np.searchsorted(numbers, number))
        ax = fig.add_subplot(1, len(picks), column, projection="3d")
        # One collection, so that cloth and bodies are depth-sorted together.
        parts = [triangles(body.frames[row], body.faces, (0.78, 0.74, 0.70)) for body in scene.bodies]
        parts.append(triangles(positions[row].astype(np.float64), faces, (0.20, 0.38, 0.72)))
        ax.add_collection3d(Poly3DCollection(np.concatenate([t for t, _ in parts]),
                                             facecolors=np.concatenate([c for _, c in parts]), edgecolors="none"))
        ax.set_xlim(-0.5, 0.5)
        ax.set_ylim(-0.5, 0.5)
        ax.set_zlim(0.0, 1.85)
        ax.set_box_aspect((1.0, 1.0, 1.85))
        ax.view_init(elev=8, azim=-60)
        ax.set_axis_off()
        ax.set_title(f"frame {number} ({(number - numbers[0]) / float(scene.shot.fps):.2f} s)")
    fig.suptitle(f"{scene.shot.name}: weft cache {args.cache.name}")
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
