"""Operations: the worker list, the queue (with its sampled history), liveness, readiness and
Prometheus metrics (farm figures read from Redis, where workers record them, plus this API
process's request counts and latencies)."""

from __future__ import annotations

import asyncio
import json
import math
import time
from typing import Annotated, Any

import redis
from fastapi import APIRouter, Depends, FastAPI, Query, Request
from fastapi.responses import JSONResponse, Response
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Histogram, generate_latest
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily, HistogramMetricFamily

from api_schemas.service import ErrorResponse, QueueSample, QueueStatus, WorkerInfo, WorkerList
from server.deps import Owner, Settings, Store, caller
from server.errors import ERRORS
from weft import jobmetrics, jobstore
from weft.jobstore import ServiceSettings

STALE_WORKER_SECONDS = 3600.0

router = APIRouter()


@router.get("/v1/workers", response_model=WorkerList, responses=ERRORS, summary="Workers and their heartbeats")
async def list_workers(r: Store, owner: Owner, settings: Settings) -> WorkerList:
    now = jobstore.now()
    out = []
    for name, record in (await r.hgetall(jobstore.WORKERS)).items():
        w = json.loads(record)
        if now - float(w["heartbeat"]) > STALE_WORKER_SECONDS:  # long dead: forget it
            await r.hdel(jobstore.WORKERS, name)
            continue
        job_id = w.get("job")
        if job_id and not owner.admin and await r.hget(jobstore.job_key(job_id), "owner") != owner:
            job_id = None
        age = now - float(w["heartbeat"])
        out.append(WorkerInfo(
            name=w["name"], host=w["host"], pid=int(w["pid"]), heartbeat=float(w["heartbeat"]),
            seconds_since_heartbeat=age, alive=age < settings.claim_after_seconds, job=job_id,
        ))
    return WorkerList(workers=sorted(out, key=lambda w: w.name))


@router.get("/healthz", summary="Liveness")
async def healthz() -> dict[str, str]:
    return {"status": "ok"}


@router.get("/readyz", summary="Readiness: Redis reachable and storage writable",
            responses={503: {"model": ErrorResponse}})
async def readyz(r: Store, settings: Settings) -> JSONResponse:
    try:
        await r.ping()
    except redis.RedisError as exc:
        return JSONResponse({"detail": f"redis unavailable: {exc}", "errors": []}, status_code=503)
    if not settings.storage.is_dir():
        return JSONResponse({"detail": f"storage {settings.storage} missing", "errors": []}, status_code=503)
    return JSONResponse({"status": "ready"})


async def farm_snapshot(r: Any, settings: ServiceSettings) -> dict[str, Any]:
    """Counts by state, the longest wait in the queue, and the workers (alive, busy): one round
    trip, whatever the number of jobs."""
    pipe = r.pipeline(transaction=False)
    for state in jobstore.STATES:
        pipe.scard(jobstore.state_key(state))
    pipe.hgetall(jobstore.WORKERS)
    pipe.zrange(jobstore.QUEUED_SINCE, 0, 0, withscores=True)
    *counts, workers, first_queued = await pipe.execute()
    now = jobstore.now()
    oldest = max(0.0, now - first_queued[0][1]) if first_queued else None
    records = [json.loads(w) for w in workers.values()]
    alive = [w for w in records if now - float(w["heartbeat"]) < settings.claim_after_seconds]
    return {
        "jobs": dict(zip(jobstore.STATES, counts, strict=True)),
        "oldest_queued_seconds": oldest,
        "workers": records,
        "workers_alive": len(alive),
        "workers_busy": sum(1 for w in alive if w.get("job")),
    }


QUEUE_HISTORY = f"{jobstore.PREFIX}:queue:history"
QUEUE_SAMPLER_LOCK = f"{jobstore.PREFIX}:queue:sampler"
QUEUE_HISTORY_LENGTH = 4320  # six hours at the default five seconds


async def sample_queue_until(stop: asyncio.Event, r: Any, settings: ServiceSettings) -> None:
    """Every queue_sample_seconds until ``stop`` is set, one sample of the queue into a capped
    Redis stream. Several API processes share the work: whoever takes the lock for the period
    samples. (A stop event rather than task cancellation: a cancellation that lands inside a
    Redis call can surface as a connection error, which the loop must survive.)"""
    period = settings.queue_sample_seconds
    while not stop.is_set():
        try:
            if await r.set(QUEUE_SAMPLER_LOCK, "1", nx=True, px=max(int(period * 900), 1)):
                snap = await farm_snapshot(r, settings)
                await r.xadd(QUEUE_HISTORY, {
                    "time": jobstore.now(), "queued": snap["jobs"]["queued"], "running": snap["jobs"]["running"],
                    "workers_alive": snap["workers_alive"], "workers_busy": snap["workers_busy"],
                }, maxlen=QUEUE_HISTORY_LENGTH, approximate=True)
        except redis.RedisError:
            pass  # Redis restarting: the next period tries again
        try:
            await asyncio.wait_for(stop.wait(), timeout=period)
        except TimeoutError:
            pass


@router.get("/v1/queue", response_model=QueueStatus, responses=ERRORS,
            summary="The farm's queue: jobs by state, the longest wait, workers, and their history")
