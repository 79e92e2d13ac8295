"""Reading a job's HDF5 cache for the API, also while a worker is still writing it (SWMR)."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from weft.cache import STATE_GROUPS, TELEMETRY_DTYPE, copy_bodies, open_cache_reader, saved_state_group


def committed_rows(f: h5py.File) -> int:
    """Frames fully written: the writer appends positions, velocities, frame number, telemetry,
    then the solver state, so the saved state's frame index bounds what a reader may use."""
    lengths = [f["frames/positions"].shape[0], f["frames/velocities"].shape[0], f["frames/frame"].shape[0], f["telemetry"].shape[0]]
    return min(*lengths, int(f[saved_state_group(f)]["frame_index"][0]) + 1)


def read_positions(cache: Path, index: int) -> np.ndarray | None:
    """Positions (V, 3) float32 of cache row ``index``, or None if that frame is not written yet."""
    with open_cache_reader(cache) as f:
        if index >= committed_rows(f):
            return None
        return np.asarray(f["frames/positions"][index])


def snapshot(cache: Path, target: Path) -> int:
    """Copy the frames finished so far into a self-contained cache file; returns their count.

    The copy is a valid cache (its solver state matches its last frame), so it can be read with
    `weft info` or resumed like any interrupted cache.
    """
    with open_cache_reader(cache) as src, h5py.File(target, "w", libver="latest") as dst:
        saved = saved_state_group(src)
        rows = min(committed_rows(src), int(src[saved]["frame_index"][0]) + 1)
        dst.attrs.update(dict(src.attrs))
        src.copy(src["cloth"], dst, "cloth")
        copy_bodies(src, dst, rows)
        for name in STATE_GROUPS:  # both from the whole one
            src.copy(src[saved], dst, name)
        frames = dst.create_group("frames")
        for name in ("positions", "velocities"):
            data = src["frames/" + name][:rows]
            frames.create_dataset(
                name, data=data, maxshape=(None, *data.shape[1:]), chunks=(1, *data.shape[1:]), dtype=np.float32
            )
        frames.create_dataset("frame", data=src["frames/frame"][:rows], maxshape=(None,), chunks=(256,), dtype=np.int32)
        dst.create_dataset("telemetry", data=src["telemetry"][:rows], maxshape=(None,), chunks=(64,), dtype=TELEMETRY_DTYPE)
    return rows
