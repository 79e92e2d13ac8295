"""Write the demo shot and the analytic test scenes to scenes/generated/.

    python scenes/generate.py [OUTPUT_DIR]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from scenes.builders import demo_flag_files, sheet_shot


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    demo = demo_flag_files(out)
    analytic = {
        # Free fall: an unpinned sheet under gravity follows the discrete backward-Euler path.
        "free_fall.json": sheet_shot("free_fall", 8, 8, 0.5, 0.5, plane="xz", frames=24),
        # A strip pinned along its top edge hangs to a static elongation rho g L^2 / (2 k).
        "hanging_strip.json": sheet_shot(
            "hanging_strip", 3, 41, 0.1, 1.0, pins=[0, 1, 2],
            material={"density": 0.2, "stretch_warp": 20.0, "stretch_weft": 20.0, "shear": 5.0, "bend": 0.0,
                      "damping": 0.05},
            frames=120, substeps=2, air_drag=0.5,
        ),
        # Stability: a stiff 64 x 64 sheet at one substep per frame.
        "stiff_sheet.json": sheet_shot(
            "stiff_sheet", 64, 64, 1.0, 1.0, pins=[0, 63],
            material={"stretch_warp": 1e4, "stretch_weft": 1e4, "shear": 1e3}, frames=240, substeps=1,
        ),
    }
    for name, shot in analytic.items():
        (out / name).write_text(json.dumps(shot))
    print(f"wrote {demo} and {len(analytic)} analytic scenes to {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "generated")
