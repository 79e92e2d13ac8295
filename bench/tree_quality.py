"""How far the collision stage's cloth tree drifts from a fresh build as the cloth moves.

The tree over the cloth's triangles is built once, from the shot's first positions, and refitted
at every step after (docs/collisions.md, "The step"): a rebuild would change the order of the
pairs it lists, so a run resumed from a cache would no longer follow the uninterrupted one bit for
bit. This script runs contact scenes (`scenes/contact.py`) and prints, every `--every` frames, the
surface-area cost of the refitted tree against that of a tree built afresh at the same positions
(`Simulation.cloth_tree_quality`): a ratio near 1 means the refit lost nothing a rebuild would win.

    python -m bench.tree_quality [--scenes drape_sphere,layered_dress] [--every 8] [--frames N] [--json PATH]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as bench/contact.py: shared 2-core machines

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

DEFAULT_SCENES = "drape_sphere,drape_sphere_16k,sleeve_swing,walking_dress,layered_dress"


def tree_drift(name: str, frames: int, every: int, threads: int) -> list[dict[str, Any]]:
    """Refitted and fresh tree costs of scene `name` at frame 0 and every `every` frames."""
    from bench.contact import build_scene
    from weft.simulate import advance, new_simulation

    rows = []
    with tempfile.TemporaryDirectory() as directory:
        scene = build_scene(name, Path(directory), frames)
        sim = new_simulation(scene, threads)
        if not sim.collisions_enabled:
            raise SystemExit(f"{name}: the scene has no collision stage")
        for index in range(frames):
            if index > 0:
                advance(sim, scene, index)
            if index % every == 0 or index == frames - 1:
                refitted, fresh = sim.cloth_tree_quality()
                rows.append({"scene": name, "frame": index, "refitted": refitted, "fresh": fresh,
                             "ratio": refitted / fresh})
    return rows


def main(argv: list[str] | None = None) -> int:
    from scenes.contact import SCENES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=DEFAULT_SCENES,
                        help="comma-separated contact scenes (" + ", ".join(SCENES) + ")")
    parser.add_argument("--every", type=int, default=8, help="frames between measurements")
    parser.add_argument("--frames", type=int, default=0,
                        help="frames per scene, the initial one included (default: the scene's)")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", type=Path, help="also write every row here")
    args = parser.parse_args(argv)
    names = [s for s in args.scenes.split(",") if s]
    unknown = [s for s in names if s not in SCENES]
    if not names or unknown:
        parser.error(f"--scenes {args.scenes!r}: unknown or no contact scene (one of {', '.join(SCENES)})")
    if args.every < 1:
        parser.error(f"--every {args.every}: must be at least 1")
    if args.frames == 1 or args.frames < 0:
        parser.error(f"--frames {args.frames}: need at least 2 (the initial frame and one simulated)")
    if args.threads < 1:
        parser.error(f"--threads {args.threads}: must be at least 1")

    from rich.console import Console
    from rich.table import Table

    from bench.contact import DEFAULT_FRAMES

    rows: list[dict[str, Any]] = []
    for name in names:
        print(f"{name} ...", file=sys.stderr, flush=True)
        rows += tree_drift(name, args.frames or DEFAULT_FRAMES[name], args.every, args.threads)
    table = Table(title="cloth tree: surface-area cost refitted vs built afresh at the same positions")
    for column in ("scene", "frame", "refitted", "fresh", "refitted / fresh"):
        table.add_column(column, justify="left" if column == "scene" else "right")
    for row in rows:
        table.add_row(row["scene"], str(row["frame"]), f"{row['refitted']:.3f}", f"{row['fresh']:.3f}",
                      f"{row['ratio']:.3f}")
    Console().print(table)
    worst = max(rows, key=lambda r: r["ratio"])
    print(f"largest ratio {worst['ratio']:.3f} ({worst['scene']}, frame {worst['frame']})")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"rows": rows}, indent=1))
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
