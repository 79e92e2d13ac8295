"""The farm views behind the dashboard (issue 16): job list filters, a job's shot summary, the
queue and its history, Prometheus histograms and failures recorded by real workers, and the
pages and vendored chart library served by the API."""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import redis
from fastapi.testclient import TestClient
from routes_support import ALICE, MISSING_JOB, Api, small_shot

from server.main import create_app
from weft import jobmetrics, jobstore
from weft.jobstore import ServiceSettings
from workers.worker import Worker

STATIC = Path(__file__).resolve().parents[2] / "server" / "static"


# -- GET /v1/jobs?name=&state= -----------------------------------------------------------------
def test_list_filters_by_name_and_state_newest_first(alice: Api, bob: Api, redis_db: redis.Redis) -> None:
    ids = {name: alice.submit(small_shot(name)) for name in ("Drape-A", "drape-b", "flag")}
    bob.submit(small_shot("drape-bob"))
    redis_db.smove(jobstore.state_key("queued"), jobstore.state_key("failed"), ids["drape-b"])  # as a worker would
    redis_db.hset(jobstore.job_key(ids["drape-b"]), "state", "failed")

    named = alice.get("/v1/jobs", params={"name": "DRAPE"}).json()
    assert [j["id"] for j in named["jobs"]] == [ids["drape-b"], ids["Drape-A"]] and named["total"] == 2
    queued = alice.get("/v1/jobs", params={"state": "queued"}).json()
    assert [j["id"] for j in queued["jobs"]] == [ids["flag"], ids["Drape-A"]] and queued["total"] == 2
    both = alice.get("/v1/jobs", params={"state": "queued", "name": "drape"}).json()
    assert [j["id"] for j in both["jobs"]] == [ids["Drape-A"]]
    paged = alice.get("/v1/jobs", params={"state": "queued", "limit": 1, "offset": 1}).json()
    assert [j["id"] for j in paged["jobs"]] == [ids["Drape-A"]] and paged["next_offset"] is None
    assert alice.get("/v1/jobs", params={"name": "nothing-like-it"}).json() == {
        "jobs": [], "total": 0, "offset": 0, "limit": 50, "next_offset": None}


def test_name_filter_finds_jobs_submitted_before_the_name_index(alice: Api, redis_db: redis.Redis) -> None:
    from server.deps import owner_of_key

    job_id = alice.submit(small_shot("older-job"))
    names = jobstore.names_key(owner_of_key(ALICE))
    redis_db.delete(names)  # as a job store written by an earlier version
    assert [j["id"] for j in alice.get("/v1/jobs", params={"name": "older"}).json()["jobs"]] == [job_id]
    assert redis_db.hget(names, job_id) == "older-job"  # added to the index on the way


def test_list_name_filter_longer_than_200_characters_is_a_422(alice: Api) -> None:
    r = alice.get("/v1/jobs", params={"name": "x" * 201})
    assert r.status_code == 422 and "name" in r.text


# -- GET /v1/jobs/{id}/shot --------------------------------------------------------------------
def test_shot_summary_names_pieces_bodies_and_features(alice: Api, bob: Api) -> None:
    job_id = alice.submit(small_shot("summary"))
    summary = alice.get(f"/v1/jobs/{job_id}/shot").json()
    assert summary["name"] == "summary" and summary["frame_range"] == [1, 5] and summary["vertices"] == 36
    assert summary["pieces"] == [{"name": "sheet", "collide": False, "self_collide": False}]
    assert summary["features"]["self-collision"] == "off" and summary["features"]["cloth/body contact"] == "off"
    assert summary["features"]["pins"] == "2 vertices"
    assert bob.get(f"/v1/jobs/{job_id}/shot").status_code == 404  # another key's job: as if missing
    assert alice.get(f"/v1/jobs/{MISSING_JOB}/shot").status_code == 404


