"""Pins: fixed vertices stay put; vertices attached to an animated body follow it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from scenes.builders import sheet_shot
from weft.cache import open_cache_reader
from weft.runner import ShotRunner
from weft.shot import load_shot_file
from weft.solver_setup import resolve_scene

from tests.helpers import make_sim

BOX_V = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], dtype=float)
BOX_F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]


def rotation_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def test_fixed_pins_hold_their_initial_positions() -> None:
    doc = sheet_shot("pinned", 6, 6, 0.3, 0.3, pins=[0, 5], frames=10, wind={"velocity": [0, 0, 3.0]},
                     air_drag=1.0)
    scene, sim = make_sim(doc)
    for k in range(20):
        sim.advance_frame(k / 24.0, 1.0 / 24.0, 4)
    assert np.abs(sim.positions[[0, 5]] - scene.positions[[0, 5]]).max() < 1e-12
    assert np.abs(sim.positions[1:5] - scene.positions[1:5]).max() > 1e-3  # the rest moved


def test_body_pins_follow_a_moving_rotating_body(tmp_path: Path) -> None:
    frames = 12
    angles = np.linspace(0.0, np.pi / 2, frames)
    shifts = np.linspace(0.0, 0.5, frames)
    anim = np.stack([BOX_V @ rotation_y(a).T + [s, 0.0, 0.0] for a, s in zip(angles, shifts)])
    np.savez(tmp_path / "box.npz", positions=anim)
    doc = sheet_shot("follow", 5, 5, 0.2, 0.2, frames=frames, substeps=3, origin=(0.02, 0.3, 0.03))
    doc["cloth"][0]["pins"] = [{"vertices": [0, 4], "body": "box"}]
    doc["bodies"] = [{"name": "box", "mesh": {"vertices": BOX_V.tolist(), "faces": BOX_F},
                      "animation": {"path": "box.npz"}}]
    shot_path = tmp_path / "shot.json"
    shot_path.write_text(json.dumps(doc))
    scene = resolve_scene(load_shot_file(shot_path), tmp_path)
    ShotRunner(scene, tmp_path / "out.h5").run()
    with open_cache_reader(tmp_path / "out.h5") as f:
        positions = f["frames/positions"][()].astype(np.float64)
    initial = scene.positions[[0, 4]]
    for k in (3, 7, frames - 1):
        # The body moves rigidly, so an attached point moves with the same rigid motion.
        expected = initial @ rotation_y(angles[k]).T + [shifts[k], 0.0, 0.0]
        assert np.abs(positions[k, [0, 4]] - expected).max() < 1e-5  # float32 cache
    assert np.abs(positions[-1, 0] - positions[0, 0]).max() > 0.3  # they really travelled
