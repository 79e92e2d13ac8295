"""`weft regress`: the stored references pass, deliberate errors fail with the scene, frame and
metric named, the reports say so, and the command runs the scenes through a real service."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from regress.judge import SceneResult, judge
from regress.references import counts, load
from regress.report import junit, markdown, write
from regress.runs import Run, read_cache, resolve, run_here, write_shot
from scenes.regression import SCENES, scene_folder

ROOT = Path(__file__).resolve().parents[2]


def run_edited(name: str, tmp_path: Path, edit: Any = None) -> tuple[Any, Run]:
    """The scene as submitted, its shot document changed by `edit` first, run in this process."""
    path = write_shot(name, tmp_path / name)
    if edit is not None:
        document = json.loads(path.read_text())
        edit(document)
        path.write_text(json.dumps(document))
    scene = resolve(path)
    return scene, run_here(scene)


def test_every_scene_has_thresholds_and_a_reference_made_as_documented() -> None:
    for name in SCENES:
        folder = scene_folder(name)
        assert (folder / "thresholds.yaml").is_file(), name
        meta = load(name)
        assert meta["scene"] == name and meta["made_by"] == "weft regress --update-references"
        assert set(meta["baseline_counts"]) == {"cg_iterations_per_substep", "ccd_candidates_per_frame",
                                                "collision_iterations_per_frame"}
        if meta["reference"] != "analytic":
            assert meta["reference"]["solver"]["cg_tolerance"] == 1e-8
            assert meta["positions"].shape == (meta["frames"], meta["reference"]["sampled_vertices"], 3)
    total = sum(p.stat().st_size for p in (ROOT / "scenes" / "regression").rglob("reference.*"))
    assert total < 5_000_000  # compact: a few MB in all


@pytest.mark.parametrize("name", ["free_fall", "hanging_strip", "drape_sphere", "through_body"])
def test_the_scene_as_submitted_passes(name: str, tmp_path: Path) -> None:
    scene, run = run_edited(name, tmp_path)
    result = judge(name, scene, run)
    assert result.passed, [f.message for f in result.failures]
    assert result.metrics["position_error_rms_mm"] >= 0.0


def test_halving_a_stiffness_fails_naming_scene_frame_and_metric(tmp_path: Path) -> None:
    def soften(document: dict[str, Any]) -> None:
        material = document["cloth"][0].setdefault("material", {})
        material["stretch_warp"] = material["stretch_weft"] = 1000.0  # half the default 2000 N/m

    scene, run = run_edited("hanging_strip", tmp_path, soften)
    result = judge("hanging_strip", scene, run)
    assert not result.passed
    failure = next(f for f in result.failures if f.metric.startswith("position error"))
    assert failure.frame is not None and scene.shot.frame_range[0] < failure.frame <= scene.shot.frame_range[1]
    assert failure.message.startswith("hanging_strip: position error") and f"frame {failure.frame}" in failure.message


def test_dropping_the_contact_fails_on_vertices_inside(tmp_path: Path) -> None:
    def no_contact(document: dict[str, Any]) -> None:
        document["features"] = {"collisions": False}

    scene, run = run_edited("drape_sphere", tmp_path, no_contact)
    result = judge("drape_sphere", scene, run)
    metrics = {f.metric for f in result.failures}
    assert "vertices inside a body" in metrics and "position error RMS (mm)" in metrics


def test_counts_are_judged_not_wall_time(tmp_path: Path) -> None:
    def tight(document: dict[str, Any]) -> None:
        # Block Jacobi: `auto` would go on with multigrid, which needs few more iterations.
        document["solver"] = {"cg_tolerance": 1e-9, "cg_max_iterations": 5000, "preconditioner": "block_jacobi"}

    scene, run = run_edited("hanging_strip", tmp_path, tight)
    result = judge("hanging_strip", scene, run)
    assert [f.metric for f in result.failures] == ["cg iterations per substep"]
    assert counts(run)["cg_iterations_per_substep"] > 1.5 * load("hanging_strip")["baseline_counts"]["cg_iterations_per_substep"]
    # A slow machine is no regression: the same run, ten times slower.
    slow = Run(run.positions, {**run.telemetry, "total_seconds": 10 * run.telemetry["total_seconds"]}, run.wall_seconds)
    assert [f.metric for f in judge("hanging_strip", scene, slow).failures] == ["cg iterations per substep"]


def test_a_failed_or_nan_run_fails(tmp_path: Path) -> None:
    scene, run = run_edited("free_fall", tmp_path)
    run.positions[5:, 3] = float("nan")
    result = judge("free_fall", scene, run)
    bad = next(f for f in result.failures if f.metric == "non-finite positions")
    assert bad.frame == scene.shot.frame_range[0] + 5
    short = Run(run.positions[:4], run.telemetry, run.wall_seconds, failure="frame 5: diverged")
    metrics = [f.metric for f in judge("free_fall", scene, short).failures]
    assert "run failed (frame 5: diverged)" in metrics and "frames written" in metrics


def test_energy_gained_fails_where_energy_is_defined(tmp_path: Path) -> None:
    scene, run = run_edited("pendulum_sheet", tmp_path)
    assert run.energy is not None and run.energy[-1] < run.energy[0]  # damped: energy only leaves
    assert judge("pendulum_sheet", scene, run).passed
    run.energy[7:] = run.energy[0] + 0.01  # a step that injects 10 mJ
    failure = next(f for f in judge("pendulum_sheet", scene, run).failures if f.metric == "energy growth (J)")
    assert failure.frame == scene.shot.frame_range[0] + 7 and failure.value > 0.009


def test_reports_name_every_failure(tmp_path: Path) -> None:
    from regress.judge import Failure

    results = [SceneResult("a", 10, 3, metrics={"position_error_rms_mm": 1.0}),
               SceneResult("b", 20, 4, failures=[Failure("b", "max edge strain", 3, 2.0, 1.5)])]
    text = markdown(results)
    assert "1 of 2 scenes passed" in text and "b: max edge strain = 2 exceeds 1.5 at frame 3" in text
    suite = ET.fromstring(junit(results))
    assert suite.get("tests") == "2" and suite.get("failures") == "1"
    failures = suite.findall("testcase[@name='b']/failure")
    assert len(failures) == 1 and "frame 3" in (failures[0].get("message") or "")
    paths = write(results, tmp_path)
    data = json.loads(paths["json"].read_text())
    assert data["passed"] is False and data["scenes"][1]["failures"][0]["metric"] == "max edge strain"


def weft(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(Path(sys.executable).parent / "weft"), *args], cwd=cwd, capture_output=True,
                          text=True, timeout=600, env={"COLUMNS": "200", "PATH": "/usr/bin:/bin"})


def test_cli_refuses_bad_options() -> None:
    result = weft("regress", "--scenes", "free_fall,no_such_scene")
    assert result.returncode == 2 and "--scenes: unknown scene(s) no_such_scene" in result.stderr
    result = weft("regress", "--local", "--server", "http://127.0.0.1:1")
    assert result.returncode == 2 and "exclude each other" in result.stderr
    listed = weft("regress", "--list")
    assert listed.returncode == 0 and listed.stdout.split() == list(SCENES)


def test_regress_through_a_real_service(tmp_path: Path) -> None:
    """No --server: the command starts Redis, the API and workers, submits over HTTP, fetches the
    caches, judges them and writes the reports."""
    result = weft("regress", "--scenes", "free_fall,hanging_strip", "--workers", "1", "-o", str(tmp_path))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "2 of 2 scenes passed" in result.stdout
    data = json.loads((tmp_path / "regress.json").read_text())
    assert [s["scene"] for s in data["scenes"]] == ["free_fall", "hanging_strip"] and data["passed"]
    assert ET.parse(tmp_path / "regress.xml").getroot().get("failures") == "0"


def test_read_cache_gives_the_runs_frames(tmp_path: Path) -> None:
    from weft.runner import ShotRunner

    path = write_shot("free_fall", tmp_path / "shot")
    scene = resolve(path)
    cache = tmp_path / "free_fall.h5"
    ShotRunner(scene, cache).run()
    run = read_cache(cache)
    assert run.failure is None and run.positions.shape == (scene.shot.frame_count, scene.vertex_count, 3)
    assert judge("free_fall", scene, run).passed
