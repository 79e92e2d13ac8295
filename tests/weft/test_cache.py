"""The HDF5 cache: one row per frame, readable while `weft run` writes it, exact resume."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scenes.builders import sheet_shot
from weft.cache import describe_cache, open_cache_reader


def write_shot(tmp_path: Path, frames: int, n: int = 12, substeps: int = 2,
               solver: dict | None = None) -> Path:
    doc = sheet_shot("cache_test", n, n, 0.5, 0.5, pins=[0, n - 1], frames=frames, substeps=substeps,
                     wind={"velocity": [0.0, 0.0, 2.0]}, air_drag=0.3, **({"solver": solver} if solver else {}))
    path = tmp_path / "shot.json"
    path.write_text(json.dumps(doc))
    return path


def weft(*args: str, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "weft.cli", *args], capture_output=True, text=True,
                          timeout=300, **kwargs)


def test_rows_per_frame_and_info(tmp_path) -> None:
    shot = write_shot(tmp_path, frames=10)
    cache = tmp_path / "out.h5"
    result = weft("run", str(shot), "-o", str(cache), "--quiet")
    assert result.returncode == 0, result.stderr
    with open_cache_reader(cache) as f:
        assert f["frames/positions"].shape == (10, 144, 3)
        assert f["frames/velocities"].shape == (10, 144, 3)
        assert f["frames/positions"].chunks == (1, 144, 3)
        assert f["frames/positions"].dtype == np.float32
        assert list(f["frames/frame"][()]) == list(range(1, 11))
        telemetry = f["telemetry"][()]
        assert len(telemetry) == 10
        assert telemetry["substeps"][0] == 0 and np.all(telemetry["substeps"][1:] == 2)
        assert np.all(telemetry["cg_iterations"][1:] > 0)
        assert np.all(telemetry["total_seconds"][1:] >= telemetry["solve_seconds"][1:])
        assert f.attrs["status"] == "complete"
        assert json.loads(f.attrs["shot_json"])["name"] == "cache_test"
        assert f["state/frame_index"][0] == 9
        assert np.array_equal(f["state/positions"][()].astype(np.float32), f["frames/positions"][9])
    info = weft("info", str(cache), "--json")
    assert info.returncode == 0, info.stderr
    summary = json.loads(info.stdout)
    assert summary["frames_written"] == 10 and summary["status"] == "complete"
    assert summary["mean_seconds_per_frame"]["solve"] > 0
    # A flag without collisions: no collision figures at all, and its strain stays near rest.
    assert "mean_collision_seconds_per_frame" not in summary and "mean_collision_counts_per_frame" not in summary
    assert summary["max_edge_strain"] >= 1.0 and summary["max_edge_strain"] < 1.5


READER = """
import json, sys
import numpy as np
from weft.cache import open_cache_reader
with open_cache_reader(sys.argv[1]) as f:
    rows = f["frames/positions"].shape[0]
    print(json.dumps({"rows": rows, "telemetry": f["telemetry"].shape[0], "frames": f["frames/frame"][()].tolist(),
                      "finite": bool(np.isfinite(f["frames/positions"][rows - 1]).all()),
                      "status": str(f.attrs["status"])}))
