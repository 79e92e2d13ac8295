"""Cloth/cloth GIA in the collision stage (docs/intersection-analysis.md, "In the step:
cloth/cloth untangling"): a sheet whose folded flap is pushed through its own lower layer, and a
small sheet pushed partly through a larger one, untangle; with GIA off they stay tangled; a
clean start is unaffected; the telemetry is in the cache."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.gia import R, fold_shot, folded_sheet, two_sheets_shot
from weft import _solver
from weft.cache import open_cache_reader
from weft.runner import ShotRunner
from weft.solver_setup import collision_switches

from tests.helpers import make_scene, simulate


def run(doc: dict, threads: int = 2) -> tuple[list, np.ndarray]:
    rows = []
    for index, sim, t in simulate(doc, threads=threads):
        rows.append((t.intersections, t.gia_self_coloured_vertices, t.gia_self_paths))
    return rows, sim.positions.copy()


def assert_untangles(rows: list, within: int) -> None:
    counts = [r[0] for r in rows]
    first_clean = next(i for i, c in enumerate(counts) if c == 0)
    assert first_clean < within, counts
    assert all(c == 0 for c in counts[first_clean:]), counts
    assert rows[0][1] > 0 and rows[0][2] > 0, rows[0]  # coloured and traced at the start
    assert rows[-1][1] == 0 and rows[-1][2] == 0, rows[-1]


def test_fold_pushed_through_its_own_layer_untangles():
    doc = fold_shot()
    assert collision_switches(make_scene(doc))["gia"] == -1  # auto, no bodies needed
    rows, x = run(doc)
    assert_untangles(rows, within=4)
    # The pushed-through tip went back: each of its vertices ends above the lower layer's
    # vertex nearest to it in the layer's plane (x, z).
    start, faces, rest = folded_sheet(4 * R)
    tip, lower = start[:, 1] < 0.0, rest[:, 1] == 0.0
    assert tip.sum() == 30
    d = np.linalg.norm(x[tip][:, None, [0, 2]] - x[lower][None, :, [0, 2]], axis=2)
    below = x[lower][d.argmin(axis=1), 1]
    assert (x[tip, 1] > below).all(), x[tip, 1] - below


@pytest.mark.parametrize("gravity", [0.0, 9.81])
def test_finer_fold_untangles(gravity):
    """The same fold at 61 x 41 (5 mm): the tip is threaded back over a few frames; also while
    the folded sheet falls freely under gravity."""
    doc = fold_shot(frames=7, k=2)
    doc["environment"]["gravity"] = [0.0, -gravity, 0.0]
    rows, _ = run(doc)
    assert rows[0][0] > 0
    assert_untangles(rows, within=4)


def test_fold_stays_tangled_without_gia():
    rows, _ = run(fold_shot(gia=False, frames=6))
    assert rows[0][0] > 0
    assert all(r[0] > 0 for r in rows), rows  # CCD holds the flap where it is
    assert all(r[1] == 0 and r[2] == 0 for r in rows)  # nothing analysed with GIA off


def test_sheet_pushed_partly_through_another_untangles():
    doc = two_sheets_shot()
    assert collision_switches(make_scene(doc))["gia"] == -1
    rows, x = run(doc)
    assert_untangles(rows, within=4)
    b = x[256:]
    assert b[:, 1].min() > x[:256, 1].max() - 1e-3  # B ends wholly above A (A is flat there)


def test_two_sheets_stay_tangled_without_gia():
    rows, _ = run(two_sheets_shot(gia=False, frames=6))
    assert all(r[0] > 0 for r in rows), rows


def test_clean_start_with_gia_forced_on_matches_gia_off_bitwise():
    """B dropped onto A under gravity: cloth/cloth contact, no intersection, nothing coloured."""
    finals = {}
    for gia in (True, False):
        doc = two_sheets_shot(pushed=False, gia=gia, frames=10, gravity=9.81)
        assert collision_switches(make_scene(doc))["gia"] == int(gia)
        rows, finals[gia] = run(doc)
        assert all(r == (0, 0, 0) for r in rows), rows
    assert np.array_equal(finals[True], finals[False])
    assert finals[True][256:, 1].min() < 0.005  # B fell onto A (contact was exercised)


def test_untangling_does_not_depend_on_the_thread_count():
    finals = [run(fold_shot(frames=4), threads=n)[1] for n in (1, 2)]
    assert np.array_equal(finals[0], finals[1])


def test_self_gia_telemetry_is_in_the_cache(tmp_path):
    summary = ShotRunner(make_scene(fold_shot(frames=3)), tmp_path / "fold.h5", threads=2).run()
    assert summary.status == "complete"
    with open_cache_reader(tmp_path / "fold.h5") as f:
        telemetry = f["telemetry"][()]
    assert {"gia_self_coloured_vertices", "gia_self_paths", "gia_seconds"} <= set(telemetry.dtype.names)
    assert telemetry["gia_self_coloured_vertices"][1] > 0 and telemetry["gia_self_paths"][1] > 0
    assert telemetry["gia_seconds"][1] > 0.0


def test_gia_switch_with_self_collision_and_no_bodies():
    doc = fold_shot(gia=True)
    assert collision_switches(make_scene(doc))["gia"] == 1
    doc["features"]["self_collision"] = False  # neither bodies nor self-collision: refused
    with pytest.raises(Exception, match="self-collision"):
        make_scene(doc)


def test_per_path_colouring_is_used_because_parity_fails_on_the_fold():
    """The step colours with BWK's per-path rule: on the fold, the lower layer's walls are a
    slit (both sides one region), which the parity colouring reads as an odd cycle."""
    start, faces, _ = folded_sheet(4 * R)
    r = _solver.intersection_analysis(start, faces.astype(np.int32))
    assert r["path_count"] >= 1
    colour = np.asarray(r["a"]["vertex_colour"])
    flap_tip = (start[:, 1] < 0.0)
    assert colour.sum() > 0 and colour[flap_tip].all()  # the pushed-through tip is coloured
    assert np.asarray(r["a"]["vertex_parity_colour"]).sum() == 0 and r["a"]["parity_conflicts"] > 0
