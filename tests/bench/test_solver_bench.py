"""`weft bench ...`: the solver bench's table formatter, the commands' wiring to the `bench`
package (the solver bench itself takes minutes; one 256-vertex sheet runs end to end), and a small CCD
bench run end to end."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from bench.solver_bench import format_tables, growth_exponent, run_bench
from weft.cli import app


def fake_result() -> dict:
    records = []
    for vertices in (10_000, 40_000):
        common = dict(scene=f"sheet-{vertices}", vertices=vertices, threads=2, force_elements=3 * vertices,
                      per_force_elements=9 * vertices, bandwidth_natural=200, bandwidth=200, narrow_columns=True)
        records.append(dict(common, path="fast", precision="float32", measured="1 frame", build_s_per_frame=0.1,
                            solve_s_per_frame=0.2, sim_s_per_frame=0.31, s_per_step=0.0775,
                            cg_iterations_per_step=300.0, extra={
                                "spmv_gb_per_s": 10.0, "triad_gb_per_s": 16.0, "spmv_fraction_of_triad": 0.6, "build_speedup": 3.0,
                                "solve_speedup": 4.0, "sim_speedup": 3.5, "same_system_fast_pcg_seconds": 0.05,
                                "same_system_fast_pcg_iterations": 300, "same_system_eigen_cg_seconds": 0.1,
                                "same_system_eigen_cg_iterations": 320, "eigen_cg_over_fast_pcg": 2.0}))
        records.append(dict(common, path="fast+multigrid", preconditioner="multigrid", precision="float32",
                            measured="1 frame", build_s_per_frame=0.1, solve_s_per_frame=0.05, sim_s_per_frame=0.16,
                            s_per_step=0.04, cg_iterations_per_step=18.5, extra={
                                "multigrid_setup_s_per_frame": 0.01, "multigrid_refreshes_per_step": 0.25, "multigrid_rows": [vertices, vertices // 9, 40],
                                "multigrid_operator_complexity": 1.24, "solve_speedup_over_block_jacobi": 4.0,
                                "sim_speedup_over_block_jacobi": 1.94}))
        records.append(dict(common, path="reference", precision="float64", measured="1 of 4 steps, scaled",
                            build_s_per_frame=0.3, solve_s_per_frame=0.8, sim_s_per_frame=1.1, s_per_step=0.275,
                            cg_iterations_per_step=320.0, extra={}))
    return {"threads": 2, "substeps_per_frame": 4, "triad_gb_per_s": 16.0, "wall_seconds": 10.0,
            "load_average_start": 1.0, "load_average_end": 1.5, "records": records}


def test_format_tables_has_every_section() -> None:
    text = format_tables(fake_result())
    assert "| sheet-10000 | 10000 | fast (float32) |" in text
    assert "Eigen CG double" in text and "Growth exponent" in text and "67% fewer" in text
    assert "| | | multigrid | 18.5 | 0.010 | 0.25 | 0.050 | 0.160 | 4.00 | 1.94 | 10000 / 1111 / 40 | 1.24 |" in text
    assert "with multigrid, of s/step: 0.00" in text
    assert abs(growth_exponent([1.0, 2.0, 4.0], [3.0, 6.0, 12.0]) - 1.0) < 1e-12


def test_bench_solver_command_passes_its_options_to_the_bench(monkeypatch, tmp_path: Path) -> None:
    import bench.solver_bench

    calls = []
    monkeypatch.setattr(bench.solver_bench, "main", lambda **kwargs: calls.append(kwargs))
    result = CliRunner().invoke(app, ["bench", "solver", "--threads", "3", "--json", str(tmp_path / "b.json"), "--quick"])
    assert result.exit_code == 0, result.output
    assert calls == [{"threads": 3, "json_path": tmp_path / "b.json", "quick": True, "sides": None, "repeat": 1}]
    result = CliRunner().invoke(app, ["bench", "solver", "--sizes", "16,32", "--repeat", "3"])
    assert result.exit_code == 0, result.output
    assert calls[-1]["sides"] == [16, 32] and calls[-1]["repeat"] == 3
    result = CliRunner().invoke(app, ["bench", "solver", "--repeat", "0"])
    assert result.exit_code == 2 and "--repeat" in result.output


def test_bench_solver_takes_several_thread_counts_and_rejects_bad_ones(monkeypatch) -> None:
    import bench.solver_bench
    from weft.simulate import usable_cpus

    calls = []
    monkeypatch.setattr(bench.solver_bench, "main", lambda **kwargs: calls.append(kwargs))
    result = CliRunner().invoke(app, ["bench", "solver", "--threads", "1,2,all,2"])
    assert result.exit_code == 0, result.output
    expected = [1, 2] + ([usable_cpus()] if usable_cpus() > 2 else [])
    assert calls[-1]["threads"] == (expected if len(expected) > 1 else expected[0])
    for bad, named in (("0", "'0'"), ("1,x", "'x'"), ("", "no thread count"), ("257", "'257'")):
        result = CliRunner().invoke(app, ["bench", "solver", "--threads", bad])
        assert result.exit_code == 2 and "--threads" in result.output and named in result.output, result.output
    result = CliRunner().invoke(app, ["bench", "solver", "--sizes", "16,sixteen"])
    assert result.exit_code == 2 and "--sizes" in result.output and "'sixteen'" in result.output, result.output
    assert len(calls) == 1


def test_a_thread_sweep_tabulates_each_count_with_the_same_iterations(tmp_path: Path, capsys) -> None:
    from bench.solver_bench import main

    combined = main(threads=[1, 2], sides=[16], json_path=tmp_path / "t.json")
    assert json.loads((tmp_path / "t.json").read_text()) == json.loads(json.dumps(combined))
    assert combined["thread_counts"] == [1, 2] and [r["threads"] for r in combined["runs"]] == [1, 2]
    rows = combined["thread_table"]
    assert [r["threads"] for r in rows] == [1, 2] and {r["vertices"] for r in rows} == {256}
    # The step is bitwise the same for any thread count, so are the iteration counts.
    assert rows[0]["multigrid_iterations_per_step"] == rows[1]["multigrid_iterations_per_step"] > 0
    assert rows[0]["block_jacobi_iterations_per_step"] == rows[1]["block_jacobi_iterations_per_step"] > 0
    assert rows[0]["multigrid_sim_speedup_over_first_count"] == 1.0
    assert rows[1]["multigrid_sim_speedup_over_first_count"] == (
        rows[0]["multigrid_sim_s_per_frame"] / rows[1]["multigrid_sim_s_per_frame"])
    out = capsys.readouterr().out
    assert "| sheet-256 | 256 | 2 |" in out and "CG iterations the same for every thread count: yes." in out


def test_bench_ccd_runs_with_zero_false_negatives() -> None:
    result = CliRunner().invoke(app, ["bench", "ccd", "--queries", "1000", "--sizes", "6", "--frames", "3", "--json"])
    assert result.exit_code == 0, result.output
    figures = json.loads(result.output)
    assert [q["query"] for q in figures["queries"]] == ["vertex-triangle", "edge-edge"]
    for q in figures["queries"]:
        assert q["queries"] == 1000 and q["hits_true"] > 0 and q["false_negatives"] == 0
    (twist,) = figures["twist"]
    assert twist["vertices"] == 36 and twist["frames"] == 2 and twist["max_intersections"] == 0


def test_repeated_blocks_give_one_speedup_each() -> None:
    result = run_bench(threads=1, sides=[16], repeat=2, log=lambda _: None)
    fast, multigrid, reference = result["records"]
    assert result["repeat"] == 2
    assert (fast["measured"], multigrid["measured"], reference["measured"]) == ("2 frames", "2 frames", "1 frame")
    runs = multigrid["extra"]["solve_speedup_runs"]
    assert len(runs) == 2 and all(r > 0.0 for r in runs)
    # Each block timed its own frame: the runs' ratios bracket the ratio over both frames.
    assert min(runs) <= multigrid["extra"]["solve_speedup_over_block_jacobi"] <= max(runs)
    text = format_tables(result)
    assert f"(median {sum(runs) / 2:.2f}, {min(runs):.2f}-{max(runs):.2f})" in text


def test_scaled_reference_steps_leave_the_fast_paths_whole_frames() -> None:
    """The largest size times the reference path by single steps scaled to a frame, and the fast
    paths by whole frames: timed as frames of one step each, multigrid would recompute its
    whole hierarchy at every step (a refresh per frame), which no 4-step frame does."""
    from bench.solver_bench import SUBSTEPS, Size, measure_size, sheet_document
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    scene = resolve_scene(parse_shot(sheet_document(32)), Path.cwd())
    (fast, multigrid), reference, _ = measure_size(scene, Size("sheet-1k", 32, 1, reference_steps=1), threads=1)
    assert (fast.measured, multigrid.measured) == ("1 frame", "1 frame")
    assert reference.measured == f"1 of {SUBSTEPS} steps, scaled"
    assert multigrid.extra["multigrid_refreshes_per_step"] == 1.0 / SUBSTEPS
    # The scaled step stands for a frame: per-frame figures of the same order as the fast paths'.
    assert reference.cg_iterations_per_step > 0 and reference.solve_s_per_frame > 0.0
