"""server/routes/jobs.py: submit, list, read, cancel."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import redis
from routes_support import MISSING_JOB, Api, assert_error, small_shot

from weft import jobstore, scheduler
from weft.jobstore import ServiceSettings

JOB = f"/v1/jobs/{MISSING_JOB}"


# -- POST /v1/jobs ------------------------------------------------------------------------------
def test_submit_queues_the_job(alice: Api, redis_db: redis.Redis, settings: ServiceSettings) -> None:
    r = alice.post("/v1/jobs", json=small_shot("queued", frames=4))
    assert r.status_code == 201, r.text
    job_id = r.json()["id"]
    assert r.json()["state"] == "queued" and r.headers["location"].endswith(f"/v1/jobs/{job_id}")
    record = redis_db.hgetall(jobstore.job_key(job_id))
    assert record["state"] == "queued" and record["frames_total"] == "4" and record["vertices"] == "36"
    assert redis_db.sismember(jobstore.state_key("queued"), job_id)
    # Waiting in its pool's ready set for a worker's dispatch (weft.scheduler), with its priority.
    ready = redis_db.zrange(scheduler.ready_key("default", record["owner"]), 0, -1, withscores=True)
    assert [job_id for job_id, _ in ready] == [job_id] and ready[0][1] == scheduler.ready_score(50, float(record["created"]))
    assert redis_db.llen(scheduler.doorbell_key("default")) == 1
    assert json.loads((settings.job_dir(job_id) / "shot.json").read_text())["name"] == "queued"


def test_submit_multipart_with_an_asset(alice: Api) -> None:
    shot = small_shot("upload")
    shot["cloth"][0]["mesh"] = {"path": "meshes/sheet.obj"}
    shot["cloth"][0]["pins"] = [{"vertices": [0, 1]}]
    obj = b"v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 3\nf 2 4 3\n"
    r = alice.post("/v1/jobs", files=[("shot", ("shot.json", json.dumps(shot), "application/json")),
                                      ("assets", ("meshes/sheet.obj", obj, "text/plain"))])
    assert r.status_code == 201, r.text
    assert alice.get(r.headers["location"]).json()["vertices"] == 4


def test_submit_hdf5_asset_stored_externally_in_etc_passwd_is_a_422(alice: Api, tmp_path) -> None:
    """Issue 15's file-read hole: the upload's dataset points at /etc/passwd; the job is refused
    naming the field, and nothing of the file comes back."""
    import h5py

    size = Path("/etc/passwd").stat().st_size // 8 * 8
    with h5py.File(tmp_path / "anim.h5", "w") as f:
        f.create_dataset("positions", shape=(size // 24, 1, 3), dtype="<f8", external=[("/etc/passwd", 0, size)])
    shot = small_shot("external", frames=4)
    shot["bodies"] = [{"name": "b", "mesh": {"vertices": [[0, -1, 0], [1, -1, 0], [0, -1, 1]], "faces": [[0, 1, 2]]},
                       "animation": {"path": "anim.h5"}}]
    r = alice.post("/v1/jobs", files=[("shot", ("shot.json", json.dumps(shot), "application/json")),
                                      ("assets", ("anim.h5", (tmp_path / "anim.h5").read_bytes(),
                                                  "application/octet-stream"))])
    assert_error(r, 422, "bodies[0].animation.key", "stored outside the file")
    assert "root" not in r.text


def test_submit_of_hours_of_work_on_a_few_vertices_is_refused_by_the_cost_budget(alice: Api) -> None:
    shot = small_shot("forever", frames=50)  # the test service's budget: 200,000 vertex-substeps
    shot["substeps"] = 1000
    r = alice.post("/v1/jobs", json=shot)
    assert_error(r, 422, "substeps", "vertex-substeps exceeds this service's budget")
    assert any(e["field"] == "frame_range" for e in r.json()["errors"])
    within = small_shot("within", frames=50)  # 36 x 49 x 4: well inside
    assert alice.post("/v1/jobs", json=within).status_code == 201


def test_submit_idempotency_key_returns_the_first_job(alice: Api, bob: Api) -> None:
    key = {"Idempotency-Key": "render-42"}
    first = alice.post("/v1/jobs", json=small_shot(), headers=key)
    again = alice.post("/v1/jobs", json=small_shot(), headers=key)
    assert first.status_code == 201 and again.status_code == 200
    assert again.json() == {**first.json(), "duplicate": True}
    other = bob.post("/v1/jobs", json=small_shot(), headers=key)
    assert other.status_code == 201 and other.json()["id"] != first.json()["id"]


def test_idempotency_key_reused_with_a_different_body_is_a_409(alice: Api, settings: ServiceSettings) -> None:
    key = {"Idempotency-Key": "render-43"}
    first = alice.post("/v1/jobs", json=small_shot("first"), headers=key)
    assert first.status_code == 201
    jobs_before = sorted(p.name for p in settings.storage.joinpath("jobs").iterdir())
    other = alice.post("/v1/jobs", json=small_shot("second"), headers=key)
    assert_error(other, 409, "was used for a different request")
    assert first.json()["id"] in other.json()["detail"]
    assert sorted(p.name for p in settings.storage.joinpath("jobs").iterdir()) == jobs_before  # nothing left
    # An invalid body under a used key is named like any invalid body, never answered with the first job.
    bad = small_shot("bad")
    bad["fps"] = -1
    assert_error(alice.post("/v1/jobs", json=bad, headers=key), 422, "fps")


def test_submit_bad_field_names_it_and_leaves_nothing(alice: Api,
                                                      settings: ServiceSettings, redis_db: redis.Redis) -> None:
    assert_error(alice.post("/v1/jobs", json={**small_shot(), "fps": "fast"}), 422, "fps")
    assert_error(alice.post("/v1/jobs", json={**small_shot(), "colour": "red"}), 422, "colour")
    assert_error(alice.post("/v1/jobs", json=small_shot(frames=80)), 422, "frame_range", "exceeds the limit of 50")
    assert_error(alice.post("/v1/jobs", content=b"name: x", headers={"Content-Type": "text/yaml"}), 415, "Content-Type")
    assert_error(alice.post("/v1/jobs", json=small_shot(), headers={"Idempotency-Key": "x" * 300}), 400, "Idempotency-Key")
    assert_error(alice.post("/v1/jobs", content=b"{" + b" " * 150_000 + b"}",
                     headers={"Content-Type": "application/json"}), 413, "limit")
    assert list((settings.storage / "jobs").iterdir()) == [], "a refused submission leaves no folder"
    assert redis_db.xlen(jobstore.QUEUE) == 0


def test_submit_needs_a_key(check_auth: Callable[..., None], redis_db: redis.Redis) -> None:
    check_auth("POST", "/v1/jobs", json=small_shot())
    assert redis_db.xlen(jobstore.QUEUE) == 0


# -- GET /v1/jobs -------------------------------------------------------------------------------
def test_list_own_jobs_newest_first_paginated(alice: Api, bob: Api) -> None:
    ids = [alice.submit(small_shot(f"job{i}")) for i in range(3)]
    bobs = bob.submit()
    listed = alice.get("/v1/jobs").json()
    assert [j["id"] for j in listed["jobs"]] == ids[::-1] and listed["total"] == 3
    page = alice.get("/v1/jobs", params={"limit": 2, "offset": 1}).json()
    assert [j["id"] for j in page["jobs"]] == ids[1::-1] and page["next_offset"] is None
    first = alice.get("/v1/jobs", params={"limit": 2}).json()
    assert first["next_offset"] == 2
    assert alice.get("/v1/jobs", params={"state": "queued"}).json()["total"] == 3
    assert alice.get("/v1/jobs", params={"state": "succeeded"}).json()["jobs"] == []
    assert [j["id"] for j in bob.get("/v1/jobs").json()["jobs"]] == [bobs]


def test_list_bad_query_names_the_field(alice: Api) -> None:
    assert_error(alice.get("/v1/jobs", params={"state": "exploded"}), 422, "query.state")
    assert_error(alice.get("/v1/jobs", params={"offset": -1}), 422, "query.offset", "greater than or equal to 0")
    assert_error(alice.get("/v1/jobs", params={"limit": 501}), 422, "query.limit", "less than or equal to 500")


def test_list_offset_that_overflows_redis_integers_is_a_422_not_a_500(alice: Api) -> None:
    assert_error(alice.get("/v1/jobs", params={"offset": 9223372036854775807}), 422, "query.offset",
                 "less than or equal to 1000000000")


def test_list_needs_a_key(check_auth: Callable[..., None]) -> None:
    check_auth("GET", "/v1/jobs")


# -- GET /v1/jobs/{id} --------------------------------------------------------------------------
def test_get_job(alice: Api) -> None:
    job_id = alice.submit(small_shot("one", frames=5))
    job = alice.get(f"/v1/jobs/{job_id}").json()
    assert job["id"] == job_id and job["name"] == "one" and job["state"] == "queued"
    assert job["frames_done"] == 0 and job["frames_total"] == 5 and job["frame_range"] == [1, 5]
    assert job["timing"] is None and job["error"] is None and job["url"].endswith(f"/v1/jobs/{job_id}")


def test_get_job_after_a_worker_ran_it(alice: Api, finished_job: str) -> None:
    job = alice.get(f"/v1/jobs/{finished_job}").json()
    assert job["state"] == "succeeded" and job["frames_done"] == 5 and job["worker"] == "test-worker"
    assert job["attempts"] == 1 and job["timing"]["frames"] == 4 and job["timing"]["solve_seconds"] > 0


def test_get_job_bad_unknown_or_foreign_id(alice: Api, bob: Api) -> None:
    assert_error(alice.get("/v1/jobs/not-a-job"), 422, "path.job_id", "pattern")
    assert_error(alice.get(JOB), 404, MISSING_JOB, "")
    bobs = bob.submit()
    assert_error(alice.get(f"/v1/jobs/{bobs}"), 404, f"no job {bobs}")


def test_get_job_needs_a_key(check_auth: Callable[..., None], alice: Api) -> None:
    check_auth("GET", f"/v1/jobs/{alice.submit()}")


# -- POST /v1/jobs/{id}/cancel ------------------------------------------------------------------
def test_cancel_queued_job(alice: Api, redis_db: redis.Redis) -> None:
    job_id = alice.submit()
    r = alice.post(f"/v1/jobs/{job_id}/cancel")
    assert r.status_code == 200 and r.json()["state"] == "cancelled" and r.json()["cancel_requested"] is True
    assert redis_db.sismember(jobstore.state_key("cancelled"), job_id)
    ((event_id, fields),) = redis_db.xrange(jobstore.events_key(job_id))
    assert event_id == jobstore.final_event_id(5) and fields["type"] == "end"
    # Cancelled is final: cancelling it again is a conflict, as for any final state.
    assert_error(alice.post(f"/v1/jobs/{job_id}/cancel"), 409, "already cancelled")


def test_cancel_finished_job_conflicts(alice: Api, finished_job: str) -> None:
    assert_error(alice.post(f"/v1/jobs/{finished_job}/cancel"), 409, "already succeeded")


def test_cancel_bad_unknown_or_foreign_id(alice: Api, bob: Api, redis_db: redis.Redis) -> None:
    assert_error(alice.post("/v1/jobs/XYZ/cancel"), 422, "path.job_id")
    assert_error(alice.post(f"{JOB}/cancel"), 404, "no job")
    bobs = bob.submit()
    assert_error(alice.post(f"/v1/jobs/{bobs}/cancel"), 404, "no job")
    assert redis_db.hget(jobstore.job_key(bobs), "state") == "queued"


def test_cancel_needs_a_key(check_auth: Callable[..., None], alice: Api, redis_db: redis.Redis) -> None:
    job_id = alice.submit()
    check_auth("POST", f"/v1/jobs/{job_id}/cancel")
    assert redis_db.hget(jobstore.job_key(job_id), "state") == "queued"
