"""Jobs: submit, list, read one, cancel, retry."""

from __future__ import annotations

import contextlib
import json
import re
import shutil
import uuid
from typing import Annotated, Any

import anyio
from fastapi import APIRouter, Depends, Header, Query, Request
from fastapi.responses import JSONResponse, Response
from redis.commands.core import AsyncScript
from redis.exceptions import WatchError

from api_schemas import Shot
from api_schemas.service import (
    Job, JobCreated, JobError, JobList, JobLog, JobState, LogLine, PieceSummary, ShotSummary, TimingSummary,
)
from server.deps import JobId, Owner, Settings, Store, load_job
from server.errors import ERRORS, ApiError
from server.uploads import UploadError, read_limited, receive_multipart
from server.validation import validate_and_hash
from weft import jobstore, scheduler
from weft.jobstore import ServiceSettings
from weft.solver_setup import feature_summary, piece_body_collide, piece_self_collide

IDEMPOTENCY = re.compile(r"^[A-Za-z0-9_.:-]{1,128}$")
TAG = re.compile(r"^[A-Za-z0-9_.:=/-]{1,64}$")
IDEMPOTENCY_TTL = 24 * 3600

router = APIRouter()


def cancel_script(request: Request) -> AsyncScript:
    return request.app.state.scripts["cancel"]  # type: ignore[no-any-return]


def list_filter_script(request: Request) -> AsyncScript:
    return request.app.state.scripts["list_filter"]  # type: ignore[no-any-return]


def delete_script(request: Request) -> AsyncScript:
    return request.app.state.scripts["delete"]  # type: ignore[no-any-return]


def retry_script(request: Request) -> AsyncScript:
    return request.app.state.scripts["retry"]  # type: ignore[no-any-return]


def job_url(request: Request, job_id: str) -> str:
    return str(request.url_for("get_job", job_id=job_id))


def to_job(request: Request, h: dict[str, str], admin: bool = False) -> Job:
    timing = None
    sim_frames = int(h.get("sim_frames", 0))
    if sim_frames:
        timing = TimingSummary(
            frames=sim_frames,
            **{f"{k}_seconds": float(h.get(f"sum_{k}", 0.0)) / sim_frames for k in jobstore.TIMING_KEYS},
        )
    error = None
    if h.get("error_reason"):
        error = JobError(frame=int(h["error_frame"]) if h.get("error_frame") else None, reason=h["error_reason"],
                         kind=h.get("failure_kind") if h["state"] == "failed" else None)  # type: ignore[arg-type]
    return Job(
        id=h["id"], url=job_url(request, h["id"]), name=h["name"], state=h["state"],  # type: ignore[arg-type]
        priority=int(h.get("priority", scheduler.DEFAULT_PRIORITY)), pool=h.get("pool", scheduler.DEFAULT_POOL),
        tags=json.loads(h.get("tags", "[]")), owner=h.get("owner") if admin else None,
        frames_done=int(h.get("frames_done", 0)), frames_total=int(h["frames_total"]),
        frame_range=(int(h["frame_first"]), int(h["frame_last"])), vertices=int(h["vertices"]),
        worker=h.get("worker") or None, attempts=int(h.get("attempts", 0)),
        resumed_from=int(h["resumed_from"]) if h.get("resumed_from") else None,
        cancel_requested=h.get("cancel_requested") == "1", created=float(h["created"]),
        started=float(h["started"]) if h.get("started") else None,
        finished=float(h["finished"]) if h.get("finished") else None, timing=timing, error=error,
    )


def duplicate_response(request: Request, job_id: str, state: str | None) -> JSONResponse:
    url = job_url(request, job_id)
    out = JobCreated(id=job_id, url=url, state=state or "queued", duplicate=True)  # type: ignore[arg-type]
    return JSONResponse(out.model_dump(), status_code=200, headers={"Location": url})


# Deletes an Idempotency-Key's record only if it still names this job (KEYS[1], ARGV[1]).
RELEASE_IDEMPOTENCY_LUA = """
if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('DEL', KEYS[1]) end
return 0
"""


def active_limit_error(active: int, settings: ServiceSettings) -> ApiError:
    return ApiError(429, f"this API key has {active} jobs queued or running, the limit is "
                         f"{settings.max_active_jobs}: wait for some to finish or cancel some")


