"""`weft report stability`: where the solver stays finite and bounded.

Small scenes (`scenes.stability`) over maps of two settings at a time, the others at their
defaults: stretch stiffness (20 N/m .. 2e6 N/m, a stiffness ratio of 1e1 .. 1e6 against the
softest) against the time step (1 .. 40 substeps at 24 fps: 1/24 .. 1/960 s), and likewise mass
density, pin speed and body speed (0.1 .. 30 m/s). Each cell is a run of 12 frames, classed:

- ok: finite, every edge within 1.5x its rest length, speeds bounded;
- strain: finite, some edge longer than 1.5x its rest length (a fast pin or body may force it);
- fast: finite, a vertex faster than twice the drivers' speed plus free fall plus 1 m/s;
- failed@F: the solver stopped cleanly at frame F with a reason (a failed job, never a NaN);
- NaN: non-finite positions got out - must never happen.
"""

from __future__ import annotations

import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from scenes.stability import stability_shot

SUBSTEPS = [1, 4, 10, 40]
MAPS: dict[str, tuple[str, list[float]]] = {
    "stiffness": ("stretch", [20.0, 200.0, 2e3, 2e4, 2e5, 2e6]),
    "density": ("density", [0.01, 0.1, 1.0, 10.0]),
    "pin_speed": ("pin_speed", [0.1, 1.0, 3.0, 10.0, 30.0]),
    "body_speed": ("body_speed", [0.1, 1.0, 3.0, 10.0, 30.0]),
}
FRAMES = 12
FPS = 24.0


@dataclass
class Cell:
    value: float
    substeps: int
    status: str
    frame: int | None
    reason: str | None
    max_strain: float | None
    max_speed: float | None


def classify(value_name: str, value: float, substeps: int, work: Path, threads: int = 1) -> Cell:
    import json

    from bench.contact_metrics import edge_rest_lengths, max_edge_strain
    from regress.runs import resolve, run_here

    directory = work / f"{value_name}_{value:g}_{substeps}"
    doc = stability_shot(directory, substeps=substeps, frames=FRAMES, fps=FPS, **{value_name: value})
    (directory / "shot.json").write_text(json.dumps(doc))
    scene = resolve(directory / "shot.json")
    run = run_here(scene, threads)
    if not np.isfinite(run.positions).all():
        return Cell(value, substeps, "NaN", None, None, None, None)
    rest = edge_rest_lengths(scene.face_uv)
    strain = max(max_edge_strain(x, scene.faces, rest) for x in run.positions)
    speed = float(np.max(np.linalg.norm(np.diff(run.positions, axis=0), axis=2)) * FPS) if len(run.positions) > 1 else 0.0
    if run.failure:
        frame = int(run.failure.split(":")[0].split()[-1]) if run.failure.startswith("frame ") else None
        return Cell(value, substeps, f"failed@{frame}", frame, run.failure, strain, speed)
    drivers = max(doc_speed(value_name, value), 0.0)
    bound = 2.0 * drivers + 9.81 * FRAMES / FPS + 1.0
    status = "fast" if speed > bound else ("strain" if strain > 1.5 else "ok")
    return Cell(value, substeps, status, None, None, strain, speed)


def doc_speed(value_name: str, value: float) -> float:
    return value if value_name in ("pin_speed", "body_speed") else 0.0


def run(maps: list[str], log: Any) -> dict[str, Any]:
    report: dict[str, Any] = {"frames": FRAMES, "fps": FPS, "substeps": SUBSTEPS, "maps": {}}
    with tempfile.TemporaryDirectory(prefix="weft-stability-") as tmp:
        for name in maps:
            value_name, values = MAPS[name]
            log(f"map {name}: {len(values)} x {len(SUBSTEPS)} runs")
            cells = [classify(value_name, v, s, Path(tmp)) for v in values for s in SUBSTEPS]
            report["maps"][name] = {"setting": value_name, "values": values, "cells": [asdict(c) for c in cells]}
    return report
