"""server/deps.py: API keys, local mode, job ownership; and ``python -m server``'s refusals."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from routes_support import ALICE, MISSING_JOB, Api, assert_error, small_shot

from server.deps import owner_of_key
from server.main import create_app
from weft.jobstore import ServiceSettings

V1_ROUTES = [
    ("POST", "/v1/jobs"), ("GET", "/v1/jobs"), ("GET", f"/v1/jobs/{MISSING_JOB}"),
    ("GET", f"/v1/jobs/{MISSING_JOB}/telemetry"), ("GET", f"/v1/jobs/{MISSING_JOB}/events"),
    ("GET", f"/v1/jobs/{MISSING_JOB}/cache"), ("GET", f"/v1/jobs/{MISSING_JOB}/frames/1"),
    ("POST", f"/v1/jobs/{MISSING_JOB}/cancel"), ("GET", "/v1/workers"),
]


def test_auth_comes_before_path_validation(client: TestClient) -> None:
    """A caller without a key learns nothing about ids: 401, not 422 or 404."""
    assert_error(client.get("/v1/jobs/not-a-job"), 401, "missing API key")


def test_parameters_are_checked_before_the_job_is_looked_up(alice: Api) -> None:
    """A bad parameter is a 422 whether or not the job exists; the lookup's 404 comes after."""
    assert_error(alice.get(f"/v1/jobs/{MISSING_JOB}/telemetry", params={"since": "x"}), 422, "query.since")
    assert_error(alice.get(f"/v1/jobs/{MISSING_JOB}/frames/first"), 422, "path.frame")
    assert_error(alice.get(f"/v1/jobs/{MISSING_JOB}/frames/1", params={"format": "exe"}), 422, "query.format")
    assert_error(alice.get(f"/v1/jobs/{MISSING_JOB}/telemetry", params={"since": 3}), 404, "no job")


def test_key_with_surrounding_spaces_is_accepted(client: TestClient) -> None:
    assert client.get("/v1/jobs", headers={"Authorization": f"Bearer   {ALICE} "}).status_code == 200


def test_a_job_belongs_to_the_hash_of_its_key(alice: Api, redis_db) -> None:  # type: ignore[no-untyped-def]
    from weft import jobstore

    job_id = alice.submit()
    assert redis_db.hget(jobstore.job_key(job_id), "owner") == owner_of_key(ALICE) != ALICE


@pytest.fixture()
def local_settings(settings: ServiceSettings) -> ServiceSettings:
    return ServiceSettings(redis_url=settings.redis_url, storage=settings.storage, local=True)


@pytest.mark.parametrize(("method", "url"), V1_ROUTES)
def test_local_mode_refuses_remote_clients(local_settings: ServiceSettings, method: str, url: str) -> None:
    with TestClient(create_app(local_settings), client=("203.0.113.7", 4000)) as remote:
        assert_error(remote.request(method, url), 403, "loopback clients")


def test_local_mode_serves_loopback_without_a_key(local_settings: ServiceSettings) -> None:
    with TestClient(create_app(local_settings), client=("127.0.0.1", 4000)) as local:
        r = local.post("/v1/jobs", json=small_shot())
        assert r.status_code == 201, r.text
        assert [j["id"] for j in local.get("/v1/jobs").json()["jobs"]] == [r.json()["id"]]


def run_server(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "server", *args], env=env, capture_output=True, text=True,
                          timeout=60, cwd=Path(__file__).parents[2])


def test_server_refuses_local_mode_on_a_public_host() -> None:
    done = run_server("--local", "--host", "0.0.0.0", env={"PATH": "/usr/bin:/bin"})
    assert done.returncode == 1 and "--local needs a loopback host" in done.stderr


def test_server_refuses_to_start_without_keys() -> None:
    done = run_server("--host", "127.0.0.1", env={"PATH": "/usr/bin:/bin"})
    assert done.returncode == 1 and "set WEFT_API_KEYS" in done.stderr


def test_uploads_an_api_crash_left_behind_are_removed_at_the_next_start(settings, redis_db) -> None:
    """Issue 15: an API killed mid-upload leaves jobs/{id}/ without a record; the next API start
    removes it once nothing touched it for an hour, and keeps real jobs and young folders."""
    import os
    import time

    from fastapi.testclient import TestClient

    from server.main import create_app
    from server.uploads import ORPHAN_AGE_SECONDS
    from weft import jobstore

    jobs_dir = settings.storage / "jobs"
    old = time.time() - ORPHAN_AGE_SECONDS - 60
    folders = {}
    for name, digit in (("orphan", "a"), ("young", "b"), ("recorded", "c")):
        folder = jobs_dir / (digit * 32)
        (folder / "assets").mkdir(parents=True)
        (folder / "assets" / "mesh.obj").write_text("v 0 0 0\n")
        folders[name] = folder
    for name in ("orphan", "recorded"):
        for path in [folders[name], folders[name] / "assets", folders[name] / "assets" / "mesh.obj"]:
            os.utime(path, (old, old))
    redis_db.hset(jobstore.job_key("c" * 32), mapping={"id": "c" * 32, "state": "queued"})
    with TestClient(create_app(settings)):
        pass
    assert not folders["orphan"].exists()
    assert folders["young"].exists() and folders["recorded"].exists()
