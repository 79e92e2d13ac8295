"""server/routes/ops.py: workers, liveness, readiness, metrics (and the OpenAPI document)."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable

import redis
from fastapi.testclient import TestClient
from routes_support import MISSING_JOB, Api

from weft import jobstore
from weft.jobstore import ServiceSettings
from workers.worker import Worker


# -- GET /v1/workers ----------------------------------------------------------------------------
def test_workers_list_hides_other_keys_jobs(alice: Api, bob: Api, settings: ServiceSettings) -> None:
    job_id = alice.submit()
    worker = Worker(settings, name="w-busy")
    worker._current = ("0-1", job_id)  # as while it runs Alice's job
    worker._beat()
    (seen_by_alice,) = alice.get("/v1/workers").json()["workers"]
    assert seen_by_alice["name"] == "w-busy" and seen_by_alice["alive"] is True and seen_by_alice["job"] == job_id
    assert 0 <= seen_by_alice["seconds_since_heartbeat"] < 5
    (seen_by_bob,) = bob.get("/v1/workers").json()["workers"]
    assert seen_by_bob["name"] == "w-busy" and seen_by_bob["job"] is None


def test_workers_list_forgets_long_dead_workers(alice: Api, redis_db: redis.Redis) -> None:
    old = {"name": "w-old", "pid": 1, "host": "h", "started": 0, "heartbeat": jobstore.now() - 7200, "job": None}
    late = {**old, "name": "w-late", "heartbeat": jobstore.now() - 60}
    redis_db.hset(jobstore.WORKERS, mapping={"w-old": json.dumps(old), "w-late": json.dumps(late)})
    workers = alice.get("/v1/workers").json()["workers"]
    assert [(w["name"], w["alive"]) for w in workers] == [("w-late", False)]
    assert not redis_db.hexists(jobstore.WORKERS, "w-old")


def test_workers_needs_a_key(check_auth: Callable[..., None]) -> None:
    check_auth("GET", "/v1/workers")


# -- GET /healthz, /readyz (public) -------------------------------------------------------------
def test_health_and_readiness_need_no_key(client: TestClient) -> None:
    assert client.get("/healthz").json() == {"status": "ok"}
    r = client.get("/readyz")
    assert r.status_code == 200 and r.json() == {"status": "ready"}


def test_not_ready_without_storage(client: TestClient, settings: ServiceSettings) -> None:
    shutil.rmtree(settings.storage)
    r = client.get("/readyz")
    assert r.status_code == 503 and f"storage {settings.storage} missing" in r.json()["detail"]


def test_not_ready_without_redis(settings: ServiceSettings) -> None:
    from server.main import create_app
    from server.stack import free_port

    down = ServiceSettings(redis_url=f"redis://127.0.0.1:{free_port()}/0", storage=settings.storage, api_keys=("k",))
    with TestClient(create_app(down)) as c:
        r = c.get("/readyz")
        assert r.status_code == 503 and "redis unavailable" in r.json()["detail"]
        listed = c.get("/v1/jobs", headers={"Authorization": "Bearer k"})
        assert listed.status_code == 503 and "job store unavailable" in listed.json()["detail"]


# -- GET /metrics (public) ----------------------------------------------------------------------
def test_metrics_count_requests_jobs_and_workers(client: TestClient, alice: Api, finished_job: str) -> None:
    alice.get(f"/v1/jobs/{MISSING_JOB}")
    alice.submit()
    text = client.get("/metrics").text
    assert 'weft_http_requests_total{method="GET",route="/v1/jobs/{job_id}",status="404"} 1.0' in text
    assert re.search(r'^weft_http_requests_total\{method="POST",route="/v1/jobs",status="201"\} 2\.0$', text, re.M)
    assert 'weft_jobs{state="succeeded"} 1.0' in text and 'weft_jobs{state="queued"} 1.0' in text
    assert "weft_workers_alive 1.0" in text and "weft_frames_simulated_total 4.0" in text


def test_openapi_lists_every_route_and_the_shot_schema(client: TestClient) -> None:
    spec = client.get("/openapi.json").json()
    assert set(spec["paths"]) == {
        "/v1/jobs", "/v1/jobs/{job_id}", "/v1/jobs/{job_id}/telemetry", "/v1/jobs/{job_id}/events",
        "/v1/jobs/{job_id}/cache", "/v1/jobs/{job_id}/frames/{frame}", "/v1/jobs/{job_id}/cancel", "/v1/jobs/{job_id}/retry",
        "/v1/jobs/{job_id}/shot", "/v1/jobs/{job_id}/log", "/v1/jobs/{job_id}/usd", "/v1/workers", "/v1/queue", "/healthz", "/readyz",
        "/metrics",
    }
    assert "Shot" in spec["components"]["schemas"]
    body = spec["paths"]["/v1/jobs"]["post"]["requestBody"]["content"]
    assert body["application/json"]["schema"] == {"$ref": "#/components/schemas/Shot"}
