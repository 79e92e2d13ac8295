"""Conservative CCD: hand-made edge cases, then a randomized set of >= 100k near-hit and
near-miss queries whose truth is exact (bench.ccd_queries): zero false negatives required, the
false-positive rate reported."""

from __future__ import annotations

import numpy as np
import pytest

from bench.ccd_queries import make_queries, verify_with_fractions
from weft import _solver

TRI = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def vt(p0, p1, tri0=TRI, tri1=None, **kw):
    tri1 = tri0 if tri1 is None else tri1
    return _solver.vertex_triangle_ccd(np.vstack([p0, tri0]), np.vstack([p1, tri1]), **kw)


def ee(a0, a1, b0, b1, **kw):
    """a0, a1: (2, 3) edge A at start/end; b0, b1 likewise for edge B."""
    return _solver.edge_edge_ccd(np.vstack([a0, b0]), np.vstack([a1, b1]), **kw)


EDGE_A = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
EDGE_B = np.array([[0.5, -1.0, 0.0], [0.5, 1.0, 0.0]])


def test_vertex_crossing_face_and_toi_is_a_tight_lower_bound():
    hit, toi = vt([0.2, 0.2, 1.0], [0.2, 0.2, -1.0])
    assert hit and 0.5 - 1e-5 <= toi <= 0.5
    assert vt([0.6, 0.6, 1.0], [0.6, 0.6, -1.0]) == (False, 1.0)  # passes beside the hypotenuse


def test_vertex_grazing_an_edge_and_a_corner():
    assert vt([0.2, 0.8, 1.0], [0.8, 0.2, -1.0])[0]  # through (0.5, 0.5, 0), on the hypotenuse
    assert vt([-1.0, 0.0, 1.0], [1.0, 0.0, -1.0])[0]  # through the corner (0, 0, 0)
    assert vt([1.0, 0.0, 1.0], [1.0, 0.0, -1.0])[0]  # straight down onto the corner (1, 0, 0)
    assert not vt([0.2, 0.8 + 1e-4, 1.0], [0.8 + 1e-4, 0.2, -1.0])[0]  # just outside
    assert not vt([-1e-4, 0.5, 1.0], [-1e-4, 0.5, -1.0])[0]


def test_coplanar_vertex_and_triangle():
    assert vt([-1.0, 0.25, 0.0], [1.0, 0.25, 0.0])[0]  # slides into the triangle in its plane
    assert not vt([-1.0, 2.0, 0.0], [2.0, 2.0, 0.0])[0]  # in the plane, never inside
    moving = TRI + [0.0, 0.0, 0.0]
    assert vt([0.3, 0.3, 0.0], [0.3, 0.3, 0.0], TRI, moving)[0]  # sits inside the whole step


