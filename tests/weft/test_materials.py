"""Material presets (api_schemas/materials.py): a preset fills the fabric fields a material leaves
out, its values reach the solver, bad names are refused with the field's path, and `weft
materials` lists every preset with where its numbers come from."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from api_schemas import Material
from api_schemas.materials import PRESET_FIELDS, PRESETS
from scenes.builders import sheet_shot
from tests.helpers import final_positions, make_scene


def weft(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "weft.cli", *args], capture_output=True, text=True, timeout=120)


def test_a_preset_fills_only_the_fields_the_material_leaves_out() -> None:
    denim = PRESETS["denim"].values
    m = Material.model_validate({"preset": "denim", "bend": 2e-5, "thickness": 0.004})
    assert m.bend == 2e-5 and m.thickness == 0.004  # given beside the preset: they win
    assert (m.density, m.stretch_warp, m.stretch_weft, m.shear) == (
        denim["density"], denim["stretch_warp"], denim["stretch_weft"], denim["shear"])
    assert m.friction == Material().friction  # contact settings are not the fabric's
    assert Material.model_validate({"preset": "silk"}).density < Material.model_validate({"preset": "leather"}).density


def test_every_preset_sets_every_fabric_field_and_says_whether_it_was_measured() -> None:
    assert set(PRESETS) == {"cotton", "denim", "silk", "leather"}
    for name, preset in PRESETS.items():
        assert set(preset.values) == set(PRESET_FIELDS), name
        assert preset.source.startswith("Wang, O'Brien & Ramamoorthi 2011" if preset.measured else "estimate:"), name
        Material.model_validate({"preset": name})  # within Material's own bounds


def test_an_unknown_preset_is_refused_with_its_field_path(tmp_path: Path) -> None:
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps(sheet_shot("bad_preset", 3, 3, 1.0, 1.0, material={"preset": "wool"})))
    result = weft("validate", str(shot))
    assert result.returncode == 2
    assert "cloth[0].material.preset" in result.stderr and "'denim'" in result.stderr


def droop(material: dict) -> float:
    """How far the free edge of a 5 cm strip clamped along one edge (two pinned rows) hangs
    below the clamp after 1.5 s."""
    n = 11
    doc = sheet_shot("droop", n, 6, 0.1, 0.05, plane="xz", pins=list(range(2 * n)),
                     material={**material, "damping": 0.01}, frames=36, air_drag=0.5)
    x = final_positions(make_scene(doc))
    assert np.isfinite(x).all()
    return float(-x[-n:, 1].mean())


def test_presets_reach_the_solver_a_strip_droops_in_the_order_of_bend_over_weight() -> None:
    drops = {name: droop({"preset": name}) for name in PRESETS}
    order = sorted(PRESETS, key=lambda n: PRESETS[n].values["bend"] / PRESETS[n].values["density"])
    # Least bending stiffness per weight droops most: silk, denim, leather, cotton.
    assert order == ["silk", "denim", "leather", "cotton"]
    for softer, stiffer in zip(order, order[1:]):
        assert drops[softer] > drops[stiffer] + 1e-3, drops
    assert drops["silk"] < 0.05 - 1e-3  # still bending, not hanging straight down
    # The same values given by hand behave the same: the preset is nothing but its values.
    assert droop(dict(PRESETS["denim"].values)) == pytest.approx(drops["denim"], abs=1e-12)


def test_weft_materials_lists_every_preset_with_its_source() -> None:
    result = weft("materials", "--json")
    assert result.returncode == 0, result.stderr
    listed = json.loads(result.stdout)
    assert set(listed) == set(PRESETS)
    for name, entry in listed.items():
        assert entry["source"] == PRESETS[name].source and entry["measured"] == PRESETS[name].measured
        assert all(entry[f] == PRESETS[name].values[f] for f in PRESET_FIELDS)
