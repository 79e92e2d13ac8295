"""Worker death, Redis restarts, solver blow-ups and cancellation."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import h5py
import httpx
import numpy as np

from server.stack import Stack
from scenes.builders import sheet_shot

from .conftest import ALICE, client, follow, job_state, slow_shot, small_shot, wait_for


def test_sigkill_worker_resumes_from_last_frame(stack: Stack, alice: httpx.Client, tmp_path: Path) -> None:
    shot = slow_shot("crash", frames=60)
    job_id = alice.post("/v1/jobs", json=shot).json()["id"]
    job = wait_for(lambda: (j := job_state(alice, job_id))["frames_done"] >= 3 and j, what="3 frames")
    victim = stack.worker_named(job["worker"])
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    killed_at = job_state(alice, job_id)["frames_done"]
    assert killed_at < 60, "the worker must die mid-shot"
    stack.start_worker()  # keep the pool at two

    events = follow(alice, job_id)
    job = job_state(alice, job_id)
    assert job["state"] == "succeeded", job
    assert job["attempts"] == 2 and job["worker"] != victim.name  # type: ignore[attr-defined]
    # It continued from the last finished frame, not from frame 0.
    assert job["resumed_from"] is not None and job["resumed_from"] >= killed_at
    resumed = [d for e, _, d in events if e == "resumed"]
    assert len(resumed) == 1 and resumed[0]["resumed_from_frame"] == job["resumed_from"]
    assert [d["frame"] for e, _, d in events if e == "frame"] == list(range(1, 61)), "each frame once, in order"
    assert len(alice.get(f"/v1/jobs/{job_id}/telemetry").json()["rows"]) == 60

    (tmp_path / "service.h5").write_bytes(alice.get(f"/v1/jobs/{job_id}/cache").content)
    shot_path = tmp_path / "crash.json"
    shot_path.write_text(json.dumps(shot))
    weft = Path(sys.executable).with_name("weft")
    subprocess.run([str(weft), "run", str(shot_path), "-o", str(tmp_path / "direct.h5"), "--threads", "1", "-q"],
                   check=True, capture_output=True)
    with h5py.File(tmp_path / "service.h5", "r") as a, h5py.File(tmp_path / "direct.h5", "r") as b:
        assert a["frames/positions"].shape == b["frames/positions"].shape == (60, 256, 3)
        assert np.array_equal(a["frames/positions"][()], b["frames/positions"][()])
        assert np.array_equal(a["frames/velocities"][()], b["frames/velocities"][()])
        assert np.array_equal(a["state/positions"][()], b["state/positions"][()]), "exact final solver state"


def test_sigterm_hands_the_job_back_at_once(stack: Stack, alice: httpx.Client) -> None:
    job_id = alice.post("/v1/jobs", json=slow_shot("sigterm", frames=40)).json()["id"]
    job = wait_for(lambda: (j := job_state(alice, job_id))["frames_done"] >= 3 and j, what="3 frames")
    leaving = stack.worker_named(job["worker"])
    leaving.send_signal(signal.SIGTERM)
    assert leaving.wait(timeout=20) == 0, "a stopped worker exits cleanly after its frame"
    stack.start_worker()
    events = follow(alice, job_id)
    job = job_state(alice, job_id)
    assert job["state"] == "succeeded" and job["attempts"] == 2 and job["resumed_from"] >= 3
    assert [d["frame"] for e, _, d in events if e == "frame"] == list(range(1, 41))
    workers = {w["name"]: w for w in alice.get("/v1/workers").json()["workers"]}
    assert leaving.name not in workers, "a worker that stops cleanly deregisters"  # type: ignore[attr-defined]


def test_solver_blowup_fails_with_frame_and_reason(alice: httpx.Client) -> None:
    # Gravity so strong that the first step's forces overflow: the solver reports non-finite
    # state at frame 2 (frame 1 is the initial state, which is kept).
    shot = sheet_shot("blowup", 4, 4, 0.5, 0.5, pins=[0, 3], frames=10, gravity=(0.0, -1e300, 0.0))
    job_id = alice.post("/v1/jobs", json=shot).json()["id"]
    events = follow(alice, job_id)
    job = job_state(alice, job_id)
    assert job["state"] == "failed"
    assert job["error"]["frame"] == 2 and "non-finite" in job["error"]["reason"]
    assert events[-1][2]["state"] == "failed" and events[-1][2]["error_frame"] == 2
    assert job["frames_done"] == 1
    # The frames before the failure are kept.
    early = alice.get(f"/v1/jobs/{job_id}/frames/1")
    assert early.status_code == 200 and all(None not in p for p in early.json()["positions"])
    assert alice.get(f"/v1/jobs/{job_id}/frames/1", params={"format": "npy"}).status_code == 200
    missing = alice.get(f"/v1/jobs/{job_id}/frames/2")
    assert missing.status_code == 404 and "not simulated" in missing.json()["detail"]


def test_cancel_stops_within_one_frame(alice: httpx.Client) -> None:
    job_id = alice.post("/v1/jobs", json=slow_shot("cancel", frames=400)).json()["id"]
    wait_for(lambda: job_state(alice, job_id)["frames_done"] >= 3, what="3 frames")
    r = alice.post(f"/v1/jobs/{job_id}/cancel")
    assert r.status_code == 200 and r.json()["cancel_requested"] is True
    at_cancel = r.json()["frames_done"]
    events = follow(alice, job_id)
    job = job_state(alice, job_id)
    assert job["state"] == "cancelled" and events[-1][2]["state"] == "cancelled"
    assert at_cancel <= job["frames_done"] <= at_cancel + 1, (at_cancel, job["frames_done"])
    again = alice.post(f"/v1/jobs/{job_id}/cancel")
    assert again.status_code == 409 and "already cancelled" in again.json()["detail"]


def test_redis_restart_loses_no_queued_job(own_stack: Stack) -> None:
    with client(own_stack, ALICE) as c:
        ids = [c.post("/v1/jobs", json=small_shot(f"queued{i}", frames=5)).json()["id"] for i in range(4)]
        cancelled = ids.pop()
        assert c.post(f"/v1/jobs/{cancelled}/cancel").json()["state"] == "cancelled"
        # Concurrent requests leave the API's pool holding several idle connections, each of
        # them stale once Redis restarts.
        with ThreadPoolExecutor(8) as pool:
            assert set(pool.map(lambda _: c.get("/v1/jobs").status_code, range(32))) == {200}
        own_stack.kill_redis()  # SIGKILL: no chance to save anything beyond the append-only file
        down = c.get("/v1/jobs")
        assert down.status_code == 503 and "unavailable" in down.json()["detail"]
        assert c.get("/readyz").status_code == 503
        own_stack.start_redis()
        # No request fails for a connection the restart left stale.
        with ThreadPoolExecutor(8) as pool:
            statuses = list(pool.map(lambda _: c.get("/v1/jobs", params={"state": "queued"}).status_code, range(32)))
        assert statuses == [200] * 32, statuses
        listed = c.get("/v1/jobs", params={"state": "queued"}).json()
        assert sorted(j["id"] for j in listed["jobs"]) == sorted(ids)
        own_stack.start_worker()
        for job_id in ids:
            assert follow(c, job_id)[-1][2]["state"] == "succeeded"
        assert job_state(c, cancelled)["state"] == "cancelled"
        assert job_state(c, cancelled)["frames_done"] == 0, "a cancelled queued job never runs"


def test_redis_killed_mid_job(own_stack: Stack) -> None:
    """Redis dies while a worker runs a job: the worker waits for it, takes the job up again
    from its cache, and the event stream (kept open by the API) still has every frame once."""
    worker_log = own_stack.log_dir / f"{own_stack.start_worker().name}.log"  # type: ignore[attr-defined]
    with client(own_stack, ALICE) as c:
        job_id = c.post("/v1/jobs", json=slow_shot("redis-mid", frames=40)).json()["id"]
        wait_for(lambda: job_state(c, job_id)["frames_done"] >= 3, what="3 frames")
        events: list[tuple[str, str, dict]] = []  # type: ignore[type-arg]
        connected = threading.Event()

        def follow_all() -> None:
            with client(own_stack, ALICE) as own:
                events.extend(follow(own, job_id, lambda *_: connected.set()))

        follower = threading.Thread(target=follow_all)
        follower.start()
        assert connected.wait(30)
        own_stack.kill_redis()
        # Redis stays down until the worker has run into it (not a fixed sleep that may be too short).
        wait_for(lambda: "redis unavailable" in worker_log.read_text(), timeout=30, what="the worker to see Redis down")
        assert c.get("/readyz").status_code == 503
        own_stack.start_redis()
        follower.join(timeout=120)
        assert not follower.is_alive()
        job = job_state(c, job_id)
        assert job["state"] == "succeeded", job
        assert job["attempts"] == 2 and job["resumed_from"] >= 3, "the interrupted run was taken up again"
        assert [d["frame"] for e, _, d in events if e == "frame"] == list(range(1, 41))
        assert len(c.get(f"/v1/jobs/{job_id}/telemetry").json()["rows"]) == 40
