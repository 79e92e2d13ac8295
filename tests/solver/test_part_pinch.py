"""Pinches between parts of one character (docs/intersection-analysis.md, "Parts of one
character closing on cloth"): a part whose surface passes closer to another part than the
cloth can lie between them (an arm along the torso) squeezes the cloth there. CCD gives way to
the smaller part only, so the cloth stays on the larger one and the smaller passes over it; the
rest of the garment keeps its contact constraints; once the part has passed, the cloth is free
of both."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.collision import part_sweep_shot
from weft import _solver
from weft.simulate import simulate
from weft.solver_setup import build_setup, collision_switches

from tests.helpers import convex_depth, make_scene

SWEEP, AFTER = 36, 6  # part_sweep_shot defaults


def run_sweep(tmp_path, part_pinch: bool = True, threads: int = 2, substeps: int = 4,
              local_aside: bool = True, thickness: float | None = None) -> list[dict]:
    shot = part_sweep_shot(tmp_path, substeps=substeps)
    if thickness is not None:
        for cloth in shot["cloth"]:
            cloth["material"]["thickness"] = thickness
    scene = make_scene(shot, tmp_path)
    switches = collision_switches(scene)
    assert switches["gia"] == -1 and len(set(switches["body_group"])) == 1  # one character, GIA auto
    setup = build_setup(scene, threads)
    setup.collision.part_pinch = part_pinch
    setup.collision.local_aside = local_aside
    rows = []
    for index, sim, t in simulate(scene, _solver.Simulation(setup)):
        x = sim.positions
        rows.append({
            "frame": index, "parts": t.gia_pinched_part_pairs, "bodies": t.gia_pinched_body_pairs,
            "intersections": t.intersections, "zones": t.impact_zones, "unresolved": t.unresolved_collisions,
            "substeps": t.substeps, "strain": t.max_edge_strain, "lowest": float(x[:, 1].min()),
            "constraints": t.contact_constraints,
            "inside": [int((convex_depth(x, body.frames[index], body.faces) < 0).sum()) for body in scene.bodies],
            "positions": np.array(x),
        })
    return rows


def trace(rows: list[dict]) -> list[tuple]:
    return [(r["frame"], r["parts"], r["intersections"], r["inside"], r["zones"], r["unresolved"], r["substeps"],
             round(r["strain"], 2), round(r["lowest"], 4)) for r in rows]


# The squeeze's largest strain is a draw of the solver's noise (a forced pinch: the strain
# bound does not hold there), so the sweep also runs with the cloth thickness (default 2 mm)
# scaled by 0.93 and 1.07, as `weft bench contact --perturb` does.
@pytest.mark.parametrize(("substeps", "thickness"), [(4, None), (4, 0.00186), (4, 0.00214), (16, None)])
def test_a_part_passing_over_squeezed_cloth_leaves_it_on_the_other_part(tmp_path, substeps, thickness):
    rows = run_sweep(tmp_path, substeps=substeps, thickness=thickness)
    t = trace(rows)
    pinched = [r["frame"] for r in rows if r["parts"] > 0]
    # Engaged while the arm rolls over the sheet (it starts 0.2 m off the sheet's edge and ends
    # 0.2 m beyond the other), never a body/body pinch.
    assert pinched and pinched == list(range(pinched[0], pinched[-1] + 1)), t
    assert 5 <= pinched[0] and pinched[-1] < SWEEP, t
    assert all(r["bodies"] == 0 for r in rows), t
    # The fail-safe has little to fight: nothing unresolved, no halved substep, and impact zones
    # (at most two per frame) only while the pinch squeezes the sheet. (None at all while contacts
    # were dropped at every frame start; kept over frames, with friction sticking inside the
    # solve, 16 substeps needed 1-2 zones in two of the pinched frames: docs/collisions.md,
    # twenty-third session.)
    assert all(r["unresolved"] == 0 and r["substeps"] == substeps for r in rows), t
    assert all(r["zones"] == 0 for r in rows if r["parts"] == 0) and max(r["zones"] for r in rows) <= 2, t
    # Never into the torso (CCD keeps it out); edges within the strain target outside the pinch,
    # and within 1.7 where the arm squeezes the sheet (a forced pinch; at 4 substeps over
    # thicknesses scaled by 0.93-1.07, the build of docs/collisions.md's thirty-first session
    # peaked at 1.42-1.63 there and at most 1.40 outside, the build before it at 1.42-2.72 and up
    # to 2.72 outside).
    assert all(r["inside"][0] == 0 for r in rows), t
    assert max(r["strain"] for r in rows if r["parts"] == 0) < 1.5, t
    assert max(r["strain"] for r in rows) < 1.7, t
    # Once the arm has passed, the cloth is free of both parts. (Whether the arm's friction
    # drags the squeezed sheet along, or the torso's holds it, is not decided by this scene:
    # both parts have the cloth's friction; at 4 substeps it stays on the block, at 16 it is
    # dragged off its edge, with or without part pinches.)
    assert all(r["intersections"] == 0 and r["inside"] == [0, 0] for r in rows if r["frame"] > pinched[-1]), t


def test_without_part_pinches_the_fail_safe_fights(tmp_path):
    rows = run_sweep(tmp_path, part_pinch=False)
    t = trace(rows)
    assert all(r["parts"] == 0 for r in rows), t
    assert sum(r["zones"] for r in rows) > 0 and max(r["substeps"] for r in rows) > 4, t


def test_contacts_stay_on_away_from_an_engaged_part_pinch(tmp_path):
    # With the pinch engaged, the cloth outside its region keeps its contact constraints; set
    # aside everywhere (local_aside off, as for a body/body pinch) none act in those frames.
    local = run_sweep(tmp_path / "local")
    everywhere = run_sweep(tmp_path / "everywhere", local_aside=False)
    for rows, held in ((local, True), (everywhere, False)):
        # The first engaged frame starts clean, and the pinch may end within the last one: the
        # frames between are engaged at every substep.
        engaged = [r for r in rows if r["parts"] > 0][1:-1]
        assert engaged, trace(rows)
        assert (sum(r["constraints"] for r in engaged) > 0) == held, trace(rows)


def test_part_pinches_give_the_same_result_on_any_thread_count(tmp_path):
    two = run_sweep(tmp_path / "two", threads=2)
    one = run_sweep(tmp_path / "one", threads=1)
    assert len(one) == len(two) == SWEEP + AFTER
    assert all(np.array_equal(a["positions"], b["positions"]) for a, b in zip(one, two))
