"""A key's share of the service (issue 15): one client holding ~100 event streams exhausted the
API's Redis connections and other keys got 503; nothing bounded a key's queued jobs. Real
Redis, real HTTP through uvicorn, no workers (jobs stay queued, streams stay open)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from server.stack import Stack

from .conftest import ALICE, BOB, FAST_CLAIM, client, small_shot, wait_for

LIMITS = {"WEFT_MAX_STREAMS_PER_KEY": "3", "WEFT_MAX_STREAMS": "5", "WEFT_MAX_ACTIVE_JOBS": "2"}


@pytest.fixture(scope="module")
def limited(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    with Stack(tmp_path_factory.mktemp("limited"), workers=0, api_keys=[ALICE, BOB], env={**FAST_CLAIM, **LIMITS}) as s:
        yield s


@contextlib.contextmanager
def open_stream(c: httpx.Client, job_id: str) -> Iterator[httpx.Response]:
    with c.stream("GET", f"/v1/jobs/{job_id}/events", timeout=httpx.Timeout(30, read=60)) as response:
        # The opening 'retry:' line: the server holds the slot. The iterator is kept: dropping
        # it would close the connection.
        chunks = response.iter_raw() if response.status_code == 200 else iter(())
        next(chunks, None)
        yield response


def assert_refused(c: httpx.Client, job_id: str, why: str) -> None:
    with open_stream(c, job_id) as refused:
        assert refused.status_code == 429
        refused.read()
        assert why in refused.json()["detail"]


def test_one_key_cannot_take_every_event_stream(limited: Stack) -> None:
    with client(limited, ALICE) as alice, client(limited, BOB) as bob, contextlib.ExitStack() as held:
        alice_job = alice.post("/v1/jobs", json=small_shot("streams-a")).json()["id"]
        bob_job = bob.post("/v1/jobs", json=small_shot("streams-b")).json()["id"]
        bob_streams = [held.enter_context(open_stream(bob, bob_job)) for _ in range(3)]
        assert all(s.status_code == 200 for s in bob_streams)
        assert_refused(bob, bob_job, "3 event streams open, the limit is 3")
        # Another key still gets its streams and its other requests.
        alice_streams = [held.enter_context(open_stream(alice, alice_job)) for _ in range(2)]
        assert all(s.status_code == 200 for s in alice_streams)
        assert_refused(alice, alice_job, "the server has 5 event streams open")
        assert alice.get("/v1/jobs").status_code == 200 and alice.get(f"/v1/jobs/{alice_job}").status_code == 200
        # A stream that ends gives its slot back.
        bob_streams[0].close()

        def reopened() -> bool:
            with open_stream(bob, bob_job) as again:
                return again.status_code == 200

        assert wait_for(reopened, timeout=20, what="the closed stream's slot to be free")


def test_a_key_over_its_active_jobs_gets_429(limited: Stack, tmp_path: Path) -> None:
    with client(limited, ALICE) as alice, client(limited, BOB) as bob:
        for job in alice.get("/v1/jobs", params={"state": "queued"}).json()["jobs"]:
            alice.post(f"/v1/jobs/{job['id']}/cancel")  # another test's queued job
        first = [alice.post("/v1/jobs", json=small_shot(f"share{i}")) for i in range(2)]
        assert [r.status_code for r in first] == [201, 201]
        over = alice.post("/v1/jobs", json=small_shot("share-over"))
        assert over.status_code == 429 and "2 jobs queued or running, the limit is 2" in over.json()["detail"]
        resubmitted = alice.post("/v1/jobs", json=small_shot("share-over"), headers={"Idempotency-Key": "k1"})
        assert resubmitted.status_code == 429, "a new Idempotency-Key is a new job"
        for job in bob.get("/v1/jobs", params={"state": "queued"}).json()["jobs"]:
            bob.post(f"/v1/jobs/{job['id']}/cancel")
        assert bob.post("/v1/jobs", json=small_shot("bob-share")).status_code == 201, "another key is not affected"
        assert alice.post(f"/v1/jobs/{first[0].json()['id']}/cancel").json()["state"] == "cancelled"
        assert alice.post("/v1/jobs", json=small_shot("share-after")).status_code == 201
        cancelled = first[0].json()["id"]
        full = alice.post(f"/v1/jobs/{cancelled}/retry")
        assert full.status_code == 429, "a retried job counts towards the key's share"
        alice.post(f"/v1/jobs/{first[1].json()['id']}/cancel")
        retried = alice.post(f"/v1/jobs/{cancelled}/retry")
        assert retried.status_code == 200 and retried.json()["state"] == "queued"
        assert alice.post("/v1/jobs", json=small_shot("share-full")).status_code == 429


def test_submissions_racing_at_the_limit_cannot_all_pass(limited: Stack) -> None:
    """Eight submissions at once with room for two: the early count sees room for all of them
    (validation takes a while), the queueing transaction lets exactly two through. A refused
    submission's Idempotency-Key does not keep pointing at the job that was never queued."""
    from concurrent.futures import ThreadPoolExecutor

    with client(limited, BOB) as bob:
        for job in bob.get("/v1/jobs", params={"state": "queued"}).json()["jobs"]:
            bob.post(f"/v1/jobs/{job['id']}/cancel")

        def submit(i: int) -> httpx.Response:
            with client(limited, BOB) as c:
                return c.post("/v1/jobs", json=small_shot(f"race{i}"), headers={"Idempotency-Key": f"race-{i}"})

        with ThreadPoolExecutor(8) as pool:
            answers = list(pool.map(submit, range(8)))
        codes = sorted(a.status_code for a in answers)
        assert codes == [201, 201] + [429] * 6, codes
        queued = bob.get("/v1/jobs", params={"state": "queued"}).json()["jobs"]
        assert len(queued) == 2
        for job in queued:
            bob.post(f"/v1/jobs/{job['id']}/cancel")
        refused = [i for i, a in enumerate(answers) if a.status_code == 429]
        again = [bob.post("/v1/jobs", json=small_shot(f"race{i}"), headers={"Idempotency-Key": f"race-{i}"})
                 for i in refused]
        assert sorted(a.status_code for a in again) == [201, 201] + [429] * 4, [a.text for a in again]
        assert not any(a.json().get("duplicate") for a in again if a.status_code < 300)


