"""A body mesh of several shells (weft.body_shells): the solver gets one body per shell, parts of
one character, so the cloth moves exactly as with the shells given as separate bodies; pins
follow the shell they are attached to; the shot's bodies are unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.builders import inline_mesh
from scenes.collision import box_mesh, drop_shot
from tests.helpers import make_scene
from weft.body_shells import SolverBody, mesh_shells, split_bodies
from weft.simulate import simulate
from weft.solver_setup import BodyArrays, build_setup, collision_switches, solver_pin_bodies


def two_boxes(gap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Two 0.3 m boxes side by side under the drop sheet: overlapping (gap < 0) or apart."""
    a, fa = box_mesh((0.3, 0.3, 0.3), (-0.15 - gap / 2, -0.3, 0.0))
    b, fb = box_mesh((0.3, 0.3, 0.3), (0.15 + gap / 2, -0.3, 0.0))
    return a, fa, b, fb


def merged(a, fa, b, fb) -> tuple[np.ndarray, np.ndarray]:
    return np.concatenate([a, b]), np.concatenate([fa, fb + len(a)])


def test_mesh_shells_and_split():
    a, fa, b, fb = two_boxes(-0.05)
    x, faces = merged(a, fa, b, fb)
    shells = mesh_shells(faces, len(x))
    assert [s.tolist() for s in shells] == [list(range(len(fa))), list(range(len(fa), len(faces)))]
    frames = np.stack([x, x + [0.0, 1.0, 0.0]])
    solver = split_bodies([BodyArrays("body", faces.astype(np.int32), frames)])
    assert [s.body for s in solver] == [0, 0]
    second = solver[1]
    assert second.vertices is not None and second.vertices.tolist() == list(range(len(a), len(x)))
    np.testing.assert_array_equal(second.faces, fb)  # renumbered to the shell's own vertices
    np.testing.assert_array_equal(second.frame([BodyArrays("body", faces, frames)], 1), b + [0.0, 1.0, 0.0])
    # One shell, or more shells than the limit: the body whole.
    whole = split_bodies([BodyArrays("box", fa.astype(np.int32), np.stack([a]))])
    assert whole == [SolverBody(0, None, whole[0].faces)]
    assert split_bodies([BodyArrays("body", faces.astype(np.int32), frames)], max_shells=1)[0].vertices is None
    assert mesh_shells(np.zeros((0, 3), dtype=np.int32), 0) == []


def shot(bodies: list[tuple[str, np.ndarray, np.ndarray]], frames: int = 10) -> dict:
    doc = drop_shot("box", n=10, frames=frames, substeps=2)
    doc["bodies"] = [{"name": name, "mesh": inline_mesh(x, f)} for name, x, f in bodies]
    return doc


def test_a_mesh_of_overlapping_shells_moves_the_cloth_as_its_parts_do():
    a, fa, b, fb = two_boxes(-0.05)  # overlapping 5 cm, as parts at a joint
    x, faces = merged(a, fa, b, fb)
    one = make_scene(shot([("body", x, faces)]))
    parts = make_scene(shot([("left", a, fa), ("right", b, fb)]))
    assert len(one.bodies) == 1 and len(one.solver_bodies) == 2  # the shot's bodies are unchanged
    switches = collision_switches(one)
    assert switches["body_group"][0] == switches["body_group"][1] >= 0  # one character
    assert switches["gia"] == collision_switches(parts)["gia"] == -1  # shells never switch body/body pinches on
    landed = 0
    for (_, sim_one, t_one), (_, sim_parts, _) in zip(simulate(one, threads=2), simulate(parts, threads=2)):
        np.testing.assert_array_equal(sim_one.positions, sim_parts.positions)
        assert t_one.intersections == 0 and t_one.gia_pinched_body_pairs == 0
        landed += int(np.sum(sim_one.positions[:, 1] < -0.14))
    assert landed > 0  # the sheet reached the boxes (tops at y = -0.15)


def test_a_pin_follows_the_shell_it_is_attached_to(tmp_path):
    # One body of two boxes apart; the right one rises 10 cm over the shot. A sheet corner near
    # each box is pinned to "body": each follows its own shell.
    a, fa, b, fb = two_boxes(0.3)
    x, faces = merged(a, fa, b, fb)
    frames = 6
    lift = np.linspace(0.0, 0.1, frames)
    animation = np.repeat(x[None], frames, axis=0)
    animation[:, len(a):, 1] += lift[:, None]
    doc = shot([("body", x, faces)], frames=frames)
    np.savez(tmp_path / "body.npz", positions=animation)
    doc["bodies"][0]["animation"] = {"path": "body.npz"}
    doc["features"] = {"collisions": False}
    cloth = np.asarray(doc["cloth"][0]["mesh"]["vertices"], dtype=float)
    left = int(np.argmin(np.linalg.norm(cloth - [-0.3, 0.0, 0.0], axis=1)))
    right = int(np.argmin(np.linalg.norm(cloth - [0.3, 0.0, 0.0], axis=1)))
    doc["cloth"][0]["pins"] = [{"vertices": [left, right], "body": "body"}]
    scene = make_scene(doc, tmp_path)
    assert solver_pin_bodies(scene).tolist() == [0, 1]
    build_setup(scene)  # the solver takes the shell indices
    start = scene.positions[[left, right]].copy()
    for _, sim, _ in simulate(scene, threads=1):
        pass
    moved = sim.positions[[left, right]] - start
    np.testing.assert_allclose(moved[0], 0.0, atol=1e-9)
    np.testing.assert_allclose(moved[1], [0.0, 0.1, 0.0], atol=1e-9)


@pytest.mark.parametrize("gap", [-0.05, 0.1])
def test_shells_keep_the_cloth_out_of_each(gap):
    # Overlapping or apart, the cloth rests on the shells with no vertex inside either.
    from weft import _solver

    a, fa, b, fb = two_boxes(gap)
    x, faces = merged(a, fa, b, fb)
    scene = make_scene(shot([("body", x, faces)], frames=16))
    for _, sim, t in simulate(scene, threads=2):
        assert t.intersections == 0
        for px, pf in ((a, fa), (b, fb)):
            assert not _solver.points_inside_closed_mesh(sim.positions, px, pf.astype(np.int32)).any()


def test_the_command_line_says_which_bodies_are_split(tmp_path):
    import json
    import subprocess
    import sys

    a, fa, b, fb = two_boxes(-0.05)
    x, faces = merged(a, fa, b, fb)
    doc = shot([("body", x, faces), ("left", a, fa)], frames=2)
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(doc))
    done = subprocess.run([sys.executable, "-m", "weft.cli", "validate", str(path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert "2 bodies" in done.stdout
    assert "bodies[0] 'body' is 2 separate shells" in done.stderr
    assert "bodies[1]" not in done.stderr  # one shell: as given


def test_mesh_shells_of_many_shuffled_shells():
    # 30 boxes in a row, the vertex numbering shuffled: 30 shells, each box's 12 faces.
    boxes = [box_mesh((0.1, 0.1, 0.1), (0.5 * k, 0.0, 0.0)) for k in range(30)]
    x = np.concatenate([v for v, _ in boxes])
    faces = np.concatenate([f + 8 * k for k, (_, f) in enumerate(boxes)])
    order = np.random.default_rng(3).permutation(len(x))
    renumber = np.argsort(order)
    shells = mesh_shells(renumber[faces], len(x))
    assert [s.tolist() for s in shells] == [list(range(12 * k, 12 * k + 12)) for k in range(30)]
