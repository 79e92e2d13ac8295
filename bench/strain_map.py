"""Where a contact scene's cloth overstretches.

`weft bench contact` reports the largest edge strain of a run; this script says where it is.
It runs one contact scene (`scenes/contact.py`) and prints, per frame, the largest edge strain,
how many edges are longer than `--threshold` times their rest length, and how far those edges'
midpoints lie from the bodies' surfaces and from the nearest pinned vertex: an edge stretched at
a body is the collision stage's, one stretched at a pin is the pin's.

    python -m bench.strain_map --scene thin_limb [--threshold 1.5] [--frames N] [--threads 2] [--json PATH]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as bench/contact.py: shared 2-core machines

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402


def unique_edges(faces: np.ndarray) -> np.ndarray:
    """The mesh's edges, each once, as sorted vertex pairs (E, 2)."""
    pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    return np.unique(np.sort(pairs, axis=1), axis=0)


def spread(values: np.ndarray) -> dict[str, float] | None:
    """Smallest, median and largest of `values` (None when empty)."""
    if values.size == 0:
        return None
    return {"min": float(values.min()), "median": float(np.median(values)), "max": float(values.max())}


def strain_map(scene: Any, positions: list[np.ndarray], threshold: float) -> list[dict[str, Any]]:
    """Per simulated frame (positions[1:]): the largest edge strain, the edges above `threshold`,
    their midpoints' distances (m) to the nearest body surface and to the nearest pinned vertex
    (fixed or held by a body)."""
    from weft.geometry import surface_distance

    faces = np.asarray(scene.faces)
    rest_shape = np.asarray(scene.rest_positions if scene.rest_positions is not None else positions[0])
    edges = unique_edges(faces)
    rest = np.linalg.norm(rest_shape[edges[:, 0]] - rest_shape[edges[:, 1]], axis=1)
    pins = np.union1d(np.asarray(scene.fixed_pins, dtype=int), np.asarray(scene.body_pin_vertices, dtype=int))
    frames = []
    for index in range(1, len(positions)):
        x = positions[index]
        strain = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1) / rest
        over = np.flatnonzero(strain > threshold)
        middle = 0.5 * (x[edges[over, 0]] + x[edges[over, 1]])
        to_body = np.full(len(over), np.inf)
        for body in scene.bodies:
            body_x = body.frames[min(index, len(body.frames) - 1)]
            to_body = np.minimum(to_body, surface_distance(middle, body_x, np.asarray(body.faces)))
        to_pin = (np.linalg.norm(middle[:, None, :] - x[pins][None, :, :], axis=2).min(axis=1)
                  if len(pins) else np.full(len(over), np.inf))
        frames.append({"frame": index, "max_strain": float(strain.max()), "edges_over": int(len(over)),
                       "to_body_m": spread(to_body) if scene.bodies else None,
                       "to_pin_m": spread(to_pin) if len(pins) else None})
    return frames


def main(argv: list[str] | None = None) -> int:
    from scenes.contact import SCENES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="thin_limb", help="a contact scene (" + ", ".join(SCENES) + ")")
    parser.add_argument("--threshold", type=float, default=1.5, help="strain above which an edge is listed")
    parser.add_argument("--frames", type=int, default=0, help="frames, the initial one included (default: the scene's)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", type=Path, help="also write the per-frame figures here")
    args = parser.parse_args(argv)
    if args.scene not in SCENES:
        parser.error(f"--scene {args.scene!r}: unknown contact scene (one of {', '.join(SCENES)})")
    if not args.threshold > 1.0:
        parser.error(f"--threshold {args.threshold}: must be above 1 (a strain: length over rest length)")
    if args.frames == 1 or args.frames < 0:
        parser.error(f"--frames {args.frames}: need at least 2 (the initial frame and one simulated)")
    if args.threads < 1:
        parser.error(f"--threads {args.threads}: must be at least 1")

    from rich.console import Console
    from rich.table import Table

    from bench.contact import DEFAULT_FRAMES, build_scene, run_weft

    frames = args.frames or DEFAULT_FRAMES[args.scene]
    with tempfile.TemporaryDirectory() as directory:
        scene = build_scene(args.scene, Path(directory), frames)
        run = run_weft(scene, frames, args.threads)
    rows = strain_map(scene, run["positions"], args.threshold)
    for row, telemetry in zip(rows, run["telemetry"]):
        row["telemetry_max_strain"] = float(telemetry.max_edge_strain)

    def mm(s: dict[str, float] | None) -> str:
        return "-" if s is None else f"{1e3 * s['min']:.0f} / {1e3 * s['median']:.0f} / {1e3 * s['max']:.0f}"

    table = Table(title=f"{args.scene}: edges above {args.threshold} times their rest length")
    for column in ("frame", "max strain", f"edges > {args.threshold}", "to body mm (min / median / max)",
                   "to pin mm (min / median / max)"):
        table.add_column(column, justify="right")
    for row in rows:
        table.add_row(str(row["frame"]), f"{row['max_strain']:.2f}", str(row["edges_over"]), mm(row["to_body_m"]),
                      mm(row["to_pin_m"]))
    Console().print(table)
    if run["failure"]:
        print(f"the run stopped: {run['failure']}", file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps({"scene": args.scene, "threshold": args.threshold, "frames": rows,
                                         "failure": run["failure"]}, indent=1))
        print(f"wrote {args.json}")
    return 0 if not run["failure"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