# -- GET /v1/queue -----------------------------------------------------------------------------
def test_queue_counts_waits_workers_and_history(redis_db: redis.Redis, settings: ServiceSettings) -> None:
    sampled = ServiceSettings(**{**settings.__dict__, "queue_sample_seconds": 0.2})
    with TestClient(create_app(sampled)) as c:
        alice = Api(c, ALICE)
        first = alice.submit()
        alice.submit()
        redis_db.zadd(jobstore.QUEUED_SINCE, {first: jobstore.now() - 120})  # as if queued two minutes ago
        Worker(settings, name="w-idle")._beat()
        queue = alice.get("/v1/queue").json()
        assert queue["jobs"]["queued"] == 2 and queue["jobs"]["running"] == 0
        assert 119 < queue["oldest_queued_seconds"] < 180
        assert queue["workers_alive"] == 1 and queue["workers_busy"] == 0
        # The API's sampler (a task of its lifespan) keeps the history.
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            history = alice.get("/v1/queue").json()["history"]
            if history and history[-1]["queued"] == 2 and history[-1]["workers_alive"] == 1:
                break
            time.sleep(0.1)
        else:
            raise AssertionError(f"no sample of the queue with two jobs and one worker: {history}")
        assert abs(history[-1]["time"] - time.time()) < 30
        assert [s["time"] for s in history] == sorted(s["time"] for s in history)
        assert alice.get("/v1/queue", params={"history": 0}).json()["history"] == []
        assert alice.get("/v1/queue", params={"history": -1}).status_code == 422


def test_longest_wait_follows_the_queue_through_start_cancel_and_retry(
    alice: Api, redis_db: redis.Redis, run_worker: Callable[[], str | None],
) -> None:
    def oldest() -> float | None:
        return alice.get("/v1/queue").json()["oldest_queued_seconds"]  # type: ignore[no-any-return]

    assert oldest() is None
    ran, cancelled = alice.submit(), alice.submit()
    assert oldest() is not None and redis_db.zcard(jobstore.QUEUED_SINCE) == 2
    assert alice.post(f"/v1/jobs/{cancelled}/cancel").json()["state"] == "cancelled"
    assert run_worker() == ran
    assert oldest() is None and redis_db.zcard(jobstore.QUEUED_SINCE) == 0
    assert alice.post(f"/v1/jobs/{cancelled}/retry").status_code == 200
    assert redis_db.zrange(jobstore.QUEUED_SINCE, 0, -1) == [cancelled] and 0 <= oldest() < 5  # type: ignore[operator]


def test_queue_needs_a_key(check_auth: Callable[..., None]) -> None:
    check_auth("GET", "/v1/queue")


# -- GET /metrics: what real workers recorded --------------------------------------------------
def test_metrics_histograms_and_failures_from_real_runs(
    client: TestClient, alice: Api, run_worker: Callable[[], str | None], settings: ServiceSettings,
) -> None:
    good = alice.submit(small_shot("good", frames=5))
    assert run_worker() == good
    bad = alice.submit(small_shot("bad", frames=5))
    (settings.job_dir(bad) / "shot.json").write_text("{}")  # the worker cannot load it: a 'shot' failure
    assert run_worker() == bad
    assert alice.get(f"/v1/jobs/{bad}").json()["error"]["kind"] == "shot"
    text = client.get("/metrics").text
    # Four simulated frames (the first frame is the initial state) in every per-frame histogram.
    for name in ("build", "solve", "collision", "total"):
        assert re.search(rf'^weft_frame_{name}_seconds_bucket{{le="\+Inf"}} 4\.0$', text, re.M), name
        assert re.search(rf"^weft_frame_{name}_seconds_count 4\.0$", text, re.M), name
    assert re.search(r"^weft_frame_cg_iterations_count 4\.0$", text, re.M)
    assert re.search(r"^weft_job_wait_seconds_count 2\.0$", text, re.M)
    assert re.search(r"^weft_job_run_seconds_count 2\.0$", text, re.M)
    assert 'weft_job_failures_total{kind="shot"} 1.0' in text and 'weft_job_failures_total{kind="solver"} 0.0' in text
    assert 'weft_jobs_finished_total{state="succeeded"} 1.0' in text
    assert "weft_frames_simulated_total 4.0" in text
    # Buckets are cumulative and end at the count.
    buckets = [float(v) for v in re.findall(r'^weft_frame_total_seconds_bucket{le="[^"]+"} (\S+)$', text, re.M)]
    assert buckets == sorted(buckets) and buckets[-1] == 4.0
    assert len(buckets) == len(jobmetrics.HISTOGRAMS["frame_total_seconds"].bounds) + 1


def test_metrics_show_busy_and_idle_workers_and_the_longest_wait(
    client: TestClient, alice: Api, redis_db: redis.Redis, settings: ServiceSettings,
) -> None:
    job_id = alice.submit()
    redis_db.zadd(jobstore.QUEUED_SINCE, {job_id: jobstore.now() - 60})
    busy, idle = Worker(settings, name="w-busy"), Worker(settings, name="w-idle")
    busy._current = ("0-1", job_id)
    busy._beat()
    idle._beat()
    text = client.get("/metrics").text
    assert re.search(r'^weft_worker_busy{host="[^"]+",worker="w-busy"} 1\.0$', text, re.M)
    assert re.search(r'^weft_worker_busy{host="[^"]+",worker="w-idle"} 0\.0$', text, re.M)
    assert "weft_queue_depth 1.0" in text
    oldest = float(re.search(r"^weft_queue_oldest_seconds (\S+)$", text, re.M).group(1))  # type: ignore[union-attr]
    assert 59 < oldest < 120


