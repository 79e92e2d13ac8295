"""Global intersection analysis (GIA): hits, paths, colouring, inside test, degenerate cases, speed."""

from __future__ import annotations


import numpy as np
import pytest
import trimesh

from weft import _solver


def grid_faces(nu: int, nv: int) -> np.ndarray:
    """Two triangles per cell of an nu x nv vertex grid (vertex (i, j) has index i * nv + j)."""
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
    a = (i * nv + j).ravel()
    b, c, d = a + nv, a + nv + 1, a + 1
    return np.ascontiguousarray(np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]), dtype=np.int32)


def sheet(u: np.ndarray, v: np.ndarray, fn) -> tuple[np.ndarray, np.ndarray]:
    """A grid sheet with positions fn(U, V) -> (..., 3) over the parameter values u, v."""
    uu, vv = np.meshgrid(u, v, indexing="ij")
    x = np.ascontiguousarray(fn(uu, vv).reshape(-1, 3), dtype=np.float64)
    return x, grid_faces(len(u), len(v))


def plane(origin, du, dv, nu: int, nv: int):
    origin, du, dv = (np.asarray(a, float) for a in (origin, du, dv))
    return sheet(np.linspace(0, 1, nu), np.linspace(0, 1, nv), lambda uu, vv: origin + uu[..., None] * du + vv[..., None] * dv)


def check_consistent(r: dict) -> None:
    """Every triangle pair had 0 or 2 hits, every open path ends on a boundary, every hit is in one path."""
    assert r["inconsistent_pairs"] == 0
    seen = np.concatenate([p["hits"] for p in r["paths"]]) if r["paths"] else np.zeros(0, int)
    assert sorted(seen.tolist()) == list(range(r["hit_count"]))
    for p in r["paths"]:
        if p["closed"]:
            assert len(p["hits"]) >= 3
        elif not r["self"]:
            assert p["end_kinds"] == ("boundary", "boundary")


def test_sheets_crossing_at_right_angles_split_the_pushed_sheet():
    xa, fa = plane([0, 0, 0], [1, 0, 0], [0, 1, 0], 21, 21)
    # Vertical sheet x = 0.503 inside A's extent, pushed 0.3 below A (and 0.7 above).
    xb, fb = plane([0.503, 0.2, -0.3], [0, 0.6, 0], [0, 0, 1.0], 13, 11)
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    check_consistent(r)
    assert r["intersecting"] and r["path_count"] == 1 and r["open_path_count"] == 1
    path = r["paths"][0]
    assert path["end_meshes"] == (1, 1)  # both ends on B's boundary
    assert path["separates"] == (False, True)  # A is only pierced; B is cut in two
    assert len(path["hits"]) == r["hit_count"]
    np.testing.assert_array_equal(r["b"]["vertex_colour"], (xb[:, 2] < 0).astype(np.int8))
    assert r["a"]["coloured_vertex_count"] == 0
    # A's faces pierced by B's edges are on the contour; B's crossing edges too.
    assert (r["a"]["face_colour"] == 2).sum() > 0 and (r["a"]["face_colour"] == 1).sum() == 0
    eb = r["b"]["edges"]
    crosses = (xb[eb[:, 0], 2] < 0) != (xb[eb[:, 1], 2] < 0)
    np.testing.assert_array_equal(r["b"]["edge_colour"] == 2, crosses)
    both_below = (xb[eb[:, 0], 2] < 0) & (xb[eb[:, 1], 2] < 0)
    np.testing.assert_array_equal(r["b"]["edge_colour"] == 1, both_below)
    # Hit points lie on the line x = 0.503, z = 0.
    np.testing.assert_allclose(r["hits"]["point"][:, 2], 0.0, atol=1e-12)
    # Swapping the roles gives the same analysis with the meshes exchanged.
    s = _solver.intersection_analysis(xb, fb, xa, fa)
    np.testing.assert_array_equal(s["a"]["vertex_colour"], r["b"]["vertex_colour"])
    assert s["paths"][0]["separates"] == (True, False)