def test_a_keys_stream_share_holds_across_api_processes(limited: Stack) -> None:
    """Two API processes on one Redis: the key's streams are counted together (in Redis), not a
    share per process; a stream's lease outlives no process that stopped renewing it."""
    import signal
    import subprocess
    import sys

    from server.stack import free_port

    port = free_port()
    second = subprocess.Popen([sys.executable, "-m", "server", "--host", "127.0.0.1", "--port", str(port)],
                              env=limited.env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        other = httpx.Client(base_url=f"http://127.0.0.1:{port}", headers={"Authorization": f"Bearer {ALICE}"},
                             timeout=30)

        def ready() -> bool:
            try:
                return other.get("/readyz").status_code == 200
            except httpx.HTTPError:
                return False

        wait_for(ready, timeout=30, what="the second API process")
        with client(limited, ALICE) as alice, contextlib.ExitStack() as held:
            for queued in alice.get("/v1/jobs", params={"state": "queued"}).json()["jobs"]:
                alice.post(f"/v1/jobs/{queued['id']}/cancel")  # another test's queued jobs
            job = alice.post("/v1/jobs", json=small_shot("streams-two-processes")).json()["id"]
            first = [held.enter_context(open_stream(alice, job)) for _ in range(2)]
            assert all(s.status_code == 200 for s in first)
            third = held.enter_context(open_stream(other, job))
            assert third.status_code == 200
            assert_refused(other, job, "3 event streams open, the limit is 3")
            assert_refused(alice, job, "3 event streams open, the limit is 3")
            # The second process dies without closing its stream: its lease runs out.
            second.send_signal(signal.SIGKILL)
            second.wait()

            def freed() -> bool:
                with open_stream(alice, job) as again:
                    return again.status_code == 200

            assert wait_for(freed, timeout=40, interval=1, what="the dead process's stream lease to expire")
        other.close()
    finally:
        if second.poll() is None:
            second.kill()
            second.wait()
