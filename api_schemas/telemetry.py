"""Per-frame telemetry: the timing and solver figures every frame reports.

The same field list defines the HDF5 cache's telemetry table (``weft.cache``), the job-status
API and the dashboard, so a field added here shows up everywhere.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict

# (name, numpy dtype, description). Order is the cache's column order.
TELEMETRY_COLUMNS: list[tuple[str, str, str]] = [
    ("frame", "i4", "frame number"),
    ("build_seconds", "f8", "wall seconds computing forces and assembling the linear system"),
    ("solve_seconds", "f8", "wall seconds in the pre-filtered PCG and the state update"),
    ("collision_seconds", "f8", "wall seconds in collision detection and response"),
    ("gia_seconds", "f8", "wall seconds in global intersection analysis"),
    ("total_seconds", "f8", "wall seconds for the whole frame, cache write excluded"),
    ("cg_iterations", "i4", "CG iterations summed over the frame's substeps"),
    ("final_residual", "f8", "relative residual of the last substep's solve"),
    ("substeps", "i4", "implicit steps taken in the frame"),
    ("unconverged_substeps", "i4", "substeps whose CG stopped at the iteration cap"),
    ("kinetic_energy", "f8", "kinetic energy at frame end, J"),
    ("potential_energy", "f8", "gravitational plus elastic energy at frame end, J"),
    # Collisions (weft/docs/collisions.md). collision_seconds is the sum of the four parts below
    # plus the intersection count at frame end.
    ("collision_broad_phase_seconds", "f8", "wall seconds refitting trees and collecting feature pairs"),
    ("collision_proximity_seconds", "f8", "wall seconds in proximity tests and repulsion impulses"),
    ("collision_ccd_seconds", "f8", "wall seconds in continuous collision detection queries"),
    ("collision_response_seconds", "f8", "wall seconds in CCD impulses and rigid impact zones"),
    ("proximity_pairs", "i4", "feature pairs within the thickness that received an impulse, summed over substeps"),
    ("ccd_candidates", "i4", "feature pairs given to CCD, summed over passes and substeps"),
    ("ccd_hits", "i4", "CCD hits, summed over passes and substeps"),
    ("impact_zones", "i4", "rigid impact zones formed, summed over substeps"),
    ("collision_iterations", "i4", "CCD impulse passes plus impact-zone passes, summed over substeps"),
    ("unresolved_collisions", "i4", "colliding pairs left when the impact-zone budget ran out"),
    ("intersections", "i4", "intersecting triangle pairs at frame end (exact; -1: not counted)"),
    # GIA against closed bodies (docs/intersection-analysis.md); gia_seconds is above.
    ("gia_coloured_vertices", "i4", "cloth vertices inside a closed body at a substep's start, most over the frame (GIA)"),
    ("gia_pushed_vertices", "i4", "contour vertices pushed out of bodies by GIA recovery, summed over substeps"),
    ("gia_paths", "i4", "cloth/body intersection paths at a substep's start, most over the frame (GIA)"),
    ("gia_body_coloured_faces", "i4", "body faces in intersection with the cloth at a substep's start, most over the frame (GIA)"),
    ("gia_pinched_body_pairs", "i4",
     "body pairs pinched, becoming pinched or becoming unpinched over a substep, most over the frame (GIA)"),
    ("gia_self_coloured_vertices", "i4", "cloth vertices coloured by cloth/cloth GIA at a substep's start, most over the frame"),
    ("gia_self_paths", "i4", "cloth/cloth intersection paths at a substep's start, most over the frame (GIA)"),
]


class FrameTelemetry(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    frame: int
    build_seconds: float
    solve_seconds: float
    collision_seconds: float
    gia_seconds: float
    total_seconds: float
    cg_iterations: int
    final_residual: float
    substeps: int
    unconverged_substeps: int
    kinetic_energy: float
    potential_energy: float
    collision_broad_phase_seconds: float = 0.0
    collision_proximity_seconds: float = 0.0
    collision_ccd_seconds: float = 0.0
    collision_response_seconds: float = 0.0
    proximity_pairs: int = 0
    ccd_candidates: int = 0
    ccd_hits: int = 0
    impact_zones: int = 0
    collision_iterations: int = 0
    unresolved_collisions: int = 0
    intersections: int = -1
    gia_coloured_vertices: int = 0
    gia_pushed_vertices: int = 0
    gia_paths: int = 0
    gia_body_coloured_faces: int = 0
    gia_pinched_body_pairs: int = 0
    gia_self_coloured_vertices: int = 0
    gia_self_paths: int = 0


assert list(FrameTelemetry.model_fields) == [c[0] for c in TELEMETRY_COLUMNS]
