"""The collision stage's cloth tree is built once and refitted (docs/collisions.md, "The step"):
`Simulation.cloth_tree_quality` compares the refitted tree's surface-area cost with a fresh
build's at the same positions. A draped sheet keeps a refitted tree as good as a rebuilt one (mesh-adjacent faces stay
together); one whose vertices are scrambled among themselves does not."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.builders import sheet_shot
from scenes.collision import drop_shot

from tests.helpers import make_sim
from weft import simulate as frame_loop


def test_a_draped_sheet_keeps_a_refitted_tree_as_good_as_a_fresh_one():
    scene, sim = make_sim(drop_shot("sphere", n=16, frames=12, substeps=4), threads=2)
    refitted, fresh = sim.cloth_tree_quality()
    assert refitted == fresh > 0.0  # at the positions it was built from, the same tree
    for _ in frame_loop.simulate(scene, sim):
        pass
    refitted, fresh = sim.cloth_tree_quality()
    assert refitted != fresh  # the sheet has draped: a fresh build splits it differently
    assert 0.8 < refitted / fresh < 1.25


def test_scrambled_positions_show_a_degraded_tree():
    scene, sim = make_sim(drop_shot("sphere", n=16, frames=2, substeps=4))
    x = np.array(sim.positions)
    shuffled = x[np.random.default_rng(3).permutation(len(x))]
    sim.set_state(shuffled, np.zeros_like(x))
    refitted, fresh = sim.cloth_tree_quality()
    # Every triangle now spans the sheet, so no tree is good; the refitted one, whose nodes group
    # faces that were neighbours, is the worse.
    assert refitted > 1.1 * fresh


def test_a_scene_without_collisions_has_no_cloth_tree():
    _, sim = make_sim(sheet_shot("flag", 6, 6, 1.0, 1.0, frames=2))
    assert not sim.collisions_enabled
    with pytest.raises(RuntimeError, match="no collision stage"):
        sim.cloth_tree_quality()
