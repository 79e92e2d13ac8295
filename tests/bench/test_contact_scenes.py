"""The contact benchmark's scenes (`scenes/contact.py`) at tiny sizes and its metrics
(`bench/contact_metrics.py`) on hand-made positions. The benchmark itself takes minutes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bench.contact import build_scene, run_weft, weft_breakdown
from bench.contact_metrics import BodyTrack, contact_metrics, edge_rest_lengths, is_closed, point_triangle_distance
from scenes.contact import SCENES, character_parts
from scenes.collision import box_mesh
from weft.shot import parse_shot
from weft.simulate import usable_cpus
from weft.solver_setup import resolve_scene

TINY = {
    "drape_sphere": {"n": 6, "frames": 2},
    "drape_sphere_16k": {"n": 6, "frames": 2},
    "table_cloth": {"n": 6, "frames": 2},
    "spinning_sphere": {"n": 6, "frames": 2},
    "fast_drop": {"n": 6, "frames": 2},
    "towel_bar": {"n": 6, "frames": 2},
    "curtain_box": {"n": 6, "frames": 2},
    "sleeve_swing": {"frames": 2},
    "box_pinch": {"n": 5, "after": 0},
    "thin_limb": {"n": 6, "frames": 2},
    "articulated_dress": {"around": 12, "along": 6, "frames": 2},
    "articulated_dress_merged": {"around": 12, "along": 6, "frames": 2},
    "walking_dress": {"around": 12, "along": 6, "frames": 2},
    "layered_dress": {"around": 12, "along": 6, "skirt_around": 14, "skirt_along": 4, "frames": 2},
    "loose_skirt": {"around": 12, "along": 6, "skirt_around": 14, "skirt_along": 4, "frames": 2},
    "trousers": {"around": 8, "along": 6, "frames": 2},
}


def test_every_scene_has_a_tiny_size() -> None:
    assert set(TINY) == set(SCENES)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_scene_validates_and_runs_two_frames(name: str, tmp_path: Path) -> None:
    scene = resolve_scene(parse_shot(SCENES[name](tmp_path, **TINY[name])), tmp_path)
    run = run_weft(scene, 2, threads=1)
    assert run["failure"] is None
    assert run["positions"].shape == (2, scene.vertex_count, 3)
    assert np.isfinite(run["positions"]).all()
    assert weft_breakdown(run["telemetry"])["cg_iterations_per_substep"] > 0


def test_a_run_asked_for_more_frames_than_the_scene_has_stops_at_its_end(tmp_path: Path) -> None:
    # The box pinch sets its own length (2 * 5 + 6 + 1 + 8 frames): asked for 40 it runs 25.
    scene = build_scene("box_pinch", tmp_path, 40)
    run = run_weft(scene, 40, threads=1)
    assert run["failure"] is None
    assert scene.frame_count == 25
    assert run["positions"].shape == (25, scene.vertex_count, 3)
    assert len(run["frame_seconds"]) == 24


def test_character_parts_are_closed_and_overlap_at_the_joints() -> None:
    from weft import _solver

    parts = {p.name: p for p in character_parts()}
    assert 10 <= len(parts) <= 16 and all(is_closed(p.faces) for p in parts.values())
    for a, b in (("torso", "hips"), ("torso", "upper_arm_l"), ("upper_arm_r", "lower_arm_r"), ("hips", "upper_leg_l"),
                 ("neck", "head"), ("lower_leg_r", "foot_r")):
        pa, pb = parts[a], parts[b]
        assert _solver.body_intersection(pa.vertices, pa.faces.astype(np.int32), pb.vertices,
                                         pb.faces.astype(np.int32))["intersecting"], (a, b)


@pytest.mark.parametrize("name, shrink", [("articulated_dress", 0.9), ("trousers", 0.95)])
def test_garment_starts_outside_the_body_with_a_smaller_rest_shape(tmp_path: Path, name: str, shrink: float) -> None:
    scene = build_scene(name, tmp_path, 2)
    bodies = [BodyTrack(b.name, b.faces, b.frames[:1]) for b in scene.bodies]

    m = contact_metrics(scene.positions[None], scene.faces, edge_rest_lengths(scene.face_uv), bodies, np.array([]), 24.0)
    assert m["inside_max"] == 0 and m["cloth_body_pairs_max"] == 0
    assert 0.004 < m["gap_min_m"] < 0.01
    assert m["max_strain"] == pytest.approx(1 / shrink)  # girth edges start 1/shrink of their rest length


def test_the_walking_character_moves_forward_rigidly_at_its_speed(tmp_path: Path) -> None:
    walking = build_scene("walking_dress", tmp_path / "walk", 24)
    standing = build_scene("articulated_dress", tmp_path / "stand", 24)
    assert walking.shot.name == "walking_dress"
    for w, s in zip(walking.bodies, standing.bodies):
        shift = np.asarray(w.frames) - np.asarray(s.frames)
        # Every vertex of every part carried the same distance forward (+z) and nowhere else.
        assert np.allclose(shift[:, :, :2], 0.0) and np.allclose(shift[:, :, 2], shift[:, :1, 2])
        forward = shift[:, 0, 2]
        assert forward[4] == 0.0 and np.all(np.diff(forward) >= 0.0)
        assert np.diff(forward)[-1] * 24.0 == pytest.approx(1.2)  # full speed after the ramp


def test_point_triangle_distance_in_every_region() -> None:
    a, b, c = np.array([[0.0, 0, 0]]), np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]])
    points = np.array([[0.2, 0.2, 0.5], [-1.0, -1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.0], [0.5, -2.0, 0.0],
                       [-2.0, 0.5, 0.0], [1.0, 1.0, 0.0]])
    expected = [0.5, np.sqrt(2.0), 1.0, 2.0, 2.0, 2.0, np.sqrt(0.5)]
    np.testing.assert_allclose(point_triangle_distance(points, a, b, c)[:, 0], expected)


def two_boxes_merged() -> BodyTrack:
    """Two overlapping unit cubes as one body mesh (x in [-0.5, 0.5] and [0, 1])."""
    va, fa = box_mesh((1.0, 1.0, 1.0))
    vb, fb = box_mesh((1.0, 1.0, 1.0), (0.5, 0.0, 0.0))
    vertices = np.concatenate([va, vb])
    return BodyTrack("boxes", np.concatenate([fa, fb + len(va)]).astype(np.int32), np.stack([vertices, vertices]))


def test_metrics_count_inside_the_union_and_measure_gaps() -> None:
    # A small cloth: a triangle whose corners are inside the overlap of the two boxes (a parity
    # test on the merged mesh would say outside), 2 cm above the top, and 3 cm right of the right box.
    cloth0 = np.array([[0.25, 0.0, 0.0], [0.25, 0.52, 0.0], [1.03, 0.0, 0.0], [1.03, 0.1, 0.2]])
    faces = np.array([[0, 1, 2], [1, 3, 2]])
    rest = np.linalg.norm(cloth0[faces[:, [1, 2, 0]]] - cloth0[faces], axis=2)
    cloth1 = cloth0.copy()
    cloth1[3] += [0.0, 0.1, 0.0]  # the second frame stretches an edge and moves a vertex at 2.4 m/s
    m = contact_metrics(np.stack([cloth0, cloth1]), faces, rest, [two_boxes_merged()], np.array([0.5]), fps=24.0)
    assert m["inside_max"] == 1 and m["per_frame"]["inside"] == [1, 1]
    assert m["gap_vertices"] == 3
    assert m["gap_min_m"] == pytest.approx(0.02)
    assert m["gap_median_m"] == pytest.approx(0.03)
    assert m["inside_depth_max_m"] == pytest.approx(0.25)  # the inner vertex is 0.25 m from the right box's left face
    assert m["cloth_body_pairs_max"] > 0  # the triangle with a corner inside crosses the surface
    assert m["max_speed_m_s"] == pytest.approx(2.4)
    assert m["max_strain"] > 1.0 and not m["nan"]
    assert m["s_per_frame_mean"] == 0.5


def test_metrics_flag_non_finite_positions() -> None:
    cloth = np.array([[0.0, 2.0, 0.0], [1.0, 2.0, 0.0], [0.0, 3.0, 0.0]])
    faces = np.array([[0, 1, 2]])
    bad = cloth.copy()
    bad[1, 0] = np.nan
    m = contact_metrics(np.stack([cloth, bad]), faces, np.ones((1, 3)), [two_boxes_merged()], np.array([0.1]), 24.0)
    assert m["nan"] and m["first_nonfinite_frame"] == 1
    assert m["inside_final"] is None and "gap_min_m" not in m


def test_self_cost_runs_the_scene_again_with_self_collision_off() -> None:
    from bench.contact import run_scene

    rows = run_scene("sleeve_swing", 3, 1, None, self_cost=True)
    on, off = rows
    assert (on["solver"], off["solver"]) == ("weft", "weft, self off")
    assert on["self_collision_cost"] == pytest.approx(on["s_per_frame_mean"] / off["s_per_frame_mean"])
    assert off["telemetry"]["ccd_candidates_per_frame"] < on["telemetry"]["ccd_candidates_per_frame"]
    assert "self-collision costs" in off["rest"]


def test_repeats_give_the_median_time_and_identical_positions() -> None:
    from bench.contact import run_scene

    (row,) = run_scene("sleeve_swing", 3, 1, None, repeat=3)
    runs = row["s_per_frame_runs"]
    assert len(runs) == 3 and all(r > 0 for r in runs)
    assert row["s_per_frame_mean"] == pytest.approx(float(np.median(runs)))
    assert row["s_per_frame_max"] >= max(runs)
    assert row["repeats_identical"] is True
    assert row["frames_on_fewer_threads"] == 0  # one thread asked: the governor has none to take


@pytest.mark.skipif(usable_cpus() < 2, reason="a run on one CPU has one thread: nothing to give way")
def test_a_run_crowded_by_other_processes_says_so_in_its_row() -> None:
    import io

    from rich.console import Console

    from bench.contact import format_tables, run_scene
    from bench.omp_wait import busy_processes

    with busy_processes(usable_cpus() + 1):
        (row,) = run_scene("drape_sphere", 5, 2, None, scene_args={"n": 48})
    assert row["frames_on_fewer_threads"] > 0
    assert [t["threads"] for t in row["telemetry_frames"]][:2] == [2, 2]
    console = Console(file=io.StringIO(), width=400)
    for table in format_tables([row]):
        console.print(table)
    assert f"{row['frames_on_fewer_threads']} frames on fewer threads (machine busy)" in console.file.getvalue()


def test_the_ratio_column_shows_the_range_over_repeats() -> None:
    from bench.contact import _ratio

    assert _ratio({"ratio": 1.5, "ratio_runs": [1.4, 1.62, 1.5]}) == "1.50 (1.40-1.62)"
    assert _ratio({"ratio": 1.5}) == "1.50"
    assert _ratio({}) == "-"


def test_repeat_must_be_positive() -> None:
    from bench.contact import main

    with pytest.raises(SystemExit) as exc:
        main(["--repeat", "0", "--scenes", "sleeve_swing"])
    assert exc.value.code == 2


def test_thickness_factors_are_spread_evenly_and_never_one() -> None:
    from bench.contact_robustness import SPREAD, thickness_factors

    for count in (1, 2, 3, 6):
        factors = thickness_factors(count)
        assert len(factors) == count
        assert all(1.0 - SPREAD <= f <= 1.0 + SPREAD and f != 1.0 for f in factors)
        assert factors == sorted(factors)
    assert thickness_factors(1) == pytest.approx([1.0 - SPREAD])
    assert thickness_factors(2) == pytest.approx([1.0 - SPREAD, 1.0 + SPREAD])
    assert thickness_factors(3) == pytest.approx([1.0 - SPREAD, 1.0 - SPREAD / 2, 1.0 + SPREAD])
    with pytest.raises(ValueError, match="at least 1"):
        thickness_factors(0)


def test_scale_thickness_scales_set_and_default_thicknesses(tmp_path: Path) -> None:
    from api_schemas.shot import Material
    from bench.contact_robustness import scale_thickness

    shot = {"cloth": [{"material": {"thickness": 0.004}}, {"material": {}}, {}]}
    scale_thickness(shot, 1.05)
    default = Material.model_fields["thickness"].default
    assert [p["material"]["thickness"] for p in shot["cloth"]] == pytest.approx([0.0042, 1.05 * default, 1.05 * default])
    plain = build_scene("sleeve_swing", tmp_path / "a", 2)
    scaled = build_scene("sleeve_swing", tmp_path / "b", 2, thickness_scale=0.95)
    assert scaled.shot.cloth[0].material.thickness == pytest.approx(0.95 * plain.shot.cloth[0].material.thickness)


def test_perturbed_copies_are_summarised_over_every_copy() -> None:
    from bench.contact import run_perturbed
    from bench.contact_robustness import thickness_factors

    row = run_perturbed("sleeve_swing", 3, 1, 2)
    copies = row["copies"]
    assert [c["thickness_factor"] for c in copies] == thickness_factors(2)
    assert all(c["s_per_frame_mean"] > 0 and c["worst_over_median_frame"] >= 1.0 for c in copies)
    assert row["worst_over_median_frame"] == max(c["worst_over_median_frame"] for c in copies)
    assert row["frames_with_intersections"] == sum(c["frames_with_intersections"] for c in copies)
    assert row["frames_with_intersections_unpinched"] == sum(c["frames_with_intersections_unpinched"] for c in copies)
    assert row["max_strain"] == max(c["max_strain"] for c in copies) >= 1.0
    lo, hi = row["s_per_frame_range"]
    assert lo <= row["s_per_frame_median"] <= hi


def test_summary_counts_frames_ending_with_intersections() -> None:
    from bench.contact_robustness import copy_summary

    class Row:
        subdivided_substeps = 1
        gia_pinched_body_pairs = 0

        def __init__(self, part_pinches: int = 0) -> None:
            self.gia_pinched_part_pairs = part_pinches

    run = {"frame_seconds": [0.1, 0.1, 0.5], "telemetry": [Row(), Row(1), Row()], "failure": None}
    metrics = {"per_frame": {"inside": [0, 0, 3, 0], "cloth_body_pairs": [0, 0, 2, 1]}, "inside_max": 3,
               "max_strain": 1.2, "nan": False}
    summary = copy_summary(1.02, run, metrics)
    assert summary["frames_with_intersections"] == 2  # frame 2 (inside) and 3 (a pair), not the initial state
    assert summary["frames_with_intersections_unpinched"] == 1  # frame 2 had a part pinch engaged
    assert summary["worst_over_median_frame"] == pytest.approx(5.0)
    assert summary["halved_substeps"] == 3


def test_perturb_must_not_be_negative() -> None:
    from bench.contact import main

    with pytest.raises(SystemExit) as exc:
        main(["--perturb", "-1", "--scenes", "sleeve_swing"])
    assert exc.value.code == 2


def test_frames_inside_tells_pinched_frames_from_the_rest() -> None:
    from api_schemas.telemetry import FrameTelemetry

    from bench.contact import frames_inside

    def row(frame: int, body: int = 0, part: int = 0) -> FrameTelemetry:
        zeros = {name: 0 for name, info in FrameTelemetry.model_fields.items() if info.is_required()}
        return FrameTelemetry(**{**zeros, "frame": frame, "gia_pinched_body_pairs": body,
                                 "gia_pinched_part_pairs": part})

    telemetry = [row(1), row(2, part=2), row(3, body=1), row(4)]
    # The initial state (index 0) is not a simulated frame; frames 2 and 3 are pinched.
    assert frames_inside([5, 0, 3, 1, 2], telemetry) == {"inside_frames": 3, "inside_frames_unpinched": 1}
    assert frames_inside([0, 0, 0, 0, 0], telemetry) == {"inside_frames": 0, "inside_frames_unpinched": 0}


def test_the_table_cloth_hangs_over_every_edge_and_stays_out_of_the_table(tmp_path: Path) -> None:
    from scenes.contact import table_cloth

    # 16 x 16 over a 0.6 m table (top at y = 0, 0.4 m tall), one second: the sheet lands flat,
    # slides over the four sharp edges and hangs; no vertex ever enters the box.
    scene = resolve_scene(parse_shot(table_cloth(tmp_path, n=16, frames=24)), tmp_path)
    run = run_weft(scene, 24, threads=2)
    assert run["failure"] is None
    x = run["positions"]
    assert np.isfinite(x).all()
    over_top = (np.abs(x[..., 0]) < 0.3) & (np.abs(x[..., 2]) < 0.3)
    inside = over_top & (x[..., 1] < 0.0) & (x[..., 1] > -0.4)
    assert inside.sum() == 0
    last = x[-1]
    for axis in (0, 2):
        for sign in (1.0, -1.0):
            hanging = sign * last[:, axis] > 0.32  # beyond the table's side
            assert hanging.any() and last[hanging, 1].min() < -0.2, (axis, sign)
    middle = (np.abs(last[:, 0]) < 0.25) & (np.abs(last[:, 2]) < 0.25)
    assert middle.sum() > 20 and 0.0 < last[middle, 1].min() and last[middle, 1].max() < 0.05  # resting on the top
    assert all(t.intersections == 0 and t.max_edge_strain < 1.5 for t in run["telemetry"])


def test_friction_carries_the_cloth_round_the_spinning_sphere(tmp_path: Path) -> None:
    from scenes.contact import spinning_sphere

    # 12 x 12 on a sphere (radius 0.3 m) turning about the vertical at 2 rad/s, 1.5 s: once
    # landed (frame 12) the cloth over the top turns with it, slipping a little (friction 0.5),
    # and never enters it.
    frames = 36
    scene = resolve_scene(parse_shot(spinning_sphere(tmp_path, n=12, frames=frames)), tmp_path)
    run = run_weft(scene, frames, threads=2)
    assert run["failure"] is None
    x = run["positions"]
    sphere = np.asarray(scene.bodies[0].frames)
    marker = int(np.argmax(sphere[0, :, 0]))  # a vertex on the sphere's equator

    def turn(points: np.ndarray) -> np.ndarray:  # angle about the vertical, unwrapped over frames
        return np.unwrap(np.arctan2(points[..., 0], points[..., 2]), axis=0)

    landed = 12
    sphere_turn = turn(sphere[:, marker])[-1] - turn(sphere[:, marker])[landed]
    assert abs(sphere_turn) == pytest.approx(2.0 * (frames - 1 - landed) / 24.0)
    top = np.hypot(x[landed, :, 0], x[landed, :, 2]) < 0.2
    assert top.sum() >= 8
    cloth_turn = turn(x[:, top])[-1] - turn(x[:, top])[landed]
    assert np.all(cloth_turn * sphere_turn > 0)  # every top vertex turned the same way
    assert 0.6 < np.median(cloth_turn) / sphere_turn < 1.05
    assert np.linalg.norm(x, axis=2).min() > 0.3  # outside the sphere in every frame
    assert all(t.intersections == 0 for t in run["telemetry"])


def test_scene_args_reach_the_builder_and_size_the_scene() -> None:
    from bench.contact import parse_scene_args, run_scene

    args = parse_scene_args(["n=7", "speed=2.5", "note=x"])
    assert args == {"n": 7, "speed": 2.5, "note": "x"}
    assert isinstance(args["n"], int) and isinstance(args["speed"], float)
    (row,) = run_scene("thin_limb", 3, 1, None, scene_args={"n": 7})
    assert row["vertices"] == 49 and row["simulated_frames"] == 2 and not row["nan"]


@pytest.mark.parametrize("items, message", [
    (["n"], "'n' is not KEY=VALUE"),
    (["=4"], "is not KEY=VALUE"),
    (["frames=4"], "frames is set by --frames"),
    (["radius=0.1"], "thin_limb takes no 'radius' (its arguments: n, speed"),
    (["around=8", "nope=1"], "walking_dress: articulated_dress() got an unexpected keyword argument"),
])
def test_bad_scene_args_are_named_before_anything_runs(items: list[str], message: str,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    from bench.contact import main

    argv = ["--scenes", "thin_limb" if "around=8" not in items else "walking_dress"]
    for item in items:
        argv += ["--scene-arg", item]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--scene-arg" in err and message in err