async def check_active_jobs(r: Any, owner: str, settings: ServiceSettings, idempotency_key: str | None) -> None:
    """A key's share of the farm, checked early (before the upload is read; a resubmission under
    a known Idempotency-Key is not a new job): 429 once it has max_active_jobs queued or
    running. The exact check is queue_within_limit's, when the job is queued."""
    if idempotency_key and await r.exists(jobstore.idempotency_key(owner, idempotency_key)):
        return
    active = await r.scard(jobstore.active_key(owner))
    if active >= settings.max_active_jobs:
        raise active_limit_error(active, settings)


async def queue_within_limit(r: Any, owner: str, settings: ServiceSettings, record: dict[str, Any],
                             tags: list[str]) -> None:
    """Queue the job in one transaction that holds only while the owner's active set is
    unchanged since it was counted (WATCH): submissions racing at the limit cannot both pass,
    however many API processes take them. 429 when the key is at its limit."""
    active_key = jobstore.active_key(owner)
    async with r.pipeline(transaction=True) as pipe:
        while True:
            try:
                await pipe.watch(active_key)
                active = await pipe.scard(active_key)
                if active >= settings.max_active_jobs:
                    raise active_limit_error(active, settings)
                pipe.multi()
                jobstore.queue_new_job(pipe, record, tags)
                await pipe.execute()
                return
            except WatchError:
                continue  # the set changed (another submission, a job ending): count again


