"""Cost of the body/body pinch states on the box pinch (docs/intersection-analysis.md):
`python -m bench.gia_pinch_cost` runs `box_pinch_shot` through ShotRunner (2 threads) and
prints the pinched column and gia_seconds against the frame time."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from scenes.collision import box_pinch_shot
from weft.runner import ShotRunner
from weft.shot import parse_shot
from weft.solver_setup import resolve_scene


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        scene = resolve_scene(parse_shot(box_pinch_shot(d)), d)
        summary = ShotRunner(scene, d / "pinch.h5", threads=2).run()
    t = summary.telemetry[1:]
    gia = np.array([r.gia_seconds for r in t])
    total = np.array([r.total_seconds for r in t])
    print("gia_pinched_body_pairs", [r.gia_pinched_body_pairs for r in t])
    print(f"gia_seconds per frame: median {np.median(gia):.2e} s, max {gia.max():.2e} s; frame total median "
          f"{np.median(total):.2e} s; GIA share {100 * gia.sum() / total.sum():.1f} %")


if __name__ == "__main__":
    main()
