"""Collisions in the step: sheets dropped on a sphere and a box, a thin fast bar through hanging
cloth, a sheet twisted by a full turn, a sheet folding onto itself on a floor; the shot's
collision switches; the exact intersection counter."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.builders import grid_sheet, sheet_shot
from scenes.collision import drop_shot, floor_fold_shot, thin_bar_shot, twist_shot
from weft import _solver
from weft import simulate as frame_loop
from weft.solver_setup import build_setup, collision_switches

from tests.helpers import convex_depth, final_positions, make_scene, make_sim, simulate


@pytest.mark.parametrize("body", ["sphere", "box"])
def test_sheet_dropped_on_body_comes_to_rest_outside_without_intersections(body):
    doc = drop_shot(body, n=16, frames=36, substeps=4)
    vertices = np.asarray(doc["bodies"][0]["mesh"]["vertices"])
    faces = np.asarray(doc["bodies"][0]["mesh"]["faces"])
    peak = 0.0
    for index, sim, t in simulate(doc):
        assert t.intersections == 0, f"frame {index}: {t.intersections} intersecting triangle pairs"
        assert t.unresolved_collisions == 0
        assert convex_depth(sim.positions, vertices, faces).min() > 0.0, f"frame {index}: a vertex is inside"
        peak = max(peak, t.kinetic_energy)
    x = sim.positions
    assert x[:, 1].min() < 0.0  # draped over the body, not stuck above it
    assert t.kinetic_energy < 0.05 * peak, f"still moving: {t.kinetic_energy} J (peak {peak} J)"
    assert t.ccd_candidates > 0 and t.proximity_pairs > 0


def test_thin_fast_bar_does_not_tunnel_through_hanging_cloth(tmp_path):
    doc = thin_bar_shot(tmp_path, n=16, frames=7, substeps=4)
    hits = 0
    for index, sim, t in simulate(doc, tmp_path):
        assert t.intersections == 0, f"frame {index}: {t.intersections} intersecting triangle pairs"
        hits += t.ccd_hits
    # The bar (5 mm radius, 0.5 m per frame, 0.125 m per substep) crossed z = 0 in frame 3 and
    # stopped at z = 0.9: cloth caught by it was carried along instead of being passed through.
    assert sim.positions[:, 2].max() > 0.6
    assert hits > 0


def test_twist_by_a_full_turn_keeps_zero_self_intersections(tmp_path):
    doc = twist_shot(tmp_path, n=12, frames=121, substeps=2)
    contacts = 0
    for index, sim, t in simulate(doc, tmp_path):
        assert t.intersections == 0, f"frame {index}: {t.intersections} self-intersecting triangle pairs"
        contacts += t.ccd_hits + t.proximity_pairs
    assert sim.count_intersections() == 0
    assert contacts > 100  # the twist really pressed the cloth onto itself


def test_sheet_folding_onto_itself_on_a_floor_stays_free_of_self_intersection():
    doc = floor_fold_shot(n=14, frames=36, substeps=4)
    contacts = 0
    for index, sim, t in simulate(doc):
        assert t.intersections == 0, f"frame {index}: {t.intersections} intersecting triangle pairs"
        assert sim.positions[:, 1].min() > 0.0
        contacts += t.ccd_hits + t.proximity_pairs
    assert sim.positions[:, 1].max() < 0.3  # down on the floor, folded
    assert contacts > 0


def test_collision_switches_and_defaults():
    flag = make_scene(sheet_shot("flag", 4, 4, 1.0, 1.0))
    assert collision_switches(flag)["enabled"] is False  # no bodies, one piece: nothing to pay
    assert _solver.Simulation(build_setup(flag)).collisions_enabled is False

    doc = drop_shot("box", n=4, frames=2)
    on = collision_switches(make_scene(doc))
    assert on["enabled"] and on["ccd"] and on["piece_collide"] == [True] and on["piece_self_collide"] == [True]
    doc["features"] = {"collisions": False, "self_collision": False}
    assert collision_switches(make_scene(doc))["enabled"] is False
    doc["features"] = {"ccd": False}
    doc["cloth"][0]["self_collide"] = False
    doc["bodies"][0]["collide"] = True
    s = collision_switches(make_scene(doc))
    assert s["enabled"] and not s["ccd"] and s["piece_self_collide"] == [False]
    doc["bodies"][0]["collide"] = False
    assert collision_switches(make_scene(doc))["enabled"] is False
    setup = build_setup(make_scene(drop_shot("box", n=4, frames=2)))
    assert setup.collision.enabled and len(setup.collision.face_collide) == 18
    assert np.allclose(setup.collision.face_thickness, 0.002)


def test_exact_intersection_counter():
    a = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    through = np.array([[0.2, 0.2, -1.0], [0.2, 0.2, 1.0], [0.3, 0.5, 0.0]])
    assert _solver.triangles_intersect(a, through)
    assert not _solver.triangles_intersect(a, through + [0.0, 0.0, 1.5])
    assert _solver.triangles_intersect(a, a + [0.2, 0.2, 0.0])  # coplanar overlap
    assert not _solver.triangles_intersect(a, a + [2.0, 0.0, 0.0])
    touching = np.array([[0.5, 0.5, 0.0], [0.5, 0.5, 1.0], [1.0, 1.0, 1.0]])  # vertex on the hypotenuse
    assert _solver.triangles_intersect(a, touching)
    assert not _solver.triangles_intersect(a, touching + [1e-15, 0.0, 0.0])  # exact: just off

    x, f = grid_sheet(6, 6, 1.0, 1.0, "xz")
    assert _solver.count_self_intersections(x, f.astype(np.int32)) == 0
    folded = x.copy()
    folded[:, 1] = np.where(x[:, 0] > 0.5, 0.3 * (x[:, 0] - 0.5), 0.0)
    assert _solver.count_self_intersections(folded, f.astype(np.int32)) == 0
    # Push one vertex of the flat sheet down through a second layer placed just below.
    layer = x + [0.1, -0.01, 0.1]
    assert _solver.count_mesh_intersections(x, f.astype(np.int32), layer, f.astype(np.int32)) == 0
    poked = x.copy()
    poked[14, 1] = -0.05
    assert _solver.count_mesh_intersections(poked, f.astype(np.int32), layer, f.astype(np.int32)) > 0


def test_collision_telemetry_reaches_the_cache(tmp_path):
    import h5py

    from weft.runner import ShotRunner

    scene = make_scene(drop_shot("box", n=8, frames=8, substeps=2))
    summary = ShotRunner(scene, tmp_path / "drop.h5", threads=1).run()
    assert summary.status == "complete"
    with h5py.File(tmp_path / "drop.h5", "r") as f:
        t = f["telemetry"][()]
    simulated = t[t["substeps"] > 0]
    assert np.all(simulated["intersections"] == 0)
    # Falling flat, far above the box: no candidate at all (a flat sheet cannot touch itself:
    # normal-cone culling); resting on it at the end: candidates.
    assert simulated["ccd_candidates"][0] == 0 and simulated["ccd_candidates"][-1] > 0
    # weft info shows what each collision part cost and the counts.
    from weft.cache import describe_cache

    info = describe_cache(tmp_path / "drop.h5")
    assert info["mean_collision_seconds_per_frame"]["broad_phase"] > 0.0
    assert info["mean_collision_counts_per_frame"]["broad_phase_pairs"] > 0.0
    parts = sum(simulated[k] for k in ("collision_broad_phase_seconds", "collision_proximity_seconds",
                                       "collision_ccd_seconds", "collision_response_seconds"))
    assert np.all(parts <= simulated["collision_seconds"] + 1e-12)


@pytest.mark.parametrize("self_collision", [True, False])
def test_feature_costs_are_parts_of_their_stages(tmp_path, self_collision):
    """A sheet folding onto itself on a floor: self-collision's broad-phase work and the search
    for the contacts held in the solve are reported per frame, each within its stage's time;
    with self-collision off it costs nothing, and `weft info` shows the features' costs."""
    import h5py

    from weft.cache import describe_cache
    from weft.runner import ShotRunner

    doc = floor_fold_shot(n=10, frames=10)
    doc["features"] = {"self_collision": self_collision}
    summary = ShotRunner(make_scene(doc), tmp_path / "fold.h5", threads=2).run()
    assert summary.status == "complete"
    with h5py.File(tmp_path / "fold.h5", "r") as f:
        t = f["telemetry"][()]
    t = t[t["substeps"] > 0]
    assert np.all(t["self_collision_seconds"] <= t["collision_broad_phase_seconds"])
    assert np.all(t["contact_constraints_seconds"] <= t["collision_proximity_seconds"])
    assert (t["self_collision_seconds"].sum() > 0.0) == self_collision
    # The sheet lands on the floor: contacts are held in the solve from then on.
    assert t["contact_constraints"][-1] > 0 and t["contact_constraints_seconds"][-1] > 0.0
    features = describe_cache(tmp_path / "fold.h5")["mean_feature_seconds_per_frame"]
    assert set(features) == {"self_collision", "contact_constraints", "gia"}
    assert features["self_collision"] == pytest.approx(float(np.mean(t["self_collision_seconds"])))


