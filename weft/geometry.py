"""Point-to-surface distances in numpy, for checks on a shot (weft.solver_setup, weft.pin_room)
and for the benchmarks' contact metrics (bench/contact_metrics.py)."""

from __future__ import annotations

import numpy as np


def point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distance from points p (P, 3) to triangles (a, b, c) (T, 3 each): (P, T). The closest point
    by Voronoi region (Ericson, Real-Time Collision Detection 5.1.5), vectorised."""
    p = p[:, None, :]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.sum(ab * ap, -1), np.sum(ac * ap, -1)
    bp = p - b
    d3, d4 = np.sum(ab * bp, -1), np.sum(ac * bp, -1)
    cp = p - c
    d5, d6 = np.sum(ab * cp, -1), np.sum(ac * cp, -1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        v, w = vb * denom, vc * denom
        closest = a + ab * v[..., None] + ac * w[..., None]  # face region
        # edges
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    regions = [
        (d1 <= 0) & (d2 <= 0), (d3 >= 0) & (d4 <= d3), (d6 >= 0) & (d5 <= d6),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0), (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
    ]
    points = [
        np.broadcast_to(a, closest.shape), np.broadcast_to(b, closest.shape), np.broadcast_to(c, closest.shape),
        a + ab * t_ab[..., None], a + ac * t_ac[..., None], b + (c - b) * t_bc[..., None],
    ]
    # The first region that holds wins (vertex regions before edge regions).
    for mask, q in zip(reversed(regions), reversed(points)):
        closest = np.where(mask[..., None], q, closest)
    return np.linalg.norm(p - closest, axis=-1)


def surface_distance(points: np.ndarray, x: np.ndarray, faces: np.ndarray, chunk: int = 2_000_000) -> np.ndarray:
    """Unsigned distance from each point to the surface (x, faces), in chunks of points."""
    a, b, c = x[faces[:, 0]], x[faces[:, 1]], x[faces[:, 2]]
    step = max(1, chunk // max(len(faces), 1))
    out = np.empty(len(points))
    for start in range(0, len(points), step):
        out[start:start + step] = point_triangle_distance(points[start:start + step], a, b, c).min(axis=1)
    return out


def distances_within(points: np.ndarray, x: np.ndarray, faces: np.ndarray, reach: float) -> np.ndarray:
    """Distance from each point to the surface (x, faces) where it is below `reach`; a number of
    at least `reach` (infinity) elsewhere. Exact distances are computed only for the point and
    face pairs whose boxes come within `reach` of each other: a face whose box is farther from
    a point is farther from it than `reach`."""
    corners = x[faces]
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    # Faces within reach of the points' box, then point and face pairs within reach.
    candidates = np.flatnonzero(np.all(hi >= points.min(axis=0) - reach, axis=1)
                                & np.all(lo <= points.max(axis=0) + reach, axis=1))
    near = np.full(len(points), np.inf)
    if len(candidates) == 0:
        return near
    lo, hi, corners = lo[candidates], hi[candidates], corners[candidates]
    point, face = np.nonzero(np.all(points[:, None, :] >= lo[None] - reach, axis=-1)
                             & np.all(points[:, None, :] <= hi[None] + reach, axis=-1))
    if len(point) == 0:
        return near
    tri = corners[face]
    d = point_triangle_distance(points[point], tri[:, None, 0], tri[:, None, 1], tri[:, None, 2])[:, 0]
    np.minimum.at(near, point, d)
    return near
