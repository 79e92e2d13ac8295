"""The per-shot HDF5 cache (layout: docs/cache-format.md).

One file per shot. Per-frame positions and velocities are float32, one chunk per frame, in
extendible datasets; a telemetry table has one row per frame. The file is written in SWMR
mode and flushed after every frame, so a reader (``open_cache_reader``) sees completed frames
while the shot runs. The ``/state`` group holds the exact double-precision solver state of the
last finished frame, which is what a resumed run continues from.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from api_schemas import TELEMETRY_COLUMNS, FrameTelemetry

CACHE_FORMAT = "weft-cache"
CACHE_FORMAT_VERSION = 1
# The exact solver state after the last finished frame, written twice per frame (append).
STATE_GROUPS = ("state", "state_next")
TELEMETRY_DTYPE = np.dtype([(name, dtype) for name, dtype, _ in TELEMETRY_COLUMNS])


class CacheError(RuntimeError):
    pass


@dataclass
class SolverState:
    frame_index: int  # index into the cache's frame rows (0 = first frame)
    positions: np.ndarray
    velocities: np.ndarray
    warm_start: np.ndarray
    # Per cloth vertex, the contact constraints' last decision (Simulation.contact_flags: 1 held,
    # 3 held and sticking, 2 released); empty in a cache written before weft kept it (such a
    # resume starts with none).
    contact_flags: np.ndarray
    # The collision stage's analysis flags (Simulation.collision_flags: GIA due, cloth/cloth
    # analysis due, every body, contacts set aside, one entry per body watched); empty without
    # collisions or in a cache written before weft kept them (such a resume starts as a new
    # simulation does: the analysis due on every body).
    collision_flags: np.ndarray


class CacheWriter:
    """Appends frames to a cache. Use ``create`` for a new shot or ``resume`` to continue one."""

    def __init__(self, file: h5py.File, path: Path) -> None:
        self._file = file
        self.path = path
        # The file this writer owns. A resume (another writer taking the shot over) replaces
        # the path by a fresh file, so a writer whose file is no longer at the path has been
        # fenced off and must not touch what is there now (``close``).
        self._identity = _file_identity(os.stat(path))
        self._positions = file["frames/positions"]
        self._velocities = file["frames/velocities"]
        self._frame_numbers = file["frames/frame"]
        self._telemetry = file["telemetry"]
        self._states = [file[name] for name in STATE_GROUPS if name in file]
        # Body motion, when the shot asked for it (outputs.body_motion): one dataset per body.
        self._body_positions = [g["positions"] for g in file["bodies"].values() if "positions" in g]

    # -- construction -------------------------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, scene: Any, weft_version: str, threads: int) -> CacheWriter:
        from weft.solver_setup import Scene  # local import: the cache module has no solver dependency

        assert isinstance(scene, Scene)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".partial")
        f = h5py.File(tmp, "w", libver="latest")
        try:
            cls._write_header(f, scene, weft_version, threads)
        except BaseException:
            f.close()
            tmp.unlink(missing_ok=True)
            raise
        f.close()
        return cls(_publish_for_writing(tmp, path), path)

    @staticmethod
    def _write_header(f: h5py.File, scene: Any, weft_version: str, threads: int) -> None:
        shot = scene.shot
        n = scene.vertex_count
        f.attrs.update(
            {
                "format": CACHE_FORMAT,
                "format_version": CACHE_FORMAT_VERSION,
                "weft_version": weft_version,
                "shot_name": shot.name,
                "shot_hash": scene.shot_hash,
                "shot_json": shot.model_dump_json(),
                "fps": shot.fps,
                "units": "m",
                "frame_first": shot.frame_range[0],
                "frame_last": shot.frame_range[1],
                "frames_planned": shot.frame_count,
                "substeps": shot.substeps,
                "threads": threads,
                "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                "status": "running",
                "error": "",
            }
        )
        cloth = f.create_group("cloth")
        cloth.create_dataset("faces", data=scene.faces.astype(np.int32))
        cloth.create_dataset("rest_uv", data=scene.face_uv)
        cloth.create_dataset("initial_positions", data=scene.positions)
        pieces = cloth.create_group("pieces")
        for piece in scene.pieces:
            g = pieces.create_group(piece.name)
            g.attrs.update(
                {
                    "vertex_offset": piece.vertex_offset,
                    "vertex_count": piece.vertex_count,
                    "face_offset": piece.face_offset,
                    "face_count": len(piece.faces),
                }
            )
            g.create_dataset("faces", data=piece.faces)
        bodies = f.create_group("bodies")
        for body in scene.bodies:
            group = bodies.create_group(body.name)
            group.create_dataset("faces", data=body.faces)
            if shot.outputs.body_motion:
                vertex_count = body.frames.shape[1]
                group.create_dataset("positions", shape=(0, vertex_count, 3), maxshape=(None, vertex_count, 3),
                                     chunks=(1, vertex_count, 3), dtype=np.float32)
        frames = f.create_group("frames")
        for name in ("positions", "velocities"):
            frames.create_dataset(
                name, shape=(0, n, 3), maxshape=(None, n, 3), chunks=(1, n, 3), dtype=np.float32
            )
        frames.create_dataset("frame", shape=(0,), maxshape=(None,), chunks=(256,), dtype=np.int32)
        f.create_dataset("telemetry", shape=(0,), maxshape=(None,), chunks=(64,), dtype=TELEMETRY_DTYPE)
        for name in STATE_GROUPS:
            state = f.create_group(name)
            state.create_dataset("frame_index", data=np.array([-1], dtype=np.int64))
            state.create_dataset("positions", data=np.zeros((n, 3)))
            state.create_dataset("velocities", data=np.zeros((n, 3)))
            state.create_dataset("warm_start", data=np.zeros(3 * n))
            state.create_dataset("contact_flags", data=np.zeros(n, dtype=np.uint8))
            state.create_dataset("collision_flags", shape=(0,), maxshape=(None,), dtype=np.uint8)

    @classmethod
    def resume(cls, path: str | Path, shot_hash: str) -> tuple[CacheWriter, SolverState | None]:
        """Reopen a cache left by an interrupted run, dropping rows past its saved state.

        A writer that died may leave the file marked as open; the completed part is copied into
        a fresh file (atomically replaced) so that nothing a finished frame wrote is lost.
        """
        path = Path(path)
        with open_cache_reader(path) as old:
            if old.attrs.get("format") != CACHE_FORMAT:
                raise CacheError(f"{path} is not a weft cache")
            if old.attrs["shot_hash"] != shot_hash:
                raise CacheError(f"{path} was written for a different shot (hash mismatch); refusing to resume")
        writer = cls(_publish_for_writing(_completed_copy(path, "running", ""), path), path)
        return writer, writer.saved_state()

    # -- writing --------------------------------------------------------------------------
    @property
    def frames_written(self) -> int:
        return int(self._frame_numbers.shape[0])

    def saved_state(self) -> SolverState | None:
        state = self._file[saved_state_group(self._file)]
        index = int(state["frame_index"][0])
        if index < 0:
            return None
        return SolverState(
            frame_index=index,
            positions=state["positions"][()],
            velocities=state["velocities"][()],
            warm_start=state["warm_start"][()],
            contact_flags=state["contact_flags"][()] if "contact_flags" in state else np.zeros(0, dtype=np.uint8),
            collision_flags=state["collision_flags"][()] if "collision_flags" in state else np.zeros(0, dtype=np.uint8),
        )

    def append(
        self,
        frame_number: int,
        positions: np.ndarray,
        velocities: np.ndarray,
        warm_start: np.ndarray,
        telemetry: FrameTelemetry,
        body_positions: list[np.ndarray] | None = None,
        contact_flags: np.ndarray | None = None,
        collision_flags: np.ndarray | None = None,
    ) -> None:
        """body_positions: each body's vertices at this frame (stored when the cache keeps body
        motion, ignored otherwise); contact_flags: Simulation.contact_flags after the frame
        (none decided when None or empty); collision_flags: Simulation.collision_flags after it
        (none kept when None)."""
        k = self.frames_written
        rows = [(self._positions, positions), (self._velocities, velocities)]
        if self._body_positions:
            if body_positions is None or len(body_positions) != len(self._body_positions):
                raise CacheError("this cache keeps body motion: append needs every body's positions")
            rows += list(zip(self._body_positions, body_positions, strict=True))
        for ds, data in rows:
            ds.resize(k + 1, axis=0)
            ds[k] = data.astype(np.float32)
        self._frame_numbers.resize(k + 1, axis=0)
        self._frame_numbers[k] = frame_number
        row = np.zeros(1, dtype=TELEMETRY_DTYPE)
        for name in TELEMETRY_DTYPE.names:
            row[name] = getattr(telemetry, name)
        self._telemetry.resize(k + 1, axis=0)
        self._telemetry[k] = row[0]
        # The exact state last, so a reader or a resume never sees state ahead of the frames;
        # first into /state_next, then into /state, each group's frame_index written after its
        # arrays. A writer killed in the middle of either leaves the other group whole, and
        # ``saved_state_group`` picks the whole one (the larger frame_index): otherwise a kill
        # between the arrays and the index left the next frame's state under this one's index
        # and a resume simulated a frame twice.
        # HDF5 may hold written chunks until a flush, so each index goes out only after its
        # arrays have been flushed.
        self._file.flush()
        for state in reversed(self._states):
            state["positions"][...] = positions
            state["velocities"][...] = velocities
            state["warm_start"][...] = warm_start
            if "contact_flags" in state:
                flags = state["contact_flags"]
                flags[...] = contact_flags if contact_flags is not None and len(contact_flags) else 0
            if "collision_flags" in state:
                analysis = np.zeros(0, dtype=np.uint8) if collision_flags is None else np.asarray(collision_flags)
                state["collision_flags"].resize(len(analysis), axis=0)
                state["collision_flags"][...] = analysis
            self._file.flush()
            state["frame_index"][0] = k
            self._file.flush()

    def close(self, status: str = "complete", error: str = "") -> None:
        """Close the file and record how the run ended ('complete', 'failed', 'cancelled', ...)."""
        if not self._file.id.valid:
            return
        self._file.close()
        # Attributes cannot be written in SWMR mode: the status goes in through a new handle,
        # opened on a descriptor checked to be this writer's own file. A stale writer (a worker
        # that froze, was replaced and woke up) finds another file at the path and leaves it.
        try:
            fd = os.open(self.path, os.O_RDWR)
        except FileNotFoundError:
            return
        with os.fdopen(fd, "r+b") as handle:
            if _file_identity(os.fstat(handle.fileno())) != self._identity:
                return
            with h5py.File(handle, "r+", libver="latest") as f:
                f.attrs["status"] = status
                f.attrs["error"] = error


def saved_state_group(f: h5py.File) -> str:
    """The group holding the last finished frame's exact state: of /state and /state_next (caches
    written before /state_next existed have /state only), the one with the larger frame_index,
    which is whole because its index is written after its arrays (``CacheWriter.append``)."""
    groups = [name for name in STATE_GROUPS if name in f]
    return max(groups, key=lambda name: (int(f[name]["frame_index"][0]), name == "state"))


def _file_identity(st: os.stat_result) -> tuple[int, int]:
    return st.st_dev, st.st_ino


def copy_bodies(src: h5py.File, dst: h5py.File, rows: int) -> None:
    """The bodies group into another file, body motion (if kept) cut to the first `rows` frames."""
    bodies = dst.create_group("bodies")
    for name, group in src["bodies"].items():
        copied = bodies.create_group(name)
        copied.create_dataset("faces", data=group["faces"][()])
        if "positions" in group:
            motion = group["positions"]
            out = copied.create_dataset("positions", shape=(rows, *motion.shape[1:]), maxshape=(None, *motion.shape[1:]),
                                        chunks=(1, *motion.shape[1:]), dtype=np.float32)
            for k in range(rows):
                out[k] = motion[k]


def _publish_for_writing(tmp: Path, path: Path) -> h5py.File:
    """`tmp` opened for appending in SWMR mode, then moved to `path` (the open handle follows the
    file). A reader polling `path` (the API, the dashboard, `weft info`) never sees the file before
    its writer holds it in SWMR mode: a reader that opened it between a rename and the writer's own
    open held HDF5's file lock and made that open fail, which ended the run."""
    f = h5py.File(tmp, "r+", libver="latest")
    try:
        f.swmr_mode = True
        os.replace(tmp, path)
    except BaseException:
        f.close()
        tmp.unlink(missing_ok=True)
        raise
    return f


