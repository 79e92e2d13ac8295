"""References of the regression scenes (`weft regress --update-references`).

A reference is the scene run converged: 4x the shot's substeps, CG to a relative residual of
1e-8, float64 values, the reference (Eigen) linear path. Stored compactly in the scene's folder:
`reference.npz` holds the positions of an evenly spaced subset of at most 1,024 cloth vertices at
every frame (float32), `reference.json` how it was made (the converged run on one thread, so
it is the same every time) and the baseline counts of the scene as
submitted (default settings): CG iterations per substep, CCD candidates and collision passes per
frame, which `weft regress` compares instead of wall time. Analytic scenes store no positions:
their reference is the formula (`analytic_positions`).
"""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

from regress.runs import Run, resolve, run_here, write_shot
from scenes.regression import ANALYTIC, scene_folder

MAX_SAMPLED_VERTICES = 1024
CONVERGED_SUBSTEP_FACTOR = 4
CONVERGED_SOLVER = {"cg_tolerance": 1e-8, "cg_max_iterations": 20000, "matrix_precision": "float64",
                    "linear_system": "reference"}
COUNTS = ("cg_iterations_per_substep", "ccd_candidates_per_frame", "collision_iterations_per_frame")


def sampled_vertices(vertex_count: int) -> np.ndarray:
    return np.unique(np.linspace(0, vertex_count - 1, min(vertex_count, MAX_SAMPLED_VERTICES)).round().astype(np.int64))


def counts(run: Run) -> dict[str, float]:
    """Load-independent cost figures of a run (means over its simulated frames)."""
    t = run.telemetry
    if not t or len(t["substeps"]) == 0:
        return {name: 0.0 for name in COUNTS}
    return {
        "cg_iterations_per_substep": float(t["cg_iterations"].sum() / max(t["substeps"].sum(), 1)),
        "ccd_candidates_per_frame": float(t["ccd_candidates"].mean()),
        "collision_iterations_per_frame": float(t["collision_iterations"].mean()),
    }


def analytic_positions(name: str, scene: Any) -> np.ndarray:
    """Free fall: x(t) = x0 + g t^2 / 2 at every frame of the shot."""
    if name != "free_fall":
        raise KeyError(f"no formula for scene {name}")
    shot = scene.shot
    t = np.arange(shot.frame_count) / shot.fps
    g = np.asarray(shot.environment.gravity, dtype=np.float64)
    return scene.positions[None, :, :] + 0.5 * (t[:, None, None] ** 2) * g[None, None, :]


def load(name: str) -> dict[str, Any]:
    """The stored reference: its metadata, and its sampled positions unless analytic."""
    folder = scene_folder(name)
    meta_path = folder / "reference.json"
    if not meta_path.is_file():
        raise FileNotFoundError(f"scene {name} has no reference ({meta_path}); run `weft regress --update-references`")
    meta = json.loads(meta_path.read_text())
    if name not in ANALYTIC:
        with np.load(folder / "reference.npz") as data:
            meta["vertices"] = data["vertices"]
            meta["positions"] = data["positions"].astype(np.float64)
    return meta


def update(name: str, work: Path, threads: int = 2) -> tuple[dict[str, Any], Any, Run]:
    """Runs the scene as submitted (for its counts) and converged (for its positions) and writes
    the reference files; returns the metadata written, the scene as submitted and its run."""
    from weft import __version__

    plain = resolve(write_shot(name, work / "plain"))
    default_run = run_here(plain, threads)
    if default_run.failure:
        raise RuntimeError(f"scene {name} failed with default settings: {default_run.failure}")
    meta: dict[str, Any] = {
        "scene": name,
        "made_by": "weft regress --update-references",
        "weft_version": __version__,
        "made_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": platform.machine(),
        "baseline_counts": counts(default_run),
        "frames": int(plain.shot.frame_count),
    }
    folder = scene_folder(name)
    if name in ANALYTIC:
        meta["reference"] = "analytic"
    else:
        overrides = {"substeps": plain.shot.substeps * CONVERGED_SUBSTEP_FACTOR, "solver": CONVERGED_SOLVER}
        converged = resolve(write_shot(name, work / "converged", overrides))
        start = time.perf_counter()
        # One thread: the reference path's Eigen CG sums in a thread-dependent order, and a
        # reference must come out the same every time it is made.
        run = run_here(converged, 1)
        if run.failure:
            raise RuntimeError(f"scene {name} failed converged: {run.failure}")
        vertices = sampled_vertices(plain.vertex_count)
        np.savez_compressed(folder / "reference.npz", vertices=vertices,
                            positions=run.positions[:, vertices].astype(np.float32))
        meta["reference"] = {"substeps": converged.shot.substeps, "solver": CONVERGED_SOLVER,
                             "sampled_vertices": int(len(vertices)), "seconds": round(time.perf_counter() - start, 2)}
    (folder / "reference.json").write_text(json.dumps(meta, indent=2) + "\n")
    return meta, plain, default_run
