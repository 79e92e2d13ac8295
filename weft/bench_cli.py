"""`weft bench ...`: performance measurements (registered into the main app by weft/cli.py)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.console import Console
from rich.table import Table

bench_app = typer.Typer(name="bench", help="Performance benchmarks.", no_args_is_help=True)
out = Console()


@bench_app.command("solver")
def solver(
    threads: Annotated[int, typer.Option("--threads", min=1, max=256, help="Solver threads")] = 2,
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Also write every figure as JSON here")] = None,
    quick: Annotated[bool, typer.Option("--quick", help="Two small sheets only (a smoke test)")] = False,
) -> None:
    """Fast vs reference linear system on 10k-640k vertex sheets (the seed's Table 1 shape)."""
    from bench.solver_bench import main

    main(threads=threads, json_path=json_path, quick=quick)


@bench_app.command("ccd")
def bench_ccd(
    queries: Annotated[int, typer.Option("--queries", min=1000, help="Randomized queries per kind")] = 100_000,
    sizes: Annotated[str, typer.Option("--sizes", help="Twisting-sheet grid sizes n (n x n vertices)")] = "8,12,16,24",
    frames: Annotated[int, typer.Option("--frames", min=3, help="Frames of the twist (full turn)")] = 121,
    substeps: Annotated[int, typer.Option("--substeps", min=1)] = 2,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256)] = 1,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
) -> None:
    """CCD queries per second and false negatives on the randomized exact-truth set; per-frame
    collision cost against vertex count on the twisting sheet."""
    from weft.bench_ccd import prefer_passive_openmp

    prefer_passive_openmp()
    from weft.bench_ccd import query_benchmark, twist_benchmark

    query_rows = query_benchmark(queries, threads)
    size_list = [int(s) for s in sizes.split(",") if s.strip()]
    twist_rows = twist_benchmark(size_list, frames, substeps, threads) if size_list else []
    if as_json:
        out.print_json(json.dumps({"queries": query_rows, "twist": twist_rows}))
        return
    table = Table(title=f"CCD queries ({threads} thread(s))", title_justify="left")
    for column in ("query", "queries", "queries/s", "false negatives", "false positives", "FP rate", "mean boxes"):
        table.add_column(column, justify="right")
    for r in query_rows:
        table.add_row(r["query"], str(r["queries"]), f"{r['queries_per_second']:,.0f}", str(r["false_negatives"]),
                      str(r["false_positives"]), f"{r['false_positive_rate']:.4f}", f"{r['mean_boxes']:.1f}")
    out.print(table)
    if twist_rows:
        table = Table(title=f"Twisting sheet, {frames} frames x {substeps} substeps", title_justify="left")
        for column in ("vertices", "collision s/frame", "max", "broad/prox/ccd/resp", "total s/frame", "CCD hits",
                       "zones", "max intersections"):
            table.add_column(column, justify="right")
        for r in twist_rows:
            table.add_row(str(r["vertices"]), f"{r['collision_seconds_per_frame']:.4f}",
                          f"{r['collision_seconds_max']:.4f}",
                          "/".join(f"{v:.4f}" for v in r["broad_proximity_ccd_response_per_frame"]),
                          f"{r['total_seconds_per_frame']:.4f}", str(r["ccd_hits"]), str(r["impact_zones"]),
                          str(r["max_intersections"]))
        out.print(table)


@bench_app.command("gia")
def bench_gia(
    sizes: Annotated[str, typer.Option("--sizes", help="Bone-sheet grid sizes n (n x n vertices)")] = "21,41,81,161",
    frames: Annotated[int, typer.Option("--frames", min=1, help="Frames per scaling run")] = 4,
    threads: Annotated[int, typer.Option("--threads", min=1, max=256)] = 2,
    cases: Annotated[bool, typer.Option("--cases/--no-cases", help="Also run the hard cases")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
) -> None:
    """GIA seconds against vertex count, and GIA's share of the frame on the hard cases. GIA runs
    in a step only while the state may be in intersection (docs/intersection-analysis.md), so
    "frame 1" holds at least one full analysis and "per step" is the average a shot pays."""
    from weft.bench_ccd import prefer_passive_openmp

    prefer_passive_openmp()
    from weft.bench_gia import hard_case_benchmark, scaling_benchmark

    size_list = [int(s) for s in sizes.split(",") if s.strip()]
    scaling = scaling_benchmark(size_list, frames, threads) if size_list else []
    hard = hard_case_benchmark(threads) if cases else []
    if as_json:
        out.print_json(json.dumps({"scaling": scaling, "cases": hard}))
        return
    for title, rows in ((f"GIA against vertex count ({threads} thread(s))", scaling),
                        (f"GIA on the hard cases ({threads} thread(s))", hard)):
        if not rows:
            continue
        table = Table(title=title, title_justify="left")
        for column in ("case", "vertices", "frames", "GIA ms frame 1", "GIA ms/step", "total ms/frame", "GIA share",
                       "max coloured", "max paths", "intersections first/last"):
            table.add_column(column, justify="right")
        for r in rows:
            first, last = r["intersections_first_last"]
            table.add_row(r["case"], str(r["vertices"]), str(r["frames"]), f"{1e3 * r['gia_seconds_first_frame']:.1f}",
                          f"{1e3 * r['gia_seconds_per_step']:.2f}",
                          f"{1e3 * r['total_seconds_per_frame']:.1f}", f"{100 * r['gia_share']:.1f} %",
                          str(r["max_coloured_vertices"]), str(r["max_paths"]), f"{first}/{last}")
        out.print(table)
