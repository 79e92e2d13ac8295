"""Contact that scales (issue 12): contact constraints inside the solve hold resting cloth so CCD
has nothing left to do, articulated characters (closed parts overlapping at joints) are not
pinches and keep a tight garment outside every part, and the per-frame strain telemetry."""

from __future__ import annotations

import numpy as np

from bench.contact import build_scene
from scenes.builders import inline_mesh, sheet_shot
from scenes.collision import box_mesh, drop_shot
from scenes.contact import thin_limb
from scenes.gia import two_sheets_shot
from tests.helpers import make_scene
from weft import _solver
from weft.simulate import new_simulation, simulate
from weft.solver_setup import body_groups, build_setup, collision_switches


def run(scene, contact_constraints: bool = True):
    setup = build_setup(scene, 2)
    setup.collision.contact_constraints = contact_constraints
    sim = _solver.Simulation(setup)
    return sim, [t for _, _, t in simulate(scene, sim)]


def table_shot() -> dict:
    """A 1 m sheet released 1 cm above a 2 m table (a box whose top is at y = 0.25)."""
    doc = sheet_shot("rest", 12, 12, 1.0, 1.0, plane="xz", origin=(-0.5, 0.26, -0.5), frames=24, substeps=2,
                     material={"friction": 0.5, "damping": 0.01})
    vertices, faces = box_mesh((2.0, 0.5, 2.0))
    doc["bodies"] = [{"name": "table", "mesh": inline_mesh(vertices, faces)}]
    return doc


def test_resting_contact_is_held_without_ccd_repairs():
    scene = make_scene(table_shot())
    sim_on, on = run(scene, True)
    sim_off, off = run(scene, False)
    # Landing, the approaching cloth is caught by contact constraints inside the solve; resting,
    # nothing is left for CCD, where the impulse-only stage repairs some pair every frame.
    assert sum(t.contact_constraints for t in on) > 100
    assert sum(t.ccd_hits for t in on[-8:]) == 0
    assert sum(t.ccd_hits for t in off[-8:]) > 0
    for sim, frames in ((sim_on, on), (sim_off, off)):
        assert all(t.intersections == 0 for t in frames)
        assert sim.energies().kinetic < 1e-3  # at rest, not jittering
        gap = sim.positions[:, 1] - 0.25
        assert gap.min() > 0.0 and gap.max() <= 0.002 + 1e-9  # on the table, within the thickness


def test_contacts_that_pull_are_released():
    # The sheet drops onto a box smaller than itself: where it drapes over the edges the
    # hanging cloth pulls the constrained vertices off the top, and those contacts let go.
    scene = make_scene(drop_shot("box", n=12, frames=20, substeps=2))
    _, frames = run(scene, True)
    constrained = sum(t.contact_constraints for t in frames)
    released = sum(t.released_contacts for t in frames)
    assert constrained > 0 and 0 < released < constrained
    assert all(t.intersections == 0 for t in frames)


def test_overlapping_parts_of_one_character_are_one_group_and_never_pinch(tmp_path):
    scene = build_scene("articulated_dress", tmp_path, 6)
    switches = collision_switches(scene)
    groups = switches["body_group"]
    assert len(set(groups)) == 1 and groups[0] >= 0  # all 14 parts overlap into one character
    assert switches["gia"] == -1  # their overlap adds no body/body pinch tracking
    parts = [(b.frames, b.faces) for b in scene.bodies]
    sim = new_simulation(scene, 2)
    for index, sim, t in simulate(scene, sim):
        assert t.gia_pinched_body_pairs == 0
        x = sim.positions
        inside = sum(int(_solver.points_inside_closed_mesh(x, frames[index], faces).sum()) for frames, faces in parts)
        assert inside == 0, f"frame {index}: {inside} dress vertices inside the body"
        assert t.intersections == 0


def test_explicit_groups_and_separate_bodies(tmp_path):
    doc = drop_shot("box", n=6, frames=3)
    a, fa = box_mesh((0.2, 0.2, 0.2), (0.0, -0.5, 0.0))
    b, fb = box_mesh((0.2, 0.2, 0.2), (0.15, -0.5, 0.0))  # overlaps a
    c, fc = box_mesh((0.2, 0.2, 0.2), (2.0, -0.5, 0.0))   # apart
    doc["bodies"] += [{"name": "a", "mesh": inline_mesh(a, fa)}, {"name": "b", "mesh": inline_mesh(b, fb)},
                      {"name": "c", "mesh": inline_mesh(c, fc)}]
    scene = make_scene(doc)
    collide = [True] * 4
    groups = body_groups(scene, collide)
    assert groups[1] == groups[2] >= 0 and groups[3] == -1 and groups[0] == -1
    doc["bodies"][0]["group"] = "rig"
    doc["bodies"][3]["group"] = "rig"
    groups = body_groups(make_scene(doc), collide)
    assert groups[0] == groups[3] >= 0 and groups[0] != groups[1]


