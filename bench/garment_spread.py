"""The garment demo's walking skirt (`scenes.garment.skirt_walk`, the scene of
tests/scenes/test_garment_demo.py) on copies whose cloth thickness is scaled down: per copy the
largest edge strain of any simulated frame (the test asks < 1.5, the issue's bound), the frames
ending with cloth vertices inside a body part and s/frame.

The skirt is chaotic like the contact bench's dresses: its largest strain is a handful of edges
in one frame and moves with the last bits of any change to the solver, so the test's one run
neither shows nor disproves a change (docs/collisions.md, thirty-first session). The copies are
thinner only: the waistband is pinned at the thickness from the hips, and a thicker cloth would
leave the pins no room (`weft validate` refuses it).

    python -m bench.garment_spread [--copies 8] [--threads 2] [--module PATH] [--json PATH]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared 2-core machines

import argparse  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from bench.solver_module import add_module_option, load_module_option  # noqa: E402
from bench.stats import write_json  # noqa: E402

# Thickness factors of the copies lie in [1 - SPREAD, 1); the unperturbed run (factor 1) is first.
SPREAD = 0.14


def factors(copies: int) -> list[float]:
    """1, then `copies` factors evenly spaced from 1 - SPREAD up to below 1."""
    return [1.0] + [float(f) for f in np.linspace(1.0 - SPREAD, 1.0, copies + 1)[:-1]]


def run_copy(factor: float, threads: int, directory: Path) -> dict[str, Any]:
    """The walking skirt with its cloth thickness scaled by `factor`: its figures."""
    import yaml

    from bench.contact import run_weft
    from bench.contact_metrics import BodyTrack, ContactGeometry
    from bench.contact_robustness import scale_thickness
    from scenes.garment import skirt_walk
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    path = skirt_walk(directory)
    document = yaml.safe_load(path.read_text())
    scale_thickness(document, factor)
    scene = resolve_scene(parse_shot(document), directory)
    frames = scene.shot.frame_range[1] - scene.shot.frame_range[0] + 1
    run = run_weft(scene, frames, threads)
    geometry = ContactGeometry([BodyTrack(b.name, b.faces, b.frames) for b in scene.bodies])
    inside = [int(geometry.inside(x, k)[0].sum()) for k, x in enumerate(run["positions"])]
    strains = [float(t.max_edge_strain) for t in run["telemetry"]]
    seconds = run["frame_seconds"]
    return {"factor": factor, "max_strain": max(strains, default=float("nan")),
            "frames_over_1_5": sum(s >= 1.5 for s in strains),
            "frames_with_inside": sum(n > 0 for n in inside), "inside_max": max(inside, default=0),
            "seconds_per_frame": float(np.mean(seconds)) if len(seconds) else float("nan"),
            "failure": run["failure"]}


def main(argv: list[str] | None = None) -> int:
    from rich.console import Console
    from rich.table import Table

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--copies", type=int, default=8, help="thinner copies besides the unperturbed run (default 8)")
    parser.add_argument("--threads", type=int, default=2)
    add_module_option(parser)
    parser.add_argument("--json", type=Path, help="also write the copies' figures here")
    args = parser.parse_args(argv)
    for option, value, least in (("--copies", args.copies, 0), ("--threads", args.threads, 1)):
        if value < least:
            parser.error(f"{option} must be at least {least}")
    load_module_option(parser, args.module)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, factor in enumerate(factors(args.copies)):
            rows.append(run_copy(factor, args.threads, Path(tmp) / f"copy_{k}"))
    table = Table(title=f"walking skirt, {len(rows)} runs, {args.threads} thread(s) (test and issue bound: strain < 1.5)")
    for column in ("thickness factor", "max strain", "frames >= 1.5", "frames with inside", "inside max", "s/frame",
                   "failure"):
        table.add_column(column)
    for row in rows:
        table.add_row(f"{row['factor']:.3f}", f"{row['max_strain']:.3f}", str(row["frames_over_1_5"]),
                      str(row["frames_with_inside"]), str(row["inside_max"]), f"{row['seconds_per_frame']:.3f}",
                      row["failure"] or "")
    strains = [row["max_strain"] for row in rows]
    table.add_section()
    table.add_row("all", f"{max(strains):.3f}", f"{sum(s >= 1.5 for s in strains)} of {len(rows)} runs",
                  str(sum(row["frames_with_inside"] for row in rows)), str(max(row["inside_max"] for row in rows)),
                  f"{np.median([row['seconds_per_frame'] for row in rows]):.3f}",
                  str(sum(row["failure"] is not None for row in rows)))
    Console(width=140).print(table)
    if args.json:
        write_json(args.json, {"copies": rows})
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
