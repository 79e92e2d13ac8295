"""In-process route tests: the FastAPI app through Starlette's TestClient (lifespan included),
over a real redis-server on a free port (the ``server.testing`` fixtures, shared with
tests/workers). Redis is flushed before each test; storage is the test's tmp_path."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import redis
from fastapi.testclient import TestClient
from routes_support import ALICE, BOB, Api, small_shot

from server.main import create_app
from server.stack import RedisServer
from server.testing import redis_db, redis_server  # noqa: F401 (fixtures)
from weft.jobstore import ServiceSettings
from workers.worker import Worker


@pytest.fixture()
def settings(redis_db: redis.Redis, redis_server: RedisServer, tmp_path: Path) -> ServiceSettings:
    return ServiceSettings(
        redis_url=redis_server.url, storage=tmp_path / "storage", api_keys=(ALICE, BOB),
        max_upload_bytes=200_000, max_json_bytes=100_000, max_vertices=500, max_frames=50, max_files=4, max_cost=200_000,
    )


@pytest.fixture()
def client(settings: ServiceSettings) -> Iterator[TestClient]:
    with TestClient(create_app(settings)) as c:
        yield c


@pytest.fixture()
def alice(client: TestClient) -> Api:
    return Api(client, ALICE)


@pytest.fixture()
def bob(client: TestClient) -> Api:
    return Api(client, BOB)


@pytest.fixture()
def run_worker(settings: ServiceSettings) -> Iterator[Callable[[], str | None]]:
    """Process the next queued job to its end in this thread with a real worker (real solver)."""
    worker = Worker(settings, name="test-worker")
    yield worker.process_next
    worker.redis.close()


@pytest.fixture()
def finished_job(alice: Api, run_worker: Callable[[], str | None]) -> str:
    """One of Alice's jobs, run to success by a real worker: 5 frames, numbered 1-5."""
    job_id = alice.submit(small_shot("done", frames=5))
    assert run_worker() == job_id
    assert alice.get(f"/v1/jobs/{job_id}").json()["state"] == "succeeded"
    return job_id


@pytest.fixture()
def check_auth(client: TestClient) -> Callable[..., None]:
    """Asserts that a route refuses a request without a key, with an unknown key and with a
    non-bearer Authorization header: 401, a message naming the problem, WWW-Authenticate."""

    def check(method: str, url: str, **kw: Any) -> None:
        for headers, message in (
            ({}, "missing API key"),
            ({"Authorization": "Bearer not-a-key"}, "unknown API key"),
            ({"Authorization": f"Basic {ALICE}"}, "expected 'Bearer <key>'"),
        ):
            r = client.request(method, url, headers=headers, **kw)
            assert r.status_code == 401, (method, url, headers, r.text)
            assert message in r.json()["detail"], r.text
            assert r.headers["www-authenticate"] == "Bearer"

    return check