def test_ccd_single_and_batch_agree():
    rng = np.random.default_rng(3)
    start = rng.normal(size=(200, 4, 3))
    end = start + rng.normal(scale=0.5, size=(200, 4, 3))
    for single, batch in ((_solver.vertex_triangle_ccd, _solver.vertex_triangle_ccd_batch),
                          (_solver.edge_edge_ccd, _solver.edge_edge_ccd_batch)):
        hit, toi, _ = batch(start, end)
        for k in range(len(start)):
            assert single(start[k], end[k]) == (bool(hit[k]), float(toi[k]))
    with pytest.raises(ValueError):
        _solver.vertex_triangle_ccd_batch(start[:, :3], end[:, :3])


def test_collision_stage_is_bitwise_reproducible_across_thread_counts():
    scene = make_scene(drop_shot("box", n=10, frames=10, substeps=2))
    assert np.array_equal(final_positions(scene, threads=1), final_positions(scene, threads=2))


def test_parallel_collision_stage_at_size_is_bitwise_the_serial_one():
    """Large enough that every parallel part of the stage splits its work (tree tasks, chunks of
    triangle pairs, proximity distances over 2048 pairs, counting over several chunks of 1024
    candidates): a sheet of 48 x 48 vertices with self-collision draping on the sphere, 1
    against 3 threads."""
    doc = drop_shot("sphere", n=48, frames=9, substeps=2)
    doc["features"] = {"self_collision": True}
    scene = make_scene(doc)
    serial = list(frame_loop.simulate(scene, threads=1))
    parallel = list(frame_loop.simulate(scene, threads=3))
    assert sum(t.proximity_pairs for _, _, t in serial) > 0  # it did reach the sphere
    assert np.array_equal(serial[-1][1].positions, parallel[-1][1].positions)
    for (_, _, a), (_, _, b) in zip(serial, parallel):
        assert (a.broad_phase_pairs, a.ccd_candidates, a.intersections) == (
            b.broad_phase_pairs, b.ccd_candidates, b.intersections)


