"""Randomized CCD queries with exact ground truth, for tests and `weft bench ccd`.

Every query is built in integer arithmetic on a dyadic grid (units of 2^-E metres, E = 38) and
converted to float64 without rounding (every integer stays below 2^52 and the scale is a power
of two), so its truth is exact by construction:

- hits: at a dyadic time t* = j/64 the vertex lies exactly at a dyadic barycentric point
  (u*, v*) of the triangle, or the two edges share the point at (u*, v*). Kinds: interior
  crossings, grazing an edge or a vertex of the triangle (or an edge's endpoint), contact
  exactly at t = 0 and t = 1, coplanar motion, parallel (collinear, overlapping) edges. The
  true earliest contact time is at most t*.
- misses: an integer direction d separates the primitives with a positive gap at t = 0, t*
  and 1 (vertex: d.p - max(d.a, d.b, d.c); edges: min over edge A of d.x - max over edge B).
  Each d.x is affine in t, a max of affine functions is convex and a min concave, so positive
  gaps at the ends of [0, t*] and [t*, 1] prove a positive gap on all of [0, 1]: a certified
  miss. Gaps along d/|d| range from about 2^-46 m to 2^-16 m (log-uniform), at coordinates of
  order 1 m: near misses down to a few ulps.

Queries can be scaled by powers of two (tiny and huge coordinates, still exact) and translated
far from the origin by whole metres (still exact up to 2^12 m). ``verify_with_fractions``
re-checks queries from their float64 values in rational arithmetic (``fractions.Fraction``).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

S_BITS = 20  # random points on a 2^-20 m grid in [-1, 1]^3
T_BITS = 6  # contact times j / 64
B_BITS = 6  # barycentric / edge parameters i / 64
E_BITS = S_BITS + 2 * T_BITS + B_BITS  # integer unit: 2^-38 m
TEN = 1 << T_BITS
BEN = 1 << B_BITS


@dataclass
class QuerySet:
    start: np.ndarray  # (N, 4, 3) float64: (p, a, b, c) or (a0, a1, b0, b1) at t = 0
    end: np.ndarray  # (N, 4, 3) float64 at t = 1
    hit: np.ndarray  # (N,) bool, exact truth
    t_star: np.ndarray  # (N,) a contact time of hits (>= the earliest), nan for misses
    params: np.ndarray  # (N, 2) (u*, v*) of hits at t_star
    direction: np.ndarray  # (N, 3) separating direction d of misses
    gap: np.ndarray  # (N,) certified separation along d/|d| of misses, metres; nan for hits
    kind: np.ndarray  # (N,) str
    edge_edge: bool

    def __len__(self) -> int:
        return len(self.hit)


def _points(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Random grid points in [-1, 1] m, in units 2^-E (multiples of 2^(2T+B))."""
    return rng.integers(-(1 << S_BITS), (1 << S_BITS) + 1, size=(*shape, 3)) << (E_BITS - S_BITS)


def _vectors(rng: np.random.Generator, n: int, multiple: int) -> np.ndarray:
    """Random displacements up to about 1 m in units 2^-E, multiples of `multiple`."""
    span = (1 << E_BITS) // multiple
    return rng.integers(-span, span + 1, size=(n, 3)) * multiple


def _at(x0: np.ndarray, x1: np.ndarray, j: np.ndarray) -> np.ndarray:
    """x0 + (j / 2^T)(x1 - x0), exact when x1 - x0 is a multiple of 2^T."""
    return x0 + (j[:, None] * (x1 - x0)) // TEN