def _rewrite_completed(path: Path, status: str, error: str) -> None:
    """Copy the frames up to the saved state (rows past it were never finished) into a fresh file
    that replaces `path` atomically, with the given status: what a recovery needs, and readable by
    any HDF5 reader even when the writer died with the file open."""
    os.replace(_completed_copy(path, status, error), path)


def _completed_copy(path: Path, status: str, error: str) -> Path:
    """The fresh file of `_rewrite_completed` (or of a resume), written beside `path`."""
    with open_cache_reader(path) as old:
        saved = saved_state_group(old)
        state_index = int(old[saved]["frame_index"][0])
        tmp = path.with_name(path.name + ".rewrite")
        with h5py.File(tmp, "w", libver="latest") as new:
            new.attrs.update(dict(old.attrs))
            new.attrs["status"] = status
            new.attrs["error"] = error
            rows = state_index + 1
            old.copy(old["cloth"], new, "cloth")
            copy_bodies(old, new, rows)
            for name in STATE_GROUPS:  # both from the whole one
                old.copy(old[saved], new, name)
            frames = new.create_group("frames")
            for name in ("positions", "velocities"):
                src = old["frames/" + name]
                dst = frames.create_dataset(
                    name, shape=(rows, *src.shape[1:]), maxshape=(None, *src.shape[1:]),
                    chunks=(1, *src.shape[1:]), dtype=np.float32,
                )
                for k in range(rows):
                    dst[k] = src[k]
            frames.create_dataset(
                "frame", data=old["frames/frame"][:rows], maxshape=(None,), chunks=(256,), dtype=np.int32
            )
            new.create_dataset(
                "telemetry", data=old["telemetry"][:rows], maxshape=(None,), chunks=(64,), dtype=TELEMETRY_DTYPE
            )
    return tmp


