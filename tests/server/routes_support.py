"""Helpers of the in-process route tests (tests/server is on sys.path while they run)."""

from __future__ import annotations

from typing import Any

import httpx
from fastapi.testclient import TestClient

from scenes.builders import sheet_shot

ALICE, BOB = "alice-key-0123456789", "bob-key-9876543210"
MISSING_JOB = "0" * 32


def small_shot(name: str = "small", frames: int = 5) -> dict[str, Any]:
    return sheet_shot(name, 6, 6, 0.5, 0.5, pins=[0, 5], frames=frames)


class Api:
    """The test client with one caller's credentials (key None: no Authorization header)."""

    def __init__(self, client: TestClient, key: str | None) -> None:
        self.client = client
        self.auth = {"Authorization": f"Bearer {key}"} if key else {}

    def request(self, method: str, url: str, headers: dict[str, str] | None = None, **kw: Any) -> httpx.Response:
        return self.client.request(method, url, headers={**self.auth, **(headers or {})}, **kw)

    def get(self, url: str, **kw: Any) -> httpx.Response:
        return self.request("GET", url, **kw)

    def post(self, url: str, **kw: Any) -> httpx.Response:
        return self.request("POST", url, **kw)

    def submit(self, shot: dict[str, Any] | None = None) -> str:
        r = self.post("/v1/jobs", json=shot or small_shot())
        assert r.status_code == 201, r.text
        return str(r.json()["id"])


def assert_error(response: httpx.Response, status: int, field: str, problem: str = "") -> None:
    """A JSON error with this status whose message or error list names the field (and problem)."""
    assert response.status_code == status, response.text
    body = response.json()
    assert field in body["detail"] or any(field in (e.get("field") or "") for e in body["errors"]), body
    assert problem in body["detail"] or any(problem in (e.get("problem") or "") for e in body["errors"]), body
