"""Dashboard benchmark (not a test): the issue-16 targets, measured in Debian's Chromium against a
local stack on loopback.

1. Follow delay: a job page open on a running shot; for each frame published after the page
   opened, the time from the worker's publication to the page having drawn it (same machine,
   same clock). Target: under 1 s.
2. Render time of a finished job's whole telemetry (one real shot of 1,000 frames): the page's
   own measurement of one full redraw of every chart (performance.now() around it), and the
   time from navigation to all frames drawn. Target: 1,000 frames drawn in under 200 ms.
3. The jobs page with 10,000 jobs of one key: records written with the job store's own
   submission transition (jobstore.queue_new_job), then GET /v1/jobs latency per filter (no
   filter, state, name; 50 requests after one warm-up) and the page's load time. Target: stays responsive (pagination on the
   server).

    python -m bench.dashboard_bench [--frames 1000] [--jobs 10000] [--json PATH]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
import uuid
from pathlib import Path
from typing import Any

import httpx
import redis
from playwright.sync_api import sync_playwright

from bench.stats import percentiles, write_json
from scenes.builders import sheet_shot
from server.stack import Stack
from weft import jobstore

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage"]


def submit(c: httpx.Client, shot: dict[str, Any]) -> str:
    r = c.post("/v1/jobs", json=shot)
    r.raise_for_status()
    return str(r.json()["id"])


def wait_final(c: httpx.Client, job_id: str, timeout: float = 600) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if c.get(f"/v1/jobs/{job_id}").json()["state"] in jobstore.FINAL_STATES:
            return
        time.sleep(0.2)
    raise RuntimeError(f"job {job_id} did not finish in {timeout} s")


def follow_delay(stack: Stack, c: httpx.Client, page: Any) -> dict[str, float]:
    job_id = submit(c, sheet_shot("bench-follow", 16, 16, 0.5, 0.5, pins=[0, 15], frames=300, substeps=8))
    page.goto(f"{stack.url}/ui/jobs/{job_id}")
    page.wait_for_function("() => window.weftDashboard && weftDashboard.stream === 'live'", timeout=60_000)
    opened = time.time()
    page.wait_for_function("() => weftDashboard.state === 'succeeded' && weftDashboard.framesShown === 300",
                           timeout=600_000)
    published = page.evaluate("() => weftDashboard.publishedAt")
    shown = page.evaluate("() => weftDashboard.shownAt")
    return percentiles([shown[i] - t for i, t in published.items() if t > opened + 0.5])


def render_finished(stack: Stack, c: httpx.Client, page: Any, frames: int) -> dict[str, float]:
    job_id = submit(c, sheet_shot("bench-render", 6, 6, 0.5, 0.5, pins=[0, 5], frames=frames, substeps=1))
    wait_final(c, job_id)
    loads, redraws = [], []
    for _ in range(5):
        page.goto(f"{stack.url}/ui/jobs/{job_id}")
        page.wait_for_function(f"() => weftDashboard.framesShown === {frames}", timeout=60_000, polling=5)
        loads.append(page.evaluate("() => weftDashboard.lastRenderAt") / 1000)
        redraws.append(page.evaluate("() => weftDashboard.lastRenderMs") / 1000)
    return {"frames": frames, "redraw_median_s": statistics.median(redraws), "redraw_max_s": max(redraws),
            "navigation_to_drawn_median_s": statistics.median(loads)}


def seed_jobs(stack: Stack, count: int) -> None:
    """count job records of the local key, through the submission transition (no solver)."""
    r = redis.Redis.from_url(stack.redis_url, decode_responses=True)
    now = jobstore.now()
    pipe = r.pipeline(transaction=False)
    for k in range(count):
        job_id = uuid.uuid4().hex
        record = {"id": job_id, "owner": "local", "name": f"seeded-{k:05d}", "state": "queued", "frames_done": 0,
                  "frames_total": 48, "frame_first": 1, "frame_last": 48, "vertices": 4096,
                  "created": now - count + k, "attempts": 0, "request_hash": "0" * 64}
        jobstore.queue_new_job(pipe, record)
        if k % 500 == 499:
            pipe.execute()
    pipe.execute()
    r.close()


def jobs_page(stack: Stack, c: httpx.Client, page: Any, count: int) -> dict[str, Any]:
    for worker in stack.workers:  # the seeded jobs have no shot: keep them queued, as a busy farm would
        worker.terminate()
        worker.wait(timeout=60)
    seed_jobs(stack, count)
    api: dict[str, Any] = {}
    for label, params in (("no filter", {}), ("state=queued", {"state": "queued"}),
                          ("name=seeded-0999", {"name": "seeded-0999"}), ("offset=9000", {"offset": 9000})):
        c.get("/v1/jobs", params=params).raise_for_status()  # one warm-up request, not timed
        times = []
        for _ in range(50):
            start = time.perf_counter()
            c.get("/v1/jobs", params=params).raise_for_status()
            times.append(time.perf_counter() - start)
        api[label] = percentiles(times)
    loads = []
    for _ in range(5):
        start = time.perf_counter()
        page.goto(f"{stack.url}/ui/jobs")
        page.wait_for_function("() => weftDashboard.loads >= 1", polling=5)
        loads.append(time.perf_counter() - start)
    return {"jobs": count, "api": api, "page_load_median_s": statistics.median(loads)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.dashboard_bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=10_000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp, Stack(Path(tmp), workers=1) as stack, \
            httpx.Client(base_url=stack.url, timeout=60) as c, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_context(viewport={"width": 1280, "height": 900}).new_page()
        results = {
            "follow_delay_s": follow_delay(stack, c, page),
            "render": render_finished(stack, c, page, args.frames),
            "jobs_page": jobs_page(stack, c, page, args.jobs),
        }
        browser.close()
    d, rnd, jp = results["follow_delay_s"], results["render"], results["jobs_page"]
    print("| measure | value | target |")
    print("|---|---|---|")
    print(f"| frame published -> drawn on the job page, p50 / p99 / max ({d['n']} frames) | "
          f"{d['p50'] * 1e3:.0f} / {d['p99'] * 1e3:.0f} / {d['max'] * 1e3:.0f} ms | < 1 s |")
    print(f"| redraw of all charts, {rnd['frames']} frames, median / max of 5 | "
          f"{rnd['redraw_median_s'] * 1e3:.1f} / {rnd['redraw_max_s'] * 1e3:.1f} ms | < 200 ms |")
    print(f"| job page: navigation start to {rnd['frames']} frames drawn (page clock), median of 5 | "
          f"{rnd['navigation_to_drawn_median_s'] * 1e3:.0f} ms | |")
    for label, q in jp["api"].items():
        print(f"| GET /v1/jobs ({label}), {jp['jobs']} jobs, p50 / p99 / max | {q['p50'] * 1e3:.1f} / {q['p99'] * 1e3:.1f} / {q['max'] * 1e3:.1f} ms | |")
    print(f"| jobs page: navigation to the first page drawn, {jp['jobs']} jobs, median of 5 | "
          f"{jp['page_load_median_s'] * 1e3:.0f} ms | responsive |")
    write_json(args.json, results)


if __name__ == "__main__":
    main()