def recover_cache(path: str | Path) -> dict[str, Any]:
    """A cache whose writer died (status still 'running', the file possibly still flagged open for
    writing, so that plain h5py refuses it): its finished frames rewritten into a clean file with
    status 'interrupted', as `h5clear -s` would make it openable. Only for a cache nobody writes
    any more; returns describe_cache of the result."""
    path = Path(path)
    with open_cache_reader(path) as f:
        if f.attrs.get("format") != CACHE_FORMAT:
            raise CacheError(f"{path} is not a weft cache")
        status = str(f.attrs["status"])
    if status != "running":
        raise CacheError(f"{path} was closed by its writer (status {status}); nothing to recover")
    _rewrite_completed(path, "interrupted", "the writer stopped without closing the cache (recovered)")
    return describe_cache(path)


def open_cache_reader(path: str | Path) -> h5py.File:
    """Open a cache for reading, also while a run is still writing it (SWMR)."""
    try:
        return h5py.File(path, "r", libver="latest", swmr=True)
    except OSError as exc:
        raise CacheError(f"cannot open cache {path}: {exc}") from None


def describe_cache(path: str | Path) -> dict[str, Any]:
    """Summary of a cache for `weft info` and the API."""
    with open_cache_reader(path) as f:
        if f.attrs.get("format") != CACHE_FORMAT:
            raise CacheError(f"{path} is not a weft cache")
        telemetry = f["telemetry"][()]
        frames = f["frames/frame"][()]
        pieces = {
            name: {k: int(v) for k, v in g.attrs.items()} for name, g in f["cloth/pieces"].items()
        }
        simulated = telemetry[telemetry["substeps"] > 0]
        summary: dict[str, Any] = {
            "path": str(path),
            "shot_name": str(f.attrs["shot_name"]),
            "shot_hash": str(f.attrs["shot_hash"]),
            "weft_version": str(f.attrs["weft_version"]),
            "status": str(f.attrs["status"]),
            "error": str(f.attrs["error"]),
            "fps": float(f.attrs["fps"]),
            "frame_range": [int(f.attrs["frame_first"]), int(f.attrs["frame_last"])],
            "frames_written": int(len(frames)),
            "frames_planned": int(f.attrs["frames_planned"]),
            "last_frame": int(frames[-1]) if len(frames) else None,
            "vertices": int(f["frames/positions"].shape[1]),
            "faces": int(f["cloth/faces"].shape[0]),
            "pieces": pieces,
            "bodies": list(f["bodies"].keys()),
            "shot": json.loads(f.attrs["shot_json"]),
        }
        if len(simulated):
            summary["mean_seconds_per_frame"] = {
                key: float(np.mean(simulated[key + "_seconds"])) for key in ("build", "solve", "collision", "gia", "total")
            }
            summary["cg_iterations_per_frame"] = float(np.mean(simulated["cg_iterations"]))
            summary["unconverged_substeps"] = int(np.sum(simulated["unconverged_substeps"]))
            names = simulated.dtype.names
            # Adaptive substepping: steps taken, halved after a failed attempt, and frames started
            # halved for their bodies' motion; steps whose kinetic friction went through the
            # cloth's response (columns of older caches may be missing).
            summary["substeps"] = int(np.sum(simulated["substeps"]))
            if "subdivided_substeps" in names:
                summary["halved_substeps"] = int(np.sum(simulated["subdivided_substeps"]))
            if "motion_halvings" in names:
                summary["frames_started_halved"] = int(np.count_nonzero(simulated["motion_halvings"]))
            if "friction_spreads" in names:
                summary["friction_spreads"] = int(np.sum(simulated["friction_spreads"]))
            # What each collision feature costs, for shots that use collisions (columns of older
            # caches may be missing).
            collides = bool(np.any(simulated["collision_seconds"] > 0.0))
            parts = {key: float(np.mean(simulated[f"collision_{key}_seconds"]))
                     for key in ("broad_phase", "proximity", "ccd", "response") if f"collision_{key}_seconds" in names}
            if parts and collides:
                summary["mean_collision_seconds_per_frame"] = parts
            # Per feature (parts of the stages above, and GIA's own column): what a shot pays for
            # self-collision, for contact in the solve and for intersection analysis.
            features = {key: float(np.mean(simulated[column])) for key, column in (
                ("self_collision", "self_collision_seconds"), ("contact_constraints", "contact_constraints_seconds"),
                ("gia", "gia_seconds")) if column in names}
            if len(features) == 3 and collides:
                summary["mean_feature_seconds_per_frame"] = features
            counts = {key: float(np.mean(simulated[key])) for key in (
                "broad_phase_pairs", "ccd_candidates", "ccd_hits", "contact_constraints", "proximity_pairs",
                "impact_zones") if key in names}
            if counts and collides:
                summary["mean_collision_counts_per_frame"] = counts
            if "max_edge_strain" in names:
                summary["max_edge_strain"] = float(np.max(simulated["max_edge_strain"]))
            # The threads each frame ran on: fewer than the run's where other processes wanted
            # the cores (weft/thread_governor.py; columns of older caches may be missing).
            if "threads" in names and np.all(simulated["threads"] > 0):
                summary["solver_threads"] = {
                    "fewest": int(np.min(simulated["threads"])), "most": int(np.max(simulated["threads"])),
                    "max_cpu_wait_share": float(np.max(simulated["cpu_wait_share"]))}
        return summary
