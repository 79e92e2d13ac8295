"""The weft simulation service: a FastAPI app over Redis (job records, queue, events) and a
storage directory (uploaded assets and HDF5 caches). Run with ``python -m server``."""

from __future__ import annotations

import asyncio
import hashlib
import hmac
import ipaddress
import json
import re
import shutil
import time
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Annotated, Any, Literal

import anyio
import numpy as np
import redis
import redis.asyncio as aioredis
from fastapi import Depends, FastAPI, Header, HTTPException, Query, Request
from fastapi import Path as PathParam
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse, Response, StreamingResponse
from fastapi.security import HTTPBearer
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Histogram, generate_latest
from prometheus_client.core import GaugeMetricFamily
from starlette.background import BackgroundTask

from api_schemas import FrameTelemetry, Shot
from api_schemas.service import (
    ErrorResponse,
    FramePositions,
    Job,
    JobCreated,
    JobError,
    JobList,
    JobState,
    TelemetryPage,
    TimingSummary,
    WorkerInfo,
    WorkerList,
)
from server import cachefiles
from server.uploads import UploadError, normalize_asset_path, read_limited, receive_multipart
from weft import jobstore
from weft.jobstore import ServiceSettings
from weft.scene import ShotError, ShotValidationError, asset_paths, parse_shot, resolve_scene

JOB_ID = r"^[0-9a-f]{32}$"
IDEMPOTENCY = re.compile(r"^[A-Za-z0-9_.:-]{1,128}$")
IDEMPOTENCY_TTL = 24 * 3600
STALE_WORKER_SECONDS = 3600.0
ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorResponse} for code in (400, 401, 403, 404, 409, 413, 415, 422, 503)
}

JobId = Annotated[str, PathParam(pattern=JOB_ID, description="Job id (32 hex digits).")]


class ApiError(Exception):
    def __init__(self, status: int, detail: str, errors: list[dict[str, Any]] | None = None) -> None:
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.errors = errors or []


