"""Bad input: every problem is a clear error naming the field and the problem; nothing crashes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scenes.builders import sheet_shot
from weft.shot import ShotError, ShotValidationError, load_shot_file, parse_shot
from weft.solver_setup import resolve_scene


def base_doc() -> dict:
    return sheet_shot("bad", 3, 3, 0.2, 0.2, pins=[0], frames=4)


def problems(doc: dict, base_dir: Path) -> list[tuple[str, str]]:
    """The (field, problem) pairs reported for a shot document."""
    try:
        resolve_scene(parse_shot(doc), base_dir)
    except ShotValidationError as exc:
        return [(e.field, e.problem) for e in exc.errors]
    except ShotError as exc:
        return [(exc.field, exc.problem)]
    return []


def expect(doc: dict, tmp_path: Path, field: str, words: str) -> None:
    found = problems(doc, tmp_path)
    assert found, "the shot was accepted"
    assert any(f == field and words.lower() in p.lower() for f, p in found), found


def write_obj(path: Path, vertices: list[str], faces: list[str]) -> None:
    path.write_text("\n".join([f"v {v}" for v in vertices] + [f"f {f}" for f in faces]) + "\n")


def test_valid_shot_is_accepted(tmp_path) -> None:
    assert problems(base_doc(), tmp_path) == []


def test_inline_nan_coordinate(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["vertices"][4][1] = float("nan")
    expect(doc, tmp_path, "cloth[0].mesh.vertices[4][1]", "finite")


def test_inline_infinite_coordinate(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["vertices"][2][0] = float("inf")
    expect(doc, tmp_path, "cloth[0].mesh.vertices[2][0]", "finite")


def test_nan_in_mesh_file(tmp_path) -> None:
    write_obj(tmp_path / "m.obj", ["0 0 0", "1 0 0", "nan 1 0"], ["1 2 3"])
    doc = base_doc()
    doc["cloth"][0]["mesh"] = {"path": "m.obj"}
    doc["cloth"][0]["pins"] = []
    expect(doc, tmp_path, "cloth[0].mesh.vertices[2]", "NaN")


def test_face_index_out_of_range(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["faces"][3] = [0, 1, 9]
    expect(doc, tmp_path, "cloth[0].mesh.faces[3]", "vertex index 9 out of range")


def test_negative_face_index(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["faces"][0] = [-1, 1, 2]
    expect(doc, tmp_path, "cloth[0].mesh.faces[0][0]", "greater than or equal to 0")


def test_huge_vertex_index_is_a_field_error(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["faces"][0] = [0, 1, 2**70]
    expect(doc, tmp_path, "cloth[0].mesh.faces[0][2]", "less than")
    doc = base_doc()
    doc["cloth"][0]["pins"] = [{"vertices": [2**64]}]
    expect(doc, tmp_path, "cloth[0].pins[0].vertices[0]", "less than")


def test_zero_area_rest_triangle(tmp_path) -> None:
    doc = {
        "name": "flat", "frame_range": [1, 3],
        "cloth": [{"name": "c", "mesh": {"vertices": [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0]],
                                         "faces": [[0, 1, 3], [0, 1, 2]]}}],
    }
    expect(doc, tmp_path, "cloth[0].mesh.faces[1]", "zero area")


def test_zero_area_uv_rest_triangle(tmp_path) -> None:
    doc = base_doc()
    faces = doc["cloth"][0]["mesh"]["faces"]
    uvs = [[[0, 0], [0.1, 0], [0, 0.1]] for _ in faces]
    uvs[5] = [[0, 0], [0.1, 0.1], [0.2, 0.2]]
    doc["cloth"][0]["rest"] = {"kind": "uv", "face_uvs": uvs}
    expect(doc, tmp_path, "cloth[0].rest.face_uvs[5]", "zero area")


def test_repeated_vertex_in_triangle(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["faces"][2] = [1, 1, 4]
    expect(doc, tmp_path, "cloth[0].mesh.faces[2]", "repeats a vertex")


def test_empty_mesh(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"] = {"vertices": [], "faces": []}
    doc["cloth"][0]["pins"] = []
    expect(doc, tmp_path, "cloth[0].mesh.vertices", "empty")


def test_mesh_file_without_faces(tmp_path) -> None:
    (tmp_path / "points.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    doc = base_doc()
    doc["cloth"][0]["mesh"] = {"path": "points.obj"}
    doc["cloth"][0]["pins"] = []
    found = problems(doc, tmp_path)
    assert found and found[0][0].startswith("cloth[0].mesh"), found


def test_pin_index_out_of_range(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["pins"] = [{"vertices": [0, 1, 42]}]
    expect(doc, tmp_path, "cloth[0].pins[0].vertices[2]", "vertex 42 out of range")


def test_pin_to_unknown_body(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["pins"] = [{"vertices": [0], "body": "hand"}]
    expect(doc, tmp_path, "shot", "no body named 'hand'")


def body_doc(tmp_path: Path, frames: int, vertices: int) -> dict:
    doc = base_doc()
    box_v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    box_f = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    np.savez(tmp_path / "anim.npz", positions=np.zeros((frames, vertices, 3)))
    doc["bodies"] = [{"name": "box", "mesh": {"vertices": box_v, "faces": box_f},
                      "animation": {"path": "anim.npz"}}]
    return doc


def test_animation_frame_count_mismatch(tmp_path) -> None:
    expect(body_doc(tmp_path, frames=3, vertices=4), tmp_path, "bodies[0].animation", "3 samples at 24 per second cover shot frames 1-3")


def test_animation_vertex_count_mismatch(tmp_path) -> None:
    expect(body_doc(tmp_path, frames=4, vertices=5), tmp_path, "bodies[0].animation", "5 vertices per frame")


def test_animation_with_nan(tmp_path) -> None:
    doc = body_doc(tmp_path, frames=4, vertices=4)
    data = np.zeros((4, 4, 3))
    data[2, 1, 0] = np.inf
    np.savez(tmp_path / "anim.npz", positions=data)
    expect(doc, tmp_path, "bodies[0].animation[2][1]", "infinite")


def test_animation_missing_key(tmp_path) -> None:
    doc = body_doc(tmp_path, frames=4, vertices=4)
    doc["bodies"][0]["animation"]["key"] = "verts"
    expect(doc, tmp_path, "bodies[0].animation.key", "'verts' not in anim.npz")


def test_unknown_field(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["material"] = {"stiffness": 3}
    expect(doc, tmp_path, "cloth[0].material.stiffness", "extra inputs")


def test_wrong_type(tmp_path) -> None:
    doc = base_doc()
    doc["substeps"] = "many"
    expect(doc, tmp_path, "substeps", "integer")


@pytest.mark.parametrize("value, words", [(0.5, "above 1"), (1.0, "above 1"), (-1.0, "greater than or equal"),
                                          (1e6, "less than or equal")])
def test_step_strain_bound_is_off_or_a_stretch(tmp_path, value, words) -> None:
    doc = base_doc()
    doc["solver"] = {"max_step_strain": value}
    expect(doc, tmp_path, "solver.max_step_strain", words)
    doc["solver"] = {"max_step_strain": 0}  # off
    assert problems(doc, tmp_path) == []


def test_backwards_frame_range(tmp_path) -> None:
    doc = base_doc()
    doc["frame_range"] = [10, 2]
    expect(doc, tmp_path, "frame_range", "must be after")


def test_asset_path_may_not_escape(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"] = {"path": "../secret.obj"}
    expect(doc, tmp_path, "cloth[0].mesh.path", "may not leave")


def test_absolute_asset_path_rejected(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"] = {"path": "/etc/passwd"}
    expect(doc, tmp_path, "cloth[0].mesh.path", "relative")


def test_missing_asset_file(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"] = {"path": "nowhere.obj"}
    expect(doc, tmp_path, "cloth[0].mesh.path", "file not found")


def test_vertex_in_no_face(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["vertices"].append([5.0, 5.0, 5.0])
    expect(doc, tmp_path, "cloth[0].mesh", "belong to no face")


def test_pinned_twice(tmp_path) -> None:
    doc = base_doc()
    doc["cloth"][0]["pins"] = [{"vertices": [0, 1]}, {"vertices": [1]}]
    expect(doc, tmp_path, "cloth.pins", "more than once")


def test_malformed_shot_file(tmp_path) -> None:
    path = tmp_path / "broken.json"
    path.write_text('{"name": "x", "cloth": [')
    with pytest.raises(ShotError) as info:
        load_shot_file(path)
    assert "cannot parse" in str(info.value)


@pytest.mark.parametrize("command", ["validate", "run"])
def test_cli_reports_bad_shot_without_traceback(tmp_path, command) -> None:
    doc = base_doc()
    doc["cloth"][0]["mesh"]["faces"][1] = [0, 1, 99]
    shot = tmp_path / "bad.json"
    shot.write_text(json.dumps(doc))
    args = [sys.executable, "-m", "weft.cli", command, str(shot)]
    if command == "run":
        args += ["-o", str(tmp_path / "out.h5")]
    result = subprocess.run(args, capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert "cloth[0].mesh.faces[1]" in result.stderr and "out of range" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "out.h5").exists()


def test_unavailable_feature_is_refused_not_ignored(tmp_path) -> None:
    doc = base_doc()
    doc["features"] = {"gia": True}
    expect(doc, tmp_path, "features.gia", "self-collision")
