"""Submit, follow, fetch: the happy paths of the API against a real Redis and real HTTP."""

from __future__ import annotations

import io
import json

import h5py
import httpx
import numpy as np
import trimesh

from scenes.builders import grid_sheet

from .conftest import follow, job_state, slow_shot, small_shot, wait_for


def test_submit_follow_fetch(alice: httpx.Client, tmp_path) -> None:  # type: ignore[no-untyped-def]
    r = alice.post("/v1/jobs", json=slow_shot("follow", frames=30))
    assert r.status_code == 201, r.text
    created = r.json()
    job_id = created["id"]
    assert r.headers["location"] == created["url"] and created["url"].endswith(f"/v1/jobs/{job_id}")

    mid_run: dict[str, int] = {}

    def on_event(event: str, data: dict) -> None:  # type: ignore[type-arg]
        # Mid-run, the cache is a readable HDF5 file with the frames finished so far.
        if event == "frame" and data["index"] == 5 and not mid_run:
            cache = alice.get(f"/v1/jobs/{job_id}/cache")
            assert cache.status_code == 200, cache.text
            path = tmp_path / "mid.h5"
            path.write_bytes(cache.content)
            with h5py.File(path, "r") as f:
                mid_run["frames"] = int(f["frames/frame"].shape[0])
                assert f["frames/positions"].shape[0] == mid_run["frames"]
                assert list(f["frames/frame"][()]) == list(range(1, mid_run["frames"] + 1))
            mid_run["state"] = job_state(alice, job_id)["state"]

    events = follow(alice, job_id, on_event)
    frames = [data["frame"] for event, _, data in events if event == "frame"]
    assert frames == list(range(1, 31)), "every frame once, in order"
    assert [e for e, _, _ in events].count("end") == 1 and events[-1][0] == "end"
    assert events[-1][2]["state"] == "succeeded"
    assert 6 <= mid_run["frames"] < 30 and mid_run["state"] == "running"

    job = job_state(alice, job_id)
    assert job["state"] == "succeeded" and job["frames_done"] == job["frames_total"] == 30
    assert job["worker"] and job["attempts"] == 1 and job["resumed_from"] is None
    timing = job["timing"]
    assert timing["frames"] == 29 and timing["solve_seconds"] > 0 and timing["build_seconds"] > 0

    telemetry = alice.get(f"/v1/jobs/{job_id}/telemetry").json()["rows"]
    assert [row["frame"] for row in telemetry] == list(range(1, 31))
    later = alice.get(f"/v1/jobs/{job_id}/telemetry", params={"since": 25}).json()["rows"]
    assert [row["frame"] for row in later] == [26, 27, 28, 29, 30]

    final = alice.get(f"/v1/jobs/{job_id}/cache")
    assert final.status_code == 200
    (tmp_path / "final.h5").write_bytes(final.content)
    with h5py.File(tmp_path / "final.h5", "r") as f:
        positions = f["frames/positions"][()]
        assert f.attrs["status"] == "complete" and positions.shape == (30, 256, 3)

    as_json = alice.get(f"/v1/jobs/{job_id}/frames/30")
    assert as_json.status_code == 200
    assert np.array_equal(np.asarray(as_json.json()["positions"], dtype=np.float32), positions[29])
    as_npy = alice.get(f"/v1/jobs/{job_id}/frames/12", headers={"Accept": "application/x-npy"})
    assert as_npy.headers["content-type"] == "application/x-npy"
    assert np.array_equal(np.load(io.BytesIO(as_npy.content)), positions[11])

    # A late client replays the whole stream; Last-Event-ID resumes after a given event.
    again = follow(alice, job_id)
    assert [d.get("frame") for e, _, d in again if e == "frame"] == frames
    with alice.stream("GET", f"/v1/jobs/{job_id}/events", headers={"Last-Event-ID": "28-0"}) as resp:
        text = "".join(resp.iter_text())
    assert "id: 29-0" in text and "id: 28-0" not in text and "event: end" in text


