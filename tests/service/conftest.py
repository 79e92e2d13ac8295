"""A real service for the tests: redis-server on a free port (append-only file in a temp dir),
the API under uvicorn on a free port, and worker processes. Everything is torn down after."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from httpx_sse import connect_sse

from server.stack import Stack
from scenes.builders import sheet_shot

ALICE, BOB = "alice-key-0123456789", "bob-key-9876543210"
FAST_CLAIM = {
    "WEFT_HEARTBEAT_SECONDS": "0.3",
    "WEFT_CLAIM_AFTER_SECONDS": "2.0",
    "WEFT_MAX_UPLOAD_BYTES": "2000000",
    "WEFT_MAX_JSON_BYTES": "1000000",
    "WEFT_MAX_VERTICES": "5000",
    "WEFT_MAX_FRAMES": "2000",
    "WEFT_SOLVER_THREADS": "1",
}


def small_shot(name: str = "small", frames: int = 20) -> dict[str, Any]:
    return sheet_shot(name, 8, 8, 0.5, 0.5, pins=[0, 7], frames=frames)


def slow_shot(name: str = "slow", frames: int = 60) -> dict[str, Any]:
    """About 50 ms a frame on one core: long enough to kill or cancel mid-shot."""
    return sheet_shot(name, 16, 16, 0.5, 0.5, pins=[0, 15], frames=frames, substeps=8)


def client(stack: Stack, key: str | None) -> httpx.Client:
    headers = {"Authorization": f"Bearer {key}"} if key else {}
    return httpx.Client(base_url=stack.url, headers=headers, timeout=30)


def wait_for(predicate: Callable[[], Any], timeout: float = 60, interval: float = 0.05, what: str = "") -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(interval)
    raise AssertionError(f"timed out after {timeout}s waiting for {what or predicate}")


def follow(c: httpx.Client, job_id: str, on_event: Callable[[str, dict[str, Any]], None] | None = None) -> list[tuple[str, str, dict[str, Any]]]:
    """Every SSE event of a job up to and including the final 'end' event: (event, id, data)."""
    events = []
    with connect_sse(c, "GET", f"/v1/jobs/{job_id}/events", timeout=httpx.Timeout(30, read=60)) as source:
        assert source.response.status_code == 200
        for sse in source.iter_sse():
            if not sse.data:  # the stream's opening 'retry:' line
                continue
            data = json.loads(sse.data)
            events.append((sse.event, sse.id, data))
            if on_event is not None:
                on_event(sse.event, data)
            if sse.event == "end":
                break
    return events


def job_state(c: httpx.Client, job_id: str) -> dict[str, Any]:
    r = c.get(f"/v1/jobs/{job_id}")
    assert r.status_code == 200, r.text
    return r.json()  # type: ignore[no-any-return]


@pytest.fixture(scope="session")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    with Stack(tmp_path_factory.mktemp("stack"), workers=2, api_keys=[ALICE, BOB], env=FAST_CLAIM) as s:
        yield s


@pytest.fixture()
def alice(stack: Stack) -> Iterator[httpx.Client]:
    with client(stack, ALICE) as c:
        yield c


@pytest.fixture()
def bob(stack: Stack) -> Iterator[httpx.Client]:
    with client(stack, BOB) as c:
        yield c


@pytest.fixture()
def own_stack(tmp_path: Path) -> Iterator[Stack]:
    """A separate stack with no workers (tests start them), for Redis restarts."""
    s = Stack(tmp_path / "stack", workers=0, api_keys=[ALICE], env=FAST_CLAIM)
    with s:
        yield s


__all__ = ["ALICE", "BOB", "client", "follow", "job_state", "slow_shot", "small_shot", "wait_for"]
