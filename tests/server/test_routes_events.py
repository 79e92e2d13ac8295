"""server/routes/events.py: the server-sent event stream."""

from __future__ import annotations

import json
from collections.abc import Callable

from routes_support import Api, assert_error


def parse_sse(text: str) -> list[dict[str, str]]:
    events = []
    for block in text.split("\n\n"):
        fields = dict(line.split(": ", 1) for line in block.splitlines() if ": " in line and not line.startswith(":"))
        if "event" in fields:
            events.append(fields)
    return events


def test_events_replay_every_frame_then_end(alice: Api, finished_job: str) -> None:
    r = alice.get(f"/v1/jobs/{finished_job}/events")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/event-stream")
    assert r.text.startswith("retry: 1000\n\n")
    events = parse_sse(r.text)
    assert [e["event"] for e in events] == ["frame"] * 5 + ["end"]
    assert [e["id"] for e in events] == ["1-0", "2-0", "3-0", "4-0", "5-0", "6-0"]
    assert [json.loads(e["data"])["frame"] for e in events[:5]] == [1, 2, 3, 4, 5]
    assert json.loads(events[-1]["data"])["state"] == "succeeded"


def test_events_resume_after_last_event_id(alice: Api, finished_job: str) -> None:
    r = alice.get(f"/v1/jobs/{finished_job}/events", headers={"Last-Event-ID": "3-0"})
    assert [e["id"] for e in parse_sse(r.text)] == ["4-0", "5-0", "6-0"]


def test_events_of_a_cancelled_queued_job_end_at_once(alice: Api) -> None:
    job_id = alice.submit()
    alice.post(f"/v1/jobs/{job_id}/cancel")
    events = parse_sse(alice.get(f"/v1/jobs/{job_id}/events").text)
    assert [e["event"] for e in events] == ["end"] and json.loads(events[0]["data"])["state"] == "cancelled"


def test_events_bad_last_event_id_or_job(alice: Api, bob: Api, finished_job: str) -> None:
    assert_error(alice.get(f"/v1/jobs/{finished_job}/events", headers={"Last-Event-ID": "../x"}), 400, "Last-Event-ID")
    assert_error(alice.get("/v1/jobs/nope/events"), 422, "path.job_id")
    assert_error(bob.get(f"/v1/jobs/{finished_job}/events"), 404, "no job")


def test_events_need_a_key(check_auth: Callable[..., None], finished_job: str) -> None:
    check_auth("GET", f"/v1/jobs/{finished_job}/events")
