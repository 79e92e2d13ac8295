"""Bad requests get a 4xx with a message naming the problem; never a 500, never a worker crash."""

from __future__ import annotations

import io
import json
import re
from collections.abc import Callable
from typing import Any

import httpx
import numpy as np
import pytest

from server.stack import Stack

from .conftest import BOB, client, small_shot, wait_for

MISSING_JOB = "0" * 32


def multipart(shot: dict[str, Any] | str, *assets: tuple[str, bytes]) -> dict[str, Any]:
    text = shot if isinstance(shot, str) else json.dumps(shot)
    return {"files": [("shot", ("shot.json", text, "application/json"))] + [("assets", (n, d, "application/octet-stream")) for n, d in assets]}


def with_body(animation_frames: int) -> tuple[dict[str, Any], bytes]:
    """A shot with an animated body whose animation has the given number of frames (the shot has 5)."""
    shot = small_shot("body", frames=5)
    shot["bodies"] = [{"name": "box", "mesh": {"vertices": [[0, -1, 0], [1, -1, 0], [0, -1, 1]], "faces": [[0, 1, 2]]},
                       "animation": {"path": "anim.npy"}}]
    buffer = io.BytesIO()
    np.save(buffer, np.zeros((animation_frames, 3, 3)))
    return shot, buffer.getvalue()


def shot_with(path: str, value: Any) -> dict[str, Any]:
    shot = small_shot("bad", frames=5)
    target: Any = shot
    keys = path.split(".")
    for key in keys[:-1]:
        target = target[int(key)] if key.isdigit() else target[key]
    last = keys[-1]
    target[int(last) if last.isdigit() else last] = value
    return shot


def someone_elses_job(stack: Stack) -> str:
    with client(stack, BOB) as bob:
        return str(bob.post("/v1/jobs", json=small_shot("bobs", frames=3)).json()["id"])


# (name, request builder, expected status, text the message must contain)
Case = tuple[str, Callable[[httpx.Client, Stack], httpx.Response], int, str]
CASES: list[Case] = [
    ("malformed JSON", lambda c, s: c.post("/v1/jobs", content=b'{"name": "x",', headers={"Content-Type": "application/json"}), 400, "not valid JSON"),
    ("JSON array, not object", lambda c, s: c.post("/v1/jobs", json=[1, 2]), 422, "JSON object"),
    ("wrong type", lambda c, s: c.post("/v1/jobs", json=shot_with("fps", "fast")), 422, "fps"),
    ("unknown field", lambda c, s: c.post("/v1/jobs", json={**small_shot(), "colour": "red"}), 422, "colour"),
    ("missing field", lambda c, s: c.post("/v1/jobs", json={k: v for k, v in small_shot().items() if k != "cloth"}), 422, "cloth"),
    ("NaN coordinate", lambda c, s: c.post("/v1/jobs", content=json.dumps(shot_with("cloth.0.mesh.vertices.3", [float("nan"), 0, 0])), headers={"Content-Type": "application/json"}), 422, "cloth[0].mesh.vertices[3]"),
    ("face index out of range", lambda c, s: c.post("/v1/jobs", json=shot_with("cloth.0.mesh.faces.2", [0, 1, 999])), 422, "cloth[0].mesh.faces[2]"),
    ("face index beyond int64", lambda c, s: c.post("/v1/jobs", json=shot_with("cloth.0.mesh.faces.2", [0, 1, 10**30])), 422, "cloth[0].mesh.faces"),
    ("pin beyond int64", lambda c, s: c.post("/v1/jobs", json=shot_with("cloth.0.pins", [{"vertices": [-(10**40)]}])), 422, "pins"),
    ("deeply nested JSON", lambda c, s: c.post("/v1/jobs", content=b"[" * 100_000 + b"]" * 100_000, headers={"Content-Type": "application/json"}), 400, "not valid JSON"),
    ("pin out of range", lambda c, s: c.post("/v1/jobs", json=shot_with("cloth.0.pins", [{"vertices": [500]}])), 422, "pins[0].vertices[0]"),
    ("reversed frame range", lambda c, s: c.post("/v1/jobs", json=shot_with("frame_range", [10, 2])), 422, "frame_range"),
    ("too many frames", lambda c, s: c.post("/v1/jobs", json=shot_with("frame_range", [1, 5000])), 422, "exceeds the limit"),
    ("too many vertices", lambda c, s: c.post("/v1/jobs", json=__import__("scenes.builders", fromlist=["x"]).sheet_shot("big", 80, 80, 1, 1)), 422, "vertices exceeds the limit"),
    ("oversize JSON body", lambda c, s: c.post("/v1/jobs", content=b"{" + b" " * 1_100_000 + b"}", headers={"Content-Type": "application/json"}), 413, "limit"),
    ("oversize upload", lambda c, s: c.post("/v1/jobs", **multipart(small_shot(), ("big.npy", b"\0" * 2_100_000))), 413, "limit"),
    ("animation shorter than the shot", lambda c, s: c.post("/v1/jobs", **multipart(*[(sh, ("anim.npy", data)) for sh, data in [with_body(3)]][0])), 422, "bodies[0].animation"),
    ("asset not uploaded", lambda c, s: c.post("/v1/jobs", **multipart(shot_with("cloth.0.mesh", {"path": "sheet.obj"}))), 422, "cloth[0].mesh.path"),
    ("unreferenced upload", lambda c, s: c.post("/v1/jobs", **multipart(small_shot(), ("extra.obj", b"v 0 0 0\n"))), 400, "not referenced"),
    ("path traversal file name", lambda c, s: c.post("/v1/jobs", **multipart(small_shot(), ("../../etc/passwd", b"x"))), 400, "bad asset file name"),
    ("absolute file name", lambda c, s: c.post("/v1/jobs", **multipart(small_shot(), ("/etc/passwd", b"x"))), 400, "bad asset file name"),
    ("absolute asset path in shot", lambda c, s: c.post("/v1/jobs", json=shot_with("cloth.0.mesh", {"path": "/etc/passwd.obj"})), 422, "relative"),
    ("corrupt mesh file", lambda c, s: c.post("/v1/jobs", **multipart(shot_with("cloth.0.mesh", {"path": "m.obj"}), ("m.obj", b"\x00\xffgarbage"))), 422, "cloth[0].mesh"),
    ("multipart without shot", lambda c, s: c.post("/v1/jobs", files=[("assets", ("a.obj", b"v 0 0 0"))]), 400, "no 'shot' part"),
    ("form field instead of file", lambda c, s: c.post("/v1/jobs", data={"other": "1"}, files=[("shot", ("s.json", json.dumps(small_shot())))]), 400, "unexpected form field"),
    ("unsupported content type", lambda c, s: c.post("/v1/jobs", content=b"name: x", headers={"Content-Type": "text/yaml"}), 415, "Content-Type"),
    ("bad idempotency key", lambda c, s: c.post("/v1/jobs", json=small_shot(), headers={"Idempotency-Key": "x" * 300}), 400, "Idempotency-Key"),
    ("bad job id", lambda c, s: c.get("/v1/jobs/not-a-job"), 422, "job_id"),
    ("unknown job id", lambda c, s: c.get(f"/v1/jobs/{MISSING_JOB}"), 404, "no job"),
    ("another key's job", lambda c, s: c.get(f"/v1/jobs/{someone_elses_job(s)}"), 404, "no job"),
    ("cancel another key's job", lambda c, s: c.post(f"/v1/jobs/{someone_elses_job(s)}/cancel"), 404, "no job"),
    ("bad state filter", lambda c, s: c.get("/v1/jobs", params={"state": "exploded"}), 422, "state"),
    ("negative offset", lambda c, s: c.get("/v1/jobs", params={"offset": -1}), 422, "offset"),
    ("non-integer since", lambda c, s: c.get(f"/v1/jobs/{MISSING_JOB}/telemetry", params={"since": "yesterday"}), 422, "since"),
    ("huge since", lambda c, s: c.get(f"/v1/jobs/{own_job(c)}/telemetry", params={"since": 10**30}), 422, "since"),
    ("non-integer frame", lambda c, s: c.get(f"/v1/jobs/{MISSING_JOB}/frames/first"), 422, "frame"),
    ("bad Last-Event-ID", lambda c, s: c.get(f"/v1/jobs/{own_job(c)}/events", headers={"Last-Event-ID": "../x"}), 400, "Last-Event-ID"),
    ("bad frame format", lambda c, s: c.get(f"/v1/jobs/{MISSING_JOB}/frames/1", params={"format": "exe"}), 422, "format"),
    ("no API key", lambda c, s: httpx.get(s.url + "/v1/jobs"), 401, "missing API key"),
    ("unknown API key", lambda c, s: httpx.get(s.url + "/v1/jobs", headers={"Authorization": "Bearer nope"}), 401, "unknown API key"),
    ("not a bearer token", lambda c, s: httpx.get(s.url + "/v1/jobs", headers={"Authorization": "Basic abc"}), 401, "Bearer"),
]


