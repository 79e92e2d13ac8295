"""Farm benchmark (not a test): the issue-17 targets on a local stack (loopback, one worker).

1. Pick-up: an idle worker, a shot submitted; the job record's start time minus its creation
   time (both written by the same Redis clock holders: the API at submission, the worker at
   start). Target: under 100 ms.
2. The API's share of a job: the API process's CPU seconds (from /proc) over a run of jobs, each
   followed by a client over its event stream as `weft submit --wait` does, divided by the
   worker's wall seconds running them. Target: under 2 %.
3. 1,000 queued jobs (real submissions; the worker stopped first): GET /v1/jobs latency per
   filter. Target: p99 under 50 ms.

    python -m bench.farm_bench [--jobs 20] [--queued 1000] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx

from bench.stats import percentiles, write_json
from scenes.builders import sheet_shot
from server.stack import Stack


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime


def follow(c: httpx.Client, job_id: str) -> None:
    with c.stream("GET", f"/v1/jobs/{job_id}/events", timeout=httpx.Timeout(30, read=300)) as response:
        for line in response.iter_lines():
            if line == "event: end":
                return


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m bench.farm_bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=20)
    parser.add_argument("--queued", type=int, default=1000)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    shot = sheet_shot("farm-bench", 32, 32, 0.5, 0.5, pins=[0, 31], frames=48, substeps=8)
    results: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp, Stack(Path(tmp), workers=1, env={"WEFT_MAX_ACTIVE_JOBS": str(args.queued + 100)}) as stack, \
            httpx.Client(base_url=stack.url, timeout=60) as c:
        assert stack.api_proc is not None
        submit = lambda **params: c.post("/v1/jobs", json=shot, params=params).raise_for_status().json()["id"]  # noqa: E731
        follow(c, submit())  # warm-up: imports, first solver setup
        pickups, run_seconds = [], 0.0
        api_before = cpu_seconds(stack.api_proc.pid)
        for _ in range(args.jobs):
            time.sleep(0.2)  # the worker is idle, blocked on its doorbell
            job_id = submit()
            follow(c, job_id)
            job = c.get(f"/v1/jobs/{job_id}").json()
            pickups.append(job["started"] - job["created"])
            run_seconds += job["finished"] - job["started"]
        api_cpu = cpu_seconds(stack.api_proc.pid) - api_before
        results["pickup_s"] = percentiles(pickups)
        frames = args.jobs * shot["frame_range"][1]
        results["api_share"] = {"api_cpu_s": api_cpu, "worker_run_s": run_seconds, "share": api_cpu / run_seconds,
                                "api_cpu_per_frame_s": api_cpu / frames, "worker_s_per_frame": run_seconds / frames}

        for worker in stack.workers:
            worker.terminate()
            worker.wait(timeout=60)
        start = time.perf_counter()
        for k in range(args.queued):
            submit(tag=f"seq:{k % 10:03d}", priority=k % 3 * 25)
        submitting = time.perf_counter() - start
        middle = c.get("/v1/jobs", params={"offset": args.queued // 2, "limit": 1}).json()["jobs"][0]["created"]
        latency: dict[str, Any] = {}
        for label, params in (("no filter", {}), ("state=queued", {"state": "queued"}), ("tag=seq:003", {"tag": "seq:003"}),
                              ("name=bench", {"name": "bench"}), ("created_after=middle", {"created_after": middle})):
            c.get("/v1/jobs", params=params).raise_for_status()
            times = []
            for _ in range(100):
                t0 = time.perf_counter()
                c.get("/v1/jobs", params=params).raise_for_status()
                times.append(time.perf_counter() - t0)
            latency[label] = percentiles(times)
        results["list"] = {"queued": args.queued, "submit_s_per_job": submitting / args.queued, "latency_s": latency}

    p, share = results["pickup_s"], results["api_share"]
    print("| measure | value | target |")
    print("|---|---|---|")
    print(f"| pick-up, submission to start, p50 / p99 / max ({p['n']} jobs) | "
          f"{p['p50'] * 1e3:.1f} / {p['p99'] * 1e3:.1f} / {p['max'] * 1e3:.1f} ms | < 100 ms |")
    print(f"| API CPU over worker run time ({args.jobs} jobs: 1,024 vertices, 48 frames, 8 substeps; followed over SSE) | "
          f"{share['share'] * 100:.2f} % ({share['api_cpu_s']:.2f} s / {share['worker_run_s']:.1f} s) | < 2 % |")
    print(f"| the same per frame: API CPU / worker wall | {share['api_cpu_per_frame_s'] * 1e3:.2f} ms / "
          f"{share['worker_s_per_frame'] * 1e3:.1f} ms | |")
    for label, q in results["list"]["latency_s"].items():
        print(f"| GET /v1/jobs ({label}), {args.queued} queued, p50 / p99 | {q['p50'] * 1e3:.1f} / {q['p99'] * 1e3:.1f} ms"
              f" | p99 < 50 ms |")
    write_json(args.json, results)


if __name__ == "__main__":
    main()
