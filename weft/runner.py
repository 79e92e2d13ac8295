"""Run a shot frame by frame into its cache.

Shared by `weft run` and the service's workers. The first frame of the range is the initial
state (its telemetry row has zero substeps); every later frame is one step of the frame loop
(``weft.simulate``). The runner adds the cache, resume from a cache's saved state, progress
callbacks and stopping between frames (the caller's signal handling sets ``should_stop``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from api_schemas import FrameTelemetry
from weft import __version__
from weft.cache import CacheWriter
from weft.simulate import (SolverFailure, advance, initial_telemetry, new_simulation, solver_threads,
                           telemetry_row)
from weft.solver_setup import Scene
from weft.thread_governor import ThreadGovernor

__all__ = ["FrameRecord", "RunSummary", "ShotRunner", "SolverFailure"]


@dataclass
class FrameRecord:
    index: int  # 0-based row in the cache
    frame: int  # frame number
    frames_total: int
    telemetry: FrameTelemetry
    wall_seconds: float  # including the cache write
    write_seconds: float = 0.0  # the cache write alone


@dataclass
class RunSummary:
    cache_path: Path
    frames_written: int
    frames_total: int
    status: str
    resumed_from: int | None
    wall_seconds: float
    telemetry: list[FrameTelemetry] = field(default_factory=list)


class RunInterrupted(BaseException):
    """Raised (from a signal handler) to stop a run between two HDF5 writes: the runner closes
    its cache with status 'interrupted', so plain HDF5 readers can open it and `--resume`
    continues it."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class ShotRunner:
    def __init__(
        self,
        scene: Scene,
        cache_path: str | Path,
        threads: int = 1,
        frames: int | None = None,
        resume: bool = False,
    ) -> None:
        """frames: simulate only the first N frames of the range (initial frame included).
        threads: asked for; the run uses at most the CPUs it may run on (``threads_used``)."""
        if frames is not None and frames < 1:
            raise ValueError("frames must be at least 1")
        self.scene = scene
        self.cache_path = Path(cache_path)
        self.threads = threads
        self.threads_used = solver_threads(threads)
        self.frames_total = min(scene.frame_count, frames) if frames else scene.frame_count
        self.resume = resume

    def run(
        self,
        on_frame: Callable[[FrameRecord], None] | None = None,
        should_stop: Callable[[], bool] | None = None,
    ) -> RunSummary:
        scene = self.scene
        shot = scene.shot
        start_wall = time.perf_counter()
        sim = new_simulation(scene, self.threads_used)
        governor = ThreadGovernor(sim, self.threads_used)
        resumed_from: int | None = None
        if self.resume and self.cache_path.exists():
            writer, state = CacheWriter.resume(self.cache_path, scene.shot_hash)
            if state is not None:
                sim.set_state(state.positions, state.velocities, state.warm_start, state.contact_flags,
                              state.collision_flags)
                resumed_from = state.frame_index
        else:
            writer = CacheWriter.create(self.cache_path, scene, __version__, self.threads_used)
        first = shot.frame_range[0]
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
                    telemetry = initial_telemetry(frame, sim)
                else:
                    telemetry = telemetry_row(frame, advance(sim, scene, index, governor), governor)
                write_start = time.perf_counter()
                writer.append(frame, sim.positions, sim.velocities, sim.warm_start, telemetry,
                              [body.frames[index] for body in scene.bodies], sim.contact_flags, sim.collision_flags)
                write_end = time.perf_counter()
                summary.telemetry.append(telemetry)
                if on_frame is not None:
                    on_frame(FrameRecord(index, frame, self.frames_total, telemetry, write_end - frame_start,
                                         write_end - write_start))
            else:
                status = "complete" if self.frames_total == scene.frame_count else "partial"
        except RunInterrupted as exc:
            status, error = "interrupted", f"stopped by {exc.reason} after {writer.frames_written} frames"
            raise
        except KeyboardInterrupt:
            status, error = "interrupted", f"stopped by SIGINT after {writer.frames_written} frames"
            raise
        except BaseException as exc:
            error = str(exc) if isinstance(exc, SolverFailure) else f"{type(exc).__name__}: {exc}"
            raise
        finally:
            summary.frames_written = writer.frames_written
            summary.status = status
            summary.wall_seconds = time.perf_counter() - start_wall
            writer.close(status, error)
        return summary