def test_a_body_that_does_not_collide_switches_nothing_on():
    doc = sheet_shot("flag", 6, 6, 1.0, 1.0, frames=2)
    a, fa = box_mesh()
    doc["bodies"] = [{"name": "prop", "mesh": inline_mesh(a, fa), "collide": False}]
    switches = collision_switches(make_scene(doc))
    assert switches["enabled"] is False and switches["piece_self_collide"] == [False]
    doc["bodies"][0]["collide"] = True
    assert collision_switches(make_scene(doc))["enabled"] is True


def test_max_edge_strain_is_reported_against_the_rest_shape():
    # Every vertex pinned where it starts, rest shape 10% smaller: strain 1 / 0.9 exactly.
    doc = sheet_shot("held", 5, 5, 1.0, 1.0, frames=2)
    x = np.asarray(doc["cloth"][0]["mesh"]["vertices"], dtype=float)
    centre = x.mean(axis=0)
    doc["cloth"][0]["rest"] = {"kind": "positions", "positions": (centre + 0.9 * (x - centre)).tolist()}
    doc["cloth"][0]["pins"] = [{"vertices": list(range(len(x)))}]
    _, frames = run(make_scene(doc), True)
    assert abs(frames[-1].max_edge_strain - 1.0 / 0.9) < 1e-9


def test_a_body_collision_offset_keeps_the_cloth_farther_away():
    """Per-body collision_offset (issue 18): the cloth rests at its thickness plus the body's
    offset, on that body only."""
    def rest_gap(offset: float) -> np.ndarray:
        doc = table_shot()
        doc["cloth"][0]["mesh"]["vertices"] = [[x, y + offset, z] for x, y, z in doc["cloth"][0]["mesh"]["vertices"]]
        doc["bodies"][0]["collision_offset"] = offset
        sim, frames = run(make_scene(doc))
        assert all(t.intersections == 0 for t in frames)
        assert sim.energies().kinetic < 1e-3
        return sim.positions[:, 1] - 0.25

    plain, offset = rest_gap(0.0), rest_gap(0.01)
    assert plain.max() <= 0.002 + 1e-9
    assert offset.min() > 0.01 and offset.max() < 0.015  # thickness 2 mm + offset 10 mm, a wrinkle or two
    assert abs(np.median(offset) - np.median(plain) - 0.01) < 5e-4


def tangled_sheets_on_a_table() -> dict:
    """`two_sheets_shot` (sheet B's end pushed through sheet A) under gravity, with a table under
    A's side away from B (its top 2.5 mm below A, x < -0.08 m; B spans x = -0.05..0.05 m)."""
    doc = two_sheets_shot(pushed=True, frames=4, gravity=9.81)
    vertices, faces = box_mesh((0.3, 0.1, 0.4), (-0.23, -0.0525, 0.0))
    doc["bodies"] = [{"name": "table", "mesh": inline_mesh(vertices, faces)}]
    return doc


def test_a_tangle_sets_aside_only_the_contacts_around_it(tmp_path):
    # While cloth/cloth GIA untangles B from A, the constraints near the tangle are left to the
    # impulses, and A keeps its contacts on the table away from it (local_aside); set aside
    # everywhere, the table holds no contact in the solve until the tangle is gone.
    scene = make_scene(tangled_sheets_on_a_table(), tmp_path)
    rows = {}
    for local in (True, False):
        setup = build_setup(scene, 2)
        setup.collision.local_aside = local
        sim = _solver.Simulation(setup)
        rows[local] = [(t.intersections, t.gia_self_coloured_vertices, t.contact_constraints)
                       for _, _, t in simulate(scene, sim)]
        x = sim.positions
        over = x[:, 0] < -0.08
        assert x[over, 1].min() > -0.0025, rows[local]  # nothing into the table
    for local in (True, False):
        assert rows[local][0][1] > 0, rows[local]  # tangled in the first frame
        assert rows[local][-1][0] == 0, rows[local]  # untangled within the shot
    assert rows[True][0][2] > 0 and rows[False][0][2] == 0, rows