def own_job(c: httpx.Client) -> str:
    """A job of the calling key."""
    return str(c.post("/v1/jobs", json=small_shot("mine", frames=3)).json()["id"])


def test_at_least_twenty_kinds() -> None:
    assert len({name for name, *_ in CASES}) >= 20


@pytest.mark.parametrize(("name", "send", "status", "message"), CASES, ids=[c[0] for c in CASES])
def test_bad_request(alice: httpx.Client, stack: Stack, name: str, send: Callable[..., httpx.Response], status: int, message: str) -> None:
    response = send(alice, stack)
    assert response.status_code == status, f"{name}: {response.status_code} {response.text[:300]}"
    body = response.json()
    assert message in body["detail"] or any(message in (e.get("field") or "") + (e.get("problem") or "") for e in body["errors"]), body


def test_no_server_errors_and_workers_alive(alice: httpx.Client, stack: Stack) -> None:
    """After bad requests of every status (sent here, so the test stands alone), the API never
    answered 5xx and every worker is still up."""
    one_per_status = {status: (name, send) for name, send, status, _ in reversed(CASES)}
    for status, (name, send) in sorted(one_per_status.items()):
        assert send(alice, stack).status_code == status, name
    metrics = alice.get("/metrics").text
    statuses = re.findall(r'^weft_http_requests_total\{.*status="(\d+)"\}', metrics, re.M)
    sent = {str(status) for status in one_per_status}
    assert sent == {"400", "401", "404", "413", "415", "422"} and sent <= set(statuses)
    # (503s come only from the Redis-restart test, which uses its own stack.)
    assert [s for s in statuses if s.startswith("5")] == []
    # Every worker still heart-beats (polled: right after the stack starts, they may not have yet).
    wait_for(lambda: len([w for w in alice.get("/v1/workers").json()["workers"] if w["alive"]]) >= 2,
             timeout=30, what="two live workers")
    # No upload left behind in storage for refused submissions.
    jobs_dir = stack.storage / "data" / "jobs"
    listed = {j["id"] for j in alice.get("/v1/jobs", params={"limit": 500}).json()["jobs"]}
    with client(stack, BOB) as bob:
        listed |= {j["id"] for j in bob.get("/v1/jobs", params={"limit": 500}).json()["jobs"]}
    assert {p.name for p in jobs_dir.iterdir()} <= listed
