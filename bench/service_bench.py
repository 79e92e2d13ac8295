"""Service benchmark (not a test). Starts a local stack on loopback and measures:

1. API overhead per frame: a job's wall time (worker start to finish) minus the solver's own
   per-frame time, per frame, relative to the solver time. It covers the cache append, the
   event publication, the cancel check and the heartbeat.
2. Status-poll latency percentiles with 100 concurrent pollers while workers run jobs.
3. Frame-finished to event-received latency over the SSE stream (worker timestamp at publish
   vs. client receive time; same machine, same clock), idle and under the polling load.

    python bench/service_bench.py [--workers 2] [--pollers 100] [--polls 20]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
from httpx_sse import aconnect_sse

from server.stack import Stack
from bench.stats import percentiles
from scenes.builders import sheet_shot


async def submit(client: httpx.AsyncClient, shot: dict[str, Any]) -> str:
    r = await client.post("/v1/jobs", json=shot)
    r.raise_for_status()
    return str(r.json()["id"])


async def follow(client: httpx.AsyncClient, job_id: str, reconnects: list[int] | None = None) -> list[float]:
    """Event latencies (seconds) for every frame event of a job; reconnects with Last-Event-ID
    if the connection drops (counted in ``reconnects``)."""
    latencies: list[float] = []
    last_id = ""
    while True:
        headers = {"Last-Event-ID": last_id} if last_id else {}
        try:
            async with aconnect_sse(client, "GET", f"/v1/jobs/{job_id}/events", headers=headers,
                                    timeout=httpx.Timeout(30, read=300)) as source:
                async for sse in source.aiter_sse():
                    if not sse.data:
                        continue
                    received = time.time()
                    last_id = sse.id or last_id
                    data = json.loads(sse.data)
                    if sse.event == "frame":
                        latencies.append(received - data["published_at"])
                    elif sse.event == "end":
                        return latencies
        except (httpx.ReadError, httpx.RemoteProtocolError):
            if reconnects is not None:
                reconnects.append(1)


async def overhead(client: httpx.AsyncClient, name: str, shot: dict[str, Any]) -> dict[str, Any]:
    job_id = await submit(client, shot)
    await follow(client, job_id)
    job = (await client.get(f"/v1/jobs/{job_id}")).json()
    telemetry = (await client.get(f"/v1/jobs/{job_id}/telemetry")).json()["rows"]
    frames = len(telemetry)
    solver = sum(row["total_seconds"] for row in telemetry)
    wall = job["finished"] - job["started"]
    per_frame = (wall - solver) / frames
    return {
        "job_id": job_id, "scene": name, "vertices": job["vertices"], "frames": frames, "solver_ms": 1000 * solver / frames,
        "overhead_ms": 1000 * per_frame, "relative": per_frame / (solver / frames),
    }


async def poll_load(client: httpx.AsyncClient, job_ids: list[str], pollers: int, polls: int) -> list[float]:
    latencies: list[float] = []

    async def poller(k: int) -> None:
        for i in range(polls):
            job_id = job_ids[(k + i) % len(job_ids)]
            start = time.perf_counter()
            r = await client.get(f"/v1/jobs/{job_id}")
            latencies.append(time.perf_counter() - start)
            assert r.status_code == 200
            await asyncio.sleep(0.01)

    await asyncio.gather(*(poller(k) for k in range(pollers)))
    return latencies


async def server_seconds(client: httpx.AsyncClient, route: str) -> tuple[float, float]:
    """(sum, count) of the API's own request-time histogram for a route, from /metrics."""
    text = (await client.get("/metrics")).text
    values = {}
    for kind in ("sum", "count"):
        match = re.search(rf'^weft_http_request_seconds_{kind}\{{route="{re.escape(route)}"\}} (\S+)$', text, re.M)
        values[kind] = float(match.group(1)) if match else 0.0
    return values["sum"], values["count"]


