"""`python -m bench.strain_map`: the edges above a strain threshold and where they lie, checked on
hand-built cases (a stretched square; two cloth pieces over a body of two parts) and on a short
run of the thin limb; clear errors for bad input."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from bench.strain_map import main, strain_map


def test_a_stretched_edge_is_found_with_its_distances() -> None:
    # Two triangles of a unit square in the plane z = 0; vertex 0 pinned; a body triangle in the
    # plane z = -0.25 under the whole square.
    rest = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    body_x = np.array([[-5.0, -5.0, -0.25], [5.0, -5.0, -0.25], [0.0, 5.0, -0.25]])
    body = SimpleNamespace(frames=[body_x, body_x], faces=np.array([[0, 1, 2]]))
    scene = SimpleNamespace(faces=faces, rest_positions=None, fixed_pins=np.array([0]),
                            body_pin_vertices=np.array([], dtype=int), bodies=[body])
    moved = rest.copy()
    moved[2] = [2.0, 1.0, 0.0]  # edge (1, 2) becomes sqrt(2) long: strain 1.41; (2, 3) 2.0; (0, 2) 1.58
    rows = strain_map(scene, [rest, moved], threshold=1.5)
    assert len(rows) == 1
    row = rows[0]
    assert row["max_strain"] == pytest.approx(2.0)
    assert row["edges_over"] == 2  # (0, 2) and (2, 3)
    assert row["to_body_m"]["min"] == pytest.approx(0.25) and row["to_body_m"]["max"] == pytest.approx(0.25)
    # Midpoints (1, 0.5, 0) and (1, 1, 0) from the pin at the origin.
    assert row["to_pin_m"]["min"] == pytest.approx(np.hypot(1.0, 0.5))
    assert row["to_pin_m"]["max"] == pytest.approx(np.sqrt(2.0))
    # Nothing above the threshold: no distances.
    assert strain_map(scene, [rest, rest], threshold=1.5)[0] == {
        "frame": 1, "max_strain": pytest.approx(1.0), "edges_over": 0, "to_body_m": None, "to_pin_m": None,
        "by_piece": {}, "between_parts": 0, "by_part": {}, "p90_by_piece": {"cloth": pytest.approx(1.0)}}


def test_edges_are_counted_by_piece_and_by_the_body_parts_they_rest_on() -> None:
    # Piece "a", a unit square in z = 0, over a body of two parts (separate triangles 5 mm below
    # the plane): part 0 under x in [-1, 0.5], part 1 under x in [1.5, 3]. Piece "b", a triangle
    # far from both.
    rest = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0],
                     [5.0, 0.0, 0.0], [6.0, 0.0, 0.0], [5.0, 1.0, 0.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]])
    body_x = np.array([[-1.0, -1.0, -0.005], [0.5, -1.0, -0.005], [0.5, 3.0, -0.005],
                       [1.5, -1.0, -0.005], [3.0, -1.0, -0.005], [1.5, 3.0, -0.005]])
    body = SimpleNamespace(name="legs", frames=[body_x, body_x], faces=np.array([[0, 1, 2], [3, 4, 5]]))
    pieces = [SimpleNamespace(name="a", vertex_offset=0, vertex_count=4),
              SimpleNamespace(name="b", vertex_offset=4, vertex_count=3)]
    scene = SimpleNamespace(faces=faces, rest_positions=None, fixed_pins=np.array([], dtype=int),
                            body_pin_vertices=np.array([], dtype=int), bodies=[body], pieces=pieces)
    moved = rest.copy()
    moved[2] = [2.0, 1.0, 0.0]  # over part 1: (0, 2) 1.58 and (2, 3) 2.0 from part 0 to part 1; (1, 2) 1.41
    moved[5] = [8.0, 0.0, 0.0]  # piece b: (4, 5) 3.0 and (5, 6) 2.24, near no part
    row = strain_map(scene, [rest, moved], threshold=1.5)[0]
    assert row["edges_over"] == 4
    assert row["by_piece"] == {"a": 2, "b": 2}
    # Both of piece a's edges end on the two parts; each is counted at its first end's part:
    # (0, 2) at part 0, (2, 3) at part 1. Piece b's rest on none.
    assert row["between_parts"] == 2
    assert row["by_part"] == {"legs part 0": 1, "legs part 1": 1}
    # 90th percentiles over each piece's own edges: a's five are 1, 1, 1.41, 1.58, 2; b's three
    # 2.24, 3 and 1 (the unmoved (4, 6)).
    assert row["p90_by_piece"]["a"] == pytest.approx(np.percentile([1.0, 1.0, np.sqrt(2.0), np.sqrt(2.5), 2.0], 90))
    assert row["p90_by_piece"]["b"] == pytest.approx(np.percentile([3.0, np.sqrt(10.0) / np.sqrt(2.0), 1.0], 90))
    # Within 4 mm nothing rests on a part (every end is 5 mm above one).
    near = strain_map(scene, [rest, moved], threshold=1.5, near=0.004)[0]
    assert near["between_parts"] == 0 and near["by_part"] == {}


def test_the_thin_limb_agrees_with_the_solver_telemetry(tmp_path: Path) -> None:
    out = tmp_path / "strain.json"
    assert main(["--scene", "thin_limb", "--frames", "4", "--threads", "1", "--threshold", "1.05",
                 "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert [row["frame"] for row in report["frames"]] == [1, 2, 3]
    for row in report["frames"]:
        # The same rest lengths and positions as the solver's own max_edge_strain.
        assert row["max_strain"] == pytest.approx(row["telemetry_max_strain"], rel=1e-9)
        assert (row["edges_over"] > 0) == (row["max_strain"] > 1.05)
        if row["edges_over"]:
            assert 0.0 <= row["to_body_m"]["min"] <= row["to_body_m"]["median"] <= row["to_body_m"]["max"]
            assert row["to_pin_m"]["min"] >= 0.0
        # One piece holds every listed edge; no more rest on parts than are listed.
        assert sum(row["by_piece"].values()) == row["edges_over"]
        assert sum(row["by_part"].values()) <= row["edges_over"]
        assert 0 <= row["between_parts"] <= row["edges_over"]


@pytest.mark.parametrize("argv, message", [
    (["--scene", "no_such_scene"], "unknown contact scene"),
    (["--threshold", "0.9"], "--threshold"),
    (["--frames", "1"], "--frames"),
    (["--threads", "0"], "--threads"),
    (["--near", "-0.01"], "--near"),
    (["--near", "nan"], "--near"),
])
def test_bad_arguments_name_the_problem(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