def test_dome_pushed_through_colours_the_enclosed_disc_only():
    # Big sheet (grid shifted so that no vertex sits near the contour) and a paraboloid patch
    # z = 0.05 - 5 r^2 whose tip pokes through it: the contour is a circle of radius ~0.1.
    xa, fa = plane([-0.5 + 0.0123, -0.5 + 0.0071, 0], [1, 0, 0], [0, 1, 0], 41, 41)
    t = np.linspace(-0.2, 0.2, 21)
    xb, fb = sheet(t, t, lambda uu, vv: np.stack([uu, vv, 0.05 - 5.0 * (uu**2 + vv**2)], -1))
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    check_consistent(r)
    assert r["path_count"] == 1 and r["closed_path_count"] == 1
    assert r["paths"][0]["separates"] == (True, True)
    radius = np.hypot(xa[:, 0], xa[:, 1])
    coloured = r["a"]["vertex_colour"].astype(bool)
    clear = np.abs(radius - 0.1) > 0.005  # the piecewise-linear contour is within 0.5 mm of r = 0.1
    np.testing.assert_array_equal(coloured[clear], radius[clear] < 0.1)
    assert coloured.sum() == (radius < 0.1).sum() > 20
    # Nothing else on the big sheet: coloured faces are all within the disc.
    fc = r["a"]["face_colour"]
    centres = xa[fa].mean(axis=1)
    assert np.all(np.hypot(centres[fc > 0, 0], centres[fc > 0, 1]) < 0.13)
    # On the dome, the tip above the sheet is the smaller region.
    np.testing.assert_array_equal(r["b"]["vertex_colour"], (xb[:, 2] > 0).astype(np.int8))
    for m in ("a", "b"):
        np.testing.assert_array_equal(r[m]["vertex_parity_colour"], r[m]["vertex_colour"])
    assert r["a"]["inside_other"] is None and r["b"]["inside_other"] is None  # neither is closed


