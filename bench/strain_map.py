"""Where a contact scene's cloth overstretches.

`weft bench contact` reports the largest edge strain of a run; this script says where it is.
It runs one contact scene (`scenes/contact.py`) and prints, per frame, the largest edge strain,
how many edges are longer than `--threshold` times their rest length, and how far those edges'
midpoints lie from the bodies' surfaces and from the nearest pinned vertex: an edge stretched at
a body is the collision stage's, one stretched at a pin is the pin's. It also says which cloth
piece holds those edges and how many of them rest on two body parts (the closed parts a body is
built of, as the solver's inside tests and pinches see them): each end within `--near` of a part
and the two ends' nearest parts different. Cloth across a joint, between two legs or caught
between two closing parts is stretched by the parts' motion; an edge at one part is stretched by
the collision response. Each piece's 90th-percentile edge strain tells a piece stretched as a
whole (a tube around legs that spread) from a few edges torn locally.

    python -m bench.strain_map --scene thin_limb [--threshold 1.5] [--near 0.01] [--frames N] [--threads 2]
                               [--json PATH]
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


def body_parts(faces: np.ndarray, vertex_count: int) -> list[np.ndarray]:
    """The closed parts of a body mesh: its faces grouped by connected vertices, each part's
    faces (F_k, 3) in the order of their lowest face."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    faces = np.asarray(faces)
    rows = np.concatenate([faces[:, 0], faces[:, 1], faces[:, 2]])
    cols = np.concatenate([faces[:, 1], faces[:, 2], faces[:, 0]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(vertex_count, vertex_count))
    _, label = connected_components(graph, directed=False)
    face_label = label[faces[:, 0]]
    order = sorted(set(face_label.tolist()), key=lambda part: int(np.flatnonzero(face_label == part)[0]))
    return [faces[face_label == part] for part in order]


def piece_of_vertex(scene: Any, vertex_count: int) -> tuple[list[str], np.ndarray]:
    """The cloth pieces' names and each vertex's piece (one piece, "cloth", where the scene lists
    none)."""
    pieces = getattr(scene, "pieces", None) or []
    if not pieces:
        return ["cloth"], np.zeros(vertex_count, dtype=int)
    owner = np.zeros(vertex_count, dtype=int)
    for k, piece in enumerate(pieces):
        owner[piece.vertex_offset:piece.vertex_offset + piece.vertex_count] = k
    return [piece.name for piece in pieces], owner


def strain_map(scene: Any, positions: list[np.ndarray], threshold: float, near: float = 0.01) -> list[dict[str, Any]]:
    """Per simulated frame (positions[1:]): the largest edge strain, the edges above `threshold`,
    their midpoints' distances (m) to the nearest body surface and to the nearest pinned vertex
    (fixed or held by a body), how many lie in each cloth piece (and each piece's 90th-percentile
    edge strain, over all its edges), and how many rest on two body
    parts: each end within `near` of a part, the two ends' nearest parts not the same (cloth
    across a joint, between two legs, caught between two closing parts), and how many rest on
    each part (at the first end's nearest part within `near`, else the second's)."""
    from weft.geometry import surface_distance

    faces = np.asarray(scene.faces)
    rest_shape = np.asarray(scene.rest_positions if scene.rest_positions is not None else positions[0])
    edges = unique_edges(faces)
    rest = np.linalg.norm(rest_shape[edges[:, 0]] - rest_shape[edges[:, 1]], axis=1)
    pins = np.union1d(np.asarray(scene.fixed_pins, dtype=int), np.asarray(scene.body_pin_vertices, dtype=int))
    piece_names, piece = piece_of_vertex(scene, len(rest_shape))
    # (body index, part faces) for every closed part of every body, and the parts' names: the
    # body's, with the part's number where the body has several.
    parts: list[tuple[int, np.ndarray]] = []
    part_names: list[str] = []
    for b, body in enumerate(scene.bodies):
        own = body_parts(np.asarray(body.faces), np.asarray(body.frames[0]).shape[0])
        name = getattr(body, "name", f"body {b}")
        parts += [(b, part) for part in own]
        part_names += [name] if len(own) == 1 else [f"{name} part {k}" for k in range(len(own))]
    frames = []
    for index in range(1, len(positions)):
        x = positions[index]
        strain = np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1) / rest
        over = np.flatnonzero(strain > threshold)
        middle = 0.5 * (x[edges[over, 0]] + x[edges[over, 1]])
        body_x = [body.frames[min(index, len(body.frames) - 1)] for body in scene.bodies]
        to_body = np.full(len(over), np.inf)
        for body, xb in zip(scene.bodies, body_x):
            to_body = np.minimum(to_body, surface_distance(middle, xb, np.asarray(body.faces)))
        to_pin = (np.linalg.norm(middle[:, None, :] - x[pins][None, :, :], axis=2).min(axis=1)
                  if len(pins) else np.full(len(over), np.inf))
        # Each end's nearest part (within `near`): edges whose ends rest on two different parts.
        between = 0
        by_part: dict[str, int] = {}
        if parts and len(over):
            nearest = []
            for end in (x[edges[over, 0]], x[edges[over, 1]]):
                distance = np.stack([surface_distance(end, body_x[b], part) for b, part in parts])
                nearest.append(np.where(distance.min(axis=0) <= near, distance.argmin(axis=0), -1))
            between = int(((nearest[0] >= 0) & (nearest[1] >= 0) & (nearest[0] != nearest[1])).sum())
            # Each edge once, at its first end's part (else its second's).
            at = np.where(nearest[0] >= 0, nearest[0], nearest[1])
            for k in at[at >= 0]:
                by_part[part_names[k]] = by_part.get(part_names[k], 0) + 1
        counts = np.bincount(piece[edges[over, 0]], minlength=len(piece_names))
        # Each piece's 90th-percentile edge strain: near 1 where a few edges are torn locally,
        # well above where the piece as a whole is stretched (a tube around spreading legs).
        edge_piece = piece[edges[:, 0]]
        p90 = {name: float(np.percentile(strain[edge_piece == k], 90))
               for k, name in enumerate(piece_names) if np.any(edge_piece == k)}
        frames.append({"frame": index, "max_strain": float(strain.max()), "edges_over": int(len(over)),
                       "to_body_m": spread(to_body) if scene.bodies else None,
                       "to_pin_m": spread(to_pin) if len(pins) else None,
                       "by_piece": {name: int(c) for name, c in zip(piece_names, counts) if c},
                       "between_parts": between if parts else None,
                       "by_part": dict(sorted(by_part.items(), key=lambda item: -item[1])),
                       "p90_by_piece": p90})
    return frames


