"""A sewing pattern's rest shape from the OBJ's own vt (issue 18): per-corner UVs, seams where
a vertex has different UVs in different faces, units by uv_scale, and clear errors."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scenes.builders import sheet_shot
from weft.shot import ShotError, parse_shot
from weft.solver_setup import resolve_scene

# Two triangles sharing the edge 1-2, folded in 3D; in the pattern they are separate panels
# (the shared vertices have different vt in each face: a seam), in centimetres.
OBJ = """# two panels sewn along one edge
v 0 0 0
v 0.3 0 0
v 0 0.3 0
v 0.3 0.1 0.25
vt 0 0
vt 30 0
vt 0 30
vt 50 0
vt 80 0
vt 50 32
f 1/1 2/2 3/3
f 2/4 4/5 3/6
"""


def shot_for(tmp_path: Path, obj: str = OBJ, **rest: Any) -> dict[str, Any]:
    (tmp_path / "pattern.obj").write_text(obj)
    shot = sheet_shot("pattern", 2, 2, 0.1, 0.1, frames=3)
    shot["cloth"][0]["mesh"] = {"path": "pattern.obj"}
    shot["cloth"][0]["rest"] = {"kind": "uv", **rest}
    return shot


def test_rest_shape_is_the_obj_vt_in_metres(tmp_path: Path) -> None:
    scene = resolve_scene(parse_shot(shot_for(tmp_path, uv_scale=0.01)), tmp_path)
    expected = np.array([[0, 0, 0.3, 0, 0, 0.3], [0.5, 0, 0.8, 0, 0.5, 0.32]])
    assert np.allclose(scene.face_uv, expected, rtol=0, atol=1e-15)
    assert len(scene.positions) == 4  # the seam does not split vertices: the topology is the file's


def test_simulating_from_the_pattern_runs(tmp_path: Path) -> None:
    from weft.simulate import simulate

    scene = resolve_scene(parse_shot(shot_for(tmp_path, uv_scale=0.01)), tmp_path)
    for _, sim, _ in simulate(scene):
        assert np.isfinite(sim.positions).all()


@pytest.mark.parametrize(("obj", "rest", "message"), [
    (OBJ.replace("f 2/4 4/5 3/6", "f 2/4 4/5 3/6 1/1"), {}, "the vt rest shape needs a triangulated OBJ"),
    ("\n".join(line for line in OBJ.splitlines() if not line.startswith("vt")).replace("/1", "").replace("/2", "")
     .replace("/3", "").replace("/4", "").replace("/5", "").replace("/6", ""), {}, "a face corner without a vt index"),
    (OBJ.replace("vt 50 32", "vt 65 0"), {}, "zero area"),
    (OBJ.replace("f 1/1 2/2 3/3", "f 1/1 2/2 3/9"), {}, "a vt that does not exist"),
])
def test_bad_patterns_name_the_field(tmp_path: Path, obj: str, rest: dict[str, Any], message: str) -> None:
    with pytest.raises(ShotError) as error:
        resolve_scene(parse_shot(shot_for(tmp_path, obj, **rest)), tmp_path)
    assert error.value.field.startswith("cloth[0].rest") and message in str(error.value), str(error.value)


def test_uv_rest_without_face_uvs_needs_an_obj(tmp_path: Path) -> None:
    shot = sheet_shot("inline", 2, 2, 0.1, 0.1, frames=3)
    shot["cloth"][0]["rest"] = {"kind": "uv"}
    with pytest.raises(ShotError, match="must be an .obj file"):
        resolve_scene(parse_shot(shot), tmp_path)
    shot["cloth"][0]["rest"] = {"kind": "initial", "uv_scale": 0.01}
    with pytest.raises(Exception, match="uv_scale"):
        parse_shot(shot)
