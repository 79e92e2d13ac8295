"""`weft bench ccd`: CCD query throughput and false negatives on the randomized exact-truth set
(bench.ccd_queries), and the per-frame collision cost against vertex count on the twisting sheet
(scenes.collision.twist_shot)."""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np


def query_benchmark(count: int, threads: int, seed: int = 7) -> list[dict[str, Any]]:
    from weft import _solver
    from bench.ccd_queries import make_queries

    rng = np.random.default_rng(seed)
    rows = []
    for edge_edge in (False, True):
        qs = make_queries(rng, count, edge_edge, scale_exponents=(-300, -40, 0, 0, 0, 40, 300), far_fraction=0.1)
        batch = _solver.edge_edge_ccd_batch if edge_edge else _solver.vertex_triangle_ccd_batch
        start = time.perf_counter()
        hit, toi, boxes = batch(qs.start, qs.end, threads=threads)
        seconds = time.perf_counter() - start
        misses = ~qs.hit
        rows.append({
            "query": "edge-edge" if edge_edge else "vertex-triangle",
            "queries": len(qs),
            "threads": threads,
            "seconds": seconds,
            "queries_per_second": len(qs) / seconds,
            "hits_true": int(qs.hit.sum()),
            "false_negatives": int(np.sum(qs.hit & ~hit)),
            "false_positives": int(np.sum(misses & hit)),
            "false_positive_rate": float(np.mean(hit[misses])),
            "toi_above_truth": int(np.sum(qs.hit & hit & (toi > qs.t_star))),
            "mean_boxes": float(boxes.mean()),
        })
    return rows


def twist_benchmark(sizes: list[int], frames: int, substeps: int, threads: int) -> list[dict[str, Any]]:
    from scenes.collision import twist_shot
    from weft.shot import parse_shot
    from weft.simulate import simulate
    from weft.solver_setup import resolve_scene

    rows = []
    for n in sizes:
        with tempfile.TemporaryDirectory() as tmp:
            doc = twist_shot(Path(tmp), n=n, frames=frames, substeps=substeps)
            scene = resolve_scene(parse_shot(doc), Path(tmp))
            collision, total, intersections, hits, zones = [], [], 0, 0, 0
            split = np.zeros(4)
            for _, _, t in simulate(scene, threads=threads):
                collision.append(t.collision_seconds)
                total.append(t.total_seconds)
                split += [t.collision_broad_phase_seconds, t.collision_proximity_seconds, t.collision_ccd_seconds,
                          t.collision_response_seconds]
                intersections = max(intersections, t.intersections)
                hits += t.ccd_hits
                zones += t.impact_zones
        frames_run = len(collision)
        rows.append({
            "vertices": n * n,
            "frames": frames_run,
            "substeps": substeps,
            "collision_seconds_per_frame": float(np.mean(collision)),
            "collision_seconds_max": float(np.max(collision)),
            "broad_proximity_ccd_response_per_frame": (split / frames_run).tolist(),
            "total_seconds_per_frame": float(np.mean(total)),
            "ccd_hits": hits,
            "impact_zones": zones,
            "max_intersections": intersections,
        })
    return rows


def main(queries: int = 100_000, sizes: list[int] | None = None, frames: int = 121, substeps: int = 2,
         threads: int = 1, as_json: bool = False) -> None:
    """Runs both benchmarks and prints their tables (or one JSON document)."""
    from rich.console import Console
    from rich.table import Table

    out = Console()
    query_rows = query_benchmark(queries, threads)
    twist_rows = twist_benchmark(sizes, frames, substeps, threads) if sizes else []
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