def owner_of_key(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()[:24]


def store(request: Request) -> aioredis.Redis:
    return request.app.state.redis  # type: ignore[no-any-return]


def check_index_sizes(shot: Shot) -> None:
    """Vertex indices must fit the solver's int32 (the schema accepts any integer)."""
    limit = 2**31

    def check(values: Any, field: str) -> None:
        for k, value in enumerate(values or []):
            items = value if isinstance(value, tuple | list) else (value,)
            if any(not -limit <= v < limit for v in items):
                raise ShotError(f"{field}[{k}]", f"vertex index {max(items, key=abs)} is out of range")

    for i, piece in enumerate(shot.cloth):
        check(piece.mesh.faces, f"cloth[{i}].mesh.faces")
        for j, pin in enumerate(piece.pins):
            check(pin.vertices, f"cloth[{i}].pins[{j}].vertices")
    for i, body in enumerate(shot.bodies):
        check(body.mesh.faces, f"bodies[{i}].mesh.faces")


# Declares bearer auth in the OpenAPI document (the 'Authorize' button of /docs); the checks
# are ours, so that each failure gets its own message.
bearer_scheme = HTTPBearer(auto_error=False, description="An API key of this service.")


async def caller(request: Request, _: Annotated[object, Depends(bearer_scheme)] = None) -> str:
    """The owner id of the caller's API key ('local' in local mode)."""
    settings: ServiceSettings = request.app.state.settings
    authorization = request.headers.get("authorization")
    if settings.local:
        host = request.client.host if request.client else ""
        try:
            loopback = ipaddress.ip_address(host).is_loopback
        except ValueError:
            loopback = host in {"testclient", "localhost"}
        if not loopback:
            raise ApiError(403, "local mode only serves loopback clients")
        return "local"
    if not authorization:
        raise ApiError(401, "missing API key: send 'Authorization: Bearer <key>'")
    scheme, _, token = authorization.partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        raise ApiError(401, "malformed Authorization header: expected 'Bearer <key>'")
    token = token.strip()
    if not any(hmac.compare_digest(token.encode(), key.encode()) for key in settings.api_keys):
        raise ApiError(401, "unknown API key")
    return owner_of_key(token)

Owner = Annotated[str, Depends(caller)]
Store = Annotated[aioredis.Redis, Depends(store)]



def create_app(settings: ServiceSettings | None = None) -> FastAPI:
    settings = settings or ServiceSettings.from_env()
    registry = CollectorRegistry()
    requests_total = Counter(
        "weft_http_requests", "HTTP requests by route and status", ["method", "route", "status"], registry=registry
    )
    latency = Histogram("weft_http_request_seconds", "HTTP request latency", ["route"], registry=registry)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        app.state.redis = aioredis.Redis.from_url(settings.redis_url, decode_responses=True)
        app.state.scripts = {
            "cancel": app.state.redis.register_script(jobstore.CANCEL_LUA),
        }
        settings.storage.mkdir(parents=True, exist_ok=True)
        try:
            await app.state.redis.xgroup_create(jobstore.QUEUE, jobstore.GROUP, id="0", mkstream=True)
        except redis.RedisError:
            pass  # exists already, or Redis is not up yet (the workers create it too)
        yield
        await app.state.redis.aclose()

    app = FastAPI(
        title="weft simulation service",
        version="1",
        description="Submit cloth shots, follow them frame by frame, fetch their HDF5 caches. See docs/service.md.",
        lifespan=lifespan,
    )
    app.state.settings = settings

    # -- errors: always a JSON body with a message; never a 500 for a bad request ----------------
    @app.exception_handler(ApiError)
    async def api_error(_: Request, exc: ApiError) -> JSONResponse:
        headers = {"WWW-Authenticate": "Bearer"} if exc.status == 401 else None
        return JSONResponse({"detail": exc.detail, "errors": exc.errors}, status_code=exc.status, headers=headers)

    @app.exception_handler(HTTPException)
    async def http_error(_: Request, exc: HTTPException) -> JSONResponse:
        return JSONResponse({"detail": str(exc.detail), "errors": []}, status_code=exc.status_code)

    @app.exception_handler(RequestValidationError)
    async def validation_error(_: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [{"field": ".".join(str(p) for p in e["loc"]), "problem": e["msg"]} for e in exc.errors()]
        detail = "; ".join(f"{e['field']}: {e['problem']}" for e in errors)
        return JSONResponse({"detail": f"invalid request: {detail}", "errors": errors}, status_code=422)

    @app.exception_handler(redis.ConnectionError)
    async def redis_down(_: Request, exc: redis.ConnectionError) -> JSONResponse:
        return JSONResponse({"detail": f"job store unavailable: {exc}", "errors": []}, status_code=503)

    app.add_middleware(MetricsMiddleware, requests_total=requests_total, latency=latency)

    def job_url(request: Request, job_id: str) -> str:
        return str(request.url_for("get_job", job_id=job_id))

    def to_job(request: Request, h: dict[str, str]) -> Job:
        timing = None
        sim_frames = int(h.get("sim_frames", 0))
        if sim_frames:
            timing = TimingSummary(
                frames=sim_frames, **{f"{k}_seconds": float(h.get(f"sum_{k}", 0.0)) / sim_frames for k in jobstore.TIMING_KEYS}
            )
        error = None
        if h.get("error_reason"):
            error = JobError(frame=int(h["error_frame"]) if h.get("error_frame") else None, reason=h["error_reason"])
        return Job(
            id=h["id"], url=job_url(request, h["id"]), name=h["name"], state=h["state"],  # type: ignore[arg-type]
            frames_done=int(h.get("frames_done", 0)), frames_total=int(h["frames_total"]),
            frame_range=(int(h["frame_first"]), int(h["frame_last"])), vertices=int(h["vertices"]),
            worker=h.get("worker") or None, attempts=int(h.get("attempts", 0)),
            resumed_from=int(h["resumed_from"]) if h.get("resumed_from") else None,
            cancel_requested=h.get("cancel_requested") == "1", created=float(h["created"]),
            started=float(h["started"]) if h.get("started") else None,
            finished=float(h["finished"]) if h.get("finished") else None, timing=timing, error=error,
        )

    async def load_job(r: aioredis.Redis, owner: str, job_id: str) -> dict[str, str]:
        h = await r.hgetall(jobstore.job_key(job_id))
        # Another key's job is indistinguishable from a missing one.
        if not h or not hmac.compare_digest(h.get("owner", ""), owner):
            raise ApiError(404, f"no job {job_id}")
        return h  # type: ignore[no-any-return]

    # -- submission ---------------------------------------------------------------------------
    submit_body = {
        "requestBody": {
            "required": True,
            "description": "The shot as JSON (inline meshes), or multipart with a 'shot' part (JSON) and asset "
            "files whose file names are the shot's relative asset paths.",
            "content": {
                "application/json": {"schema": {"$ref": "#/components/schemas/Shot"}},
                "multipart/form-data": {
                    "schema": {
                        "type": "object",
                        "required": ["shot"],
                        "properties": {
                            "shot": {"type": "string", "description": "The shot document, JSON."},
                            "assets": {"type": "array", "items": {"type": "string", "format": "binary"}},
                        },
                    }
                },
            },
        }
    }

    @app.post(
        "/v1/jobs", status_code=201, response_model=JobCreated, responses=ERRORS, openapi_extra=submit_body,
        summary="Submit a shot",
    )
    async def submit_job(
        request: Request,
        r: Store,
        owner: Owner,
        idempotency_key: Annotated[str | None, Header(description="Makes a resubmission return the first job.")] = None,
    ) -> Response:
        if idempotency_key is not None and not IDEMPOTENCY.match(idempotency_key):
            raise ApiError(400, "Idempotency-Key must be 1-128 characters of letters, digits, '_', '-', '.', ':'")
        if idempotency_key:
            existing = await r.get(jobstore.idempotency_key(owner, idempotency_key))
            if existing:
                return duplicate_response(request, existing, await r.hget(jobstore.job_key(existing), "state"))
        content_type = request.headers.get("content-type", "")
        declared = request.headers.get("content-length")
        if declared and declared.isdigit() and int(declared) > settings.max_upload_bytes:
            raise ApiError(413, f"upload of {declared} bytes exceeds the limit of {settings.max_upload_bytes} bytes")
        job_id = uuid.uuid4().hex
        job_dir = settings.job_dir(job_id)
        assets = settings.assets_dir(job_dir)
        assets.mkdir(parents=True)
        try:
            if content_type.startswith("multipart/form-data"):
                upload = await receive_multipart(
                    request.stream(), content_type, assets, settings.max_upload_bytes, settings.max_json_bytes,
                    settings.max_files,
                )
                body, uploaded = upload.shot_bytes or b"", set(upload.assets)
            elif content_type.startswith("application/json"):
                body, uploaded = await read_limited(request.stream(), settings.max_json_bytes), set()
            else:
                raise ApiError(415, f"unsupported Content-Type {content_type!r}: use application/json or multipart/form-data")
            shot, scene_info = await anyio.to_thread.run_sync(validate_shot, body, assets, uploaded)
            (job_dir / "shot.json").write_text(shot.model_dump_json())
            if idempotency_key:
                idem = jobstore.idempotency_key(owner, idempotency_key)
                if not await r.set(idem, job_id, nx=True, ex=IDEMPOTENCY_TTL):
                    existing = await r.get(idem)
                    shutil.rmtree(job_dir, ignore_errors=True)
                    return duplicate_response(request, existing, await r.hget(jobstore.job_key(existing), "state"))
            created = jobstore.now()
            record = {
                "id": job_id, "owner": owner, "name": shot.name, "state": "queued", "frames_done": 0,
                "frames_total": shot.frame_count, "frame_first": shot.frame_range[0],
                "frame_last": shot.frame_range[1], "vertices": scene_info, "created": created, "attempts": 0,
            }
            pipe = r.pipeline(transaction=True)
            jobstore.queue_new_job(pipe, record)
            await pipe.execute()
        except UploadError as exc:
            shutil.rmtree(job_dir, ignore_errors=True)
            raise ApiError(exc.status, exc.problem, [{"field": exc.field, "problem": exc.problem}]) from None
        except BaseException:
            shutil.rmtree(job_dir, ignore_errors=True)
            raise
        url = job_url(request, job_id)
        body_out = JobCreated(id=job_id, url=url, state="queued")
        return JSONResponse(body_out.model_dump(), status_code=201, headers={"Location": url})

    def duplicate_response(request: Request, job_id: str, state: str | None) -> JSONResponse:
        url = job_url(request, job_id)
        out = JobCreated(id=job_id, url=url, state=state or "queued", duplicate=True)  # type: ignore[arg-type]
        return JSONResponse(out.model_dump(), status_code=200, headers={"Location": url})

    def validate_shot(body: bytes, assets: Path, uploaded: set[str]) -> tuple[Any, int]:
        """Parse and fully resolve a shot (assets included); ApiError 4xx naming the field."""
        try:
            document = json.loads(body)
        except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as exc:
            problem = "nested too deeply" if isinstance(exc, RecursionError) else str(exc)
            raise ApiError(400, f"shot is not valid JSON: {problem}", [{"field": "shot", "problem": problem}]) from None
        if not isinstance(document, dict):
            raise ApiError(422, "the shot must be a JSON object", [{"field": "shot", "problem": "not an object"}])
        try:
            shot = parse_shot(document)
            check_index_sizes(shot)
            if shot.frame_count > settings.max_frames:
                raise ShotError("frame_range", f"{shot.frame_count} frames exceeds the limit of {settings.max_frames}")
            referenced = {normalize_asset_path(path) for path in asset_paths(shot)}
            extra = sorted(uploaded - referenced)
            if extra:
                raise ApiError(400, f"uploaded file {extra[0]!r} is not referenced by the shot",
                               [{"field": "assets", "problem": f"unreferenced file {extra[0]!r}"}])
            vertices = sum(len(p.mesh.vertices or []) for p in shot.cloth)
            if vertices > settings.max_vertices:
                raise ShotError("cloth", f"{vertices} vertices exceeds the limit of {settings.max_vertices}")
            scene = resolve_scene(shot, assets)
        except ShotValidationError as exc:
            errors = [{"field": e.field, "problem": e.problem} for e in exc.errors]
            raise ApiError(422, f"invalid shot: {exc}", errors) from None
        except ShotError as exc:
            raise ApiError(422, f"invalid shot: {exc}", [{"field": exc.field, "problem": exc.problem}]) from None
        if scene.vertex_count > settings.max_vertices:
            raise ApiError(422, f"invalid shot: cloth: {scene.vertex_count} vertices exceeds the limit of "
                           f"{settings.max_vertices}", [{"field": "cloth", "problem": "too many vertices"}])
        return shot, scene.vertex_count

    # -- reading jobs -------------------------------------------------------------------------------
    @app.get("/v1/jobs", response_model=JobList, responses=ERRORS, summary="List your jobs, newest first")
    async def list_jobs(
        request: Request,
        r: Store,
        owner: Owner,
        state: Annotated[JobState | None, Query(description="Only jobs in this state.")] = None,
        offset: Annotated[int, Query(ge=0)] = 0,
        limit: Annotated[int, Query(ge=1, le=500)] = 50,
    ) -> JobList:
        index = jobstore.owner_key(owner)
        if state is None:  # one page straight from the sorted index
            total = await r.zcard(index)
            ids = await r.zrevrange(index, offset, offset + limit - 1)
        else:
            ids = await r.zrevrange(index, 0, -1)
        pipe = r.pipeline(transaction=False)
        for job_id in ids:
            pipe.hgetall(jobstore.job_key(job_id))
        records = [h for h in await pipe.execute() if h and (state is None or h.get("state") == state)]
        if state is not None:
            total = len(records)
            records = records[offset : offset + limit]
        next_offset = offset + limit if offset + limit < total else None
        return JobList(jobs=[to_job(request, h) for h in records], total=total, offset=offset, limit=limit,
                       next_offset=next_offset)

    @app.get("/v1/jobs/{job_id}", response_model=Job, responses=ERRORS, summary="A job's state and progress")
    async def get_job(request: Request, job_id: JobId, r: Store, owner: Owner) -> Job:
        return to_job(request, await load_job(r, owner, job_id))

    @app.get("/v1/jobs/{job_id}/telemetry", response_model=TelemetryPage, responses=ERRORS,
             summary="Per-frame telemetry rows")
    async def get_telemetry(
        job_id: JobId,
        r: Store,
        owner: Owner,
        since: Annotated[
            int | None, Query(ge=-(10**9), le=10**9, description="Only frames after this frame number.")
        ] = None,
    ) -> TelemetryPage:
        h = await load_job(r, owner, job_id)
        start = "-"
        if since is not None:
            start = jobstore.frame_event_id(max(since - int(h["frame_first"]) + 1, 0))
        rows = []
        for _, fields in await r.xrange(jobstore.events_key(job_id), start, "+"):
            if fields.get("type") == "frame":
                data = json.loads(fields["data"])
                rows.append(FrameTelemetry(**{k: data[k] for k in FrameTelemetry.model_fields}))
        return TelemetryPage(job_id=job_id, rows=rows)

    @app.get(
        "/v1/jobs/{job_id}/events", responses={**ERRORS, 200: {"content": {"text/event-stream": {}}}},
        summary="Server-sent events: one 'frame' event per finished frame, then an 'end' event with the final state",
        response_class=StreamingResponse,
    )
    async def job_events(
        request: Request,
        job_id: JobId,
        r: Store,
        owner: Owner,
        last_event_id: Annotated[str | None, Header(description="Resume after this event id.")] = None,
    ) -> StreamingResponse:
        await load_job(r, owner, job_id)
        start = last_event_id or "0-0"
        if not re.match(r"^\d{1,19}-\d{1,19}$", start):
            raise ApiError(400, "Last-Event-ID must be an event id like '12-0'")

        async def stream() -> AsyncIterator[str]:
            last = start
            yield "retry: 1000\n\n"
            while not await request.is_disconnected():
                try:
                    found = await r.xread({jobstore.events_key(job_id): last}, count=200, block=2000)
                except redis.ConnectionError:  # Redis restarting: keep the client, retry
                    yield ": job store unavailable, retrying\n\n"
                    await asyncio.sleep(0.5)
                    continue
                if not found:
                    yield ": keep-alive\n\n"
                    continue
                for _, entries in found:
                    for event_id, fields in entries:
                        last = event_id
                        yield f"id: {event_id}\nevent: {fields['type']}\ndata: {fields['data']}\n\n"
                        if fields["type"] == "end":
                            return

        return StreamingResponse(stream(), media_type="text/event-stream", headers={"Cache-Control": "no-cache"})

    @app.get(
        "/v1/jobs/{job_id}/cache", responses={**ERRORS, 200: {"content": {"application/x-hdf5": {}}}},
        summary="The HDF5 cache (while running: the frames finished so far)", response_class=FileResponse,
    )
    async def get_cache(job_id: JobId, r: Store, owner: Owner) -> FileResponse:
        h = await load_job(r, owner, job_id)
        cache = settings.cache_path(settings.job_dir(job_id))
        if not cache.exists():
            raise ApiError(404, f"job {job_id} has no cached frames yet (state {h['state']})")
        filename = f"{h['name']}-{job_id[:8]}.h5"
        for stale in settings.job_dir(job_id).glob("snapshot-*.h5"):  # left by an interrupted download
            if time.time() - stale.stat().st_mtime > 600:
                stale.unlink(missing_ok=True)
        if h["state"] in jobstore.FINAL_STATES:
            return FileResponse(cache, media_type="application/x-hdf5", filename=filename)
        target = settings.job_dir(job_id) / f"snapshot-{uuid.uuid4().hex}.h5"
        try:
            await anyio.to_thread.run_sync(cachefiles.snapshot, cache, target)
        except Exception as exc:
            target.unlink(missing_ok=True)
            raise ApiError(503, f"cache is being rewritten (resume in progress), retry: {exc}") from None
        return FileResponse(target, media_type="application/x-hdf5", filename=filename,
                            background=BackgroundTask(target.unlink, missing_ok=True))

    @app.get(
        "/v1/jobs/{job_id}/frames/{frame}",
        responses={**ERRORS, 200: {"content": {"application/json": {}, "application/x-npy": {}}}},
        summary="One frame's cloth positions, as JSON or as a NumPy .npy file",
        response_model=FramePositions,
    )
    async def get_frame(
        request: Request,
        job_id: JobId,
        frame: int,
        r: Store,
        owner: Owner,
        format: Annotated[Literal["json", "npy"] | None, Query(description="Default: from Accept.")] = None,
    ) -> Response:
        h = await load_job(r, owner, job_id)
        first, last = int(h["frame_first"]), int(h["frame_last"])
        if not first <= frame <= last:
            raise ApiError(404, f"frame {frame} is outside the shot's frame range [{first}, {last}]")
        cache = settings.cache_path(settings.job_dir(job_id))
        positions = None
        if cache.exists():
            try:
                positions = await anyio.to_thread.run_sync(cachefiles.read_positions, cache, frame - first)
            except Exception as exc:
                raise ApiError(503, f"cache is being rewritten (resume in progress), retry: {exc}") from None
        if positions is None:
            raise ApiError(404, f"frame {frame} is not simulated yet (state {h['state']})")
        wants_npy = format == "npy" or (format is None and "application/x-npy" in request.headers.get("accept", ""))
        if wants_npy:
            import io

            buffer = io.BytesIO()
            np.save(buffer, positions, allow_pickle=False)
            return Response(buffer.getvalue(), media_type="application/x-npy")
        # JSON has no inf/NaN: non-finite coordinates (a diverging run's last frames) become null.
        values = np.where(np.isfinite(positions), positions, np.nan).tolist()
        rows = [tuple(None if v != v else v for v in row) for row in values]
        return JSONResponse(FramePositions(job_id=job_id, frame=frame, positions=rows).model_dump())

    @app.post("/v1/jobs/{job_id}/cancel", response_model=Job, responses=ERRORS, summary="Cancel a job")
    async def cancel_job(request: Request, job_id: JobId, r: Store, owner: Owner) -> Job:
        h = await load_job(r, owner, job_id)
        payload = json.dumps({"state": "cancelled", "frames_done": int(h.get("frames_done", 0)),
                              "error_frame": None, "error_reason": None})
        result = await request.app.state.scripts["cancel"](
            keys=[jobstore.job_key(job_id), jobstore.events_key(job_id)],
            args=[jobstore.now(), payload, jobstore.final_event_id(int(h["frames_total"])), job_id],
        )
        if result in ("succeeded", "failed"):
            raise ApiError(409, f"job {job_id} already {result}; nothing to cancel")
        return to_job(request, await load_job(r, owner, job_id))

    @app.get("/v1/workers", response_model=WorkerList, responses=ERRORS, summary="Workers and their heartbeats")
    async def list_workers(r: Store, owner: Owner) -> WorkerList:
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

    # -- operations ---------------------------------------------------------------------------------
    @app.get("/healthz", summary="Liveness")
    async def healthz() -> dict[str, str]:
        return {"status": "ok"}

    @app.get("/readyz", summary="Readiness: Redis reachable and storage writable", responses={503: {"model": ErrorResponse}})
    async def readyz(r: Store) -> JSONResponse:
        try:
            await r.ping()
        except redis.RedisError as exc:
            return JSONResponse({"detail": f"redis unavailable: {exc}", "errors": []}, status_code=503)
        if not settings.storage.is_dir():
            return JSONResponse({"detail": f"storage {settings.storage} missing", "errors": []}, status_code=503)
        return JSONResponse({"status": "ready"})

    @app.get("/metrics", summary="Prometheus metrics", response_class=Response)
    async def metrics(r: Store) -> Response:
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
        extra = b"".join(
            generate_latest(_Static([m])) for m in (jobs_gauge, worker_gauge, frames)
        )
        return Response(generate_latest(registry) + extra, media_type=CONTENT_TYPE_LATEST)

    generate_openapi = app.openapi

    def openapi_with_shot() -> dict[str, Any]:
        """The generated spec plus the Shot schema that POST /v1/jobs takes as its JSON body."""
        if app.openapi_schema is None:
            spec = generate_openapi()
            shot_schema = Shot.model_json_schema(ref_template="#/components/schemas/{model}")
            spec["components"]["schemas"].update(shot_schema.pop("$defs", {}))
            spec["components"]["schemas"]["Shot"] = shot_schema
        return app.openapi_schema  # type: ignore[return-value]

    app.openapi = openapi_with_shot  # type: ignore[method-assign]
    return app


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
