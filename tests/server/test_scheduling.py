"""Scheduling and farm operations (issue 17): priorities, pools, fair share between keys, running
quotas, tags and time filters served by indexes, an admin key, delete, the per-job log. Real
Redis, real API (in-process) and real workers' dispatch."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import redis
from fastapi.testclient import TestClient
from routes_support import MISSING_JOB, Api, small_shot

from server.main import create_app
from weft import jobstore, scheduler
from weft.jobstore import ServiceSettings
from workers.worker import Worker

ADMIN = "admin-key-5555555555"


def submit(api: Api, name: str, **params: Any) -> str:
    r = api.post("/v1/jobs", json=small_shot(name), params=params)
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def make_worker(settings: ServiceSettings, name: str, **overrides: Any) -> Worker:
    return Worker(ServiceSettings(**{**settings.__dict__, **overrides}), name=name)


def dispatch(worker: Worker) -> str | None:
    """The job the scheduler gives this worker (its entry now pending on it), or None."""
    worker._ensure_group()
    entry = worker._next_entry()
    return None if entry is None else entry[1]


def start(worker: Worker, job_id: str) -> None:
    """Mark a dispatched job running on the worker (as the worker does before the solver)."""
    state = worker.start_script(keys=[jobstore.job_key(job_id), jobstore.events_key(job_id)],
                                args=[worker.name, jobstore.now(), job_id, "new"])
    assert state == "running"


@pytest.fixture()
def admin(settings: ServiceSettings) -> Iterator[Api]:
    with TestClient(create_app(ServiceSettings(**{**settings.__dict__, "admin_keys": (ADMIN,)}))) as c:
        yield Api(c, ADMIN)


# -- priority, pools, fair share, quotas ---------------------------------------------------------
def test_higher_priority_runs_first_then_the_oldest(alice: Api, settings: ServiceSettings) -> None:
    low = submit(alice, "low", priority=10)
    normal_old, normal_new = submit(alice, "normal-1"), submit(alice, "normal-2")
    high = submit(alice, "high", priority=90)
    worker = make_worker(settings, "w")
    assert [dispatch(worker) for _ in range(5)] == [high, normal_old, normal_new, low, None]
    assert alice.get(f"/v1/jobs/{high}").json()["priority"] == 90


def test_a_job_runs_only_on_a_worker_of_its_pool(alice: Api, settings: ServiceSettings) -> None:
    plain = submit(alice, "plain")
    big = submit(alice, "big", pool="bigmem")
    assert alice.get(f"/v1/jobs/{big}").json()["pool"] == "bigmem"
    ordinary = make_worker(settings, "w-ordinary")
    assert dispatch(ordinary) == plain and dispatch(ordinary) is None  # never the bigmem job
    big_host = make_worker(settings, "w-big", pools=("bigmem", "default"))
    assert dispatch(big_host) == big


def test_keys_tied_on_priority_share_the_farm(alice: Api, bob: Api, settings: ServiceSettings) -> None:
    alice_jobs = [submit(alice, f"a{k}") for k in range(3)]
    bob_job = submit(bob, "b0")  # newer than all of Alice's
    w1, w2, w3 = (make_worker(settings, f"w{k}") for k in range(3))
    assert dispatch(w1) == alice_jobs[0]  # no one runs anything: the oldest job
    start(w1, alice_jobs[0])
    assert dispatch(w2) == bob_job  # Alice has one running, Bob none: Bob's turn
    start(w2, bob_job)
    assert dispatch(w3) == alice_jobs[1]


def test_a_key_at_its_running_quota_waits(alice: Api, bob: Api, settings: ServiceSettings) -> None:
    first, second = submit(alice, "a0"), submit(alice, "a1")
    w1, w2 = (make_worker(settings, f"w{k}", max_running_jobs=1) for k in range(2))
    assert dispatch(w1) == first
    start(w1, first)
    assert dispatch(w2) is None  # Alice's second job waits for her first
    bob_job = submit(bob, "b0")
    assert dispatch(w2) == bob_job
    assert alice.get(f"/v1/jobs/{second}").json()["state"] == "queued"


def test_an_entry_queued_by_an_earlier_version_is_served_first(alice: Api, redis_db: redis.Redis,
                                                              settings: ServiceSettings) -> None:
    new = submit(alice, "new")
    legacy = submit(alice, "legacy")
    redis_db.zrem(scheduler.ready_key("default", redis_db.hget(jobstore.job_key(legacy), "owner")), legacy)
    redis_db.xadd(jobstore.QUEUE, {"job": legacy})  # as the old submission did
    worker = make_worker(settings, "w")
    assert [dispatch(worker), dispatch(worker)] == [legacy, new]


def test_an_idle_worker_wakes_on_the_doorbell(alice: Api, settings: ServiceSettings) -> None:
    worker = make_worker(settings, "w-idle")
    worker._ensure_group()
    got: list[Any] = []

    def wait_for_a_job() -> None:  # as the worker's loop: ask, blocking on the doorbell, until given one
        deadline = time.monotonic() + 10
        entry = None
        while entry is None and time.monotonic() < deadline:
            entry = worker._next_entry()
        got.append((entry, time.monotonic()))

    waiting = threading.Thread(target=wait_for_a_job)
    waiting.start()
    time.sleep(0.3)  # blocked on the doorbell
    job_id = submit(alice, "wake")
    submitted = time.monotonic()  # queued by now (validation happened before)
    waiting.join(timeout=15)
    (entry, picked_up) = got[0]
    assert entry is not None and entry[1] == job_id
    assert picked_up - submitted < 0.5, "woken by the doorbell, not by a poll"


def test_submit_refuses_bad_priority_pool_and_tags(alice: Api) -> None:
    for params, field in (({"priority": 101}, "priority"), ({"pool": "no spaces"}, "pool"),
                          ({"tag": "bad tag!"}, "tag"), ({"tag": [f"t{k}" for k in range(17)]}, "tag")):
        r = alice.post("/v1/jobs", json=small_shot(), params=params)
        assert r.status_code == 422 and field in r.text, (params, r.text)


# -- tags, time filters, admin -------------------------------------------------------------------
def test_tags_and_submission_time_filters(alice: Api, bob: Api, redis_db: redis.Redis) -> None:
    shot_a = submit(alice, "sh010", tag=["seq:010", "show:coco"])
    shot_b = submit(alice, "sh020", tag=["seq:020", "show:coco"])
    submit(bob, "bobs", tag=["show:coco"])
    assert alice.get(f"/v1/jobs/{shot_a}").json()["tags"] == ["seq:010", "show:coco"]
    coco = alice.get("/v1/jobs", params={"tag": "show:coco"}).json()
    assert [j["id"] for j in coco["jobs"]] == [shot_b, shot_a] and coco["total"] == 2  # not Bob's
    assert [j["id"] for j in alice.get("/v1/jobs", params={"tag": "seq:010"}).json()["jobs"]] == [shot_a]
    created_b = float(redis_db.hget(jobstore.job_key(shot_b), "created"))
    before_b = alice.get("/v1/jobs", params={"created_before": created_b - 1e-3}).json()
    assert [j["id"] for j in before_b["jobs"]] == [shot_a]
    after_b = alice.get("/v1/jobs", params={"created_after": created_b, "tag": "show:coco"}).json()
    assert [j["id"] for j in after_b["jobs"]] == [shot_b]
    assert all(j["owner"] is None for j in coco["jobs"])  # owners are shown to admin keys only


def test_an_admin_key_sees_and_manages_every_key_s_jobs(
    alice: Api, bob: Api, admin: Api, run_worker: Callable[[], str | None],
) -> None:
    alices = submit(alice, "alices", tag=["show:coco"])
    bobs = submit(bob, "bobs", tag=["show:coco"])
    listed = admin.get("/v1/jobs").json()
    assert {j["id"] for j in listed["jobs"]} == {alices, bobs} and listed["total"] == 2
    owners = {j["id"]: j["owner"] for j in listed["jobs"]}
    assert owners[alices] != owners[bobs] and all(owners.values())
    assert {j["id"] for j in admin.get("/v1/jobs", params={"tag": "show:coco"}).json()["jobs"]} == {alices, bobs}
    assert admin.get(f"/v1/jobs/{bobs}").json()["owner"] == owners[bobs]
    assert admin.post(f"/v1/jobs/{alices}/cancel").json()["state"] == "cancelled"
    assert bob.get(f"/v1/jobs/{alices}").status_code == 404  # a plain key still sees only its own


# -- delete, log ---------------------------------------------------------------------------------
def test_delete_removes_a_finished_job_everywhere(
    alice: Api, bob: Api, redis_db: redis.Redis, settings: ServiceSettings, finished_job: str,
) -> None:
    queued = submit(alice, "still-queued", tag=["x"])
    assert alice.request("DELETE", f"/v1/jobs/{queued}").status_code == 409
    assert bob.request("DELETE", f"/v1/jobs/{finished_job}").status_code == 404
    assert settings.job_dir(finished_job).exists()
    r = alice.request("DELETE", f"/v1/jobs/{finished_job}")
    assert r.status_code == 204
    assert alice.get(f"/v1/jobs/{finished_job}").status_code == 404
    assert not settings.job_dir(finished_job).exists()
    assert [j["id"] for j in alice.get("/v1/jobs").json()["jobs"]] == [queued]
    assert not any(finished_job in key for key in redis_db.keys("weft:job:*"))
    for index in (jobstore.ALL_JOBS, jobstore.FINISHED, jobstore.QUEUED_SINCE):
        assert redis_db.zscore(index, finished_job) is None, index
    assert not redis_db.sismember(jobstore.state_key("succeeded"), finished_job)
    assert alice.request("DELETE", f"/v1/jobs/{MISSING_JOB}").status_code == 404


def test_the_job_log_has_the_worker_s_lines(alice: Api, run_worker: Callable[[], str | None]) -> None:
    job_id = submit(alice, "logged")
    assert run_worker() == job_id
    lines = alice.get(f"/v1/jobs/{job_id}/log").json()["lines"]
    messages = [line["message"] for line in lines]
    assert messages[0].startswith(f"job {job_id} started on worker test-worker")
    assert any(m.startswith("frame 5 (5 of 5)") for m in messages) and messages[-1] == f"job {job_id} succeeded"
    assert all(line["worker"] == "test-worker" and line["level"] == "INFO" for line in lines)
    later = alice.get(f"/v1/jobs/{job_id}/log", params={"since": lines[0]["id"]}).json()["lines"]
    assert [line["id"] for line in later] == [line["id"] for line in lines[1:]]
    assert alice.get(f"/v1/jobs/{job_id}/log", params={"since": "yesterday"}).status_code == 422


# -- retention -----------------------------------------------------------------------------------
def test_retention_deletes_old_and_oversized_finished_jobs_only(
    alice: Api, redis_db: redis.Redis, settings: ServiceSettings, run_worker: Callable[[], str | None],
) -> None:
    import asyncio

    import redis.asyncio as aioredis

    from server import retention

    done = []
    for name in ("oldest", "middle", "newest"):
        done.append(submit(alice, name))
        assert run_worker() == done[-1]
    queued = submit(alice, "queued")
    now = jobstore.now()
    for job_id, days_ago in zip(done, (40, 20, 1), strict=True):  # finished 40, 20 and 1 days ago
        redis_db.zadd(jobstore.FINISHED, {job_id: now - days_ago * 86400})
    sizes = {job_id: retention.folder_bytes(settings.job_dir(job_id)) for job_id in done}

    async def run(policy: dict[str, Any]) -> list[str]:
        client = aioredis.Redis.from_url(settings.redis_url, decode_responses=True)
        try:
            script = client.register_script(jobstore.DELETE_LUA)
            return await retention.sweep(client, ServiceSettings(**{**settings.__dict__, **policy}), script, now)
        finally:
            await client.aclose()

    assert asyncio.run(run({"retention_days": 30})) == [done[0]]
    assert not settings.job_dir(done[0]).exists() and alice.get(f"/v1/jobs/{done[0]}").status_code == 404
    # Over the size limit by less than the oldest remaining job: only that one goes.
    kept = sizes[done[2]] + retention.folder_bytes(settings.job_dir(queued))
    assert asyncio.run(run({"retention_bytes": kept + sizes[done[1]] // 2})) == [done[1]]
    assert asyncio.run(run({"retention_bytes": 1})) == [done[2]]  # never the queued job
    assert alice.get(f"/v1/jobs/{queued}").json()["state"] == "queued" and settings.job_dir(queued).exists()


def test_jobs_from_before_the_global_index_are_listed_for_admins(
    alice: Api, redis_db: redis.Redis, settings: ServiceSettings,
) -> None:
    old = submit(alice, "from-an-older-version")
    redis_db.delete(jobstore.ALL_JOBS, jobstore.ALL_NAMES)  # as a store written before they existed
    with TestClient(create_app(ServiceSettings(**{**settings.__dict__, "admin_keys": (ADMIN,)}))) as c:
        listed = Api(c, ADMIN).get("/v1/jobs", params={"name": "older"}).json()
    assert [j["id"] for j in listed["jobs"]] == [old]