def test_contact_constraints_in_the_solve_keep_the_sheet_outside():
    doc = drop_shot("sphere", n=12, frames=20, substeps=4)
    scene = make_scene(doc)
    setup = build_setup(scene, 2)
    settings = setup.collision
    settings.contact_constraints = True
    setup.collision = settings
    vertices = np.asarray(doc["bodies"][0]["mesh"]["vertices"])
    faces = np.asarray(doc["bodies"][0]["mesh"]["faces"])
    for index, sim, t in frame_loop.simulate(scene, _solver.Simulation(setup)):
        assert t.intersections == 0
        assert convex_depth(sim.positions, vertices, faces).min() > 0.0
    assert sim.positions[:, 1].min() < 0.0


@pytest.mark.parametrize("threads", [1, 2])
def test_culled_intersection_count_equals_the_all_pairs_count(threads):
    """The frame-end count runs over the broad phase's trees with self-culling; on a crumpled
    sheet cut by the sphere it finds exactly what the all-pairs counter finds, for any thread
    count, and the flat sheet (every node culled) still counts zero."""
    doc = drop_shot("sphere", n=24, frames=2)
    doc["features"] = {"self_collision": True, "gia": False}
    scene, sim = make_sim(doc, threads)
    body_x = np.asarray(doc["bodies"][0]["mesh"]["vertices"], dtype=np.float64)
    body_f = np.asarray(doc["bodies"][0]["mesh"]["faces"], dtype=np.int32)
    faces = np.asarray(scene.faces, dtype=np.int32)
    assert sim.count_intersections() == 0
    rng = np.random.default_rng(7)
    x = scene.positions.copy()
    x[:, 1] = 0.1 + 0.05 * np.sin(9.0 * x[:, 0]) * np.cos(7.0 * x[:, 2])
    x += rng.normal(scale=0.03, size=x.shape)  # folds through itself (edges are ~4 cm)
    sim.set_state(x, np.zeros_like(x), np.zeros(0))
    expected_self = _solver.count_self_intersections(x, faces)
    expected_body = _solver.count_mesh_intersections(x, faces, body_x, body_f)
    assert expected_self > 0 and expected_body > 0
    assert sim.count_intersections() == expected_self + expected_body


def test_contact_flags_carry_over_frames_and_are_checked_when_restored():
    # Contacts the constraints hold at a frame's end stay held into the next frame (a frame
    # boundary is no event for resting cloth); set_state restores them and refuses bad ones.
    doc = drop_shot("sphere", n=12, frames=12)
    scene, sim = make_sim(doc, 1)
    assert len(sim.contact_flags) == 0  # nothing decided before the first step
    for index in range(1, 11):
        frame_loop.advance(sim, scene, index)
    flags = np.array(sim.contact_flags)
    assert flags.shape == (scene.vertex_count,) and flags.dtype == np.uint8
    # 1 held, 2 released, 3 held and sticking (friction stopped it on the sphere)
    assert set(np.unique(flags)) <= {0, 1, 2, 3} and np.count_nonzero(flags == 3) > 0
    x, v, warm = np.array(sim.positions), np.array(sim.velocities), np.array(sim.warm_start)
    with pytest.raises(ValueError, match="contact_flags entries must be 0"):
        sim.set_state(x, v, warm, np.full(scene.vertex_count, 4, dtype=np.uint8))
    with pytest.raises(ValueError, match="contact_flags must be empty or have one entry per vertex"):
        sim.set_state(x, v, warm, np.ones(scene.vertex_count + 1, dtype=np.uint8))
    assert np.array_equal(np.array(sim.contact_flags), flags)  # a refused state changes nothing
    sim.set_state(x, v, warm, np.zeros(0, dtype=np.uint8))
    assert len(sim.contact_flags) == 0
