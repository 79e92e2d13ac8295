"""Per-frame telemetry: the timing and solver figures every frame reports.

``FrameTelemetry`` is the one definition of the fields: the HDF5 cache's telemetry table
(``TELEMETRY_COLUMNS``, ``weft.cache``), the runner's conversion from the solver's per-frame
record (``weft.simulate``), the job-status API and the dashboard all derive from it, so a field
added here shows up everywhere. Field order is the cache's column order; an ``int`` field is
stored as ``i4``, a ``float`` one as ``f8``.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, create_model


class FrameTelemetry(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    frame: int = Field(description="frame number")
    build_seconds: float = Field(description="wall seconds computing forces and assembling the linear system")
    solve_seconds: float = Field(description="wall seconds in the pre-filtered PCG and the state update")
    collision_seconds: float = Field(description="wall seconds in collision detection and response")
    gia_seconds: float = Field(description="wall seconds in global intersection analysis")
    total_seconds: float = Field(description="wall seconds for the whole frame, cache write excluded")
    cg_iterations: int = Field(description="CG iterations summed over the frame's substeps")
    final_residual: float = Field(description="relative residual of the last substep's solve")
    substeps: int = Field(description="implicit steps taken in the frame (more than asked when halved)")
    unconverged_substeps: int = Field(description="substeps whose CG stopped at the iteration cap")
    kinetic_energy: float = Field(description="kinetic energy at frame end, J")
    potential_energy: float = Field(description="gravitational plus elastic energy at frame end, J")
    # Collisions (docs/collisions.md). collision_seconds is the sum of the four parts below plus
    # the intersection count at frame end.
    collision_broad_phase_seconds: float = Field(
        0.0, description="wall seconds refitting trees and collecting feature pairs")
    collision_proximity_seconds: float = Field(0.0, description="wall seconds in proximity tests and repulsion impulses")
    collision_ccd_seconds: float = Field(0.0, description="wall seconds in continuous collision detection queries")
    collision_response_seconds: float = Field(0.0, description="wall seconds in CCD impulses and rigid impact zones")
    proximity_pairs: int = Field(
        0, description="feature pairs within the thickness that received an impulse, summed over substeps")
    ccd_candidates: int = Field(
        0, description="feature pairs a CCD pass examined (later passes: those with a moved vertex), summed over passes and substeps")
    ccd_hits: int = Field(0, description="CCD hits, summed over passes and substeps")
    impact_zones: int = Field(0, description="rigid impact zones formed, summed over substeps")
    collision_iterations: int = Field(
        0, description="CCD impulse passes plus impact-zone passes, summed over substeps")
    unresolved_collisions: int = Field(0, description="colliding pairs left when the impact-zone budget ran out")
    intersections: int = Field(-1, description="intersecting triangle pairs at frame end (exact; -1: not counted)")
    # GIA (docs/intersection-analysis.md); gia_seconds is above.
    gia_coloured_vertices: int = Field(
        0, description="cloth vertices inside a closed body at a substep's start, most over the frame (GIA)")
    gia_pushed_vertices: int = Field(
        0, description="contour vertices pushed out of bodies by GIA recovery, summed over substeps")
    gia_paths: int = Field(
        0, description="cloth/body intersection paths at a substep's start, most over the frame (GIA)")
    gia_body_coloured_faces: int = Field(
        0, description="body faces in intersection with the cloth at a substep's start, most over the frame (GIA)")
    gia_pinched_body_pairs: int = Field(
        0, description="body pairs pinched, becoming pinched or becoming unpinched over a substep, most over the "
                       "frame (GIA)")
    gia_pinched_part_pairs: int = Field(
        0, description="pairs of parts of one character whose surfaces close on cloth (facing each other nearer "
                       "than two cloth thicknesses, cloth between them) over a substep, most over the frame (GIA)")
    gia_self_coloured_vertices: int = Field(
        0, description="cloth vertices coloured by cloth/cloth GIA at a substep's start, most over the frame")
    gia_self_paths: int = Field(
        0, description="cloth/cloth intersection paths at a substep's start, most over the frame (GIA)")
    # Contact in the solve and the collision stage's work (docs/collisions.md); appended, so older
    # caches keep their column order.
    broad_phase_pairs: int = Field(
        0, description="feature pairs the broad phase produced (proximity and CCD lists), summed over passes and substeps")
    contact_constraints: int = Field(
        0, description="cloth/body contacts constrained inside the linear solve, summed over substeps")
    released_contacts: int = Field(
        0, description="contact constraints released after the solve (the cloth pulled away), summed over substeps")
    max_edge_strain: float = Field(
        0.0, description="longest cloth edge over its rest length at frame end (1: rest; 1.5: stretched by half)")
    strain_limited_edges: int = Field(
        0, description="edge corrections of the strain limit before CCD, summed over passes and substeps")
    subdivided_substeps: int = Field(
        0, description="substeps redone as two halves because their collision stage left pairs unresolved or "
                       "their responses stretched an edge past solver.max_step_strain")
    # The preconditioner's share of the solve (issue 13); appended like the columns above.
    setup_seconds: float = Field(
        0.0, description="of solve_seconds: the preconditioner's setup (multigrid hierarchy values), summed over substeps")
    # What single collision features cost per frame (issue 12); parts of the sums above, appended.
    self_collision_seconds: float = Field(
        0.0, description="of collision_broad_phase_seconds: self-collision's culling, traversal and cloth/cloth pair "
                         "expansion, summed over passes and substeps")
    contact_constraints_seconds: float = Field(
        0.0, description="of collision_proximity_seconds: finding the cloth/body contacts the solve constrains "
                         "(nearest body faces, cloth edges across sharp body edges), summed over substeps")
    # Adaptive substepping decided before the frame (issue 12); appended.
    motion_halvings: int = Field(
        0, description="halvings every substep of the frame started at because a body moves faster than its "
                       "thickness through the cloth it meets within one substep (0: whole substeps)")
    # Kinetic friction spread through the cloth (issue 12); appended.
    friction_spreads: int = Field(
        0, description="substeps whose kinetic friction lengthened an edge past the strain limit when applied to "
                       "the held vertices alone, and went through the cloth's implicit response instead")
    # The solver threads giving way to other processes (weft/thread_governor.py); appended.
    threads: int = Field(0, description="solver threads the frame ran on (0: not recorded)")
    cpu_wait_share: float = Field(
        0.0, description="seconds the process's threads waited for a CPU while runnable, per solver thread and "
                         "second of the frame (0: idle cores or not measured; above 0.25 the next frames run on "
                         "fewer threads)")


_DTYPES = {int: "i4", float: "f8"}

# (name, numpy dtype, description), derived from FrameTelemetry. Order is the cache's column order.
TELEMETRY_COLUMNS: list[tuple[str, str, str]] = [
    (name, _DTYPES[info.annotation], info.description or "") for name, info in FrameTelemetry.model_fields.items()
]


# The same row as JSON (event streams, GET /v1/jobs/{id}/telemetry): JSON has no NaN or Infinity,
# so a non-finite float (a diverging solve's residual) is null, and the schema says so.
FrameTelemetryJson: type[BaseModel] = create_model(  # type: ignore[call-overload]
    "FrameTelemetryJson",
    __config__=ConfigDict(extra="forbid", frozen=True),
    __doc__="A frame's telemetry as JSON: FrameTelemetry with each float null when it is not finite.",
    **{
        name: ((float | None, Field(info.default, description=f"{info.description} (null when not finite)"))
               if info.annotation is float else (info.annotation, Field(info.default, description=info.description)))
        for name, info in FrameTelemetry.model_fields.items()
    },
)