def main(argv: list[str] | None = None) -> int:
    from scenes.contact import SCENES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default="thin_limb", help="a contact scene (" + ", ".join(SCENES) + ")")
    parser.add_argument("--threshold", type=float, default=1.5, help="strain above which an edge is listed")
    parser.add_argument("--frames", type=int, default=0, help="frames, the initial one included (default: the scene's)")
    parser.add_argument("--near", type=float, default=0.01,
                        help="distance (m) within which an edge's end rests on a body part (default 0.01)")
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
    if not (args.near >= 0.0 and np.isfinite(args.near)):
        parser.error(f"--near {args.near}: must be a finite distance of 0 m or more")

    from rich.console import Console
    from rich.table import Table

    from bench.contact import DEFAULT_FRAMES, build_scene, run_weft

    frames = args.frames or DEFAULT_FRAMES[args.scene]
    with tempfile.TemporaryDirectory() as directory:
        scene = build_scene(args.scene, Path(directory), frames)
        run = run_weft(scene, frames, args.threads)
    rows = strain_map(scene, run["positions"], args.threshold, args.near)
    for row, telemetry in zip(rows, run["telemetry"]):
        row["telemetry_max_strain"] = float(telemetry.max_edge_strain)

    def mm(s: dict[str, float] | None) -> str:
        return "-" if s is None else f"{1e3 * s['min']:.0f} / {1e3 * s['median']:.0f} / {1e3 * s['max']:.0f}"

    table = Table(title=f"{args.scene}: edges above {args.threshold} times their rest length")
    for column in ("frame", "max strain", f"edges > {args.threshold}", "to body mm (min / median / max)",
                   "to pin mm (min / median / max)", "on two parts", "by piece", "at parts (within --near)",
                   "p90 strain by piece"):
        table.add_column(column, justify="right")
    for row in rows:
        table.add_row(str(row["frame"]), f"{row['max_strain']:.2f}", str(row["edges_over"]), mm(row["to_body_m"]),
                      mm(row["to_pin_m"]), "-" if row["between_parts"] is None else str(row["between_parts"]),
                      ", ".join(f"{name} {count}" for name, count in row["by_piece"].items()) or "-",
                      ", ".join(f"{name} {count}" for name, count in list(row["by_part"].items())[:3]) or "-",
                      ", ".join(f"{name} {value:.2f}" for name, value in row["p90_by_piece"].items()))
    Console().print(table)
    if run["failure"]:
        print(f"the run stopped: {run['failure']}", file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps({"scene": args.scene, "threshold": args.threshold, "near": args.near,
                                         "frames": rows,
                                         "failure": run["failure"]}, indent=1))
        print(f"wrote {args.json}")
    return 0 if not run["failure"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
