"""`weft bench gia`: the cost of global intersection analysis in the step. Per-step GIA seconds
against vertex count (a sheet over a thin bone, tangled and clean), and GIA's share of the frame
on the hard cases of docs/intersection-analysis.md. Figures come from the solver's own per-frame
telemetry (gia_seconds, total_seconds), so they are the costs a shot pays."""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def run_shot(doc: dict[str, Any], base_dir: Path | None, threads: int) -> dict[str, Any]:
    """Simulates a shot document; returns per-frame GIA and total seconds and GIA counts."""
    from weft.shot import parse_shot
    from weft.simulate import simulate
    from weft.solver_setup import resolve_scene

    scene = resolve_scene(parse_shot(doc), base_dir or Path("."))
    substeps = scene.shot.substeps
    gia, total, coloured, paths, intersections = [], [], 0, 0, []
    for _, _, t in simulate(scene, threads=threads):
        gia.append(t.gia_seconds)
        total.append(t.total_seconds)
        coloured = max(coloured, t.gia_coloured_vertices)
        paths = max(paths, t.gia_paths)
        intersections.append(t.intersections)
    return {
        "vertices": int(sum(p.vertex_count for p in scene.pieces)),
        "frames": len(gia),
        "substeps": substeps,
        "gia_seconds_first_frame": float(gia[0]),
        "gia_seconds_per_frame": float(np.mean(gia)),
        "gia_seconds_per_step": float(np.mean(gia)) / substeps,
        "total_seconds_per_frame": float(np.mean(total)),
        "gia_share": float(np.sum(gia) / np.sum(total)),
        "max_coloured_vertices": coloured,
        "max_paths": paths,
        "intersections_first_last": [intersections[0], intersections[-1]],
    }


def scaling_benchmark(sizes: list[int], frames: int, threads: int) -> list[dict[str, Any]]:
    """Sheets of n x n vertices over the bone, with a patch pushed in (tangled) and without
    (clean, GIA forced on: the cost of analysing a scene that has nothing to recover)."""
    from scenes.gia import bone_shot

    rows = []
    for n in sizes:
        for tangled in (True, False):
            doc = bone_shot(n=n, frames=frames + 1, patch=tangled, gia=True)
            row = run_shot(doc, None, threads)
            row["case"] = "bone, patch in" if tangled else "bone, clean"
            rows.append(row)
    return rows


def hard_cases() -> dict[str, Callable[[Path], dict[str, Any]]]:
    """The issue's hard cases, each a function of a scratch directory returning a shot."""
    from scenes.collision import box_pinch_shot, sleeve_shot
    from scenes.gia import bone_shot, fold_shot, through_shot, two_sheets_shot

    return {
        "bone: patch 7 mm in (21x21)": lambda d: bone_shot(n=21, frames=13),
        "bone: 3 rows past the axis (41x41)": lambda d: bone_shot(n=41, half_width=0.0075, depth=-0.003, frames=13),
        "bone: patch wholly through (21x21)": lambda d: through_shot(frames=13),
        "sleeve on a fast limb, GIA on": lambda d: {**sleeve_shot(d, frames=13), "features": {"gia": True}},
        "sleeve on a fast limb, GIA off": lambda d: {**sleeve_shot(d, frames=13), "features": {"gia": False}},
        "cloth pinched between two boxes (16x16)": lambda d: box_pinch_shot(d),
        "fold pushed through its own layer (31x21)": lambda d: fold_shot(frames=13),
        "fold pushed through its own layer (61x41)": lambda d: fold_shot(frames=13, k=2),
        "small sheet partly through a larger one": lambda d: two_sheets_shot(frames=13),
    }


def hard_case_benchmark(threads: int, only: str | None = None) -> list[dict[str, Any]]:
    rows = []
    for name, make in hard_cases().items():
        if only and only not in name:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            row = run_shot(make(Path(tmp)), Path(tmp), threads)
        row["case"] = name
        rows.append(row)
    return rows


def main(sizes: list[int] | None = None, frames: int = 4, threads: int = 2, cases: bool = True,
         as_json: bool = False) -> None:
    """Runs the scaling runs and the hard cases and prints their tables (or one JSON document)."""
    from rich.console import Console
    from rich.table import Table

    out = Console()
    scaling = scaling_benchmark(sizes, frames, threads) if sizes else []
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