async def queue_status(
    r: Store, owner: Owner, settings: Settings,
    history: Annotated[int, Query(ge=0, le=QUEUE_HISTORY_LENGTH, description="Newest samples to return.")] = 720,
) -> QueueStatus:
    snap = await farm_snapshot(r, settings)
    samples = []
    if history:
        for _, fields in reversed(await r.xrevrange(QUEUE_HISTORY, count=history)):
            samples.append(QueueSample(time=float(fields["time"]), queued=int(fields["queued"]),
                                       running=int(fields["running"]), workers_alive=int(fields["workers_alive"]),
                                       workers_busy=int(fields["workers_busy"])))
    return QueueStatus(jobs=snap["jobs"], oldest_queued_seconds=snap["oldest_queued_seconds"],
                       workers_alive=snap["workers_alive"], workers_busy=snap["workers_busy"], history=samples)


async def metrics_caller(request: Request, settings: Settings) -> str | None:
    """/metrics asks for an API key only when WEFT_METRICS_REQUIRE_KEY=1."""
    if not settings.metrics_require_key:
        return None
    return await caller(request, settings)


@router.get("/metrics", summary="Prometheus metrics", response_class=Response, responses=ERRORS)
async def metrics(request: Request, r: Store, settings: Settings,
                  _: Annotated[str | None, Depends(metrics_caller)] = None) -> Response:
    snap = await farm_snapshot(r, settings)
    pipe = r.pipeline(transaction=False)
    pipe.hgetall(jobstore.STATS)
    pipe.hgetall(jobmetrics.FAILURES)
    for spec in jobmetrics.HISTOGRAMS.values():
        pipe.hgetall(jobmetrics.histogram_key(spec.name))
    stats, failures, *histograms = await pipe.execute()
    families: list[Any] = []
    jobs_gauge = GaugeMetricFamily("weft_jobs", "Jobs by state", labels=["state"])
    for state, count in snap["jobs"].items():
        jobs_gauge.add_metric([state], count)
    families.append(jobs_gauge)
    families.append(GaugeMetricFamily("weft_queue_depth", "Jobs waiting for a worker", value=snap["jobs"]["queued"]))
    families.append(GaugeMetricFamily("weft_queue_oldest_seconds", "Seconds the longest-waiting queued job has waited",
                                      value=snap["oldest_queued_seconds"] or 0.0))
    families.append(GaugeMetricFamily("weft_workers_alive", "Workers with a recent heartbeat", value=snap["workers_alive"]))
    families.append(GaugeMetricFamily("weft_workers_busy", "Live workers running a job", value=snap["workers_busy"]))
    busy = GaugeMetricFamily("weft_worker_busy", "Per live worker: 1 running a job, 0 idle", labels=["worker", "host"])
    now = jobstore.now()
    for w in sorted(snap["workers"], key=lambda w: w["name"]):
        if now - float(w["heartbeat"]) < settings.claim_after_seconds:
            busy.add_metric([w["name"], w["host"]], 1.0 if w.get("job") else 0.0)
    families.append(busy)
    families.append(CounterMetricFamily("weft_frames_simulated", "Frames simulated by all workers",
                                        value=float(stats.get("frames_simulated", 0))))
    finished = CounterMetricFamily("weft_jobs_finished", "Jobs that reached a final state", labels=["state"])
    for state in jobstore.FINAL_STATES:
        finished.add_metric([state], float(stats.get(f"jobs_{state}", 0)))
    families.append(finished)
    failed = CounterMetricFamily("weft_job_failures", "Failed jobs by kind of failure", labels=["kind"])
    for kind in jobmetrics.FAILURE_KINDS:
        failed.add_metric([kind], float(failures.get(kind, 0)))
    families.append(failed)
    for spec, fields in zip(jobmetrics.HISTOGRAMS.values(), histograms, strict=True):
        value = jobmetrics.parse_histogram(spec, fields)
        families.append(HistogramMetricFamily(
            f"weft_{spec.name}", spec.help,
            buckets=[("+Inf" if math.isinf(b) else repr(b), c) for b, c in value.buckets], sum_value=value.total))
    registry: CollectorRegistry = request.app.state.metrics_registry
    return Response(generate_latest(registry) + generate_latest(_Static(families)), media_type=CONTENT_TYPE_LATEST)


def install_request_metrics(app: FastAPI) -> None:
    """Count and time the app's requests into its own registry (served by /metrics)."""
    registry = CollectorRegistry()
    requests_total = Counter(
        "weft_http_requests", "HTTP requests by route and status", ["method", "route", "status"], registry=registry
    )
    latency = Histogram("weft_http_request_seconds", "HTTP request latency", ["route"], registry=registry)
    app.state.metrics_registry = registry
    app.add_middleware(MetricsMiddleware, requests_total=requests_total, latency=latency)


class MetricsMiddleware:
    """Counts requests by route template and status and times them. Plain ASGI: no task per
    request, and streaming responses (SSE, cache downloads) pass straight through."""

    def __init__(self, app: Any, requests_total: Counter, latency: Histogram) -> None:
        self.app = app
        self.requests_total = requests_total
        self.latency = latency

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        start = time.perf_counter()
        status = [500]

        async def send_status(message: dict[str, Any]) -> None:
            if message["type"] == "http.response.start":
                status[0] = message["status"]
            await send(message)

        try:
            await self.app(scope, receive, send_status)
        finally:
            path = getattr(scope.get("route"), "path", "unmatched")
            self.requests_total.labels(scope["method"], path, str(status[0])).inc()
            self.latency.labels(path).observe(time.perf_counter() - start)


class _Static:
    """A one-off collector for metrics computed at scrape time."""

    def __init__(self, families: list[Any]) -> None:
        self._families = families

    def collect(self) -> list[Any]:
        return self._families
