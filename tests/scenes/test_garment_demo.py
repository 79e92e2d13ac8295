"""The garment demo (issue 18, scenes/garment.py) through `weft run`: a skirt cut from its OBJ
pattern on a walking character of 14 overlapping closed parts, waistband pinned to the hips,
hem released after the settle. No cloth vertex inside any part at the end of any frame, the
hem really let go and the skirt really on the body."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from bench.contact_metrics import BodyTrack, ContactGeometry
from scenes.garment import AROUND, skirt_walk
from weft.shot import load_shot_file
from weft.solver_setup import resolve_scene

WEFT = str(Path(sys.executable).with_name("weft"))


def test_skirt_walk_stays_outside_every_part_and_moves_with_the_walk(tmp_path: Path) -> None:
    shot_path = skirt_walk(tmp_path / "garment")
    cache = tmp_path / "skirt.h5"
    done = subprocess.run([WEFT, "run", str(shot_path), "-o", str(cache), "--threads", "2", "-q"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    scene = resolve_scene(load_shot_file(shot_path), shot_path.parent)
    geometry = ContactGeometry([BodyTrack(b.name, b.faces, b.frames) for b in scene.bodies])
    with h5py.File(cache, "r") as f:
        positions = f["frames/positions"][()].astype(np.float64)
        telemetry = f["telemetry"][()]
    assert len(positions) == 72
    inside = [int(geometry.inside(x, k)[0].sum()) for k, x in enumerate(positions)]
    assert inside == [0] * 72, inside
    assert int(telemetry["gia_pinched_body_pairs"].max()) == 0  # joints are never pinches
    hem = slice(len(positions[0]) - AROUND, len(positions[0]))
    held, dropped = positions[5][hem], positions[-1][hem]
    assert np.array_equal(held, positions[0][hem]), "the hem is held during the settle"
    moved = np.linalg.norm(dropped - held, axis=1)
    assert moved.max() > 0.01, "released, the hem moves with the legs"
    walking = telemetry[16:]
    assert (walking["contact_constraints"] + walking["proximity_pairs"]).sum() > 0, "the legs touch the skirt"
    hips = scene.bodies[[b.name for b in scene.bodies].index("hips")].frames
    waist = positions[:, :AROUND]
    assert np.abs(waist[-1, :, 1].mean() - hips[-1][:, 1].max()) < 0.2  # the waistband stayed at the hips
    assert float(telemetry["max_edge_strain"][1:].max()) < 1.5
