"""Contact metrics of one cloth run, the same function for every solver (`bench.contact`).

Input: the cloth's positions at every frame (frame index 0 is the initial state), its faces and
rest edge lengths, the bodies' positions at the same frames, and the wall seconds of each
simulated frame. Exact tests come from weft's own predicates (`weft._solver`):
`points_inside_closed_mesh` (ray parity with exact perturbed predicates) per closed part, and
`count_mesh_intersections` / `count_self_intersections` (exact triangle pair counts).

A body may be several closed parts (a merged character: connected components of its mesh,
which may overlap); "inside" is inside the union, i.e. inside some part (a parity test on the
merged mesh would call a point inside two overlapping parts outside).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from weft.body_shells import mesh_shells
from weft.geometry import point_triangle_distance, surface_distance  # noqa: F401 - re-exported


@dataclass
class BodyTrack:
    """A body's faces and its positions at every frame (frames, V, 3)."""

    name: str
    faces: np.ndarray
    frames: np.ndarray


def is_closed(faces: np.ndarray) -> bool:
    """Every edge shared by exactly two faces (watertight; points can be inside)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


def edge_rest_lengths(face_uv: np.ndarray) -> np.ndarray:
    """(F, 3) rest lengths of each face's edges (corner k to corner k+1) from the per-face
    flattened rest coordinates (weft's `Scene.face_uv`, (F, 6))."""
    uv = face_uv.reshape(-1, 3, 2)
    return np.linalg.norm(uv[:, [1, 2, 0]] - uv, axis=2)


def max_edge_strain(x: np.ndarray, faces: np.ndarray, rest_lengths: np.ndarray) -> float:
    lengths = np.linalg.norm(x[faces[:, [1, 2, 0]]] - x[faces], axis=2)
    return float(np.max(lengths / rest_lengths))


class ContactGeometry:
    """The bodies split once into their parts (connected components), for per-frame tests; only
    closed parts can hold a point inside."""

    def __init__(self, bodies: list[BodyTrack], threads: int = 2) -> None:
        self.bodies = bodies
        self.threads = threads
        self.parts: list[tuple[int, np.ndarray, np.ndarray]] = []  # (body, vertex indices, local faces)
        self.closed: list[bool] = []
        for b, body in enumerate(bodies):
            for face_ids in mesh_shells(body.faces, body.frames.shape[1]):
                vertices, local = np.unique(body.faces[face_ids], return_inverse=True)
                local = local.reshape(-1, 3).astype(np.int32)
                self.parts.append((b, vertices, local))
                self.closed.append(is_closed(local))

    def part_positions(self, k: int) -> list[np.ndarray]:
        return [np.ascontiguousarray(self.bodies[b].frames[k][v]) for b, v, _ in self.parts]

    def inside(self, x: np.ndarray, k: int) -> tuple[np.ndarray, list[np.ndarray]]:
        """Per cloth vertex, inside some closed part at frame k; and per part the inside mask."""
        from weft import _solver

        union = np.zeros(len(x), dtype=bool)
        masks = []
        for (_, _, faces), closed, px in zip(self.parts, self.closed, self.part_positions(k)):
            mask = np.zeros(len(x), dtype=bool)
            near = np.all((x >= px.min(axis=0)) & (x <= px.max(axis=0)), axis=1)
            if closed and near.any():
                mask[near] = _solver.points_inside_closed_mesh(np.ascontiguousarray(x[near]), px, faces,
                                                               self.threads).astype(bool)
            union |= mask
            masks.append(mask)
        return union, masks

    def body_intersections(self, x: np.ndarray, faces: np.ndarray, k: int) -> int:
        from weft import _solver

        return int(sum(_solver.count_mesh_intersections(x, faces, np.ascontiguousarray(body.frames[k]), body.faces)
                       for body in self.bodies))

    def gaps(self, x: np.ndarray, k: int, near: float, inside_masks: list[np.ndarray]) -> dict[str, Any]:
        """Distance to the nearest body surface of the cloth vertices outside every part and within
        `near` of a part's bounding box; and the deepest inside vertex (a lower bound of its depth
        in the union: its distance to the surface of a part holding it)."""
        outside = ~np.any(inside_masks, axis=0) if inside_masks else np.ones(len(x), dtype=bool)
        gap = np.full(len(x), np.inf)
        depth = np.zeros(len(x))
        for (_, _, faces), px, mask in zip(self.parts, self.part_positions(k), inside_masks):
            close = np.all((x >= px.min(axis=0) - near) & (x <= px.max(axis=0) + near), axis=1)
            test = np.flatnonzero(close & outside)
            if len(test):
                gap[test] = np.minimum(gap[test], surface_distance(x[test], px, faces))
            held = np.flatnonzero(mask)
            if len(held):
                depth[held] = np.maximum(depth[held], surface_distance(x[held], px, faces))
        within = gap[gap <= near]
        return {
            "gap_vertices": int(len(within)),
            "gap_min_m": float(within.min()) if len(within) else None,
            "gap_median_m": float(np.median(within)) if len(within) else None,
            "inside_depth_max_m": float(depth.max()) if len(depth) else 0.0,
        }


def contact_metrics(positions: np.ndarray, faces: np.ndarray, rest_lengths: np.ndarray, bodies: list[BodyTrack],
                    frame_seconds: np.ndarray, fps: float, near: float = 0.05, threads: int = 2) -> dict[str, Any]:
    """Metrics of one run. positions: (frames, N, 3) cloth positions, index 0 the initial state;
    frame_seconds: wall seconds of each simulated frame (frames 1.. of positions, setup excluded);
    bodies' frames must cover the same frame indices. Per frame: vertices inside a body part,
    cloth/body and cloth/cloth intersecting triangle pairs, max edge strain, max vertex speed;
    at the last frame also the gaps (`ContactGeometry.gaps`)."""
    from weft import _solver

    faces = np.ascontiguousarray(faces, dtype=np.int32)
    frames = len(positions)
    geometry = ContactGeometry(bodies, threads)
    finite = [bool(np.isfinite(x).all()) for x in positions]
    per_frame: dict[str, list] = {"inside": [], "cloth_body_pairs": [], "cloth_cloth_pairs": [], "max_strain": [],
                                  "max_speed_m_s": []}
    masks: list[np.ndarray] = []
    for k in range(frames):
        x = np.ascontiguousarray(positions[k], dtype=np.float64)
        if not finite[k]:
            for values in per_frame.values():
                values.append(None)
            continue
        union, masks = geometry.inside(x, k)
        per_frame["inside"].append(int(union.sum()))
        per_frame["cloth_body_pairs"].append(geometry.body_intersections(x, faces, k))
        per_frame["cloth_cloth_pairs"].append(int(_solver.count_self_intersections(x, faces)))
        per_frame["max_strain"].append(max_edge_strain(x, faces, rest_lengths))
        speed = 0.0 if k == 0 or not finite[k - 1] else float(np.max(np.linalg.norm(x - positions[k - 1], axis=1)) * fps)
        per_frame["max_speed_m_s"].append(speed)
    seconds = np.asarray(frame_seconds, dtype=np.float64)
    last = frames - 1
    result: dict[str, Any] = {
        "frames": frames,
        "simulated_frames": len(seconds),
        "s_per_frame_mean": float(seconds.mean()) if len(seconds) else None,
        "s_per_frame_max": float(seconds.max()) if len(seconds) else None,
        "nan": not all(finite),
        "first_nonfinite_frame": None if all(finite) else finite.index(False),
        "inside_max": max((v for v in per_frame["inside"] if v is not None), default=None),
        "inside_final": per_frame["inside"][last],
        "cloth_body_pairs_max": max((v for v in per_frame["cloth_body_pairs"] if v is not None), default=None),
        "cloth_body_pairs_final": per_frame["cloth_body_pairs"][last],
        "cloth_cloth_pairs_max": max((v for v in per_frame["cloth_cloth_pairs"] if v is not None), default=None),
        "cloth_cloth_pairs_final": per_frame["cloth_cloth_pairs"][last],
        "max_strain": max((v for v in per_frame["max_strain"] if v is not None), default=None),
        "max_speed_m_s": max((v for v in per_frame["max_speed_m_s"] if v is not None), default=None),
        "per_frame": per_frame,
        "frame_seconds": seconds.tolist(),
    }
    if finite[last]:
        result.update(geometry.gaps(np.asarray(positions[last], dtype=np.float64), last, near, masks))
    return result