async def main_async(args: argparse.Namespace) -> None:
    with tempfile.TemporaryDirectory() as tmp, Stack(Path(tmp), workers=args.workers) as stack:
        limits = httpx.Limits(max_connections=args.pollers + 10, max_keepalive_connections=args.pollers + 10)
        async with httpx.AsyncClient(base_url=stack.url, limits=limits, timeout=60) as client:
            print(f"stack: {stack.url}, {args.workers} worker(s), 1 solver thread each\n")
            rows = [
                await overhead(client, "sheet 8x8, 4 substeps", sheet_shot("tiny", 8, 8, 0.5, 0.5, pins=[0, 7], frames=60)),
                await overhead(client, "sheet 24x24, 4 substeps", sheet_shot("mid", 24, 24, 0.5, 0.5, pins=[0, 23], frames=40)),
                await overhead(client, "sheet 48x48, 4 substeps", sheet_shot("big", 48, 48, 1, 1, pins=[0, 47], frames=15)),
            ]
            print("1. API overhead per frame (job wall time minus solver time)")
            print(f"   {'scene':<26}{'vertices':>9}{'frames':>7}{'solver ms/frame':>17}{'overhead ms/frame':>19}{'overhead/solver':>17}")
            for r in rows:
                print(f"   {r['scene']:<26}{r['vertices']:>9}{r['frames']:>7}{r['solver_ms']:>17.2f}{r['overhead_ms']:>19.2f}{r['relative']:>16.1%}")

            idle_polls = []
            for _ in range(100):
                start = time.perf_counter()
                (await client.get(f"/v1/jobs/{rows[0]['job_id']}")).raise_for_status()
                idle_polls.append(time.perf_counter() - start)
            idle = await follow(client, await submit(client, sheet_shot("idle", 16, 16, 0.5, 0.5, pins=[0, 15], frames=60, substeps=8)))

            # Load: jobs running on every worker while 100 clients poll their status.
            load_jobs = [await submit(client, sheet_shot(f"load{i}", 16, 16, 0.5, 0.5, pins=[0, 15], frames=400, substeps=8))
                         for i in range(args.workers)]
            while (await client.get(f"/v1/jobs/{load_jobs[0]}")).json()["state"] != "running":
                await asyncio.sleep(0.05)
            reconnects: list[int] = []
            events_task = asyncio.create_task(follow(client, load_jobs[0], reconnects))
            before = await server_seconds(client, "/v1/jobs/{job_id}")
            started = time.perf_counter()
            polls = await poll_load(client, load_jobs, args.pollers, args.polls)
            elapsed = time.perf_counter() - started
            after = await server_seconds(client, "/v1/jobs/{job_id}")
            for job_id in load_jobs:
                await client.post(f"/v1/jobs/{job_id}/cancel")
            loaded_events = await events_task

            print(f"\n2. Status-poll latency, {args.pollers} concurrent pollers x {args.polls} polls, workers running (ms)")
            p = percentiles(idle_polls)
            print(f"   one poller, no job running: n {p['n']}  p50 {1000 * p['p50']:.1f}  p99 {1000 * p['p99']:.1f}")
            p = percentiles(polls)
            print(f"   client-observed: n {p['n']}  p50 {1000 * p['p50']:.1f}  p90 {1000 * p['p90']:.1f}  "
                  f"p99 {1000 * p['p99']:.1f}  max {1000 * p['max']:.1f}  ({len(polls) / elapsed:.0f} req/s)")
            served = (after[0] - before[0]) / max(after[1] - before[1], 1)
            print(f"   inside the API (route handler to response, from /metrics): mean {1000 * served:.2f} ms")
            print("\n3. Frame finished -> SSE event received (ms)")
            for label, values in (("idle", idle), (f"under {args.pollers} pollers", loaded_events)):
                p = percentiles(values)
                print(f"   {label:<18} n {p['n']:>4}  p50 {1000 * p['p50']:.1f}  p90 {1000 * p['p90']:.1f}  "
                      f"p99 {1000 * p['p99']:.1f}  max {1000 * p['max']:.1f}  mean {1000 * statistics.mean(values):.1f}")
            print(f"   SSE reconnects under load: {len(reconnects)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--pollers", type=int, default=100)
    parser.add_argument("--polls", type=int, default=20)
    asyncio.run(main_async(parser.parse_args()))


if __name__ == "__main__":
    main()
