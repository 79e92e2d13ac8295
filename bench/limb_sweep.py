"""The thin limb (`scenes.contact.thin_limb`: a hanging sheet a limb sweeps through) over variants
of the limb's speed and thickness, the cloth's friction and the substeps: per variant the
largest edge strain of any frame, the strain of the last frame (the limb stands from frame 6
at 3 m/s: a sheet it carried stays stretched) and s/frame. One scene is chaotic; a rule for
cloth on fast bodies is judged over these variants (docs/collisions.md, twenty-fourth session).

    python -m bench.limb_sweep [--frames 12] [--threads 1] [--cg-tolerance T] [--json out/limb_sweep.json]

`--module PATH` runs a solver module built elsewhere (bench.module_ab.load_module), to compare
two builds variant by variant. `--cg-tolerance T` runs every variant at that CG tolerance: the
thin limb's strain moves with the solver's own error as much as with a rule (twenty-fifth
session, docs/collisions.md), so a rule is judged at more than one tolerance.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from bench.solver_module import add_module_option, load_module_option

# Keyword arguments of scenes.contact.thin_limb; {} is the bench scene itself.
VARIANTS: list[dict[str, Any]] = [
    {},
    {"friction": 0.6},
    {"friction": 0.0},
    {"speed": 2.5},
    {"speed": 4.0},
    {"substeps": 6},
    {"limb_radius": 0.01},
]


def run_variant(variant: dict[str, Any], frames: int, threads: int, directory: Path,
                cg_tolerance: float | None = None) -> dict[str, Any]:
    from bench.contact import run_weft
    from scenes.contact import thin_limb
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    shot = thin_limb(directory, frames=frames, **variant)
    if cg_tolerance is not None:
        shot.setdefault("solver", {})["cg_tolerance"] = cg_tolerance
    scene = resolve_scene(parse_shot(shot), directory)
    run = run_weft(scene, frames, threads)
    strains = [float(t.max_edge_strain) for t in run["telemetry"]]
    seconds = run["frame_seconds"]
    return {"variant": variant, "cg_tolerance": scene.shot.solver.cg_tolerance, "strain_per_frame": strains, "max_strain": max(strains, default=float("nan")),
            "last_strain": strains[-1] if strains else float("nan"),
            "seconds_per_frame": float(np.mean(seconds)) if len(seconds) else float("nan"), "failure": run["failure"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=12, help="frames per run, the first included (default 12)")
    parser.add_argument("--threads", type=int, default=1)
    add_module_option(parser)
    parser.add_argument("--cg-tolerance", type=float,
                        help="solver.cg_tolerance of every variant (default: the shot's); the spread between "
                             "tolerances is how far a rule's figures move with the solver's own error")
    parser.add_argument("--json", type=Path, help="write the rows here")
    args = parser.parse_args(argv)
    if args.frames < 2:
        parser.error("--frames must be at least 2")
    if args.threads < 1:
        parser.error("--threads must be at least 1")
    if args.cg_tolerance is not None and not 0.0 < args.cg_tolerance < 1.0:
        parser.error("--cg-tolerance must be between 0 and 1 (exclusive)")
    load_module_option(parser, args.module)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, variant in enumerate(VARIANTS):
            rows.append(run_variant(variant, args.frames, args.threads, Path(tmp) / f"variant_{k}", args.cg_tolerance))
    tolerance = f", CG tolerance {args.cg_tolerance:g}" if args.cg_tolerance is not None else ""
    table = Table(title=f"thin limb variants, {args.frames} frames, {args.threads} thread(s){tolerance}")
    for column in ("variant", "max strain", "last frame", "s/frame", "failure"):
        table.add_column(column)
    for row in rows:
        name = ", ".join(f"{key} {value}" for key, value in row["variant"].items()) or "bench scene"
        table.add_row(name, f"{row['max_strain']:.2f}", f"{row['last_strain']:.2f}",
                      f"{row['seconds_per_frame']:.3f}", row["failure"] or "")
    Console(width=140).print(table)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(rows, indent=1))
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
