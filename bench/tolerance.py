"""Speed against error of the CG tolerance (issue 14's speed-vs-error, the default's evidence).

    python -m bench.tolerance [--scenes hanging_sheet,drape_sphere] [--frames N] [--threads 2] [--json PATH]

Each scene runs once per tolerance in this process, one after the other, with every other
setting at its default. The error of a run is the distance of its vertices from those of the
reference run (the tightest tolerance, `--reference`) at the last frame: RMS and max, in mm.
A second tight run (`--floor`, ten times looser than the reference) shows the floor below which
differences are the scene's own sensitivity, not the tolerance: in contact-rich shots tiny
perturbations grow (which fold a wrinkle takes), so there the error is read against that floor
and against the contact figures (vertices inside, max edge strain) rather than alone.

Scenes:
  hanging_sheet  1 m sheet, 48 x 48 vertices, pinned at its two top corners, swinging down under
                 gravity, no contact: smooth dynamics, the tolerance's error alone.
  drape_sphere   the contact bench's drape (bench/contact.py): 64 x 64 sheet on a sphere.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

DEFAULT_TOLERANCES = (1e-2, 1e-3, 3e-4, 1e-4, 1e-5)


def hanging_sheet(directory: Path, frames: int) -> dict[str, Any]:
    from scenes.builders import sheet_shot

    n = 48
    return sheet_shot("hanging_sheet", n, n, 1.0, 1.0, plane="xz", pins=[n * (n - 1), n * n - 1],
                      frames=frames, substeps=4, air_drag=0.2)


def drape_sphere(directory: Path, frames: int) -> dict[str, Any]:
    from scenes.contact import drape_sphere as build

    return build(directory, frames=frames)


SCENES = {"hanging_sheet": (hanging_sheet, 24), "drape_sphere": (drape_sphere, 24)}


def run(shot: dict[str, Any], directory: Path, tolerance: float, threads: int) -> dict[str, Any]:
    """Simulates the shot at one CG tolerance; the last frame's positions and the timings."""
    from weft.shot import parse_shot
    from weft.simulate import new_simulation, simulate
    from weft.solver_setup import resolve_scene

    shot = {**shot, "solver": {**shot.get("solver", {}), "cg_tolerance": tolerance}}
    scene = resolve_scene(parse_shot(shot), directory)
    sim = new_simulation(scene, threads)
    seconds, solve, iterations, substeps, strain, inside = [], 0.0, 0, 0, 0.0, 0
    start = time.perf_counter()
    for _, _, t in simulate(scene, sim, threads):
        seconds.append(time.perf_counter() - start)
        solve += t.solve_seconds
        iterations += t.cg_iterations
        substeps += t.substeps
        strain = max(strain, t.max_edge_strain)
        inside = max(inside, max(t.intersections, 0))
        start = time.perf_counter()
    frames = len(seconds)
    return {"tolerance": tolerance, "positions": np.array(sim.positions), "seconds_per_frame": sum(seconds) / frames,
            "solve_seconds_per_frame": solve / frames, "cg_iterations_per_substep": iterations / max(substeps, 1),
            "max_edge_strain": strain, "intersections_max": inside}


def compare(rows: list[dict[str, Any]], reference: np.ndarray) -> None:
    for row in rows:
        distance = np.linalg.norm(row["positions"] - reference, axis=1)
        row["rms_error_mm"] = 1e3 * float(np.sqrt(np.mean(distance**2)))
        row["max_error_mm"] = 1e3 * float(distance.max())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(SCENES), help=f"comma-separated subset of {sorted(SCENES)}")
    parser.add_argument("--tolerances", default=",".join(f"{t:g}" for t in DEFAULT_TOLERANCES))
    parser.add_argument("--reference", type=float, default=1e-8, help="the reference run's tolerance")
    parser.add_argument("--frames", type=int, default=None, help="frames per scene, the initial one included")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    names = [s for s in args.scenes.split(",") if s]
    unknown = [s for s in names if s not in SCENES]
    if unknown:
        parser.error(f"unknown scene(s) {unknown}; choose from {sorted(SCENES)}")
    try:
        tolerances = [float(t) for t in args.tolerances.split(",") if t]
    except ValueError:
        parser.error(f"--tolerances: not a comma-separated list of numbers: {args.tolerances!r}")
    if not tolerances or any(not 0.0 < t < 1.0 for t in tolerances) or not 0.0 < args.reference < min(tolerances):
        parser.error("tolerances must lie in (0, 1), the reference below all of them")

    from rich.console import Console
    from rich.table import Table

    results: dict[str, Any] = {}
    for name in names:
        make, default_frames = SCENES[name]
        with tempfile.TemporaryDirectory() as tmp:
            directory = Path(tmp)
            shot = make(directory, args.frames or default_frames)
            print(f"{name} ...", file=sys.stderr)
            reference = run(shot, directory, args.reference, args.threads)
            floor = run(shot, directory, 10 * args.reference, args.threads)
            rows = [run(shot, directory, t, args.threads) for t in tolerances]
        compare([floor, *rows], reference["positions"])
        floor["tolerance_label"] = f"{floor['tolerance']:g} (floor)"
        results[name] = {"reference": reference, "floor": floor, "rows": rows}

        table = Table(title=f"{name}: CG tolerance against error (reference {args.reference:g}, "
                            f"{args.frames or default_frames} frames, {args.threads} threads)")
        for column in ("tolerance", "s/frame", "solve s/frame", "CG it/substep", "RMS err mm", "max err mm",
                       "max strain", "intersections max", "speed-up vs 1e-5"):
            table.add_column(column, justify="right")
        base = next((r for r in rows if r["tolerance"] == 1e-5), None)
        for row in [floor, *rows]:
            speedup = f"{base['seconds_per_frame'] / row['seconds_per_frame']:.2f}" if base else "-"
            table.add_row(row.get("tolerance_label", f"{row['tolerance']:g}"), f"{row['seconds_per_frame']:.3f}",
                          f"{row['solve_seconds_per_frame']:.3f}", f"{row['cg_iterations_per_substep']:.1f}",
                          f"{row['rms_error_mm']:.3f}", f"{row['max_error_mm']:.3f}",
                          f"{row['max_edge_strain']:.3f}", str(row["intersections_max"]), speedup)
        Console().print(table)

    if args.json:
        def plain(row: dict[str, Any]) -> dict[str, Any]:
            return {k: v for k, v in row.items() if k != "positions"}

        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({name: {"reference": plain(r["reference"]), "floor": plain(r["floor"]),
                                                "rows": [plain(x) for x in r["rows"]]}
                                         for name, r in results.items()}, indent=2))
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