def point_in_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Strictly inside a convex counter-clockwise polygon (2D)."""
    inside = np.ones(len(points), bool)
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0)):
        inside &= (b[0] - a[0]) * (points[:, 1] - a[1]) - (b[1] - a[1]) * (points[:, 0] - a[0]) > 0
    return inside


def test_sheet_cut_by_thin_cylinder_colours_exactly_the_inside():
    cyl = trimesh.creation.cylinder(radius=0.01, height=0.1, sections=32)
    xb = np.ascontiguousarray(cyl.vertices, dtype=np.float64)
    fb = np.ascontiguousarray(cyl.faces, dtype=np.int32)
    t = np.linspace(-0.05, 0.05, 61)
    xa, fa = sheet(t + 0.00031, t - 0.00017, lambda uu, vv: np.stack([uu, vv, 0.0013 + 0.01 * uu], -1))
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    check_consistent(r)
    assert r["b"]["closed"] and r["path_count"] == 1 and r["closed_path_count"] == 1
    coloured = r["a"]["vertex_colour"]
    inside = r["a"]["inside_other"]
    np.testing.assert_array_equal(coloured, inside)  # path colouring agrees with ray parity
    np.testing.assert_array_equal(r["a"]["vertex_parity_colour"], coloured)
    np.testing.assert_array_equal(inside, _solver.points_inside_closed_mesh(xa, xb, fb))
    # Analytic: inside the 32-gon cross-section (the sheet lies between the caps).
    ring = xb[(xb[:, 2] > 0) & (np.hypot(xb[:, 0], xb[:, 1]) > 0.005)]
    polygon = ring[np.argsort(np.arctan2(ring[:, 1], ring[:, 0])), :2]
    np.testing.assert_array_equal(inside.astype(bool), point_in_polygon(xa[:, :2], polygon))
    assert 80 < coloured.sum() < 130  # ~ pi r^2 / h^2 = 113 vertices
    assert r["paths"][0]["separates"] == (True, True)  # the loop also cuts the cylinder in two


def test_sheet_through_a_long_cylinder_parity_colouring_finds_the_inside_band():
    # A horizontal cylinder (radius 5 cm, along y, longer than the sheet) cuts the sheet along two
    # lines, each from boundary to boundary. Per path, each line splits the sheet and its smaller
    # side is coloured (BWK's rule), which here is the outside on the left; the parity colouring
    # of both paths together colours the band inside the cylinder.
    cyl = trimesh.creation.cylinder(radius=0.05, height=2.0, sections=48)
    cyl.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    xb = np.ascontiguousarray(cyl.vertices + [-0.2, 0.0, 0.0], dtype=np.float64)
    fb = np.ascontiguousarray(cyl.faces, dtype=np.int32)
    xa, fa = plane([-0.5 + 0.0011, -0.5 + 0.0007, 0.0013], [1, 0, 0], [0, 1, 0], 61, 61)
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    check_consistent(r)
    assert r["path_count"] == 2 and all(p["separates"][0] for p in r["paths"])
    inside = r["a"]["inside_other"]
    assert inside.sum() > 100
    np.testing.assert_array_equal(r["a"]["vertex_parity_colour"], inside)
    assert r["a"]["parity_conflicts"] == 0
    per_path = r["a"]["vertex_colour"].astype(bool)
    np.testing.assert_array_equal(per_path, xa[:, 0] < -0.2 + 0.05)  # left side, inside band included
    # For single paths the two colourings coincide (checked on the other scenarios too).


FOLD_RADIUS = 0.05


def folded_strip(top_length: float, n_top: int, width: float, nv: int, top_z, taper: float = 0.0):
    """A strip: a bottom part (0 <= x <= 1, z = 0), a half-cylinder fold of radius 0.05 at x = 1 and
    a top part running back towards x = 0 at height top_z(s, x, v) (s = distance from the fold).
    The fold narrows the strip by the factor (1 - taper) around its centre line. Returns the
    positions, faces and a per-vertex mask of the top part."""
    r0 = FOLD_RADIUS
    u = np.concatenate(
        [np.linspace(0, 1, 41), 1 + np.linspace(0, np.pi * r0, 9)[1:], 1 + np.pi * r0 + np.linspace(0, top_length, n_top)[1:]]
    )
    v = np.linspace(0, width, nv)

    def fn(uu, vv):
        phi = np.clip((uu - 1) / r0, 0, np.pi)
        s = np.clip(uu - 1 - np.pi * r0, 0, None)
        x = np.where(uu <= 1, uu, np.where(s > 0, 1 - s, 1 + r0 * np.sin(phi)))
        z = np.where(uu <= 1, 0.0, np.where(s > 0, top_z(s, x, vv), r0 * (1 - np.cos(phi))))
        y = width / 2 + (vv - width / 2) * (1 - taper * phi / np.pi)
        return np.stack([x, y, z], -1)

    x, f = sheet(u, v, fn)
    return x, f, np.repeat(u > 1 + np.pi * r0, len(v))


def test_self_intersection_of_a_folded_flap_colours_the_tip():
    # The returning flap is narrower and tilts down through the bottom part: its tip ends below it.
    x, f, flap = folded_strip(0.6, 25, 0.5, 21, lambda s, x, v: 2 * FOLD_RADIUS - 0.3 * s, taper=0.4)
    r = _solver.intersection_analysis(x, f)
    assert r["self"] and r["b"] is None
    check_consistent(r)
    assert r["path_count"] == 1
    path = r["paths"][0]
    assert not path["closed"] and path["end_kinds"] == ("boundary", "boundary") and path["separates"][0]
    tip = flap & (x[:, 2] < 0)
    assert tip.sum() > 20
    np.testing.assert_array_equal(r["a"]["vertex_colour"].astype(bool), tip)


def test_self_intersection_closed_loop_colours_both_discs():
    # A strip folded over (U shape) with a bump on the top layer pushed down through the bottom layer:
    # the double curve has two preimages, one loop on each layer; both discs are coloured.
    def top_z(s, x, v):
        return 2 * FOLD_RADIUS - 0.15 * np.exp(-((x - 0.4013) ** 2 + (v - 0.3007) ** 2) / (2 * 0.06**2))

    x, f, top = folded_strip(1.0, 41, 0.6, 25, top_z)
    r = _solver.intersection_analysis(x, f)
    check_consistent(r)
    assert r["path_count"] == 1 and r["closed_path_count"] == 1
    coloured = r["a"]["vertex_colour"].astype(bool)
    bump_tip = top & (x[:, 2] < 0)  # top-layer vertices pushed below the bottom layer
    assert bump_tip.sum() > 3
    np.testing.assert_array_equal(coloured[top], bump_tip[top])
    np.testing.assert_array_equal(r["a"]["vertex_parity_colour"], r["a"]["vertex_colour"])
    # On the bottom layer, the pierced disc: vertices under the part of the bump that is below z = 0.
    bottom_disc = coloured & ~top
    assert bottom_disc.sum() > 3
    d = np.hypot(x[bottom_disc, 0] - 0.4013, x[bottom_disc, 1] - 0.3007)
    assert d.max() < 0.06 * np.sqrt(2 * np.log(0.15 / 0.1)) + 0.03


def test_self_intersection_through_a_crease_vertex():
    # A strip folded flat at a crease (x = |u - 1|); near the crease the top layer dips below the
    # bottom one inside a half disc of radius 0.2. The double curve runs from crease vertex to
    # crease vertex (shared-vertex ends); on the unfolded strip its two preimages close into a loop
    # through those vertices, which are walls, so the disc (on both layers) is coloured.
    yc = 0.3013

    def fn(uu, vv):
        x = np.abs(uu - 1)
        return np.stack([x, vv, np.where(uu > 1, 0.5 * x * (np.hypot(x, vv - yc) - 0.2), 0.0)], -1)

    x, f = sheet(np.linspace(0, 2, 81), np.linspace(0, 0.6, 25), fn)
    r = _solver.intersection_analysis(x, f)
    check_consistent(r)
    assert r["path_count"] == 1
    path = r["paths"][0]
    assert path["end_kinds"] == ("shared_vertex", "shared_vertex") and path["separates"][0]
    assert len(path["vertices"]) == 2 and np.all(x[path["vertices"], 0] == 0)  # crease vertices
    radius = np.hypot(x[:, 0], x[:, 1] - yc)
    coloured = r["a"]["vertex_colour"].astype(bool)
    assert not coloured[radius > 0.2].any() and coloured[radius < 0.17].all()
    assert not coloured[path["vertices"]].any()


def test_no_intersection_gives_nothing():
    xa, fa = plane([0, 0, 0], [1, 0, 0], [0, 1, 0], 11, 11)
    xb, fb = plane([0, 0, 0.01], [1, 0, 0], [0, 1, 0], 11, 11)
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    assert not r["intersecting"] and r["hit_count"] == 0 and r["path_count"] == 0
    assert r["a"]["coloured_vertex_count"] == 0 and r["b"]["coloured_vertex_count"] == 0
    assert np.all(r["a"]["face_colour"] == 0) and np.all(r["b"]["edge_colour"] == 0)
    s = _solver.intersection_analysis(xa, fa)  # a flat sheet does not intersect itself
    assert s["hit_count"] == 0 and s["a"]["coloured_vertex_count"] == 0


@pytest.mark.parametrize(
    "name",
    ["coplanar_overlap", "coplanar_identical", "edge_touching", "vertex_on_face"],
)
def test_degenerate_contact_is_consistent_and_deterministic(name):
    xa, fa = plane([0, 0, 0], [1, 0, 0], [0, 1, 0], 11, 11)
    if name == "coplanar_overlap":
        xb, fb = plane([0.05, 0.05, 0], [1, 0, 0], [0, 1, 0], 11, 11)
    elif name == "coplanar_identical":
        xb, fb = xa.copy(), fa.copy()
    elif name == "edge_touching":  # a vertical sheet standing on A, its bottom edge in A's plane
        xb, fb = plane([0.5, 0.2, 0], [0, 0.6, 0], [0, 0, 0.5], 7, 5)
    else:  # a tent whose apex touches A exactly at a grid vertex
        xb = np.array([[0.5, 0.5, 0.0], [0.3, 0.3, 0.2], [0.7, 0.3, 0.2], [0.5, 0.7, 0.2]])
        fb = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1]], np.int32)
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    check_consistent(r)
    again = _solver.intersection_analysis(xa, fa, xb, fb, threads=1)
    for key in ("edge_mesh", "edge", "tri"):
        np.testing.assert_array_equal(r["hits"][key], again["hits"][key])
    np.testing.assert_array_equal(r["a"]["vertex_colour"], again["a"]["vertex_colour"])
    swapped = _solver.intersection_analysis(xb, fb, xa, fa)
    check_consistent(swapped)
    # The documented outcomes of the symbolic perturbation (mesh A nudged, roughly, along +x, +y, +z).
    if name.startswith("coplanar"):
        assert r["hit_count"] == 0 and swapped["hit_count"] == 0
    elif name == "edge_touching":  # B standing on A counts as pushed through; swapped, as touching
        assert r["path_count"] == 1 and r["paths"][0]["separates"] == (False, True)
        np.testing.assert_array_equal(r["b"]["vertex_colour"], (xb[:, 2] == 0).astype(np.int8))
        assert swapped["hit_count"] == 0
    else:  # the tent touching A at one point: one tiny loop, or nothing when swapped
        assert r["closed_path_count"] == 1 and r["open_path_count"] == 0 and swapped["hit_count"] == 0


def test_orient3d_sign_convention():
    a, b, c = [0.0, 0, 0], [1.0, 0, 0], [0.0, 1, 0]
    assert _solver.orient3d(a, b, c, [0.2, 0.2, -1.0]) == 1  # below counter-clockwise abc
    assert _solver.orient3d(a, b, c, [0.2, 0.2, 1.0]) == -1
    assert _solver.orient3d(a, b, c, [0.3, 0.7, 0.0]) == 0


def test_nonmanifold_spine_ends_paths():
    # Three pages sharing a spine (edges with three faces), cut by a horizontal sheet: the spine's
    # hit has three links, so three paths end there ("nonmanifold") and run to the pages' edges.
    nz, nr = 11, 5
    z, rr = np.linspace(-0.5, 0.5, nz), np.linspace(0, 0.5, nr)
    points, faces = [np.stack([np.zeros(nz), np.zeros(nz), z], 1)], []
    for page, angle in enumerate([0.1, 2.2, 4.3]):
        base = nz + page * nz * (nr - 1)
        direction = np.array([np.cos(angle), np.sin(angle), 0])
        points.append(np.array([rr[j] * direction + [0, 0, z[i]] for j in range(1, nr) for i in range(nz)]))

        def index(i, j):
            return i if j == 0 else base + (j - 1) * nz + i

        for j in range(nr - 1):
            for i in range(nz - 1):
                faces += [[index(i, j), index(i, j + 1), index(i + 1, j + 1)], [index(i, j), index(i + 1, j + 1), index(i + 1, j)]]
    xa, fa = np.ascontiguousarray(np.concatenate(points)), np.array(faces, np.int32)
    xb, fb = plane([-1, -1, 0.013], [2, 0, 0], [0, 2, 0], 9, 9)
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    assert r["inconsistent_pairs"] == 0 and r["path_count"] == 3
    spine_hit = {p["hits"][0] for p in r["paths"]}
    assert len(spine_hit) == 1
    for p in r["paths"]:
        assert p["end_kinds"] == ("nonmanifold", "boundary") and p["end_meshes"] == (-1, 0)
    assert r["a"]["coloured_vertex_count"] == 0  # no single path separates A (documented)


def test_bad_input_is_rejected():
    xa, fa = plane([0, 0, 0], [1, 0, 0], [0, 1, 0], 3, 3)
    bad = fa.copy()
    bad[0, 0] = 99
    with pytest.raises(ValueError, match="outside"):
        _solver.intersection_analysis(xa, bad)
    nan = xa.copy()
    nan[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        _solver.intersection_analysis(nan, fa)
    with pytest.raises(ValueError, match="not closed"):
        _solver.points_inside_closed_mesh(xa, xa, fa)


def test_20k_triangle_pair_prunes_to_the_crossings_and_agrees_with_the_exact_counter():
    # Two 101 x 101 sheets (20k triangles each): a flat one and an egg-crate crossing it many
    # times. The cost is checked by what the analysis did, not by a wall time (that is bench/'s).
    xa, fa = plane([0, 0, 0], [1, 0, 0], [0, 1, 0], 101, 101)
    t = np.linspace(0, 1, 101)
    xb, fb = sheet(t + 0.0031, t + 0.0047, lambda uu, vv: np.stack([uu, vv, 0.02 * np.sin(6 * np.pi * uu) * np.sin(6 * np.pi * vv) + 0.001], -1))
    assert len(fa) == len(fb) == 20000
    r = _solver.intersection_analysis(xa, fa, xb, fb)
    check_consistent(r)
    single = _solver.intersection_analysis(xa, fa, xb, fb, threads=1)
    np.testing.assert_array_equal(single["a"]["vertex_colour"], r["a"]["vertex_colour"])
    np.testing.assert_array_equal(single["hits"]["edge"], r["hits"]["edge"])
    # Every intersecting triangle pair is found, as the independent exact counter counts them.
    exact = _solver.count_mesh_intersections(xa, fa.astype(np.int32), xb, fb.astype(np.int32))
    assert r["intersecting_pairs"] == exact > 1000
    # The broad phase prunes the 4e8 pairs to a few candidates per crossing pair.
    assert r["intersecting_pairs"] <= r["candidate_pairs"] < 10 * r["intersecting_pairs"]
    assert r["path_count"] == r["closed_path_count"] + r["open_path_count"]
    assert r["closed_path_count"] > 10


def test_body_body_query_for_pinch_detection():
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    x1 = np.ascontiguousarray(sphere.vertices, dtype=np.float64)
    f1 = np.ascontiguousarray(sphere.faces, dtype=np.int32)
    overlapping = _solver.intersection_analysis(x1, f1, x1 + [0.15, 0.0013, 0.0007], f1, colour=False)
    assert overlapping["intersecting"] and overlapping["path_count"] == 1 and overlapping["closed_path_count"] == 1
    assert overlapping["a"]["coloured_vertex_count"] == 0  # colouring skipped
    # Inside tests come for free between closed bodies: vertices of each sphere inside the other.
    inside = overlapping["a"]["inside_other"].astype(bool)
    d = np.linalg.norm(x1 - [0.15, 0.0013, 0.0007], axis=1)  # the faceted sphere lies between r = 0.09 and 0.1
    assert inside[d < 0.09].all() and not inside[d > 0.1].any() and inside.sum() >= (d < 0.09).sum() > 0
    apart = _solver.intersection_analysis(x1, f1, x1 + [0.25, 0, 0], f1, colour=False)
    assert not apart["intersecting"] and apart["path_count"] == 0
