"""Body/body pinch states (docs/intersection-analysis.md, "Body/body pinch states"): kinematic
bodies that intersect each other pinch the cloth between them; CCD is off for that cloth, the
cloth squeezed into a body moves with it, and GIA recovers it once they open; the shot switch
turns GIA on when bodies meet at some frame."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.builders import inline_mesh, sheet_shot
from scenes.collision import box_mesh, box_pinch_shot
from weft import _solver
from weft.cache import open_cache_reader
from weft.runner import ShotRunner
from weft.simulate import simulate
from weft.solver_setup import bodies_intersect_each_other, build_setup, collision_switches

from tests.helpers import convex_depth, final_positions, make_scene

CLOSE, HOLD = 5, 6  # box_pinch_shot defaults
BOX_SPEED = (0.05 + 0.003) / CLOSE * 24.0  # the upper box's speed while it moves, m/s (0.25)
# While the boxes stay closed they do not move: cloth at rest on them moves at most by the
# small proximity/gravity cycle of resting contact (about 0.1 m/s in the frames before the
# pinch). Twice the speed the box had is a generous bound that a jitter of one thickness per
# substep (0.002 m * 96 = 0.19 m/s) plus that cycle stays under and a push out of a body does not.
SPEED_BOUND = 2.0 * BOX_SPEED
PINCH_FRAMES = range(CLOSE, 2 * CLOSE + HOLD - 3)  # 5..12: some substep not free
CLOSED_FRAMES = range(CLOSE + 1, CLOSE + HOLD + 1)  # 6..11: the boxes do not move


def summary(rows: list[dict], label: str) -> str:
    after = [r for r in rows if r["frame"] >= max(PINCH_FRAMES)]
    return (f"{label}: max vertex speed closed frames {max(r['speed'] for r in rows if r['frame'] in CLOSED_FRAMES):.3f} "
            f"m/s, pinch frames {max(r['speed'] for r in rows if r['frame'] in PINCH_FRAMES):.3f} m/s; after opening: "
            f"intersections {sorted({r['intersections'] for r in after})}, inside {sorted({tuple(r['inside']) for r in after})}, "
            f"max speed {max(r['speed'] for r in after):.3f} m/s; inside the lower box while closed "
            f"{[r['inside'][0] for r in rows if r['frame'] in CLOSED_FRAMES]}")


def run_pinch(tmp_path, body_pinch: bool = True, depth: float = 0.003, thickness: float | None = None,
              **shape: int) -> list[dict]:
    doc = box_pinch_shot(tmp_path, depth=depth, **shape)
    if thickness is not None:
        doc["cloth"][0]["material"]["thickness"] = thickness
    scene = make_scene(doc, tmp_path)
    assert collision_switches(scene)["gia"] == 1  # auto: the boxes intersect at some frame
    setup = build_setup(scene, 2)
    setup.collision.body_pinch = body_pinch
    if not body_pinch:  # the control: the plain impulse stage, without its later safety nets
        setup.solver.max_substep_halvings = 0
        setup.collision.max_strain = 0.0
    rows = []
    for index, sim, t in simulate(scene, _solver.Simulation(setup)):
        x = sim.positions
        rows.append({
            "frame": index, "pairs": t.gia_pinched_body_pairs, "intersections": t.intersections,
            "speed": float(np.linalg.norm(sim.velocities, axis=1).max()),
            "inside": [int((convex_depth(x, body.frames[index], body.faces) < 0).sum()) for body in scene.bodies],
            "states": [p["state"] for p in sim.pinch_states()], "gripped": t.gia_gripped_vertices,
        })
    return rows


def test_cloth_pinched_between_two_boxes_does_not_jitter_and_recovers(tmp_path):
    rows = run_pinch(tmp_path)
    print(summary(rows, "pinch states on"))
    by_frame = {r["frame"]: r for r in rows}
    trace = [(r["frame"], r["pairs"], round(r["speed"], 3), r["intersections"], r["inside"]) for r in rows]
    # Telemetry: the pair is not free exactly in the frames where the boxes meet, stay closed or part.
    assert [r["frame"] for r in rows if r["pairs"] == 1] == list(PINCH_FRAMES), trace
    assert all(r["pairs"] == 0 for r in rows if r["frame"] not in PINCH_FRAMES), trace
    # Pair state over each frame's last substep: free before, becoming pinched within frame 5
    # (pinched over its last substep), pinched while closed, unpinched within frame 12.
    assert by_frame[CLOSE - 1]["states"] == ["free"]
    assert all(by_frame[f]["states"] == ["pinched"] for f in range(CLOSE, CLOSE + HOLD + 1))
    assert by_frame[max(PINCH_FRAMES)]["states"] == ["free"]
    # The cloth was squeezed: the upper box pushed part of it into the lower one.
    assert all(by_frame[f]["inside"][0] > 0 and by_frame[f]["intersections"] > 0 for f in CLOSED_FRAMES), trace
    # ... and held there: gripped by the lower box in every substep while closed.
    assert all(by_frame[f]["gripped"] >= 4 * by_frame[f]["inside"][0] for f in CLOSED_FRAMES), trace
    # No jitter while pinched.
    assert max(by_frame[f]["speed"] for f in CLOSED_FRAMES) < SPEED_BOUND, trace
    # Recovered once open: no intersection and no vertex inside either box, to the end.
    after = [r for r in rows if r["frame"] >= max(PINCH_FRAMES)]
    assert all(r["intersections"] == 0 and r["inside"] == [0, 0] for r in after), trace
    assert max(r["speed"] for r in after) < SPEED_BOUND, trace


def test_without_the_pinch_handling_the_squeezed_cloth_is_thrown(tmp_path):
    """The control: GIA on, pinch states off (and neither adaptive substepping nor the strain
    limit, which only soften the symptom). CCD and the impact zones cannot make the squeezed
    cloth collision-free: it is thrown far faster than the box moves while the boxes are closed.
    (It used to stay tangled after they opened too; since the cloth/body membrane also opens
    body faces on the contour, GIA recovers it once they open.)"""
    rows = run_pinch(tmp_path, body_pinch=False)
    print(summary(rows, "body_pinch = False"))
    trace = [(r["frame"], round(r["speed"], 3), r["intersections"]) for r in rows]
    assert all(r["pairs"] == 0 and r["states"] == [] and r["gripped"] == 0 for r in rows)
    assert max(r["speed"] for r in rows if r["frame"] in CLOSED_FRAMES) > 4 * SPEED_BOUND, trace


def test_a_deeper_pinch_cuts_the_cloth_with_the_rim_and_it_still_recovers(tmp_path):
    """6 mm interpenetration: the upper box's rim cuts cloth triangles (no vertex inside it)
    while CCD is off. Those faces keep no CCD against the box (CCD would lock the tangle), so
    three frames after the box lifts the cloth is free (two while contacts were dropped at every
    frame start; kept over frames, the cloth rests differently on the lower box before the pinch
    and the last 8 of ~100 cut triangle pairs take one frame more)."""
    rows = run_pinch(tmp_path, depth=0.006)
    print(summary(rows, "6 mm"))
    by_frame = {r["frame"]: r for r in rows}
    trace = [(r["frame"], r["pairs"], round(r["speed"], 3), r["intersections"], r["inside"]) for r in rows]
    assert [r["frame"] for r in rows if r["pairs"] == 1] == list(PINCH_FRAMES), trace
    assert max(by_frame[f]["speed"] for f in CLOSED_FRAMES) < SPEED_BOUND, trace
    assert by_frame[max(PINCH_FRAMES)]["intersections"] > 0 and by_frame[max(PINCH_FRAMES)]["inside"] == [0, 0]
    after = [r for r in rows if r["frame"] >= max(PINCH_FRAMES) + 3]
    assert all(r["intersections"] == 0 and r["inside"] == [0, 0] for r in after), trace


def test_a_cloth_edge_left_across_the_rising_boxs_corner_is_not_carried_up(tmp_path):
    """The regression box pinch (a 12 x 12 sheet) at a 2.14 mm thickness (1.07x the default):
    the parting boxes leave one cloth edge across the upper box's bottom corner, in through its
    front face and out through its bottom, no vertex inside, so nothing for GIA to colour. The
    pinch's proximity pairs along that edge pushed it with the box, and friction on the front
    face held it: four intersecting triangle pairs were carried 5 cm up to the last frame.
    GIA's recovery now pushes such an edge out of the corner and the proximity response leaves
    it alone (docs/intersection-analysis.md)."""
    rows = run_pinch(tmp_path, thickness=0.00214, n=12, after=2)
    trace = [(r["frame"], r["pairs"], r["intersections"], r["inside"]) for r in rows]
    by_frame = {r["frame"]: r for r in rows}
    assert all(by_frame[f]["intersections"] > 0 for f in CLOSED_FRAMES), trace  # the pinch happened
    after = [r for r in rows if r["frame"] >= max(PINCH_FRAMES)]
    assert all(r["intersections"] == 0 and r["inside"] == [0, 0] for r in after), trace


def test_pinch_telemetry_is_in_the_cache(tmp_path):
    scene = make_scene(box_pinch_shot(tmp_path, close=2, hold=2, after=1, travel=0.004), tmp_path)
    summary = ShotRunner(scene, tmp_path / "pinch.h5", threads=2).run()
    assert summary.status == "complete"
    with open_cache_reader(tmp_path / "pinch.h5") as f:
        telemetry = f["telemetry"][()]
    assert "gia_pinched_body_pairs" in telemetry.dtype.names
    assert telemetry["gia_pinched_body_pairs"].max() == 1 and telemetry["gia_pinched_body_pairs"][-1] == 0
    assert telemetry["gia_seconds"][1:].min() > 0.0


def _box(centre, size=0.2):
    return box_mesh((size, size, size), centre)


def test_two_boxes_moving_through_each_other_go_free_becoming_pinched_pinched_unpinched_free():
    va, fa = _box((0.0, 0.0, 0.0))
    vb, fb = _box((0.0, 0.0, 0.0), size=0.1)
    tracker = _solver.BodyPinchTracker([fa.astype(np.int32), fb.astype(np.int32)])
    # Box b moves along x from far left to far right, through box a: centre at these x.
    xs = [-0.5, -0.3, -0.16, -0.14, -0.12, 0.0, 0.12, 0.14, 0.16, 0.3]
    states, regions = [], []
    for x0, x1 in zip(xs, xs[1:]):
        out = tracker.update([va, vb + [x0, 0.0, 0.0]], [va, vb + [x1, 0.0, 0.0]])
        assert len(out) == 1 and (out[0]["a"], out[0]["b"]) == (0, 1)
        states.append(out[0]["state"])
        regions.append(out[0]["region"])
    # Surfaces cross while |x| < 0.15; at x = 0 b lies wholly inside a (no surface crossing):
    # still intersecting, by the inside test.
    assert states == ["free", "free", "becoming_pinched", "pinched", "pinched", "pinched", "pinched",
                      "becoming_unpinched", "free"]
    assert regions[0] is None and regions[-1] is None
    lo, hi = (np.asarray(v) for v in regions[2])  # x from -0.16 to -0.14: b's right part inside a
    assert lo[0] == pytest.approx(-0.1) and hi[0] == pytest.approx(-0.09)
    assert lo[1] == pytest.approx(-0.05) and hi[1] == pytest.approx(0.05)


def test_body_intersection_query():
    va, fa = _box((0.0, 0.0, 0.0))
    vb, fb = _box((0.2, 0.0, 0.0), size=0.1)  # 5 cm apart
    assert not _solver.body_intersection(va, fa, vb, fb)["intersecting"]
    assert _solver.body_intersection(va, fa, vb, fb)["region"] is None
    r = _solver.body_intersection(va, fa, vb - [0.06, 0.0, 0.0], fb)  # 1 cm overlap
    assert r["intersecting"] and r["hits"] > 0 and r["paths"] == 1
    lo, hi = (np.asarray(v) for v in r["region"])  # the overlap slab's box
    assert lo == pytest.approx([0.09, -0.05, -0.05]) and hi == pytest.approx([0.1, 0.05, 0.05])
    inner_v, inner_f = _box((0.0, 0.0, 0.0), size=0.05)
    nested = _solver.body_intersection(va, fa, inner_v, inner_f)
    assert nested["intersecting"] and nested["hits"] == 0  # wholly inside: volumes intersect


def _two_box_shot(tmp_path, gap_at_closest: float) -> dict:
    """A sheet far above two boxes; the second box slides towards the first and back, its
    closest approach `gap_at_closest` (negative: overlap) at one middle frame only."""
    doc = sheet_shot("two_boxes", 4, 4, 0.2, 0.2, plane="xz", origin=(-0.1, 1.0, -0.1), frames=9, substeps=1)
    va, fa = _box((0.0, 0.0, 0.0))
    vb, fb = _box((0.5, 0.01, 0.0), size=0.15)  # 0.225 m from a
    closest = 0.325 - gap_at_closest
    offsets = np.concatenate([np.linspace(0.0, closest, 5), np.linspace(closest, 0.0, 5)[1:]])
    frames = np.stack([vb - [d, 0.0, 0.0] for d in offsets])
    np.savez(tmp_path / "b.npz", positions=frames)
    doc["bodies"] = [{"name": "a", "mesh": inline_mesh(va, fa)},
                     {"name": "b", "mesh": inline_mesh(vb, fb), "animation": {"path": "b.npz"}}]
    return doc


def test_gia_switch_turns_on_when_bodies_meet_at_a_later_frame(tmp_path):
    meet = make_scene(_two_box_shot(tmp_path, -0.01), tmp_path)  # 1 cm overlap at frame 4 only
    assert bodies_intersect_each_other(meet)
    assert collision_switches(meet)["gia"] == 1
    apart = make_scene(_two_box_shot(tmp_path, 0.01), tmp_path)  # 1 cm apart at the closest
    assert not bodies_intersect_each_other(apart)
    assert collision_switches(apart)["gia"] == -1  # auto, and the clean cloth start ...
    sim = _solver.Simulation(build_setup(apart, 1))
    assert sim.pinch_states() == []  # ... resolves to off in the solver: no pinch tracking
    # Bodies that do not collide are not looked at.
    doc = _two_box_shot(tmp_path, -0.01)
    doc["bodies"][1]["collide"] = False
    assert collision_switches(make_scene(doc, tmp_path))["gia"] == -1
    doc = _two_box_shot(tmp_path, -0.01)
    doc["features"] = {"gia": False}
    assert collision_switches(make_scene(doc, tmp_path))["gia"] == 0


def test_pinch_does_not_depend_on_the_thread_count(tmp_path):
    scene = make_scene(box_pinch_shot(tmp_path, close=2, hold=2, after=1, travel=0.004), tmp_path)
    assert np.array_equal(final_positions(scene, threads=1), final_positions(scene, threads=2))
