"""Pytest fixtures for in-process tests of the API and the workers: a real redis-server on a
free loopback port for the session, flushed before each test. Import them into a conftest:
``from server.testing import redis_db, redis_server``. (Needs pytest; not used by the service.)"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import redis

from server.stack import RedisServer


@pytest.fixture(scope="session")
def redis_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RedisServer]:
    base = tmp_path_factory.mktemp("redis")
    with RedisServer(base / "data", base / "redis.log") as server:
        yield server


@pytest.fixture()
def redis_db(redis_server: RedisServer) -> Iterator[redis.Redis]:
    """A sync client on the session's Redis, flushed for this test."""
    client = redis.Redis.from_url(redis_server.url, decode_responses=True)
    client.flushdb()
    yield client
    client.close()
