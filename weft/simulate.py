"""The frame loop: the one place where a shot's frame index becomes a call into the solver.

Frame 0 of the range is the initial state. Frame ``index`` >= 1 releases the pins whose time
has come (at the frame's start), moves the bodies and the pins with paths from their keyframe
``index - 1`` to ``index`` and takes ``shot.substeps`` implicit steps of the frame's duration. The runner (cache, resume), the tests and the benchmarks all step through here, so
they simulate exactly the same thing; ``telemetry_row`` turns the solver's per-frame record
into the schema's ``FrameTelemetry``, field by field.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import nullcontext
from typing import Any

import numpy as np

from api_schemas import FrameTelemetry
from weft.solver_setup import Scene, build_setup
from weft.thread_governor import ThreadGovernor


class SolverFailure(RuntimeError):
    """The solver failed at a frame; frames before it are in the cache."""

    def __init__(self, frame: int, reason: str) -> None:
        super().__init__(f"frame {frame}: {reason}")
        self.frame = frame
        self.reason = reason


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask: a container's cpuset, `taskset`)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def solver_threads(requested: int) -> int:
    """The threads a run uses for `requested`: at most the usable CPUs. More threads than CPUs
    only wait for each other at the solver's barriers (the articulated dress on 2 CPUs: 0.065
    s/frame with 2 threads, 0.114 with 4), and the results are bitwise the same for any count."""
    return max(1, min(requested, usable_cpus()))


def new_simulation(scene: Scene, threads: int = 1, linear_system: str | None = None) -> Any:
    """The solver's Simulation for a scene, at its initial state (frame 0)."""
    from weft import _solver

    return _solver.Simulation(build_setup(scene, threads, linear_system))


def advance(sim: Any, scene: Scene, index: int, governor: ThreadGovernor | None = None) -> Any:
    """Simulate frame ``index`` (1 .. frame_count - 1); returns the solver's FrameTelemetry.
    Raises SolverFailure (with the frame number) when the solver diverges or leaves non-finite
    positions. With a ``governor`` (made for ``sim``) the frame's CPU wait chooses the next
    frame's threads (weft/thread_governor.py)."""
    from weft import _solver

    shot = scene.shot
    frame = shot.frame_range[0] + index
    dt = 1.0 / shot.fps
    for b, body in enumerate(scene.solver_bodies):
        sim.set_body_keyframes(b, body.frame(scene.bodies, index - 1), body.frame(scene.bodies, index))
    frame_start_time = (index - 1) * dt
    released = [vertices for time, vertices in scene.pin_releases if time <= frame_start_time + 1e-9 * dt]
    if released:  # idempotent: a resumed run releases what the first run had released
        sim.release_pins(np.concatenate(released).tolist())
    let_go = set() if not released else set(np.concatenate(released).tolist())
    for vertices, path in scene.pin_paths:
        if not let_go.intersection(vertices.tolist()):
            sim.set_pin_targets(vertices.tolist(), path[index - 1], path[index])
    try:
        with governor.frame() if governor is not None else nullcontext():
            t = sim.advance_frame((index - 1) * dt, dt, shot.substeps)
    except _solver.SolverDivergence as exc:
        raise SolverFailure(frame, str(exc)) from None
    if not np.isfinite(sim.positions).all():
        raise SolverFailure(frame, "non-finite positions")
    return t


def simulate(scene: Scene, sim: Any = None, threads: int = 1, start: int = 1,
             stop: int | None = None) -> Iterator[tuple[int, Any, Any]]:
    """Yields (frame index, simulation, solver telemetry) for frames start .. stop - 1 (default:
    every simulated frame of the shot). A new Simulation is made unless ``sim`` is given; its
    threads give way to other processes (`ThreadGovernor`)."""
    sim = new_simulation(scene, threads) if sim is None else sim
    governor = ThreadGovernor(sim, getattr(sim, "threads", threads))  # older builds lack it
    for index in range(start, scene.frame_count if stop is None else stop):
        yield index, sim, advance(sim, scene, index, governor)


def telemetry_row(frame: int, t: Any, governor: ThreadGovernor | None = None) -> FrameTelemetry:
    """The schema's row for a simulated frame, read field by field from the solver's record. A
    figure the schema gives a default for and the record lacks (an older build of the solver,
    as `bench.module_ab` loads) takes that default; a required one must be there. The CPU wait
    is the frame's ``governor``'s (the schema's default without one)."""
    fields = FrameTelemetry.model_fields
    values = {k: getattr(t, k) if info.is_required() or hasattr(t, k) else info.default
              for k, info in fields.items() if k not in {"frame", "cpu_wait_share"}}
    if governor is not None and governor.last_cpu_wait_share is not None:
        values["cpu_wait_share"] = governor.last_cpu_wait_share
    return FrameTelemetry(frame=frame, **values)


def initial_telemetry(frame: int, sim: Any) -> FrameTelemetry:
    """The row for the initial frame: every required figure zero (no substeps, no time), the
    optional ones at their defaults, and the state's energies."""
    e = sim.energies()
    zeros = {name: 0 for name, info in FrameTelemetry.model_fields.items() if info.is_required()}
    return FrameTelemetry(**{**zeros, "frame": frame, "kinetic_energy": e.kinetic,
                             "potential_energy": e.gravity + e.elastic})
