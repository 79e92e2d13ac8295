"""POST /v1/jobs/{id}/retry (issue 15): a failed or cancelled job continues from its last
finished frame, through real HTTP, Redis and workers."""

from __future__ import annotations

import httpx

from .conftest import follow, job_state, slow_shot, small_shot, wait_for


def test_a_cancelled_job_retried_continues_from_its_last_frame(alice: httpx.Client) -> None:
    job_id = alice.post("/v1/jobs", json=slow_shot("retry", frames=30)).json()["id"]
    wait_for(lambda: job_state(alice, job_id)["frames_done"] >= 3, what="3 frames")
    assert alice.post(f"/v1/jobs/{job_id}/cancel").status_code == 200
    assert follow(alice, job_id)[-1][2]["state"] == "cancelled"
    stopped_at = job_state(alice, job_id)["frames_done"]
    assert stopped_at < 30

    r = alice.post(f"/v1/jobs/{job_id}/retry")
    assert r.status_code == 200, r.text
    assert r.json()["state"] in ("queued", "running") and r.json()["cancel_requested"] is False
    events = follow(alice, job_id)
    job = job_state(alice, job_id)
    assert job["state"] == "succeeded" and job["error"] is None
    kinds = [e for e, _, _ in events]
    assert kinds.count("end") == 1 and kinds[-1] == "end", "the cancelled run's end event is gone"
    retried = [d for e, _, d in events if e == "retried"]
    assert len(retried) == 1 and retried[0] == {"frames_done": stopped_at, "previous_state": "cancelled",
                                                "previous_error": None}
    assert [d["frame"] for e, _, d in events if e == "frame"] == list(range(1, 31)), "each frame once, in order"
    ids = [tuple(map(int, i.split("-"))) for _, i, _ in events]
    assert ids == sorted(ids), "event ids increase, so Last-Event-ID resumes work across the retry"
    assert job["resumed_from"] is not None and job["resumed_from"] >= stopped_at, "not re-simulated from frame 1"
    assert len(alice.get(f"/v1/jobs/{job_id}/telemetry").json()["rows"]) == 30


def test_only_failed_or_cancelled_jobs_can_be_retried(alice: httpx.Client, bob: httpx.Client) -> None:
    job_id = alice.post("/v1/jobs", json=small_shot("retry-done", frames=3)).json()["id"]
    assert follow(alice, job_id)[-1][2]["state"] == "succeeded"
    again = alice.post(f"/v1/jobs/{job_id}/retry")
    assert again.status_code == 409 and "only failed or cancelled" in again.json()["detail"]
    assert bob.post(f"/v1/jobs/{job_id}/retry").status_code == 404, "another key's job is not found"
    assert alice.post("/v1/jobs/0123456789abcdef0123456789abcdef/retry").status_code == 404
