"""A regression run judged against its scene's reference and thresholds.

Thresholds live beside each scene (`scenes/regression/<name>/thresholds.yaml`):

    position_error_mm: {rms: 2.0, max: 8.0}  # per frame, against the reference (sampled vertices)
    inside: 0               # cloth vertices inside a closed body part, any frame
    cloth_body_final: 0     # intersecting cloth/body triangle pairs at the last frame
    self_final: 0           # intersecting cloth/cloth triangle pairs at the last frame
    max_strain: 1.5         # longest edge over its rest length, any frame
    counts_ratio: 1.5       # CG iterations, CCD candidates, collision passes vs the baseline
    energy_growth_j: 1e-6   # where energy is defined (no wind, no moving body or pin): total
                            # energy at any frame above the initial one by more than this

A missing key is not judged. Wall time is reported, never judged: it depends on the machine's
load; the counts do not (the solver's results do not depend on the thread count).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import yaml

from regress import references
from regress.runs import Run
from scenes.regression import ANALYTIC, scene_folder

# Counts may also grow by these absolute amounts (small scenes have few of each).
COUNT_SLACK = {"cg_iterations_per_substep": 2.0, "ccd_candidates_per_frame": 200.0,
               "collision_iterations_per_frame": 1.0}


@dataclass
class Failure:
    scene: str
    metric: str
    frame: int | None
    value: float
    limit: float

    @property
    def message(self) -> str:
        where = f"frame {self.frame}" if self.frame is not None else "whole run"
        return f"{self.scene}: {self.metric} = {self.value:.6g} exceeds {self.limit:.6g} at {where}"


@dataclass
class SceneResult:
    scene: str
    vertices: int
    frames: int
    failures: list[Failure] = field(default_factory=list)
    metrics: dict[str, Any] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not self.failures

    def as_dict(self) -> dict[str, Any]:
        return {"scene": self.scene, "passed": self.passed, "vertices": self.vertices, "frames": self.frames,
                "failures": [{**asdict(f), "message": f.message} for f in self.failures], "metrics": self.metrics}


def thresholds(name: str) -> dict[str, Any]:
    path = scene_folder(name) / "thresholds.yaml"
    if not path.is_file():
        raise FileNotFoundError(f"scene {name} has no thresholds ({path})")
    return yaml.safe_load(path.read_text()) or {}


def position_errors(name: str, scene: Any, run: Run, reference: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Per frame RMS and max distance (mm) of the run from the reference."""
    if name in ANALYTIC:
        expected, vertices = references.analytic_positions(name, scene), slice(None)
    else:
        expected, vertices = reference["positions"], reference["vertices"]
    frames = min(len(run.positions), len(expected))
    distance = np.linalg.norm(run.positions[:frames][:, vertices] - expected[:frames], axis=2) * 1e3
    return np.sqrt(np.mean(distance**2, axis=1)), np.max(distance, axis=1)


def first_over(values: np.ndarray, limit: float) -> int | None:
    """Index of the first value over the limit (NaN counts as over), else None."""
    over = np.flatnonzero(~(np.asarray(values, dtype=np.float64) <= limit))
    return int(over[0]) if len(over) else None


def judge(name: str, scene: Any, run: Run, threads: int = 2) -> SceneResult:
    from bench.contact_metrics import BodyTrack, contact_metrics, edge_rest_lengths

    limits = thresholds(name)
    reference = references.load(name)
    frame0 = scene.shot.frame_range[0]
    result = SceneResult(name, int(scene.vertex_count), int(len(run.positions)))

    def check(metric: str, values: np.ndarray, limit: float | None) -> None:
        if limit is None:
            return
        k = first_over(values, limit)
        if k is not None:
            result.failures.append(Failure(name, metric, frame0 + k, float(values[k]), float(limit)))

    if run.failure:
        result.failures.append(Failure(name, f"run failed ({run.failure})", None, 1.0, 0.0))
    finite = bool(np.isfinite(run.positions).all())
    if not finite:
        bad = int(np.flatnonzero(~np.isfinite(run.positions).all(axis=(1, 2)))[0])
        result.failures.append(Failure(name, "non-finite positions", frame0 + bad, float("nan"), 0.0))
    if len(run.positions) < scene.shot.frame_count:
        result.failures.append(Failure(name, "frames written", None, len(run.positions), scene.shot.frame_count))

    rms, worst = position_errors(name, scene, run, reference)
    error_limits = limits.get("position_error_mm", {})
    check("position error RMS (mm)", rms, error_limits.get("rms"))
    check("position error max (mm)", worst, error_limits.get("max"))

    metrics: dict[str, Any] = {"position_error_rms_mm": float(np.max(rms)), "position_error_max_mm": float(np.max(worst))}
    if finite:
        collidable = [b for b, spec in zip(scene.bodies, scene.shot.bodies) if spec.collide]
        bodies = [BodyTrack(b.name, b.faces, np.asarray(b.frames[:len(run.positions)])) for b in collidable]
        seconds = np.asarray(run.telemetry.get("total_seconds", np.zeros(len(run.positions) - 1)))
        m = contact_metrics(run.positions, scene.faces, edge_rest_lengths(scene.face_uv), bodies, seconds,
                            scene.shot.fps, threads=threads)
        per = m["per_frame"]
        check("vertices inside a body", np.asarray(per["inside"], dtype=float), limits.get("inside"))
        check("max edge strain", np.asarray(per["max_strain"], dtype=float), limits.get("max_strain"))
        for metric, key, values in (("cloth/body intersections at the end", "cloth_body_final", per["cloth_body_pairs"]),
                                    ("self intersections at the end", "self_final", per["cloth_cloth_pairs"])):
            if limits.get(key) is not None and values[-1] > limits[key]:
                result.failures.append(Failure(name, metric, frame0 + len(values) - 1, float(values[-1]), float(limits[key])))
        metrics.update({"inside_max": m["inside_max"], "cloth_body_final": m["cloth_body_pairs_final"],
                        "self_final": m["cloth_cloth_pairs_final"], "max_strain": m["max_strain"]})

    if run.energy is not None and len(run.energy):
        growth = run.energy - run.energy[0]
        metrics["energy_growth_j"] = float(np.max(growth))
        check("energy growth (J)", growth, limits.get("energy_growth_j"))

    measured = references.counts(run)
    baseline = reference.get("baseline_counts", {})
    ratio = limits.get("counts_ratio")
    for key, value in measured.items():
        metrics[key] = value
        if ratio is not None and key in baseline:
            limit = ratio * baseline[key] + COUNT_SLACK[key]
            if value > limit:
                result.failures.append(Failure(name, key.replace("_", " "), None, value, limit))
    simulated = max(len(run.positions) - 1, 1)
    metrics["s_per_frame"] = float(np.sum(run.telemetry.get("total_seconds", 0.0)) / simulated)
    result.metrics = metrics
    return result