def test_multipart_upload_with_mesh_file(alice: httpx.Client) -> None:
    vertices, faces = grid_sheet(6, 6, 0.4, 0.4)
    obj = trimesh.exchange.obj.export_obj(trimesh.Trimesh(vertices, faces, process=False))
    shot = small_shot("upload", frames=6)
    shot["cloth"][0]["mesh"] = {"path": "./meshes/sheet.obj"}  # matched to the upload's normalized name
    shot["cloth"][0]["pins"] = [{"vertices": [0, 5]}]
    r = alice.post(
        "/v1/jobs",
        files=[("shot", ("shot.json", json.dumps(shot), "application/json")),
               ("assets", ("meshes/sheet.obj", obj.encode(), "text/plain"))],
    )
    assert r.status_code == 201, r.text
    events = follow(alice, r.json()["id"])
    assert events[-1][2]["state"] == "succeeded"
    job = job_state(alice, r.json()["id"])
    assert job["vertices"] == 36 and job["frames_done"] == 6


def test_idempotency_listing_and_workers(alice: httpx.Client, bob: httpx.Client) -> None:
    shot = small_shot("idem", frames=4)
    second = alice.post("/v1/jobs", json=small_shot("idem-2", frames=4))  # two of Alice's jobs to page through
    first = alice.post("/v1/jobs", json=shot, headers={"Idempotency-Key": "render-42"})
    again = alice.post("/v1/jobs", json=shot, headers={"Idempotency-Key": "render-42"})
    assert first.status_code == 201 and again.status_code == 200
    assert again.json()["id"] == first.json()["id"] and again.json()["duplicate"] is True
    # The same key from another API key is a different submission.
    other = bob.post("/v1/jobs", json=shot, headers={"Idempotency-Key": "render-42"})
    assert other.status_code == 201 and other.json()["id"] != first.json()["id"]
    for c, r in ((alice, first), (alice, second), (bob, other)):
        wait_for(lambda c=c, r=r: job_state(c, r.json()["id"])["state"] == "succeeded", what="jobs to finish")

    ids = {j["id"] for j in bob.get("/v1/jobs").json()["jobs"]}
    assert other.json()["id"] in ids and first.json()["id"] not in ids, "each key sees only its own jobs"

    page1 = alice.get("/v1/jobs", params={"state": "succeeded", "limit": 1}).json()
    assert page1["total"] >= 2 and len(page1["jobs"]) == 1 and page1["next_offset"] == 1
    page2 = alice.get("/v1/jobs", params={"state": "succeeded", "limit": 1, "offset": 1}).json()
    assert page2["jobs"][0]["id"] != page1["jobs"][0]["id"]
    assert all(j["state"] == "succeeded" for j in page1["jobs"] + page2["jobs"])
    queued = alice.get("/v1/jobs", params={"state": "queued"}).json()["jobs"]
    assert all(j["state"] == "queued" for j in queued) and first.json()["id"] not in {j["id"] for j in queued}

    def live_workers() -> list[dict] | None:  # type: ignore[type-arg]
        workers = [w for w in alice.get("/v1/workers").json()["workers"] if w["alive"]]
        return workers if len(workers) >= 2 else None

    workers = wait_for(live_workers, timeout=30, what="two live workers")
    assert all(w["seconds_since_heartbeat"] < 5 for w in workers)


def test_health_ready_metrics_openapi(alice: httpx.Client) -> None:
    assert alice.get("/healthz").json() == {"status": "ok"}
    assert alice.get("/readyz").status_code == 200
    metrics = alice.get("/metrics")
    assert metrics.status_code == 200 and "weft_jobs{state=\"succeeded\"}" in metrics.text
    assert "weft_workers_alive" in metrics.text
    spec = alice.get("/openapi.json").json()
    for path in ("/v1/jobs", "/v1/jobs/{job_id}", "/v1/jobs/{job_id}/telemetry", "/v1/jobs/{job_id}/events",
                 "/v1/jobs/{job_id}/cache", "/v1/jobs/{job_id}/frames/{frame}", "/v1/jobs/{job_id}/cancel",
                 "/v1/workers", "/healthz", "/readyz", "/metrics"):
        assert path in spec["paths"], path
    assert "Shot" in spec["components"]["schemas"]
