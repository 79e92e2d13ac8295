"""Operations: the worker list, liveness, readiness and Prometheus metrics (with the request
counting middleware that feeds them)."""

from __future__ import annotations

import json
import time
from typing import Any

import redis
from fastapi import APIRouter, FastAPI, Request
from fastapi.responses import JSONResponse, Response
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Histogram, generate_latest
from prometheus_client.core import GaugeMetricFamily

from api_schemas.service import ErrorResponse, WorkerInfo, WorkerList
from server.deps import Owner, Settings, Store
from server.errors import ERRORS
from weft import jobstore

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
        if job_id and await r.hget(jobstore.job_key(job_id), "owner") != owner:
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


@router.get("/metrics", summary="Prometheus metrics", response_class=Response)
async def metrics(request: Request, r: Store, settings: Settings) -> Response:
    pipe = r.pipeline(transaction=False)
    for state in jobstore.STATES:
        pipe.scard(jobstore.state_key(state))
    pipe.hgetall(jobstore.WORKERS)
    pipe.hgetall(jobstore.STATS)
    *counts, workers, stats = await pipe.execute()
    jobs_gauge = GaugeMetricFamily("weft_jobs", "Jobs by state", labels=["state"])
    for state, count in zip(jobstore.STATES, counts, strict=True):
        jobs_gauge.add_metric([state], count)
    now = jobstore.now()
    alive = sum(1 for w in workers.values() if now - json.loads(w)["heartbeat"] < settings.claim_after_seconds)
    worker_gauge = GaugeMetricFamily("weft_workers_alive", "Workers with a recent heartbeat", value=alive)
    frames = GaugeMetricFamily("weft_frames_simulated", "Frames simulated by all workers",
                               value=float(stats.get("frames_simulated", 0)))
    extra = b"".join(generate_latest(_Static([m])) for m in (jobs_gauge, worker_gauge, frames))
    registry: CollectorRegistry = request.app.state.metrics_registry
    return Response(generate_latest(registry) + extra, media_type=CONTENT_TYPE_LATEST)


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
