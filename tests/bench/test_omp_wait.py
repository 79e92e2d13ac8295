"""`python -m bench.omp_wait`: its medians and ratios, the busy processes it starts and always stops,
a short real run, and clear errors for bad input."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import weft
from bench.omp_wait import busy_processes, default_spin_count, main, summarize


@pytest.mark.parametrize("user_value", [None, "7"])
def test_weft_sets_its_spin_count_unless_the_user_chose_one(user_value: str | None) -> None:
    env = {k: v for k, v in os.environ.items() if k != "GOMP_SPINCOUNT"}
    if user_value is not None:
        env["GOMP_SPINCOUNT"] = user_value
    done = subprocess.run([sys.executable, "-c", "import os, weft; print(os.environ['GOMP_SPINCOUNT'])"],
                          capture_output=True, text=True, env=env, check=True)
    expected = user_value if user_value is not None else str(weft.OPENMP_SPIN_COUNT)
    assert done.stdout.strip() == expected
    assert default_spin_count() == weft.OPENMP_SPIN_COUNT


def test_medians_and_ratios_to_the_default_under_the_same_load() -> None:
    runs = [
        {"scene": "a", "busy": 0, "spin": 100, "s_per_frame": 2.0},
        {"scene": "a", "busy": 0, "spin": 100, "s_per_frame": 4.0},
        {"scene": "a", "busy": 0, "spin": 0, "s_per_frame": 6.0},
        {"scene": "a", "busy": 1, "spin": 100, "s_per_frame": 10.0},
        {"scene": "a", "busy": 1, "spin": 0, "s_per_frame": 5.0},
        {"scene": "b", "busy": 0, "spin": 0, "s_per_frame": 1.0},  # the default was not run here
        {"scene": "a", "busy": 1, "spin": 100, "governor": "off", "s_per_frame": 30.0},
    ]
    summary = summarize(runs, default_spin=100)
    off = next(r for r in summary if r["governor"] == "off")
    assert off["median"] == 30.0 and off["ratio_to_default"] == 3.0  # against the governor on
    rows = {(r["scene"], r["busy"], r["spin"]): r for r in summary if r["governor"] == "on"}
    assert rows[("a", 0, 100)]["median"] == 3.0 and rows[("a", 0, 100)]["ratio_to_default"] == 1.0
    assert rows[("a", 0, 0)]["ratio_to_default"] == 2.0
    assert rows[("a", 1, 0)]["ratio_to_default"] == 0.5  # compared with the default under its own load
    assert rows[("b", 0, 0)]["ratio_to_default"] is None
    assert rows[("a", 0, 100)]["s_per_frame"] == [2.0, 4.0]


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_busy_processes_run_inside_the_block_and_are_gone_after_it_even_on_error() -> None:
    with busy_processes(2) as processes:
        pids = [p.pid for p in processes]
        assert len(pids) == 2 and all(p.poll() is None for p in processes)
    assert not any(alive(pid) for pid in pids)
    with pytest.raises(RuntimeError), busy_processes(1) as processes:
        pid = processes[0].pid
        raise RuntimeError("a run failed")
    assert not alive(pid)


def test_a_short_run_reports_every_scene_load_and_spin(tmp_path: Path) -> None:
    out = tmp_path / "wait.json"
    default = default_spin_count()
    assert main(["--scenes", "sleeve_swing", "--spins", f"0,{default}", "--busy", "0", "--threads", "1",
                 "--frames", "3", "--repeat", "1", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["default_spin"] == default
    assert sorted((r["scene"], r["busy"], r["spin"]) for r in report["rows"]) == [
        ("sleeve_swing", 0, 0), ("sleeve_swing", 0, default)]
    for row in report["rows"]:
        assert 0.0 < row["median"] < 60.0
    assert next(r for r in report["rows"] if r["spin"] == default)["ratio_to_default"] == 1.0
    # Each run is a real simulation: 2 simulated frames with the solver's own breakdown.
    assert all(run["cg_iterations_per_substep"] > 0 for run in report["runs"])


@pytest.mark.parametrize("argv, message", [
    (["--scenes", "no_such_scene"], "unknown scene"),
    (["--spins", "x"], "--spins"),
    (["--spins", "-5"], "--spins"),
    (["--busy", ""], "--busy"),
    (["--threads", "0"], "--threads"),
    (["--frames", "1"], "--frames"),
    (["--governor", "maybe"], "--governor"),
])
def test_bad_arguments_are_named(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
