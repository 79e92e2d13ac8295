"""Robustness of `weft bench contact`'s scenes under small perturbations (`--perturb N`).

Contact scenes with pinches and folds are chaotic: one run's worst frame, its frames with cloth
inside a body and its maximum edge strain move with the last bits of any change to the solver
(docs/collisions.md), so a single run neither shows nor disproves a change. `--perturb N` runs
weft on N copies of each scene whose cloth thickness is scaled by factors spread over +-`SPREAD`
(`thickness_factors`; never 1: the unperturbed run is the main table's), and reports what the issue's
targets ask of every frame, over all the copies:

- s/frame: the median of the copies' means, and their range;
- worst frame over median frame: each copy's slowest frame over its own median frame, the
  largest over the copies (the issue's bound: 5);
- frames ending with cloth/body intersections (vertices inside a body part or intersecting
  triangle pairs), summed over the copies, of those the frames in which no pinch (body/body or
  between parts of one character) was engaged, and the most vertices inside at a frame end;
- substeps halved by the adaptive substepping, summed; the largest edge strain; NaN or a
  stopped run in any copy.

    python -m bench.contact --scenes articulated_dress --perturb 6

The runs themselves are `bench.contact.run_perturbed`; this module holds the perturbation and the
summary (it imports nothing of `bench.contact`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

# Thickness factors lie in [1 - SPREAD, 1 + SPREAD].
SPREAD = 0.07


def thickness_factors(count: int) -> list[float]:
    """`count` factors in increasing order, half of them (the larger half when odd) evenly spaced
    below 1 down to 1 - SPREAD, the rest evenly spaced above 1 up to 1 + SPREAD; never 1."""
    if count < 1:
        raise ValueError("the number of perturbed copies must be at least 1")
    below, above = (count + 1) // 2, count // 2
    return sorted([1.0 - SPREAD * j / below for j in range(1, below + 1)] +
                  [1.0 + SPREAD * j / above for j in range(1, above + 1)])


def scale_thickness(shot: dict[str, Any], factor: float) -> None:
    """Scales every cloth piece's collision thickness (its schema default when unset) in place."""
    from api_schemas.shot import Material

    default = Material.model_fields["thickness"].default
    for piece in shot["cloth"]:
        material = piece.setdefault("material", {})
        material["thickness"] = float(material.get("thickness", default)) * factor


def copy_summary(factor: float, run: dict[str, Any], metrics: dict[str, Any]) -> dict[str, Any]:
    """What one perturbed copy contributes: its timing, its frames with intersections, strain."""
    seconds = np.asarray(run["frame_seconds"], dtype=np.float64)
    # Frame ends after the initial state; a non-finite frame (None) counts as failing.
    inside = metrics["per_frame"]["inside"][1:]
    pairs = metrics["per_frame"]["cloth_body_pairs"][1:]
    flags = [a is None or b is None or a > 0 or b > 0 for a, b in zip(inside, pairs)]
    dirty = sum(flags)
    # Of those, the frames no pinch held (GIA's rules allow intersections only in a pinch).
    pinched = [t.gia_pinched_body_pairs + t.gia_pinched_part_pairs > 0 for t in run["telemetry"]]
    unpinched = sum(1 for k, flag in enumerate(flags) if flag and not (k < len(pinched) and pinched[k]))
    return {
        "thickness_factor": factor,
        "s_per_frame_mean": float(seconds.mean()) if len(seconds) else None,
        "worst_over_median_frame": float(seconds.max() / np.median(seconds)) if len(seconds) else None,
        "frames_with_intersections": dirty,
        "frames_with_intersections_unpinched": unpinched,
        "inside_max": metrics["inside_max"],
        "halved_substeps": int(sum(t.subdivided_substeps for t in run["telemetry"])),
        "max_strain": metrics["max_strain"],
        "nan": metrics["nan"],
        "failure": run["failure"],
    }


def summarise(name: str, copies: list[dict[str, Any]]) -> dict[str, Any]:
    """A scene's row of the copies table: medians, sums and extremes over its copies' summaries."""
    means = [c["s_per_frame_mean"] for c in copies if c["s_per_frame_mean"] is not None]
    worst = [c["worst_over_median_frame"] for c in copies if c["worst_over_median_frame"] is not None]
    strains = [c["max_strain"] for c in copies if c["max_strain"] is not None]
    insides = [c["inside_max"] for c in copies if c["inside_max"] is not None]
    return {
        "scene": name,
        "copies": copies,
        "s_per_frame_median": float(np.median(means)) if means else None,
        "s_per_frame_range": [min(means), max(means)] if means else None,
        "worst_over_median_frame": max(worst) if worst else None,
        "frames_with_intersections": sum(c["frames_with_intersections"] for c in copies),
        "copies_with_intersections": sum(1 for c in copies if c["frames_with_intersections"] > 0),
        "frames_with_intersections_unpinched": sum(c["frames_with_intersections_unpinched"] for c in copies),
        "inside_max": max(insides) if insides else None,
        "halved_substeps": sum(c["halved_substeps"] for c in copies),
        "max_strain": max(strains) if strains else None,
        "nan_or_stopped": sum(1 for c in copies if c["nan"] or c["failure"]),
    }


def format_table(rows: list[dict[str, Any]], count: int) -> Any:
    from rich.table import Table

    table = Table(title=f"weft over {count} copies per scene, cloth thickness scaled by {1 - SPREAD:.2f}-"
                        f"{1 + SPREAD:.2f} (issue targets: worst frame <= 5x median, no frame ending with "
                        "intersections, strain < 1.5)")
    for column in ("scene", "s/frame median (range)", "worst/median frame", "frames w/ intersections (copies)",
                   "inside max", "halved substeps", "max strain", "NaN or stopped"):
        table.add_column(column, justify="left" if column == "scene" else "right")
    for r in rows:
        lo_hi = r["s_per_frame_range"]
        table.add_row(
            r["scene"],
            "-" if lo_hi is None else f"{r['s_per_frame_median']:.3f} ({lo_hi[0]:.3f}-{lo_hi[1]:.3f})",
            "-" if r["worst_over_median_frame"] is None else f"{r['worst_over_median_frame']:.1f}",
            f"{r['frames_with_intersections']} ({r['copies_with_intersections']}/{len(r['copies'])}), "
            f"{r['frames_with_intersections_unpinched']} unpinched",
            "-" if r["inside_max"] is None else str(r["inside_max"]), str(r["halved_substeps"]),
            "-" if r["max_strain"] is None else f"{r['max_strain']:.2f}", str(r["nan_or_stopped"]),
        )
    return table
