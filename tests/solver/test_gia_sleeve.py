"""A sleeve on a thin limb swung fast (a skeleton-like arm, scenes.collision.sleeve_shot):
the sleeve never ends a frame on the wrong side of the limb, with GIA on (its membrane must not
weaken CCD) and with the default switches. The limb rotates, so impact zones caught on it move
with its affine velocity field (docs/collisions.md)."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.collision import sleeve_shot, swing_angles
from weft import _solver

from tests.helpers import simulate

AROUND = 16  # sleeve vertices per ring (sleeve_shot)


def winding_about_limb(ring: np.ndarray, limb: np.ndarray) -> float:
    """How many times a closed ring of points turns about the limb's axis (the line through its
    two cap centres, the last two vertices of the tube mesh)."""
    a, b = limb[-2], limb[-1]
    axis = (b - a) / np.linalg.norm(b - a)
    u = np.cross(axis, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    d = ring - a
    angles = np.arctan2(d @ w, d @ u)
    steps = np.diff(np.append(angles, angles[0]))
    steps = (steps + np.pi) % (2 * np.pi) - np.pi
    return float(steps.sum() / (2 * np.pi))


@pytest.mark.parametrize("gia", [True, None])
def test_sleeve_on_a_fast_swinging_limb_never_ends_on_the_wrong_side(tmp_path, gia):
    frames, swing_frames = 13, 4
    doc = sleeve_shot(tmp_path, frames=frames, swing_frames=swing_frames)
    if gia is not None:
        doc["features"] = {"gia": gia}
    limb = np.load(tmp_path / "limb.npz")["positions"]
    limb_faces = np.asarray(doc["bodies"][0]["mesh"]["faces"], dtype=np.int32)
    sleeve_faces = np.asarray(doc["cloth"][0]["mesh"]["faces"], dtype=np.int32)
    # The swing is fast: the limb's tip (0.5 m out) reaches several metres per second.
    tip_speed = np.abs(np.diff(swing_angles(frames, swing_frames, np.pi / 2))).max() * 24.0 * 0.5
    assert tip_speed > 4.0
    for index, sim, t in simulate(doc, tmp_path):
        x = sim.positions
        assert np.isfinite(x).all()
        inside = _solver.points_inside_closed_mesh(x, limb[index], limb_faces)
        assert inside.sum() == 0, f"frame {index}: {int(inside.sum())} sleeve vertices inside the limb"
        through = _solver.intersection_analysis(x, sleeve_faces, limb[index], limb_faces, colour=False)
        assert through["hit_count"] == 0, f"frame {index}: the sleeve cuts the limb"
        assert t.intersections == 0, f"frame {index}: {t.intersections} intersecting triangle pairs"
    # Still a sleeve on the arm: every ring goes once around the limb.
    rings = x.reshape(-1, AROUND, 3)
    assert all(abs(abs(winding_about_limb(ring, limb[-1])) - 1.0) < 1e-6 for ring in rings)
