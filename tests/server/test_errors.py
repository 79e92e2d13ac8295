"""server/errors.py: every error is JSON with a detail and a list of field problems."""

from __future__ import annotations

from fastapi.testclient import TestClient
from routes_support import Api


def test_unknown_route_is_a_json_404(client: TestClient) -> None:
    r = client.get("/v2/nothing")
    assert r.status_code == 404 and r.json() == {"detail": "Not Found", "errors": []}


def test_wrong_method_is_a_json_405(client: TestClient) -> None:
    r = client.delete("/v1/jobs")
    assert r.status_code == 405 and r.json() == {"detail": "Method Not Allowed", "errors": []}
    assert "POST" in r.headers["allow"]  # the header survives the JSON body


def test_validation_errors_list_each_field(alice: Api) -> None:
    r = alice.get("/v1/jobs", params={"offset": -1, "limit": 0})
    assert r.status_code == 422
    body = r.json()
    assert [e["field"] for e in body["errors"]] == ["query.offset", "query.limit"]
    assert body["detail"].startswith("invalid request: query.offset: ")
