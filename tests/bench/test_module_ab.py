"""`python -m bench.module_ab`: two builds (here the installed one under two names) run the box
pinch in processes of their own, alternating; their figures and whether their positions are bit
for bit the same, and clear errors for what it cannot run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.module_ab import main


def test_two_runs_of_one_build_agree_bit_for_bit(tmp_path: Path) -> None:
    out = tmp_path / "ab.json"
    argv = ["--scene", "box_pinch", "--module", "one=installed", "--module", "two=installed", "--threads", "1",
            "--repeat", "1", "--frames", "4", "--save-positions", "--json", str(out)]
    assert main(argv) == 0
    report = json.loads(out.read_text())
    assert report["modules"] == {"one": "installed", "two": "installed"}
    assert report["bitwise"] == {"one": True, "two": True}
    for name in ("one", "two"):
        (run,) = report["runs"][name]
        assert run["failure"] is None
        assert run["s_per_frame"] > 0.0 and run["cpu_per_frame"] > 0.0
        assert run["max_frame"] >= run["median_frame"] > 0.0
        assert run["worst_over_median_frame"] == pytest.approx(run["max_frame"] / run["median_frame"])
        assert run["cg_iterations_per_substep"] > 0.0
    # The same build does the same work: the same counts.
    assert report["runs"]["one"][0]["cg_iterations_per_substep"] == report["runs"]["two"][0]["cg_iterations_per_substep"]


def test_a_shot_file_runs_as_a_scene(tmp_path: Path) -> None:
    from scenes.generate import main as generate

    generate(tmp_path)
    shot = next(tmp_path.glob("demo_flag.*"))
    out = tmp_path / "ab.json"
    assert main(["--scene", str(shot), "--module", "one=installed", "--module", "two=installed", "--repeat", "1",
                 "--frames", "3", "--json", str(out)]) == 0
    runs = json.loads(out.read_text())["runs"]
    assert runs["one"][0]["cg_iterations_per_substep"] == runs["two"][0]["cg_iterations_per_substep"] > 0.0


def test_a_bench_sheet_runs_at_a_size_of_its_own(tmp_path: Path) -> None:
    out = tmp_path / "ab.json"
    assert main(["--scene", "sheet:12", "--module", "one=installed", "--module", "two=installed", "--repeat", "1",
                 "--save-positions", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["bitwise"] == {"one": True, "two": True}
    run = report["runs"]["one"][0]
    assert run["failure"] is None and run["cg_iterations_per_substep"] > 0.0


@pytest.mark.parametrize("argv, message", [
    (["--scene", "sheet:x", "--module", "a=installed", "--module", "b=installed"], "sheet:N"),
    (["--scene", "sheet:1", "--module", "a=installed", "--module", "b=installed"], "sheet:N"),
    (["--module", "a=installed"], "at least two builds"),
    (["--module", "a=installed", "--module", "b"], "expected NAME=PATH"),
    (["--module", "a=installed", "--module", "b=/no/such/module.so"], "no such file"),
    (["--module", "a=installed", "--module", "a=installed"], "named twice"),
    (["--scene", "no_such_scene", "--module", "a=installed", "--module", "b=installed"], "--scene"),
    (["--frames", "1", "--module", "a=installed", "--module", "b=installed"], "--frames"),
    (["--scene", "no/such/shot.yaml", "--module", "a=installed", "--module", "b=installed"], "no such shot file"),
])
def test_bad_arguments_name_the_problem(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