def test_parallel_configurations():
    # Triangle moving parallel to itself under a still vertex: no contact.
    assert not vt([0.2, 0.2, 0.1], [0.2, 0.2, 0.1], TRI, TRI + [5.0, 0.0, 0.0])[0]
    # Parallel edges approaching and overlapping: hit; shifted so they never overlap: miss.
    a = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
    b = np.array([[0.5, 0.0, 0.0], [1.5, 0.0, 0.0]])
    assert ee(a, a - [0.0, 0.0, 2.0], b, b)[0]
    assert not ee(a, a - [0.0, 0.0, 2.0], b + [1.5, 0.0, 0.0], b + [1.5, 0.0, 0.0])[0]
    # Collinear edges sliding into each other along their line.
    c = np.array([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    assert ee(b, b, c, c - [2.0, 0.0, 0.0])[0]
    assert not ee(b, b, c, c - [0.4, 0.0, 0.0])[0]


def test_edge_edge_crossing_and_endpoint_grazing():
    hit, toi = ee(EDGE_A, EDGE_A - [0, 0, 2], EDGE_B, EDGE_B)
    assert hit and 0.5 - 1e-5 <= toi <= 0.5
    assert not ee(EDGE_A, EDGE_A - [0, 0, 2], EDGE_B + [1.5, 0, 0], EDGE_B + [1.5, 0, 0])[0]
    assert ee(EDGE_A, EDGE_A - [0, 0, 2], EDGE_B + [0.5, 0, 0], EDGE_B + [0.5, 0, 0])[0]  # endpoint graze
    assert not ee(EDGE_A, EDGE_A - [0, 0, 2], EDGE_B + [0.5 + 1e-4, 0, 0], EDGE_B + [0.5 + 1e-4, 0, 0])[0]


def test_contact_exactly_at_the_start_and_the_end():
    hit, toi = vt([0.2, 0.2, 0.0], [0.2, 0.2, 1.0])
    assert hit and toi == 0.0
    hit, toi = vt([0.2, 0.2, 1.0], [0.2, 0.2, 0.0])
    assert hit and 1.0 - 1e-5 <= toi <= 1.0
    hit, toi = ee(EDGE_A - [0, 0, 1], EDGE_A, EDGE_B, EDGE_B)
    assert hit and toi == 0.0
    hit, toi = ee(EDGE_A, EDGE_A - [0, 0, 1], EDGE_B, EDGE_B)
    assert hit and 1.0 - 1e-5 <= toi <= 1.0


@pytest.mark.parametrize("scale", [2.0**-500, 2.0**-60, 2.0**60, 2.0**500])
def test_tiny_and_huge_coordinates(scale):
    s = scale
    assert vt(np.array([0.2, 0.2, 1.0]) * s, np.array([0.2, 0.2, -1.0]) * s, TRI * s)[0]
    assert vt(np.array([0.2, 0.8, 1.0]) * s, np.array([0.8, 0.2, -1.0]) * s, TRI * s)[0]
    assert not vt(np.array([0.6, 0.6, 1.0]) * s, np.array([0.6, 0.6, -1.0]) * s, TRI * s)[0]
    assert ee(EDGE_A * s, (EDGE_A - [0, 0, 2]) * s, EDGE_B * s, EDGE_B * s)[0]
    assert not ee(EDGE_A * s, (EDGE_A - [0, 0, 2]) * s, (EDGE_B + [1.5, 0, 0]) * s, (EDGE_B + [1.5, 0, 0]) * s)[0]


def test_far_from_the_origin():
    far = np.array([3.0e7, -1.0e8, 2.5e7])  # 1e8 m: a millimetre-size feature is 2^-50 of it
    s = 1e-3
    assert vt(far + np.array([0.2, 0.2, 1.0]) * s, far + np.array([0.2, 0.2, -1.0]) * s, far + TRI * s)[0]
    assert vt(far + np.array([0.2, 0.8, 1.0]) * s, far + np.array([0.8, 0.2, -1.0]) * s, far + TRI * s)[0]


def test_minimum_separation_and_non_finite_input():
    p0, p1 = [0.2, 0.2, 1.0], [0.2, 0.2, 0.01]  # stops 1 cm above the face
    assert not vt(p0, p1)[0]
    assert vt(p0, p1, minimum_separation=0.02)[0]
    assert vt([np.nan, 0.0, 0.0], [0.0, 0.0, 0.0])[0]  # nothing known: conservatively a hit


@pytest.mark.parametrize("edge_edge", [False, True], ids=["vertex_triangle", "edge_edge"])
def test_randomized_exact_truth_no_false_negatives(edge_edge):
    rng = np.random.default_rng(20261122 + edge_edge)
    qs = make_queries(rng, 60_000, edge_edge, scale_exponents=(-300, -40, 0, 0, 0, 40, 300), far_fraction=0.1)
    verify_with_fractions(qs, rng.choice(len(qs), 150, replace=False))  # truth re-checked in rationals
    batch = _solver.edge_edge_ccd_batch if edge_edge else _solver.vertex_triangle_ccd_batch
    hit, toi, boxes = batch(qs.start, qs.end, threads=2)
    false_negatives = np.flatnonzero(qs.hit & ~hit)
    misses = ~qs.hit
    fp_rate = float(np.mean(hit[misses]))
    name = "edge-edge" if edge_edge else "vertex-triangle"
    print(f"\n{name}: {len(qs)} queries ({qs.hit.sum()} hits, {misses.sum()} certified misses), "
          f"false negatives {len(false_negatives)}, false positives {hit[misses].sum()} "
          f"(rate {fp_rate:.4f}), mean boxes {boxes.mean():.1f}")
    relative_gap = qs.gap[misses] / np.abs(qs.start[misses]).max(axis=(1, 2))
    for lo, hi in [(0.0, 1e-12), (1e-12, 1e-9), (1e-9, 1e-6), (1e-6, 1.0)]:
        sel = (relative_gap >= lo) & (relative_gap < hi)
        if sel.any():
            print(f"  misses with gap/scale in [{lo:g}, {hi:g}): {sel.sum():6d}, false-positive rate "
                  f"{np.mean(hit[misses][sel]):.4f}")
    assert len(false_negatives) == 0, f"false negatives: {qs.kind[false_negatives[:10]]}"
    # The reported time is a lower bound of the earliest contact (at most t*).
    assert np.all(toi[qs.hit] <= qs.t_star[qs.hit])
    assert fp_rate < 0.1


def test_displacement_that_overflows_is_treated_as_unknown():
    # Finite ends whose difference overflows to infinity: nothing can be said, so a hit at the start.
    big = np.finfo(np.float64).max / 2 * 1.5
    hit, toi = vt([0.2, 0.2, big], [0.2, 0.2, -big])
    assert hit and toi == 0.0
    hit, toi = ee(EDGE_A + [0, 0, big], EDGE_A - [0, 0, big], EDGE_B, EDGE_B)
    assert hit and toi == 0.0


@pytest.mark.parametrize("offset", [1.0e3, 1.0e5])
def test_tolerance_does_not_grow_with_the_distance_from_the_origin(offset):
    # A 1 cm triangle far from the origin; a vertex crossing its plane 10 um outside the
    # hypotenuse is a miss, one crossing inside a hit (the tolerance follows the query's extent).
    far = np.array([offset, -offset, 0.5 * offset])
    s = 0.01
    tri = far + TRI * s
    outside = np.array([0.5, 0.5, 0.0]) * s + np.array([1.0, 1.0, 0.0]) * (1e-5 / np.sqrt(2))
    assert not vt(far + outside + [0, 0, s], far + outside - [0, 0, s], tri)[0]
    assert vt(far + np.array([0.2, 0.2, 1.0]) * s, far + np.array([0.2, 0.2, -1.0]) * s, tri)[0]
    # Edge-edge likewise: edges 1 cm long passing 10 um apart.
    a = far + EDGE_A * s
    b = far + EDGE_B * s + [0.5 * s + 1e-5, 0, 0]
    assert not ee(a, a - [0, 0, 2 * s], b, b)[0]