SUBMIT_BODY = {
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


@router.post(
    "/v1/jobs", status_code=201, response_model=JobCreated, responses=ERRORS, openapi_extra=SUBMIT_BODY,
    summary="Submit a shot",
)
async def submit_job(
    request: Request,
    r: Store,
    owner: Owner,
    settings: Settings,
    idempotency_key: Annotated[str | None, Header(description="Makes a resubmission return the first job.")] = None,
    priority: Annotated[int, Query(ge=0, le=100, description="0-100, higher runs first.")] = scheduler.DEFAULT_PRIORITY,
    pool: Annotated[str, Query(pattern=scheduler.POOL_NAME.pattern,
                               description="Worker pool to run it (workers serve the pools of WEFT_POOLS).")]
    = scheduler.DEFAULT_POOL,
    tag: Annotated[list[str] | None, Query(max_length=16, description="Tags to find it by (repeat for several): "
                                                                      "1-64 of letters, digits and _.:=/-")] = None,
) -> Response:
    tags = sorted(set(tag or []))
    bad = next((t for t in tags if not TAG.match(t)), None)
    if bad is not None:
        raise ApiError(422, f"tag {bad!r}: 1-64 characters of letters, digits and _.:=/-",
                       [{"field": "tag", "problem": f"{bad!r} is not a tag"}])
    if idempotency_key is not None and not IDEMPOTENCY.match(idempotency_key):
        raise ApiError(400, "Idempotency-Key must be 1-128 characters of letters, digits, '_', '-', '.', ':'")
    content_type = request.headers.get("content-type", "")
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_upload_bytes:
        raise ApiError(413, f"upload of {declared} bytes exceeds the limit of {settings.max_upload_bytes} bytes")
    await check_active_jobs(r, owner, settings, idempotency_key)
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
        shot, vertices, request_hash = await request.app.state.validator.run(
            validate_and_hash, body, assets, uploaded, settings)
        (job_dir / "shot.json").write_text(shot.model_dump_json())
        if idempotency_key:
            idem = jobstore.idempotency_key(owner, idempotency_key)
            if not await r.set(idem, job_id, nx=True, ex=IDEMPOTENCY_TTL):
                existing = await r.get(idem)
                shutil.rmtree(job_dir, ignore_errors=True)
                first_hash = await r.hget(jobstore.job_key(existing), "request_hash")
                if first_hash is not None and first_hash != request_hash:
                    raise ApiError(409, f"Idempotency-Key {idempotency_key!r} was used for a different request "
                                        f"(job {existing}): use a new key for a new shot")
                return duplicate_response(request, existing, await r.hget(jobstore.job_key(existing), "state"))
        record: dict[str, Any] = {
            "id": job_id, "owner": owner, "name": shot.name, "state": "queued", "frames_done": 0,
            "frames_total": shot.frame_count, "frame_first": shot.frame_range[0],
            "frame_last": shot.frame_range[1], "vertices": vertices, "created": jobstore.now(), "attempts": 0,
            "request_hash": request_hash, "priority": priority, "pool": pool, "tags": json.dumps(tags),
        }
        await queue_within_limit(r, owner, settings, record, tags)
    except UploadError as exc:
        shutil.rmtree(job_dir, ignore_errors=True)
        raise ApiError(exc.status, exc.problem, [{"field": exc.field, "problem": exc.problem}]) from None
    except BaseException:
        shutil.rmtree(job_dir, ignore_errors=True)
        if idempotency_key:  # the key must not keep pointing at a job that was never queued
            with contextlib.suppress(Exception):  # best effort: never hide the error itself
                await r.eval(RELEASE_IDEMPOTENCY_LUA, 1, jobstore.idempotency_key(owner, idempotency_key), job_id)
        raise
    url = job_url(request, job_id)
    body_out = JobCreated(id=job_id, url=url, state="queued")
    return JSONResponse(body_out.model_dump(), status_code=201, headers={"Location": url})


@router.get("/v1/jobs", response_model=JobList, responses=ERRORS,
            summary="List your jobs (an admin key: every key's), newest first")
async def list_jobs(
    request: Request,
    r: Store,
    owner: Owner,
    list_filter: Annotated[AsyncScript, Depends(list_filter_script)],
    state: Annotated[JobState | None, Query(description="Only jobs in this state.")] = None,
    name: Annotated[str | None, Query(max_length=200, description="Only jobs whose name contains this text "
                                                                  "(case-insensitive).")] = None,
    tag: Annotated[str | None, Query(max_length=64, description="Only jobs with this tag.")] = None,
    created_after: Annotated[float | None, Query(ge=0, le=1e10, description="Submitted at or after (Unix time).")]
    = None,
    created_before: Annotated[float | None, Query(ge=0, le=1e10, description="Submitted at or before (Unix time).")]
    = None,
    offset: Annotated[int, Query(ge=0, le=1_000_000_000)] = 0,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
) -> JobList:
    """Pages come from the sorted index of submission times (the key's own, or every job's for
    an admin key). Filters run inside Redis (LIST_FILTER_LUA: time range from the index, state
    and tag from their sets, name from the name hash, never the job records), which answers the
    count and one page of ids; only the page's records are read."""
    admin = owner.admin
    index = jobstore.ALL_JOBS if admin else jobstore.owner_key(owner)
    if state is None and not name and not tag and created_after is None and created_before is None:
        total = await r.zcard(index)
        ids = await r.zrevrange(index, offset, offset + limit - 1)
    else:
        total, *ids = await list_filter(
            keys=[index, jobstore.ALL_NAMES if admin else jobstore.names_key(owner),
                  jobstore.state_key(state or "queued"), jobstore.tag_key(None if admin else owner, tag or "-")],
            args=[(name or "").lower(), "1" if state else "0", offset, limit, "1" if tag else "0",
                  "-inf" if created_after is None else repr(created_after),
                  "+inf" if created_before is None else repr(created_before)])
    pipe = r.pipeline(transaction=False)
    for job_id in ids:
        pipe.hgetall(jobstore.job_key(job_id))
    records = [h for h in await pipe.execute() if h]
    next_offset = offset + limit if offset + limit < total else None
    return JobList(jobs=[to_job(request, h, admin) for h in records], total=total, offset=offset, limit=limit,
                   next_offset=next_offset)


@router.delete("/v1/jobs/{job_id}", status_code=204, responses=ERRORS,
               summary="Delete a finished job: its record, events, log, uploaded assets and cache")
async def delete_job(job_id: JobId, r: Store, owner: Owner, settings: Settings,
                     delete: Annotated[AsyncScript, Depends(delete_script)]) -> Response:
    await load_job(r, owner, job_id)
    result = await delete(keys=[jobstore.job_key(job_id)], args=[job_id])
    if result not in jobstore.FINAL_STATES:
        raise ApiError(409, f"job {job_id} is {result}: cancel it first; only finished jobs are deleted")
    await anyio.to_thread.run_sync(lambda: shutil.rmtree(settings.job_dir(job_id), ignore_errors=True))
    return Response(status_code=204)


@router.get("/v1/jobs/{job_id}/log", response_model=JobLog, responses=ERRORS,
            summary="The log lines workers wrote while running the job")
async def get_job_log(
    job_id: JobId, r: Store, owner: Owner,
    since: Annotated[str | None, Query(pattern=r"^\d{1,19}-\d{1,19}$", description="Only lines after this id.")] = None,
    limit: Annotated[int, Query(ge=1, le=10_000)] = 1000,
) -> JobLog:
    await load_job(r, owner, job_id)
    entries = await r.xrange(jobstore.log_key(job_id), f"({since}" if since else "-", "+", count=limit)
    return JobLog(job_id=job_id, lines=[
        LogLine(id=entry_id, time=float(f["time"]), level=f["level"], worker=f["worker"], message=f["message"])
        for entry_id, f in entries])


@router.get("/v1/jobs/{job_id}/shot", response_model=ShotSummary, responses=ERRORS,
            summary="What a job's shot asks for: frames, pieces, bodies and the physics it turns on")
async def get_shot_summary(job_id: JobId, r: Store, owner: Owner, settings: Settings) -> ShotSummary:
    h = await load_job(r, owner, job_id)
    path = settings.job_dir(job_id) / "shot.json"
    try:
        shot = await anyio.to_thread.run_sync(lambda: Shot.model_validate_json(path.read_bytes()))
    except (OSError, ValueError) as exc:
        raise ApiError(404, f"job {job_id} has no readable shot: {exc}") from None
    collide, self_collide = piece_body_collide(shot), piece_self_collide(shot)
    return ShotSummary(
        job_id=job_id, name=shot.name, fps=shot.fps, substeps=shot.substeps, frame_range=shot.frame_range,
        vertices=int(h["vertices"]),
        pieces=[PieceSummary(name=p.name, collide=c, self_collide=sc)
                for p, c, sc in zip(shot.cloth, collide, self_collide, strict=True)],
        bodies=[b.name for b in shot.bodies if b.collide], features=feature_summary(shot),
    )


@router.get("/v1/jobs/{job_id}", response_model=Job, responses=ERRORS, summary="A job's state and progress")
async def get_job(request: Request, job_id: JobId, r: Store, owner: Owner) -> Job:
    return to_job(request, await load_job(r, owner, job_id), owner.admin)


@router.post("/v1/jobs/{job_id}/cancel", response_model=Job, responses=ERRORS, summary="Cancel a job")
async def cancel_job(
    request: Request, job_id: JobId, r: Store, owner: Owner, cancel: Annotated[AsyncScript, Depends(cancel_script)]
) -> Job:
    h = await load_job(r, owner, job_id)
    if h.get("state") == "cancelled":
        raise ApiError(409, f"job {job_id} already cancelled; nothing to cancel")
    payload = json.dumps({"state": "cancelled", "frames_done": int(h.get("frames_done", 0)),
                          "error_frame": None, "error_reason": None})
    result = await cancel(
        keys=[jobstore.job_key(job_id), jobstore.events_key(job_id)],
        args=[jobstore.now(), payload, jobstore.final_event_id(int(h["frames_total"])), job_id],
    )
    if result in ("succeeded", "failed"):
        raise ApiError(409, f"job {job_id} already {result}; nothing to cancel")
    return to_job(request, await load_job(r, owner, job_id))


@router.post(
    "/v1/jobs/{job_id}/retry", response_model=Job, responses=ERRORS,
    summary="Queue a failed or cancelled job again; it continues from its last finished frame",
)
async def retry_job(
    request: Request, job_id: JobId, r: Store, owner: Owner, settings: Settings,
    retry: Annotated[AsyncScript, Depends(retry_script)],
) -> Job:
    """The job's cache keeps every finished frame and the exact solver state of the last one, so
    the retried run resumes there (bitwise as if never stopped). Its event stream keeps the
    frames published so far, then a 'retried' event, the frames still to come and one final
    'end' event. A solver failure is deterministic: retrying one fails again at the same frame
    unless the cause was outside the shot (a lost worker, a full disk)."""
    h = await load_job(r, owner, job_id)
    payload = json.dumps({"frames_done": int(h.get("frames_done", 0)), "previous_state": h.get("state"),
                          "previous_error": h.get("error_reason") or None})
    # A retried job counts towards the key's share: the script checks it where it queues.
    result = await retry(
        keys=[jobstore.job_key(job_id), jobstore.events_key(job_id)],
        args=[jobstore.now(), job_id, payload, settings.max_active_jobs],
    )
    if result == "limit":
        raise active_limit_error(await r.scard(jobstore.active_key(owner)), settings)
    if result != "queued":
        raise ApiError(409, f"job {job_id} is {result}; only failed or cancelled jobs can be retried")
    return to_job(request, await load_job(r, owner, job_id))