def _dot(d: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", d, x)


def _times(rng: np.random.Generator, n: int) -> np.ndarray:
    j = rng.integers(0, TEN + 1, size=n)
    r = rng.random(n)
    j[r < 0.1] = 0  # contact exactly at t = 0
    j[(r >= 0.1) & (r < 0.2)] = TEN  # exactly at t = 1
    return j


def _trajectory(point: np.ndarray, velocity: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end of a point that is at `point` at t* = j/2^T (velocity a multiple of 2^T)."""
    return point - (j[:, None] * velocity) // TEN, point + ((TEN - j)[:, None] * velocity) // TEN


def _gaps(rng: np.random.Generator, n: int, d: np.ndarray) -> np.ndarray:
    """Target gap d.(x - y) in units 2^-E: |d| * 2^g, g log-uniform over [-8, 22]."""
    norm = np.sqrt(_dot(d, d).astype(np.float64))
    return np.maximum(1, np.floor(norm * np.exp2(rng.uniform(-8.0, 22.0, size=n)))).astype(np.int64)


def _directions(rng: np.random.Generator, n: int) -> np.ndarray:
    d = rng.integers(-256, 257, size=(n, 3))
    d[np.all(d == 0, axis=1), 2] = 1
    return d


def _ceil_div(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return -((-a) // b)


def _fit_velocity(
    rng: np.random.Generator, d: np.ndarray, r: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """r + lambda d, lambda a multiple of 2^T, with d.w aimed inside (lo, hi) (either may be
    infinite). Rounding may miss a narrow interval: callers check the result exactly."""
    dd = _dot(d, d).astype(np.float64)
    with np.errstate(invalid="ignore"):
        return _fit(rng, d, r, lo, hi, dd)


def _fit(rng, d, r, lo, hi, dd):
    width = np.where(np.isfinite(lo) & np.isfinite(hi), hi - lo, np.inf)
    step = np.minimum(np.abs(np.where(np.isfinite(width), width, 0.0)) * rng.random(len(d)), 1e12) + dd * TEN
    target = np.where(
        np.isfinite(lo) & np.isfinite(hi), lo + rng.uniform(0.25, 0.75, len(d)) * (hi - lo),
        np.where(np.isfinite(lo), lo + step, np.where(np.isfinite(hi), hi - step, _dot(d, r).astype(np.float64))),
    )
    lam = np.round((target - _dot(d, r)) / (dd * TEN)).astype(np.int64) * TEN
    return r + lam[:, None] * d


def _bounds(j: np.ndarray, at_start: np.ndarray, at_end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounds on X = d.w for a point whose projection must rise less than at_start over
    [0, t*] and fall less than at_end over [t*, 1]: t* X < at_start, -(1 - t*) X < at_end."""
    with np.errstate(divide="ignore", invalid="ignore"):
        hi = np.where(j > 0, at_start.astype(np.float64) * TEN / j, np.inf)
        lo = np.where(j < TEN, -at_end.astype(np.float64) * TEN / (TEN - j), -np.inf)
    return lo, hi


def _barycentric(rng: np.random.Generator, kinds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = len(kinds)
    iu = rng.integers(0, BEN + 1, size=n)
    iv = rng.integers(0, BEN + 1, size=n)
    over = iu + iv > BEN
    iu[over], iv[over] = BEN - iu[over], BEN - iv[over]
    which = rng.integers(0, 3, size=n)
    edge = kinds == "edge"
    iu[edge & (which == 0)] = 0
    iv[edge & (which == 1)] = 0
    e2 = edge & (which == 2)
    iv[e2] = BEN - iu[e2]
    vertex = kinds == "vertex"
    iu[vertex] = np.where(which[vertex] == 1, BEN, 0)
    iv[vertex] = np.where(which[vertex] == 2, BEN, 0)
    return iu, iv


def _vt_hits(rng: np.random.Generator, n: int):
    kinds = rng.choice(np.array(["interior", "edge", "vertex", "coplanar"]), size=n, p=[0.4, 0.3, 0.15, 0.15])
    tri0, tri1 = _points(rng, (n, 3)), _points(rng, (n, 3))
    coplanar = kinds == "coplanar"
    tri1[coplanar] = tri0[coplanar]  # still triangle, the vertex moves in its plane
    j = _times(rng, n)
    a, b, c = (_at(tri0[:, k], tri1[:, k], j) for k in range(3))
    iu, iv = _barycentric(rng, np.where(coplanar, "interior", kinds))
    q = a + (iu[:, None] * (b - a) + iv[:, None] * (c - a)) // BEN
    w = _vectors(rng, n, TEN)
    in_plane = (rng.integers(-BEN, BEN + 1, (n, 1)) * (b - a) + rng.integers(-BEN, BEN + 1, (n, 1)) * (c - a)) // BEN
    w = np.where(coplanar[:, None], in_plane, w)
    p0, p1 = _trajectory(q, w, j)
    start = np.concatenate([p0[:, None], tri0], axis=1)
    end = np.concatenate([p1[:, None], tri1], axis=1)
    return start, end, j, np.stack([iu, iv], axis=1) / BEN, kinds


def _vt_misses(rng: np.random.Generator, n: int):
    m = 5 * n  # oversample, keep certified ones (about 30% are)
    kinds = rng.choice(np.array(["interior", "edge", "vertex"]), size=m)
    tri0, tri1 = _points(rng, (m, 3)), _points(rng, (m, 3))
    j = _times(rng, m)
    a, b, c = (_at(tri0[:, k], tri1[:, k], j) for k in range(3))
    iu, iv = _barycentric(rng, kinds)
    q = a + (iu[:, None] * (b - a) + iv[:, None] * (c - a)) // BEN
    d = _directions(rng, m)
    normal = np.cross((b - a).astype(np.float64), (c - a).astype(np.float64))
    scale = np.maximum(np.abs(normal).max(axis=1, keepdims=True), 1.0)
    normal_d = np.round(normal / scale * 256).astype(np.int64)
    use_normal = (kinds == "interior") & np.any(normal_d != 0, axis=1)  # just above the face
    d[use_normal] = normal_d[use_normal]
    d *= np.where(rng.random(m) < 0.5, 1, -1)[:, None]
    top = np.max(np.stack([_dot(d, a), _dot(d, b), _dot(d, c)]), axis=0)
    shift = np.maximum(0, _ceil_div(top + _gaps(rng, m, d) - _dot(d, q), _dot(d, d)))
    p = q + shift[:, None] * d
    with_triangle = ((tri1 - tri0).sum(axis=1) // 3 // TEN) * TEN  # drifting along with the triangle
    r = np.where((rng.random(m) < 0.5)[:, None], _vectors(rng, m, TEN), with_triangle)
    top0 = np.max(np.stack([_dot(d, tri0[:, k]) for k in range(3)]), axis=0)
    top1 = np.max(np.stack([_dot(d, tri1[:, k]) for k in range(3)]), axis=0)
    lo, hi = _bounds(j, _dot(d, p) - top0, _dot(d, p) - top1)
    w = _fit_velocity(rng, d, r, lo, hi)
    p0, p1 = _trajectory(p, w, j)
    start = np.concatenate([p0[:, None], tri0], axis=1)
    end = np.concatenate([p1[:, None], tri1], axis=1)
    gaps = [_dot(d, x[:, 0]) - np.max(np.stack([_dot(d, x[:, k]) for k in (1, 2, 3)]), axis=0) for x in (start, end)]
    gaps.append(_dot(d, p) - top)
    gap = np.minimum.reduce(gaps)
    keep = np.flatnonzero(gap > 0)[:n]
    if len(keep) < n:
        raise RuntimeError("too few certified misses; raise the oversampling")
    return start[keep], end[keep], j[keep], d[keep], gap[keep], np.char.add("miss-", kinds[keep])


def _ee_edges(rng: np.random.Generator, m: int, kinds: np.ndarray):
    """Edge A's trajectory, t*, the point on A at (t*, u*), and B's direction e at t*."""
    a0, a1 = _points(rng, (m, 2)), _points(rng, (m, 2))  # (m, 2 endpoints, 3) at t = 0 and 1
    planar = kinds == "planar"
    a0[planar, :, 2] = 0
    a1[planar, :, 2] = 0
    j = _times(rng, m)
    A0, A1 = _at(a0[:, 0], a1[:, 0], j), _at(a0[:, 1], a1[:, 1], j)
    iu = rng.integers(0, BEN + 1, size=m)
    iv = rng.integers(0, BEN + 1, size=m)
    endpoint = kinds == "endpoint"
    which = rng.integers(0, 4, size=m)
    iu[endpoint & (which == 0)] = 0
    iu[endpoint & (which == 1)] = BEN
    iv[endpoint & (which == 2)] = 0
    iv[endpoint & (which == 3)] = BEN
    q = A0 + (iu[:, None] * (A1 - A0)) // BEN
    e = _vectors(rng, m, BEN)
    parallel = kinds == "parallel"
    e[parallel] = (A1 - A0)[parallel] // 2
    e[planar, 2] = 0
    return a0, a1, j, A0, A1, iu, iv, q, e


def _ee_b_trajectory(rng, m, j, b0, b1, kinds, follow, d=None, low_a=None):
    w0, w1 = _vectors(rng, m, TEN), _vectors(rng, m, TEN)
    if follow is not None:
        chosen = rng.random(m) < 0.5
        w0[chosen] = follow[chosen]
        w1[chosen] = follow[chosen]
    if d is not None:  # keep each endpoint of B below edge A along d at t = 0 and 1
        for k, (b, w) in enumerate(((b0, w0), (b1, w1))):
            lo, hi = _bounds(j, low_a[1] - _dot(d, b), low_a[0] - _dot(d, b))
            # here X = d.w must satisfy -t* X < low_a(0) - d.b and (1 - t*) X < low_a(1) - d.b
            w[:] = _fit_velocity(rng, d, w, -hi, -lo)
    planar = kinds == "planar"
    w0[planar, 2] = 0
    w1[planar, 2] = 0
    (b00, b01), (b10, b11) = _trajectory(b0, w0, j), _trajectory(b1, w1, j)
    return b00, b01, b10, b11


def _ee_hits(rng: np.random.Generator, n: int):
    kinds = rng.choice(np.array(["cross", "endpoint", "parallel", "planar"]), size=n, p=[0.45, 0.25, 0.15, 0.15])
    a0, a1, j, A0, A1, iu, iv, q, e = _ee_edges(rng, n, kinds)
    b0 = q - (iv[:, None] * e) // BEN
    b1 = q + ((BEN - iv)[:, None] * e) // BEN
    b00, b01, b10, b11 = _ee_b_trajectory(rng, n, j, b0, b1, kinds, None)
    start = np.stack([a0[:, 0], a0[:, 1], b00, b10], axis=1)
    end = np.stack([a1[:, 0], a1[:, 1], b01, b11], axis=1)
    return start, end, j, np.stack([iu, iv], axis=1) / BEN, kinds


def _ee_misses(rng: np.random.Generator, n: int):
    m = 14 * n  # oversample, keep certified ones (about 11% are)
    kinds = rng.choice(np.array(["cross", "endpoint", "parallel"]), size=m, p=[0.5, 0.3, 0.2])
    a0, a1, j, A0, A1, iu, iv, q, e = _ee_edges(rng, m, kinds)
    d = _directions(rng, m)
    b0 = q - (iv[:, None] * e) // BEN
    b1 = q + ((BEN - iv)[:, None] * e) // BEN
    low_a = np.minimum(_dot(d, A0), _dot(d, A1))
    high_b = np.maximum(_dot(d, b0), _dot(d, b1))
    shift = np.maximum(0, _ceil_div(high_b - low_a + _gaps(rng, m, d), _dot(d, d)))
    b0 = b0 - shift[:, None] * d
    b1 = b1 - shift[:, None] * d
    follow = (((a1 - a0).sum(axis=1)) // 2 // TEN) * TEN
    low_a_ends = (np.minimum(_dot(d, a0[:, 0]), _dot(d, a0[:, 1])), np.minimum(_dot(d, a1[:, 0]), _dot(d, a1[:, 1])))
    b00, b01, b10, b11 = _ee_b_trajectory(rng, m, j, b0, b1, kinds, follow, d, low_a_ends)
    start = np.stack([a0[:, 0], a0[:, 1], b00, b10], axis=1)
    end = np.stack([a1[:, 0], a1[:, 1], b01, b11], axis=1)

    def gap_of(x: np.ndarray) -> np.ndarray:
        return np.minimum(_dot(d, x[:, 0]), _dot(d, x[:, 1])) - np.maximum(_dot(d, x[:, 2]), _dot(d, x[:, 3]))

    mid = np.stack([A0, A1, b0, b1], axis=1)
    gap = np.minimum.reduce([gap_of(start), gap_of(end), gap_of(mid)])
    keep = np.flatnonzero(gap > 0)[:n]
    if len(keep) < n:
        raise RuntimeError("too few certified misses; raise the oversampling")
    return start[keep], end[keep], j[keep], d[keep], gap[keep], np.char.add("miss-", kinds[keep])


def make_queries(
    rng: np.random.Generator,
    n: int,
    edge_edge: bool,
    scale_exponents: tuple[int, ...] = (0,),
    far_fraction: float = 0.0,
) -> QuerySet:
    """n queries, half exact hits and half certified near misses, shuffled.

    scale_exponents: each query is scaled by 2^k, k drawn from these (e.g. (-80, 0, 80)).
    far_fraction: share of queries translated by up to 2^12 whole metres (before scaling).
    """
    n_hit = n // 2
    hits = (_ee_hits if edge_edge else _vt_hits)(rng, n_hit)
    misses = (_ee_misses if edge_edge else _vt_misses)(rng, n - n_hit)
    start_i = np.concatenate([hits[0], misses[0]])
    end_i = np.concatenate([hits[1], misses[1]])
    if max(np.abs(start_i).max(), np.abs(end_i).max()) >= 1 << 52:
        raise AssertionError("integer coordinates exceed 2^52: the float conversion would round")
    hit = np.concatenate([np.ones(n_hit, bool), np.zeros(n - n_hit, bool)])
    t_star = np.concatenate([hits[2] / TEN, np.full(n - n_hit, np.nan)])
    params = np.concatenate([hits[3], np.full((n - n_hit, 2), np.nan)])
    direction = np.concatenate([np.zeros((n_hit, 3), np.int64), misses[3]])
    d_norm = np.sqrt(_dot(misses[3], misses[3]).astype(np.float64))
    gap_units = np.concatenate([np.full(n_hit, np.nan), misses[4] / d_norm])
    kind = np.concatenate([hits[4].astype(str), misses[5].astype(str)])

    exponent = rng.choice(np.asarray(scale_exponents), size=n)
    start = np.ldexp(start_i.astype(np.float64), (exponent - E_BITS)[:, None, None])
    end = np.ldexp(end_i.astype(np.float64), (exponent - E_BITS)[:, None, None])
    gap = np.ldexp(gap_units, exponent - E_BITS)
    if far_fraction > 0.0:
        far = rng.random(n) < far_fraction
        offset = rng.integers(-(1 << 12), (1 << 12) + 1, size=(n, 1, 3)).astype(np.float64)
        offset = np.ldexp(offset, exponent[:, None, None]) * far[:, None, None]
        start = start + offset
        end = end + offset
        kind = np.where(far, np.char.add(kind, "+far"), kind)
    kind = np.where(exponent != 0, np.char.add(kind, np.char.add("*2^", exponent.astype(str))), kind)
    order = rng.permutation(n)
    return QuerySet(
        start[order], end[order], hit[order], t_star[order], params[order], direction[order], gap[order],
        kind[order], edge_edge,
    )


def _lerp(x0: list[Fraction], x1: list[Fraction], t: Fraction) -> list[Fraction]:
    return [a + t * (b - a) for a, b in zip(x0, x1)]


def verify_with_fractions(qs: QuerySet, indices: np.ndarray) -> None:
    """Re-check the truth of the given queries in exact rational arithmetic from the float64
    inputs; raises AssertionError on any disagreement."""
    for q in indices:
        s = [[Fraction(float(c)) for c in qs.start[q, i]] for i in range(4)]
        e = [[Fraction(float(c)) for c in qs.end[q, i]] for i in range(4)]
        if qs.hit[q]:
            t = Fraction(float(qs.t_star[q]))
            u, v = Fraction(float(qs.params[q, 0])), Fraction(float(qs.params[q, 1]))
            x = [_lerp(s[i], e[i], t) for i in range(4)]
            if qs.edge_edge:
                assert 0 <= u <= 1 and 0 <= v <= 1
                gap = [x[0][k] + u * (x[1][k] - x[0][k]) - x[2][k] - v * (x[3][k] - x[2][k]) for k in range(3)]
            else:
                assert u >= 0 and v >= 0 and u + v <= 1
                gap = [x[0][k] - x[1][k] - u * (x[2][k] - x[1][k]) - v * (x[3][k] - x[1][k]) for k in range(3)]
            assert gap == [0, 0, 0], f"query {q} ({qs.kind[q]}): constructed contact is not exact"
        else:
            d = [Fraction(int(c)) for c in qs.direction[q]]
            # Positive separation at every t = k/64 (which include 0, t* and 1) proves it on
            # each interval between them (concave in t), so on all of [0, 1].
            for t in (Fraction(k, TEN) for k in range(TEN + 1)):
                x = [_lerp(s[i], e[i], t) for i in range(4)]
                proj = [sum(dk * xk for dk, xk in zip(d, x[i])) for i in range(4)]
                if qs.edge_edge:
                    sep = min(proj[0], proj[1]) - max(proj[2], proj[3])
                else:
                    sep = proj[0] - max(proj[1], proj[2], proj[3])
                assert sep > 0, f"query {q} ({qs.kind[q]}): separation {float(sep)} at t = {t}"
