"""Per-frame cost of cloth/cloth GIA untangling (docs/intersection-analysis.md): the fold scene
(scenes.gia.fold_shot, as in the untangling tests) at two resolutions, pushed through or clean,
GIA on and off.

Run from the repository root: python -m bench.gia_untangling_cost
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from scenes.gia import R, fold_shot
from weft.shot import parse_shot
from weft.simulate import simulate
from weft.solver_setup import resolve_scene


def main() -> None:
    for k in (1, 4):
        for gia in (True, False):
            for dip in (4 * R, 0.0):
                doc = fold_shot(dip=dip, gia=gia, frames=4, k=k)
                rows = []
                start = time.perf_counter()
                for _, _, t in simulate(resolve_scene(parse_shot(doc), Path.cwd()), threads=2):
                    rows.append((t.gia_seconds, t.collision_seconds, t.total_seconds, t.intersections, t.gia_self_paths))
                wall = time.perf_counter() - start
                r = np.array(rows)
                faces = len(doc["cloth"][0]["mesh"]["faces"])
                print(
                    f"faces={faces} dip={'yes' if dip else 'no '} gia={gia!s:5} gia_s/frame={r[:, 0].mean():.4f} "
                    f"collision_s/frame={r[:, 1].mean():.4f} total_s/frame={r[:, 2].mean():.4f} wall={wall:.2f} "
                    f"intersections={[int(x) for x in r[:, 3]]} paths={[int(x) for x in r[:, 4]]}"
                )


if __name__ == "__main__":
    main()
