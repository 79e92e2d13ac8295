"""Spread of the regression scenes' judged figures under small perturbations.

`weft regress` judges one run of each scene against its reference (`regress/judge.py`). On a
chaotic contact scene (the thin limb dragging a pinned sheet at 3 m/s) that one run's position
error moves with the last bits of any change to the collision stage, so a threshold set from
one run can fail a change that is neither better nor worse. This script runs a scene on copies
whose cloth thickness is scaled by `bench.contact_robustness.thickness_factors` (plus the
unperturbed run) and prints, per copy and over all of them, the figures `weft regress` judges:
the largest per-frame RMS and max position error against the stored reference, and the largest
edge strain. A threshold should sit above the spread, a change should move its mean.

    python -m bench.regress_spread --scenes thin_limb --copies 8 [--json PATH]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # shared 2-core machines

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from bench.contact_robustness import scale_thickness, thickness_factors  # noqa: E402


def run_copy(name: str, factor: float, threads: int, reference: dict[str, Any]) -> dict[str, float]:
    """One copy of a regression scene, thickness scaled by `factor`: its judged figures."""
    from regress.judge import position_errors
    from regress.runs import resolve, run_here, write_shot

    with tempfile.TemporaryDirectory() as directory:
        path = write_shot(name, Path(directory))
        document = json.loads(path.read_text())
        scale_thickness(document, factor)
        path.write_text(json.dumps(document))
        scene = resolve(path)
        run = run_here(scene, threads)
    rms, largest = position_errors(name, scene, run, reference)
    strain = run.telemetry.get("max_edge_strain", np.zeros(1))
    return {"factor": factor, "rms_mm": float(np.max(rms)), "max_mm": float(np.max(largest)),
            "strain": float(np.max(strain)), "failed": run.failure is not None}


def main(argv: list[str] | None = None) -> int:
    from regress import references
    from scenes.regression import ANALYTIC, SCENES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default="thin_limb", help="comma-separated regression scenes")
    parser.add_argument("--copies", type=int, default=8, help="perturbed copies besides the unperturbed run")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--json", type=Path, help="also write the copies' figures here")
    args = parser.parse_args(argv)
    if args.copies < 1:
        parser.error(f"--copies: must be at least 1, got {args.copies}")
    names = [n for n in args.scenes.split(",") if n]
    unknown = [n for n in names if n not in SCENES]
    if unknown:
        parser.error(f"--scenes: unknown regression scene(s) {', '.join(unknown)}; known: {', '.join(SCENES)}")
    analytic = [n for n in names if n in ANALYTIC]
    if analytic:
        parser.error(f"--scenes: {', '.join(analytic)} is analytic (its error has no spread)")
    factors = sorted(thickness_factors(args.copies) + [1.0])
    print("| scene | thickness factor | pos. error RMS (mm) | max (mm) | strain |")
    print("|---|---|---|---|---|")
    results: dict[str, list[dict[str, float]]] = {}
    for name in names:
        reference = references.load(name)
        copies = [run_copy(name, f, args.threads, reference) for f in factors]
        results[name] = copies
        for c in copies:
            stopped = " (stopped)" if c["failed"] else ""
            print(f"| {name} | {c['factor']:.3f} | {c['rms_mm']:.1f}{stopped} | {c['max_mm']:.1f} | {c['strain']:.2f} |")
        rms = np.array([c["rms_mm"] for c in copies])
        print(f"| {name} | all {len(copies)} | mean {rms.mean():.1f}, range {rms.min():.1f}-{rms.max():.1f} | "
              f"{max(c['max_mm'] for c in copies):.1f} | {max(c['strain'] for c in copies):.2f} |")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
