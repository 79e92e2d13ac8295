"""`weft report speed-error`: what a setting costs in time and what it buys in accuracy.

For each scene, every sweep point (the shot as submitted with one setting changed, or a few
together) runs `repeats` times in this process; its cost is the median wall seconds per frame,
its error the worst per-frame RMS distance (mm) of the sampled vertices from the scene's
converged reference (`regress.references`). Output: a table, a Pareto-front plot per scene
(PNG), JSON, and per scene the cheapest point whose error is within a stated bound.

The settings swept are those a shot can set that trade time for error: substeps per frame, the
CG tolerance, the preconditioner, the matrix precision and the linear path. (Collision passes
and thickness are not swept: thickness is the cloth's, and the pass counts are not shot
settings.)
"""

from __future__ import annotations

import json
import statistics
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from regress import references
from regress.judge import position_errors
from regress.runs import resolve, run_here, write_shot

# (label, top-level shot overrides); substeps are multiples of the shot's own (x0.5 ... x2).
SWEEP: list[tuple[str, dict[str, Any]]] = [
    ("defaults", {}),
    ("substeps x0.5", {"substeps": 0.5}),
    ("substeps x0.25", {"substeps": 0.25}),
    ("substeps x2", {"substeps": 2.0}),
    ("CG 1e-2", {"solver": {"cg_tolerance": 1e-2}}),
    ("CG 1e-5", {"solver": {"cg_tolerance": 1e-5}}),
    ("block Jacobi", {"solver": {"preconditioner": "block_jacobi"}}),
    ("multigrid", {"solver": {"preconditioner": "multigrid"}}),
    ("float64", {"solver": {"matrix_precision": "float64"}}),
    ("reference path", {"solver": {"linear_system": "reference"}}),
    ("substeps x0.5, CG 1e-2", {"substeps": 0.5, "solver": {"cg_tolerance": 1e-2}}),
    ("substeps x2, CG 1e-2", {"substeps": 2.0, "solver": {"cg_tolerance": 1e-2}}),
]


@dataclass
class Point:
    scene: str
    label: str
    substeps: int
    settings: dict[str, Any]
    s_per_frame: float | None
    error_rms_mm: float | None
    error_max_mm: float | None
    failure: str | None
    pareto: bool = False


def overrides_for(base_substeps: int, change: dict[str, Any]) -> dict[str, Any]:
    out = {k: v for k, v in change.items() if k != "substeps"}
    if "substeps" in change:
        out["substeps"] = max(1, int(round(base_substeps * change["substeps"])))
    return out


def measure(scene_name: str, label: str, change: dict[str, Any], base_substeps: int, work: Path, repeats: int,
            threads: int) -> Point:
    overrides = overrides_for(base_substeps, change)
    scene = resolve(write_shot(scene_name, work / label.replace(" ", "_").replace(",", ""), overrides))
    reference = references.load(scene_name)
    seconds, run = [], None
    for _ in range(repeats):
        run = run_here(scene, threads)
        if run.failure:
            break
        seconds.append(float(np.sum(run.telemetry["total_seconds"])) / max(len(run.positions) - 1, 1))
    assert run is not None
    settings = {"substeps": scene.shot.substeps, **overrides.get("solver", {})}
    if run.failure or not np.isfinite(run.positions).all():
        return Point(scene_name, label, scene.shot.substeps, settings, None, None, None, run.failure or "non-finite positions")
    rms, worst = position_errors(scene_name, scene, run, reference)
    return Point(scene_name, label, scene.shot.substeps, settings, statistics.median(seconds), float(np.max(rms)),
                 float(np.max(worst)), None)


def mark_pareto(points: list[Point]) -> None:
    """A point is on the front when no other is at most as slow and at most as wrong, and
    strictly better in one."""
    done = [p for p in points if p.s_per_frame is not None and p.error_rms_mm is not None]
    for p in done:
        p.pareto = not any(
            q is not p and q.s_per_frame <= p.s_per_frame and q.error_rms_mm <= p.error_rms_mm  # type: ignore[operator]
            and (q.s_per_frame < p.s_per_frame or q.error_rms_mm < p.error_rms_mm)  # type: ignore[operator]
            for q in done)


def cheapest_within(points: list[Point], within_mm: float) -> Point | None:
    ok = [p for p in points if p.error_rms_mm is not None and p.error_rms_mm <= within_mm]
    return min(ok, key=lambda p: p.s_per_frame) if ok else None  # type: ignore[arg-type, return-value]


def plot(scene_name: str, points: list[Point], within_mm: float, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    done = [p for p in points if p.s_per_frame is not None]
    def y(p: Point) -> float:
        return max(p.error_rms_mm or 0.0, 1e-4)  # mm: a log axis shows an exact match at this floor

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=110)
    ax.scatter([p.s_per_frame for p in done], [y(p) for p in done], color="0.55", zorder=2)
    front = sorted((p for p in done if p.pareto), key=lambda p: p.s_per_frame)  # type: ignore[arg-type, return-value]
    ax.plot([p.s_per_frame for p in front], [y(p) for p in front], "o-", color="tab:blue", zorder=3,
            label="Pareto front")
    for p in done:
        ax.annotate(p.label, (p.s_per_frame, y(p)), fontsize=7, xytext=(4, 3), textcoords="offset points")
    ax.axhline(within_mm, color="tab:red", linestyle="--", linewidth=0.8, label=f"{within_mm:g} mm")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall seconds per frame (median)")
    ax.set_ylabel("position error vs converged, worst frame RMS (mm)")
    ax.set_title(f"{scene_name}: speed against error")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def run(scenes: list[str], out: Path, repeats: int, threads: int, within_mm: float, log: Any) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    report: dict[str, Any] = {"within_mm": within_mm, "repeats": repeats, "threads": threads, "scenes": {}}
    with tempfile.TemporaryDirectory(prefix="weft-speed-error-") as tmp:
        for name in scenes:
            points = []
            base_substeps = resolve(write_shot(name, Path(tmp) / name / "base")).shot.substeps
            for label, change in SWEEP:
                log(f"{name}: {label}")
                points.append(measure(name, label, change, base_substeps, Path(tmp) / name, repeats, threads))
            mark_pareto(points)
            best = cheapest_within(points, within_mm)
            plot(name, points, within_mm, out / f"speed_error_{name}.png")
            report["scenes"][name] = {"points": [asdict(p) for p in points],
                                      "cheapest_within": asdict(best) if best else None,
                                      "plot": str(out / f"speed_error_{name}.png")}
    (out / "speed_error.json").write_text(json.dumps(report, indent=2) + "\n")
    return report
