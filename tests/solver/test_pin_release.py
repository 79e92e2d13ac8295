"""Timed pin release and prescribed pin paths (issue 18), through the real solver."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenes.builders import sheet_shot
from weft.runner import ShotRunner
from weft.shot import ShotError, parse_shot
from weft.simulate import simulate
from weft.solver_setup import resolve_scene

CORNERS = [0, 7]  # a 8x8 sheet in the xz plane, held at two corners


def held_sheet(frames: int = 14, **pin: Any) -> dict[str, Any]:
    shot = sheet_shot("held", 8, 8, 0.4, 0.4, plane="xz", pins=CORNERS, frames=frames)
    shot["cloth"][0]["pins"] = [{"vertices": CORNERS, **pin}]
    return shot


def run(shot: dict[str, Any], tmp_path: Path) -> list[np.ndarray]:
    scene = resolve_scene(parse_shot(shot), tmp_path)
    return [np.array(sim.positions) for _, sim, _ in simulate(scene)]


def test_pins_hold_until_their_release_then_the_sheet_falls(tmp_path: Path) -> None:
    start = np.array(parse_shot(held_sheet()).cloth[0].mesh.vertices)[CORNERS]
    frames = run(held_sheet(release=0.25), tmp_path)  # 24 fps: frame index 7 starts at 0.25 s
    for index, x in enumerate(frames, start=1):
        if index <= 6:
            assert np.array_equal(x[CORNERS], start), index  # held exactly
    assert frames[6][CORNERS, 1].max() < start[:, 1].min() - 1e-4, "let go at the frame starting at 0.25 s"
    assert frames[-1][CORNERS, 1].max() < frames[6][CORNERS, 1].max(), "and falling"
    held = run(held_sheet(), tmp_path)
    assert np.array_equal(held[-1][CORNERS], start)


def test_a_resumed_run_releases_as_the_first_did(tmp_path: Path) -> None:
    scene = resolve_scene(parse_shot(held_sheet(release=0.25)), tmp_path)
    ShotRunner(scene, tmp_path / "straight.h5").run()
    ShotRunner(scene, tmp_path / "resumed.h5", frames=10).run()  # stopped after the release
    ShotRunner(scene, tmp_path / "resumed.h5", resume=True).run()
    import h5py

    with h5py.File(tmp_path / "straight.h5") as a, h5py.File(tmp_path / "resumed.h5") as b:
        assert np.array_equal(a["frames/positions"][()], b["frames/positions"][()])


def test_pins_follow_their_path_exactly_at_every_frame(tmp_path: Path) -> None:
    start = np.array(parse_shot(held_sheet()).cloth[0].mesh.vertices)[CORNERS]
    t = np.arange(14)[:, None, None] / 24.0
    path = start[None] + t * np.array([0.5, 0.2, 0.0])  # both corners move up and sideways
    frames = run(held_sheet(animation=path.tolist()), tmp_path)
    for index, x in enumerate(frames, start=1):
        assert np.allclose(x[CORNERS], path[index], rtol=0, atol=1e-12), index
    assert frames[-1][:, 0].mean() > 0.2 + 0.5 * 12 / 24  # the sheet was dragged along


def test_a_path_then_a_release(tmp_path: Path) -> None:
    start = np.array(parse_shot(held_sheet()).cloth[0].mesh.vertices)[CORNERS]
    path = start[None] + np.arange(14)[:, None, None] / 24.0 * np.array([0.0, 0.6, 0.0])
    frames = run(held_sheet(animation=path.tolist(), release=0.25), tmp_path)
    assert np.allclose(frames[5][CORNERS], path[6], atol=1e-12)  # lifted on the path ...
    assert frames[-1][CORNERS, 1].max() < path[13][:, 1].min()  # ... then dropped


@pytest.mark.parametrize(("pin", "field", "problem"), [
    ({"release": 5.0}, "cloth[0].pins[0].release", "after the shot's last frame"),
    ({"animation": np.zeros((3, 2, 3)).tolist()}, "cloth[0].pins[0].animation", "is not (14, 2, 3)"),
    ({"animation": np.zeros((14, 2, 3)).tolist()}, "cloth[0].pins[0].animation[0]", "from where the pinned vertices start"),
])
def test_bad_pins_name_the_field(tmp_path: Path, pin: dict[str, Any], field: str, problem: str) -> None:
    with pytest.raises(ShotError) as error:
        resolve_scene(parse_shot(held_sheet(**pin)), tmp_path)
    assert error.value.field == field and problem in str(error.value), str(error.value)


def test_a_pin_cannot_follow_a_body_and_a_path() -> None:
    shot = held_sheet(animation=np.zeros((14, 2, 3)).tolist(), body="hand")
    with pytest.raises(Exception, match="either a body or its own animation"):
        parse_shot(shot)


def sheet_on_a_block(gap: float, **body: Any) -> dict[str, Any]:
    """The held sheet with a block whose top is `gap` below its pinned corner 0 (at the origin)."""
    from scenes.builders import inline_mesh
    from scenes.collision import box_mesh

    shot = held_sheet()
    vertices, faces = box_mesh(extents=(0.1, 0.1, 0.1), centre=(0.0, -0.05 - gap, 0.0))
    shot["bodies"] = [{"name": "block", "mesh": inline_mesh(vertices, faces), **body}]
    shot["cloth"][0]["material"] = {"thickness": 0.002}
    return shot


def test_offsets_that_leave_no_room_are_refused(tmp_path: Path) -> None:
    """A pin 3 mm above a block: room for a 2 mm cloth, none once the block asks for 5 mm more."""
    resolve_scene(parse_shot(sheet_on_a_block(0.003)), tmp_path)  # 3 mm >= 2 mm
    resolve_scene(parse_shot(sheet_on_a_block(0.002)), tmp_path)  # exactly the thickness: room enough
    with pytest.raises(ShotError) as error:
        resolve_scene(parse_shot(sheet_on_a_block(0.003, collision_offset=0.005)), tmp_path)
    message = str(error.value)
    assert error.value.field == "cloth[0].pins[0]", message
    assert "'block'" in message and "7 mm" in message and "collision_offset 5 mm" in message, message
    assert "its vertex 0 is 3 mm away" in message, message
    # A body that does not collide, or a piece that does not, leaves the pin alone.
    resolve_scene(parse_shot(sheet_on_a_block(0.003, collision_offset=0.005, collide=False)), tmp_path)
    no_collision = sheet_on_a_block(0.003, collision_offset=0.005)
    no_collision["cloth"][0]["collide"] = False
    resolve_scene(parse_shot(no_collision), tmp_path)


def corner_path(drop: float, frames: int = 14) -> list:
    """Both pinned corners (0 at the origin, 7 at x = 0.4) moving straight down by `drop` over
    the shot, one position per keyframe."""
    start = np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]])
    steps = np.linspace(0.0, drop, frames)
    return (start[None] - steps[:, None, None] * np.array([0.0, 1.0, 0.0])).tolist()


def test_no_room_is_looked_for_at_every_frame_a_pin_holds(tmp_path: Path) -> None:
    """10 mm above the block at the first frame; a path that ends 1 mm above it, or a block that
    rises to 1 mm below the pin, leaves no room at a later frame; released first, it does."""
    resolve_scene(parse_shot(sheet_on_a_block(0.010)), tmp_path)
    lowered = sheet_on_a_block(0.010)
    lowered["cloth"][0]["pins"][0]["animation"] = corner_path(0.009)
    with pytest.raises(ShotError) as error:
        resolve_scene(parse_shot(lowered), tmp_path)
    message = str(error.value)
    assert error.value.field == "cloth[0].pins[0]" and "'block'" in message, message
    # The path crosses 2 mm (the thickness) 8/9 of the way down: keyframe 12 (frame 13).
    assert "its vertex 0 is 1.69 mm away at frame 13" in message, message
    lowered["cloth"][0]["pins"][0]["release"] = 0.4  # let go at frame 11 (0.417 s), before it gets there
    resolve_scene(parse_shot(lowered), tmp_path)

    from scenes.collision import box_mesh

    rising = sheet_on_a_block(0.010)
    vertices, _ = box_mesh(extents=(0.1, 0.1, 0.1), centre=(0.0, -0.05 - 0.010, 0.0))
    lift = np.linspace(0.0, 0.009, 14)[:, None, None] * np.array([0.0, 1.0, 0.0])
    np.save(tmp_path / "rise.npy", vertices[None] + lift)
    rising["bodies"][0]["animation"] = {"path": "rise.npy"}
    with pytest.raises(ShotError, match="its vertex 0 is 1.69 mm away at frame 13"):
        resolve_scene(parse_shot(rising), tmp_path)


def test_pin_room_distances_are_exact_below_the_reach_and_at_least_it_above() -> None:
    """distances_within (the pin-room check's pruned distances) against the full point-surface
    distance: equal where below the reach, at least the reach elsewhere."""
    from scenes.collision import sphere_mesh
    from weft.geometry import distances_within, surface_distance

    vertices, faces = sphere_mesh(0.3, subdivisions=3)
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(400, 3))
    points = directions / np.linalg.norm(directions, axis=1)[:, None] * rng.uniform(0.29, 0.33, size=(400, 1))
    reach = 0.01
    full = surface_distance(points, vertices, faces)
    pruned = distances_within(points, vertices, faces, reach)
    below = full < reach
    assert 50 < below.sum() < 350  # both kinds are present
    assert np.array_equal(pruned[below], full[below])
    assert np.all(pruned[~below] >= reach)
    assert np.all(np.isinf(distances_within(points + 5.0, vertices, faces, reach)))  # nothing in reach
