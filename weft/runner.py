"""Run a shot frame by frame into its cache.

Shared by `weft run` and the service's workers. The first frame of the range is the initial
state (its telemetry row has zero substeps); every later frame is one call into the C++
solver. Callbacks report each finished frame and let the caller stop between frames.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from api_schemas import FrameTelemetry
from weft import __version__
from weft.cache import CacheWriter
from weft.solver_setup import Scene, build_setup


class SolverFailure(RuntimeError):
    """The solver failed at a frame; frames before it are in the cache."""

    def __init__(self, frame: int, reason: str) -> None:
        super().__init__(f"frame {frame}: {reason}")
        self.frame = frame
        self.reason = reason


@dataclass
class FrameRecord:
    index: int  # 0-based row in the cache
    frame: int  # frame number
    frames_total: int
    telemetry: FrameTelemetry
    wall_seconds: float  # including the cache write


@dataclass
class RunSummary:
    cache_path: Path
    frames_written: int
    frames_total: int
    status: str
    resumed_from: int | None
    wall_seconds: float
    telemetry: list[FrameTelemetry] = field(default_factory=list)


def zero_telemetry(frame: int, sim: object) -> FrameTelemetry:
    e = sim.energies()  # type: ignore[attr-defined]
    return FrameTelemetry(
        frame=frame, build_seconds=0.0, solve_seconds=0.0, collision_seconds=0.0, gia_seconds=0.0,
        total_seconds=0.0, cg_iterations=0, final_residual=0.0, substeps=0, unconverged_substeps=0,
        kinetic_energy=e.kinetic, potential_energy=e.gravity + e.elastic,
    )


def to_telemetry(frame: int, t: object) -> FrameTelemetry:
    return FrameTelemetry(frame=frame, **{k: getattr(t, k) for k in FrameTelemetry.model_fields if k != "frame"})


class ShotRunner:
    def __init__(
        self,
        scene: Scene,
        cache_path: str | Path,
        threads: int = 1,
        frames: int | None = None,
        resume: bool = False,
    ) -> None:
        """frames: simulate only the first N frames of the range (initial frame included)."""
        if frames is not None and frames < 1:
            raise ValueError("frames must be at least 1")
        self.scene = scene
        self.cache_path = Path(cache_path)
        self.threads = threads
        self.frames_total = min(scene.frame_count, frames) if frames else scene.frame_count
        self.resume = resume

    def run(
        self,
        on_frame: Callable[[FrameRecord], None] | None = None,
        should_stop: Callable[[], bool] | None = None,
    ) -> RunSummary:
        from weft import _solver

        scene = self.scene
        shot = scene.shot
        start_wall = time.perf_counter()
        sim = _solver.Simulation(build_setup(scene, self.threads))
        resumed_from: int | None = None
        if self.resume and self.cache_path.exists():
            writer, state = CacheWriter.resume(self.cache_path, scene.shot_hash)
            if state is not None:
                sim.set_state(state.positions, state.velocities, state.warm_start)
                resumed_from = state.frame_index
        else:
            writer = CacheWriter.create(self.cache_path, scene, __version__, self.threads)
        first = shot.frame_range[0]
        dt = 1.0 / shot.fps
        summary = RunSummary(self.cache_path, 0, self.frames_total, "running", resumed_from, 0.0)
        status, error = "failed", ""
        try:
            start_index = writer.frames_written
            for index in range(start_index, self.frames_total):
                if should_stop is not None and index > start_index and should_stop():
                    status = "cancelled"
                    break
                frame_start = time.perf_counter()
                frame = first + index
                if index == 0:
                    telemetry = zero_telemetry(frame, sim)
                else:
                    for b, body in enumerate(scene.bodies):
                        sim.set_body_keyframes(b, body.frames[index - 1], body.frames[index])
                    try:
                        t = sim.advance_frame((index - 1) * dt, dt, shot.substeps)
                    except _solver.SolverDivergence as exc:
                        raise SolverFailure(frame, str(exc)) from None
                    telemetry = to_telemetry(frame, t)
                positions = sim.positions
                if not np.isfinite(positions).all():
                    raise SolverFailure(frame, "non-finite positions")
                writer.append(frame, positions, sim.velocities, sim.warm_start, telemetry)
                summary.telemetry.append(telemetry)
                if on_frame is not None:
                    on_frame(FrameRecord(index, frame, self.frames_total, telemetry, time.perf_counter() - frame_start))
            else:
                status = "complete" if self.frames_total == scene.frame_count else "partial"
        except BaseException as exc:
            error = str(exc) if isinstance(exc, SolverFailure) else f"{type(exc).__name__}: {exc}"
            raise
        finally:
            summary.frames_written = writer.frames_written
            summary.status = status
            summary.wall_seconds = time.perf_counter() - start_wall
            writer.close(status, error)
        return summary