def incline_run(friction: float, angle_degrees: float = 20.0, frames: int = 12) -> list[tuple[float, float]]:
    """A 0.6 m sheet landing on a table under gravity tilted by `angle_degrees` (an incline):
    per frame, the sheet's mean x (down the slope) and its elastic energy."""
    import math

    angle = math.radians(angle_degrees)
    doc = sheet_shot("incline", 12, 12, 0.6, 0.6, plane="xz", origin=(-0.3, 0.252, -0.3), frames=frames, substeps=2,
                     material={"friction": friction, "damping": 0.01},
                     gravity=(9.81 * math.sin(angle), -9.81 * math.cos(angle), 0.0))
    vertices, faces = box_mesh((2.0, 0.5, 2.0))
    doc["bodies"] = [{"name": "table", "mesh": inline_mesh(vertices, faces)}]
    scene = make_scene(doc)
    sim = _solver.Simulation(build_setup(scene, 2))
    rows = []
    for _, sim, t in simulate(scene, sim):
        assert t.intersections == 0
        rows.append((float(sim.positions[:, 0].mean()), sim.energies().elastic))
    return rows


def test_static_friction_holds_cloth_on_an_incline_and_kinetic_friction_lets_it_slide():
    # tan 20 deg = 0.36: friction 0.6 holds the sheet (static friction inside the solve), 0.1
    # does not, and the sheet slides at g (sin 20 - 0.1 cos 20) = 2.43 m/s^2 (Coulomb).
    held = incline_run(0.6)
    drift = [x - held[1][0] for x, _ in held[1:]]
    assert max(abs(d) for d in drift) < 1e-3, drift
    # Sticking adds no elastic energy (applied after the solve, friction stopping a vertex
    # whose neighbours moved as if it slid stretched the cloth a little more at every step).
    energies = [e for _, e in held]
    assert max(energies[3:]) <= energies[3] * 1.001, energies
    sliding = incline_run(0.1)
    x = [x for x, _ in sliding]
    acceleration = (x[-1] - 2 * x[-2] + x[-3]) * 24.0**2
    assert x[-1] > 0.2 and abs(acceleration - 2.43) < 0.25, (x, acceleration)


def test_a_fast_thin_limb_does_not_carry_the_sheet_it_sweeps_by_friction(tmp_path):
    """A limb 3 or 2 cm thick sweeping a hanging sheet at 3 m/s, friction 0.3: the sheet slides
    round it, and off once it stops, instead of being carried. Friction after the solve acts on a
    vertex alone; while it took the impact's share of a new contact's normal impulse and made
    vertices stopped from sliding at metres per second stick, the limb dragged them and edges
    reached 3.3x and 6.2x their rest length, the thinner limb's sheet still 6.2x after the limb
    stood (docs/collisions.md, twenty-fourth session). The largest strain on the way is the
    scene's chaos as much as the rules': over CG tolerances 1e-3 to 1e-5 and two builds it
    ranged 1.48-4.85 for the 3 cm limb and 1.54-5.94 for the 2 cm one, and at 1e-4 the 2 cm limb
    still carries the sheet (docs/collisions.md, twenty-fifth session; Known limits). At the
    default tolerance the bound below is the old rules' failure, not the halving's bound
    (`solver.max_step_strain`)."""
    for radius in (0.015, 0.01):
        directory = tmp_path / f"limb_{radius}"
        scene = make_scene(thin_limb(directory, frames=11, friction=0.3, limb_radius=radius), directory)
        _, rows = run(scene)
        strains = [t.max_edge_strain for t in rows]
        assert all(t.intersections == 0 for t in rows), radius
        assert max(strains) < 3.0, (radius, strains)
        assert strains[-1] < 1.1, (radius, strains)  # the limb stands from frame 6: the sheet hangs free


def test_friction_that_would_tear_an_edge_is_spread_through_the_sheet(tmp_path):
    """The 3 cm limb sweeping the hanging sheet: kinetic friction stops held vertices on the limb
    while their neighbours hang back. Where that would stretch an edge past the strain limit,
    the friction impulses go through the sheet's implicit response instead
    (`collision.spread_friction`, on by default), and the strain limit finds far fewer edges to
    pull back in that frame; switched off, no step spreads and the telemetry says so."""
    scene = make_scene(thin_limb(tmp_path, frames=5, friction=0.3), tmp_path)
    rows = {}
    for spread in (True, False):
        setup = build_setup(scene, 2)
        setup.collision.spread_friction = spread
        rows[spread] = [t for _, _, t in simulate(scene, _solver.Simulation(setup))]
    assert all(t.friction_spreads == 0 for t in rows[False])
    first = next(k for k, t in enumerate(rows[True]) if t.friction_spreads > 0)
    # Until then both runs are the same; in that frame the spread run's limit works far less.
    assert [t.max_edge_strain for t in rows[True][:first]] == [t.max_edge_strain for t in rows[False][:first]]
    assert rows[True][first].strain_limited_edges < 0.5 * rows[False][first].strain_limited_edges, (
        rows[True][first].strain_limited_edges, rows[False][first].strain_limited_edges)
    assert all(t.intersections == 0 for spread in rows for t in rows[spread])
