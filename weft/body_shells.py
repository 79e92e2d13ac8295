"""Bodies as the solver sees them: a body mesh made of several separate shells is split into
one solver body per shell, parts of one character.

A collision proxy is often one mesh object holding several closed shells that overlap at the
joints (head, torso, arms as capsules). As one body such a mesh is not a closed surface: a
point inside two overlapping shells crosses the surface an even number of times, so the
inside tests, GIA's colouring and the recovery read it as outside, and an arm closing on the
torso is a fold of one body that no pinch tracking sees. Split into its shells, the mesh is the
same character given as separate parts (``solver_setup.body_groups``): GIA works on each
closed shell, cloth is kept out of every one, and pairs of shells are tracked as parts that can
close on the cloth but are never pinches between bodies. The shot's bodies, caches and reports
are unchanged; only the solver's list differs (``SolverBody``).

Only meshes of at most ``MAX_SHELLS`` shells are split: one of thousands of shells (debris,
foliage) would cost a body per shell and gains nothing a union of overlapping closed shells
needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np

# Shells a body mesh may have and still be split (see the module's note).
MAX_SHELLS = 64


class HasFrames(Protocol):
    faces: np.ndarray
    frames: np.ndarray


@dataclass(frozen=True)
class SolverBody:
    """One body of the solver: the whole of the shot's body `body` (vertices None) or one
    shell of it (its vertices in the body's mesh, its faces renumbered to them)."""

    body: int
    vertices: np.ndarray | None
    faces: np.ndarray  # (F, 3) int32

    def frame(self, bodies: Sequence[HasFrames], k: int) -> np.ndarray:
        """The solver body's vertex positions at animation frame k, contiguous."""
        x = bodies[self.body].frames[k]
        return np.ascontiguousarray(x if self.vertices is None else x[self.vertices], dtype=np.float64)


def mesh_shells(faces: np.ndarray, vertex_count: int) -> list[np.ndarray]:
    """Face indices of each connected component of a mesh (components share no vertex), in
    order of their lowest face."""
    faces = np.asarray(faces)
    if len(faces) == 0:
        return []
    # Labels (a vertex of the same shell) only decrease; each round hooks every vertex and its
    # old label to the smallest label of its faces, then follows labels to their roots (the
    # Shiloach-Vishkin scheme): about ten rounds on a 300k-face sphere, where following one step
    # per round took over a hundred.
    label = np.arange(vertex_count)
    while True:
        face_label = label[faces].min(axis=1)
        new = label.copy()
        np.minimum.at(new, faces.ravel(), np.repeat(face_label, 3))
        np.minimum.at(new, label, new)
        while True:
            root = new[new]
            if np.array_equal(root, new):
                break
            new = root
        if np.array_equal(new, label):
            break
        label = new
    face_label = label[faces[:, 0]]
    _, first = np.unique(face_label, return_index=True)
    return [np.flatnonzero(face_label == face_label[f]) for f in np.sort(first)]


def split_bodies(bodies: Sequence[HasFrames], max_shells: int = MAX_SHELLS) -> list[SolverBody]:
    """The solver's bodies for the shot's: each body whole, or, when its mesh has 2 to
    `max_shells` shells, one solver body per shell (in order of their lowest face)."""
    out: list[SolverBody] = []
    for b, body in enumerate(bodies):
        faces = np.asarray(body.faces, dtype=np.int32)
        vertex_count = int(body.frames.shape[1])
        shells = mesh_shells(faces, vertex_count)
        if not 2 <= len(shells) <= max_shells:
            out.append(SolverBody(b, None, faces))
            continue
        for face_ids in shells:
            vertices, local = np.unique(faces[face_ids], return_inverse=True)
            out.append(SolverBody(b, vertices.astype(np.int64), local.reshape(-1, 3).astype(np.int32)))
    return out


def split_notes(names: Sequence[str], solver_bodies: Sequence[SolverBody]) -> list[str]:
    """One line per body split into shells, for the command line (`weft validate`, `weft run`)."""
    counts: dict[int, int] = {}
    for s in solver_bodies:
        if s.vertices is not None:
            counts[s.body] = counts.get(s.body, 0) + 1
    return [f"note: bodies[{b}] '{names[b]}' is {n} separate shells: simulated as {n} parts of one character "
            "(they may overlap; cloth is kept out of each)" for b, n in sorted(counts.items())]


def shell_of_nearest_point(solver_bodies: Sequence[SolverBody], bodies: Sequence[HasFrames], body: int,
                           points: np.ndarray) -> np.ndarray:
    """For points attached to the shot's body `body` (its closest point at frame 0), the index
    of the solver body holding that closest point: the shell nearest each point."""
    from weft.geometry import surface_distance

    candidates = [k for k, s in enumerate(solver_bodies) if s.body == body]
    if len(candidates) == 1:
        return np.full(len(points), candidates[0], dtype=np.int32)
    distances = np.stack([surface_distance(points, solver_bodies[k].frame(bodies, 0), solver_bodies[k].faces)
                          for k in candidates], axis=1)
    # The lowest shell on a tie, as np.argmin gives.
    return np.asarray(candidates, dtype=np.int32)[np.argmin(distances, axis=1)]