def test_metrics_can_require_a_key(settings: ServiceSettings) -> None:
    guarded = ServiceSettings(**{**settings.__dict__, "metrics_require_key": True})
    with TestClient(create_app(guarded)) as c:
        assert c.get("/metrics").status_code == 401
        assert c.get("/metrics", headers={"Authorization": "Bearer wrong"}).status_code == 401
        r = c.get("/metrics", headers={"Authorization": f"Bearer {ALICE}"})
        assert r.status_code == 200 and "weft_jobs{" in r.text


def test_failure_kinds_are_the_api_schemas_kinds() -> None:
    from api_schemas.service import FailureKind

    assert set(jobmetrics.FAILURE_KINDS) == set(FailureKind.__args__)  # type: ignore[attr-defined]


def test_observe_lua_files_values_into_prometheus_buckets(redis_db: redis.Redis) -> None:
    script = redis_db.register_script(jobmetrics.OBSERVE_LUA + "observe(ARGV[1], ARGV[2]) return 1")
    spec = jobmetrics.HISTOGRAMS["frame_solve_seconds"]
    for value in (0.0005, 0.001, 0.0011, 5.0, 1e9, "nan", -1):  # a bound is its own bucket (le); NaN, <0 ignored
        script(args=[spec.name, value])
    value = jobmetrics.parse_histogram(spec, redis_db.hgetall(jobmetrics.histogram_key(spec.name)))
    cumulative = dict(value.buckets)
    assert cumulative[0.001] == 2 and cumulative[0.003] == 3 and cumulative[3.0] == 3 and cumulative[10.0] == 4
    assert value.buckets[-1] == (float("inf"), 5) and value.count == 5
    assert value.total == pytest.approx(0.0005 + 0.001 + 0.0011 + 5.0 + 1e9)


# -- the pages -----------------------------------------------------------------------------------
@pytest.mark.parametrize("path", ["/ui/jobs", f"/ui/jobs/{MISSING_JOB}", "/ui/jobs/not-an-id", "/ui/compare",
                                  "/ui/workers"])
def test_pages_are_served_with_a_strict_content_security_policy(client: TestClient, path: str) -> None:
    r = client.get(path)
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    policy = r.headers["content-security-policy"]
    assert "script-src 'self'" in policy and "connect-src 'self'" in policy and "unsafe" not in policy
    for src in re.findall(r'(?:src|href)="(/ui/static/[^"]+)"', r.text):  # every script and sheet exists
        assert client.get(src).status_code == 200, src


def test_home_and_dashboard_redirect_to_the_jobs_page(client: TestClient) -> None:
    for path in ("/", "/ui", "/dashboard"):
        r = client.get(path, follow_redirects=False)
        assert r.status_code == 307 and r.headers["location"] == "/ui/jobs"


def test_vendored_uplot_is_the_registry_package_unchanged() -> None:
    readme = (STATIC / "vendor" / "uplot" / "README.md").read_text()
    recorded = dict(re.findall(r"^\| (\S+) \| ([0-9a-f]{64}) \|$", readme, re.M))
    assert set(recorded) == {"uPlot.iife.min.js", "uPlot.min.css", "LICENSE"}
    for name, digest in recorded.items():
        assert hashlib.sha256((STATIC / "vendor" / "uplot" / name).read_bytes()).hexdigest() == digest, name
    assert "MIT License" in (STATIC / "vendor" / "uplot" / "LICENSE").read_text()


def test_pages_load_nothing_from_other_hosts() -> None:
    for page in STATIC.glob("**/*.html"):
        assert not re.search(r'(?:src|href)="(?:https?:)?//', page.read_text()), page.name
    for script in STATIC.glob("*.js"):
        assert "http://" not in script.read_text() and "https://" not in script.read_text(), script.name


def test_events_carry_the_cache_write_time(alice: Api, run_worker: Callable[[], str | None],
                                          redis_db: redis.Redis) -> None:
    job_id = alice.submit(small_shot("io", frames=3))
    assert run_worker() == job_id
    frames = [json.loads(f["data"]) for _, f in redis_db.xrange(jobstore.events_key(job_id)) if f["type"] == "frame"]
    assert len(frames) == 3 and all(0 < f["io_seconds"] < 5 for f in frames)