"""


def test_reader_sees_frames_while_run_is_writing(tmp_path) -> None:
    """Another process opens the cache while the run holds it open for writing: the run is paused
    in its frame callback, so the reader must see exactly the frames finished so far."""
    from weft.runner import FrameRecord, ShotRunner
    from weft.shot import load_shot_file
    from weft.solver_setup import resolve_scene

    shot = write_shot(tmp_path, frames=8)
    cache = tmp_path / "live.h5"
    seen: dict[int, dict] = {}

    def read_while_writing(record: FrameRecord) -> None:
        if record.index in (0, 3, 6):
            reader = subprocess.run([sys.executable, "-c", READER, str(cache)], capture_output=True, text=True,
                                    timeout=120)
            assert reader.returncode == 0, reader.stderr
            seen[record.index] = json.loads(reader.stdout)

    summary = ShotRunner(resolve_scene(load_shot_file(shot), tmp_path), cache).run(on_frame=read_while_writing)
    assert summary.status == "complete" and summary.frames_written == 8
    assert sorted(seen) == [0, 3, 6]
    for index, view in seen.items():
        assert view["rows"] == view["telemetry"] == index + 1
        assert view["frames"] == list(range(1, index + 2))
        assert view["finite"] and view["status"] == "running"


@pytest.mark.parametrize("preconditioner", ["block_jacobi", "multigrid"])
def test_resume_is_bitwise_identical(tmp_path, preconditioner: str) -> None:
    # Multigrid reuses its hierarchy from substep to substep within a frame (4 substeps here),
    # never across a frame boundary: a run resumed at frame 5 must repeat the whole run's bits.
    shot = write_shot(tmp_path, frames=12, substeps=4, solver={"preconditioner": preconditioner})
    whole, split = tmp_path / "whole.h5", tmp_path / "split.h5"
    assert weft("run", str(shot), "-o", str(whole), "--quiet").returncode == 0
    first = weft("run", str(shot), "-o", str(split), "--quiet", "--frames", "5")
    assert first.returncode == 0, first.stderr
    assert describe_cache(split)["status"] == "partial"
    refused = weft("run", str(shot), "-o", str(split), "--quiet")
    assert refused.returncode == 2 and "--resume" in refused.stderr
    second = weft("run", str(shot), "-o", str(split), "--quiet", "--resume")
    assert second.returncode == 0, second.stderr
    with open_cache_reader(whole) as a, open_cache_reader(split) as b:
        assert a["frames/positions"].shape == b["frames/positions"].shape == (12, 144, 3)
        assert np.array_equal(a["frames/positions"][()], b["frames/positions"][()])
        assert np.array_equal(a["state/positions"][()], b["state/positions"][()])
        assert np.array_equal(a["state/velocities"][()], b["state/velocities"][()])


def test_the_state_keeps_the_contact_constraints_decisions(tmp_path) -> None:
    # A sheet resting on a sphere: contacts held at the end of a frame carry into the next one
    # (Simulation.contact_flags), so the cache keeps them with the state and a resume gets them
    # back (weft.runner hands them to Simulation.set_state).
    from scenes.contact import drape_sphere
    from weft.cache import CacheWriter

    doc = drape_sphere(tmp_path, n=16, frames=14, width=0.5, radius=0.2, drop=0.02)
    shot = tmp_path / "drape.json"
    shot.write_text(json.dumps(doc))
    split = tmp_path / "split.h5"
    first = weft("run", str(shot), "-o", str(split), "--quiet", "--frames", "7")
    assert first.returncode == 0, first.stderr
    with open_cache_reader(split) as f:
        flags = f["state/contact_flags"][()]
        assert flags.shape == (256,) and flags.dtype == np.uint8
        assert set(np.unique(flags)) <= {0, 1, 2, 3}
        # resting contacts held (1, or 3: sticking) across the frame boundary
        assert int(np.count_nonzero((flags == 1) | (flags == 3))) > 0
        shot_hash = f.attrs["shot_hash"]
    writer, state = CacheWriter.resume(split, shot_hash)
    writer.close("partial")
    assert state is not None and state.frame_index == 6
    assert np.array_equal(state.contact_flags, flags)
    second = weft("run", str(shot), "-o", str(split), "--quiet", "--resume")
    assert second.returncode == 0, second.stderr
    assert describe_cache(split)["status"] == "complete"


@pytest.mark.parametrize("scene", ["drape", "box_pinch", "thin_limb"])
def test_a_shot_with_bodies_resumes_bitwise(tmp_path, scene: str) -> None:
    # The collision stage's analysis flags (GIA due, on which bodies, contacts set aside) are in
    # the state: a new simulation starts with the analysis due on every body, which a run resumed
    # from a clean frame would otherwise redo (the drape then moved 1.8 mm off the uninterrupted
    # run in its first resumed frame, the box pinch 1.1 mm; docs/cache-format.md). The box pinch
    # resumes while its two boxes squeeze the sheet; the thin limb while it drags the sheet, in
    # frames whose substeps are halved and start halved (SubstepLevel; a frame starts halved
    # only for its bodies' motion, decided from the frame's state: body_motion.h).
    from scenes.contact import box_pinch, drape_sphere, thin_limb

    if scene == "drape":
        doc, frames, cut = drape_sphere(tmp_path, n=16, frames=14, width=0.5, radius=0.2, drop=0.02), 14, 7
    elif scene == "thin_limb":
        doc, frames, cut = thin_limb(tmp_path, frames=7), 7, 4
    else:
        doc, frames, cut = box_pinch(tmp_path), 25, 10
    shot = tmp_path / "shot.json"
    shot.write_text(json.dumps(doc))
    whole, split = tmp_path / "whole.h5", tmp_path / "split.h5"
    assert weft("run", str(shot), "-o", str(whole), "--quiet").returncode == 0
    first = weft("run", str(shot), "-o", str(split), "--quiet", "--frames", str(cut))
    assert first.returncode == 0, first.stderr
    with open_cache_reader(split) as f:
        flags = f["state/collision_flags"][()]
        assert flags.dtype == np.uint8 and len(flags) == 4 + len(doc["bodies"]) and set(flags) <= {0, 1}
    second = weft("run", str(shot), "-o", str(split), "--quiet", "--resume")
    assert second.returncode == 0, second.stderr
    with open_cache_reader(whole) as a, open_cache_reader(split) as b:
        assert a["frames/positions"].shape[0] == b["frames/positions"].shape[0] == frames
        assert np.array_equal(a["frames/positions"][()], b["frames/positions"][()])
        assert np.array_equal(a["state/velocities"][()], b["state/velocities"][()])
        assert np.array_equal(a["state/collision_flags"][()], b["state/collision_flags"][()])
    # `weft info`'s substeps: the same steps in both; only the thin limb (3 cm thick, 3 m/s) has
    # frames started halved for its motion.
    info_whole, info_split = describe_cache(whole), describe_cache(split)
    for key in ("substeps", "halved_substeps", "frames_started_halved", "friction_spreads"):
        assert info_whole[key] == info_split[key], key
    assert (info_whole["frames_started_halved"] > 0) == (scene == "thin_limb"), info_whole
    if scene == "thin_limb":  # resumed across steps whose friction went through the sheet's response
        assert info_whole["friction_spreads"] > 0, info_whole


def test_set_state_checks_the_collision_flags(tmp_path) -> None:
    from scenes.contact import drape_sphere
    from tests.helpers import make_scene
    from weft import _solver
    from weft.solver_setup import build_setup

    scene = make_scene(drape_sphere(tmp_path, n=8, frames=3, width=0.5, radius=0.2, drop=0.02), tmp_path)
    sim = _solver.Simulation(build_setup(scene, 1))
    x, v = np.array(sim.positions), np.array(sim.velocities)
    # A new simulation: GIA due on every body, the cloth/cloth part not (the start's exact count
    # found no cloth/cloth intersection), contacts not set aside, no body watched.
    assert list(sim.collision_flags) == [1, 0, 1, 0, 0]
    with pytest.raises(ValueError, match=r"collision_flags must be empty or have 4 \+ one entry per body \(5\), not 2"):
        sim.set_state(x, v, collision_flags=np.array([0, 0], dtype=np.uint8))
    with pytest.raises(ValueError, match="collision_flags entries must be 0 or 1"):
        sim.set_state(x, v, collision_flags=np.array([0, 0, 2, 0, 0], dtype=np.uint8))
    assert list(sim.collision_flags) == [1, 0, 1, 0, 0]  # refused: nothing changed
    sim.set_state(x, v, collision_flags=np.array([0, 0, 0, 0, 0], dtype=np.uint8))
    assert list(sim.collision_flags) == [0, 0, 0, 0, 0]
    flag = _solver.Simulation(build_setup(make_scene(json.loads(write_shot(tmp_path, frames=2).read_text())), 1))
    with pytest.raises(ValueError, match="collision_flags given for a simulation without collisions"):
        flag.set_state(np.array(flag.positions), np.array(flag.velocities), collision_flags=np.zeros(4, dtype=np.uint8))


def test_resume_refuses_a_different_shot(tmp_path) -> None:
    shot = write_shot(tmp_path, frames=6)
    cache = tmp_path / "c.h5"
    assert weft("run", str(shot), "-o", str(cache), "--quiet", "--frames", "3").returncode == 0
    (tmp_path / "other").mkdir()
    other = write_shot(tmp_path / "other", frames=6, n=10)
    result = weft("run", str(other), "-o", str(cache), "--quiet", "--resume")
    assert result.returncode == 2 and "different shot" in result.stderr


def start_run(tmp_path: Path, frames: int = 3000) -> tuple[subprocess.Popen, Path]:
    """`weft run` on a long shot, returned once it has finished four frames: the saved state's
    frame index (written last of a frame, `CacheWriter.append`) has reached the fourth. The
    frame rows alone are not enough: a reader sees a frame's row before its state is saved, and
    a kill in between leaves that frame unfinished (a recovery keeps three)."""
    import time

    from weft.cache import saved_state_group

    shot = write_shot(tmp_path, frames=frames, n=24, substeps=8)
    cache = tmp_path / "stopped.h5"
    proc = subprocess.Popen([sys.executable, "-m", "weft.cli", "run", str(shot), "-o", str(cache), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            _, err = proc.communicate()
            raise AssertionError(f"the run ended (exit {proc.returncode}) before four frames: {err[-2000:]}")
        try:
            with open_cache_reader(cache) as f:
                if int(f[saved_state_group(f)]["frame_index"][0]) >= 3:
                    return proc, cache
        except Exception:  # not created yet
            pass
        time.sleep(0.05)
    proc.kill()
    _, err = proc.communicate()
    raise AssertionError(f"the run wrote no frames in 120 s: {err[-2000:]}")


def plain_open_status(cache: Path) -> tuple[str, int]:
    """Opened the way any HDF5 tool does (no SWMR, no weft)."""
    import h5py

    with h5py.File(cache, "r") as f:
        return str(f.attrs["status"]), int(f["frames/frame"].shape[0])


def test_a_reader_polling_the_cache_does_not_stop_its_writer(tmp_path) -> None:
    """A reader (the API, the dashboard, `weft info`) that opened the cache between the file's
    appearance at its path and the writer's own open held HDF5's file lock, and the writer's open
    failed ('unable to lock file'), ending the run: with a reader polling as fast as it can, every
    run of the old code failed. The writer now holds the file in SWMR mode before it appears,
    also when it resumes."""
    shot = write_shot(tmp_path, frames=6, n=10, substeps=1)
    cache = tmp_path / "polled.h5"
    for args in (["--frames", "3"], ["--resume"]):
        proc = subprocess.Popen([sys.executable, "-m", "weft.cli", "run", str(shot), "-o", str(cache), "--quiet", *args],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        opened = 0
        while proc.poll() is None:
            try:
                with open_cache_reader(cache):
                    opened += 1
            except Exception:  # not there yet, or being replaced
                pass
        _, err = proc.communicate()
        assert proc.returncode == 0, err
        assert opened > 0
    assert plain_open_status(cache) == ("complete", 6)


def test_sigterm_closes_the_cache_readable_by_plain_h5py_and_resumable(tmp_path) -> None:
    import signal

    proc, cache = start_run(tmp_path)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "stopped by SIGTERM" in err and "--resume" in err
    status, rows = plain_open_status(cache)
    assert status == "interrupted" and rows >= 4
    resumed = weft("run", str(tmp_path / "shot.json"), "-o", str(cache), "--resume", "--frames", str(rows + 2), "-q")
    assert resumed.returncode == 0, resumed.stderr
    assert plain_open_status(cache) == ("partial", rows + 2)


def test_a_writer_killed_outright_is_recovered_by_weft_info(tmp_path) -> None:
    import h5py
    import pytest

    proc, cache = start_run(tmp_path)
    proc.kill()  # SIGKILL: no handler runs, the file stays flagged open for writing
    proc.communicate(timeout=60)
    with pytest.raises(OSError):
        h5py.File(cache, "r")
    hint = weft("info", str(cache))
    assert hint.returncode == 0 and "--recover" in hint.stderr
    recovered = weft("info", str(cache), "--recover", "--json")
    assert recovered.returncode == 0, recovered.stderr
    summary = json.loads(recovered.stdout)
    assert summary["status"] == "interrupted" and summary["frames_written"] >= 4
    status, rows = plain_open_status(cache)
    assert status == "interrupted" and rows == summary["frames_written"]
    again = weft("info", str(cache), "--recover")
    assert again.returncode == 2 and "nothing to recover" in again.stderr


def test_a_stale_writer_cannot_rewrite_a_taken_over_cache(tmp_path) -> None:
    """Issue 15: a worker that froze, was replaced, and woke after its successor finished the
    job rewrote the finished cache's status to failed ("Superseded"). A resume replaces the file,
    and a writer whose file is no longer at the path leaves what is there alone."""
    from weft.cache import CacheWriter
    from weft.runner import ShotRunner
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    shot_path = write_shot(tmp_path, frames=6)
    scene = resolve_scene(parse_shot(json.loads(shot_path.read_text())), tmp_path)
    cache = tmp_path / "c.h5"
    ShotRunner(scene, cache, frames=3).run()
    stale, _ = CacheWriter.resume(cache, scene.shot_hash)  # the worker that will freeze
    summary = ShotRunner(scene, cache, resume=True).run()  # its successor takes over and finishes
    assert summary.status == "complete" and describe_cache(cache)["status"] == "complete"
    stale.close("failed", "Superseded")  # the frozen worker wakes up and gives up
    info = describe_cache(cache)
    assert (info["status"], info["frames_written"]) == ("complete", 6)
    # Its own file, still at the path, does get the status.
    ShotRunner(scene, tmp_path / "own.h5", frames=2).run()
    own, _ = CacheWriter.resume(tmp_path / "own.h5", scene.shot_hash)
    own.close("cancelled")
    assert describe_cache(tmp_path / "own.h5")["status"] == "cancelled"


def test_a_writer_killed_between_state_arrays_and_index_resumes_exactly(tmp_path) -> None:
    """A worker SIGKILLed after writing a frame's state arrays but before its frame index left
    the next frame's state under the previous frame's index, and the resumed run simulated that
    frame twice (a service cache that differed from the direct run, seen once in five runs of
    tests/service/test_crash.py). The state goes to /state_next, then /state, each index last:
    a kill in either leaves the other whole. The torn write is made here by hand."""
    import h5py

    from weft.runner import ShotRunner
    from weft.shot import parse_shot
    from weft.solver_setup import resolve_scene

    shot_path = write_shot(tmp_path, frames=8)
    scene = resolve_scene(parse_shot(json.loads(shot_path.read_text())), tmp_path)
    whole, four, torn = tmp_path / "whole.h5", tmp_path / "four.h5", tmp_path / "torn.h5"
    ShotRunner(scene, whole).run()
    ShotRunner(scene, four, frames=4).run()
    ShotRunner(scene, torn, frames=3).run()
    with h5py.File(four, "r") as done, h5py.File(torn, "r+") as f:
        # Frame row 3 written, then /state_next whole, then /state's arrays but not its index.
        for name in ("frames/positions", "frames/velocities", "frames/frame", "telemetry"):
            f[name].resize(4, axis=0)
            f[name][3] = done[name][3]
        for group in ("state_next", "state"):
            for name in ("positions", "velocities", "warm_start"):
                f[f"{group}/{name}"][...] = done[f"state/{name}"][()]
        f["state_next/frame_index"][0] = 3
        assert f["state/frame_index"][0] == 2
    assert ShotRunner(scene, torn, resume=True).run().resumed_from == 3
    with open_cache_reader(whole) as a, open_cache_reader(torn) as b:
        assert np.array_equal(a["frames/positions"][()], b["frames/positions"][()])
        for group in ("state", "state_next"):
            assert np.array_equal(a["state/positions"][()], b[f"{group}/positions"][()])
