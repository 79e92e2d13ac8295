"""A job's results: per-frame telemetry, the HDF5 cache, one frame's positions."""

from __future__ import annotations

import io
import json
import time
import uuid
from typing import Annotated, Literal

import anyio
import numpy as np
from fastapi import APIRouter, Query, Request
from fastapi.responses import FileResponse, JSONResponse, Response
from starlette.background import BackgroundTask

from api_schemas import FrameTelemetryJson
from api_schemas.service import FramePositions, TelemetryPage
from server import cachefiles
from server.deps import JobId, Owner, Settings, Store, load_job
from server.errors import ERRORS, ApiError
from weft import jobstore

router = APIRouter()

REWRITING = "cache is being rewritten (resume in progress), retry"


@router.get("/v1/jobs/{job_id}/telemetry", response_model=TelemetryPage, responses=ERRORS,
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
            rows.append(FrameTelemetryJson(**{k: data[k] for k in FrameTelemetryJson.model_fields}))
    return TelemetryPage(job_id=job_id, rows=rows)


@router.get(
    "/v1/jobs/{job_id}/cache", responses={**ERRORS, 200: {"content": {"application/x-hdf5": {}}}},
    summary="The HDF5 cache (while running: the frames finished so far)", response_class=FileResponse,
)
async def get_cache(job_id: JobId, r: Store, owner: Owner, settings: Settings) -> FileResponse:
    h = await load_job(r, owner, job_id)
    job_dir = settings.job_dir(job_id)
    cache = settings.cache_path(job_dir)
    if not cache.exists():
        raise ApiError(404, f"job {job_id} has no cached frames yet (state {h['state']})")
    filename = f"{h['name']}-{job_id[:8]}.h5"
    for stale in job_dir.glob("snapshot-*.h5"):  # left by an interrupted download
        if time.time() - stale.stat().st_mtime > 600:
            stale.unlink(missing_ok=True)
    if h["state"] in jobstore.FINAL_STATES:
        return FileResponse(cache, media_type="application/x-hdf5", filename=filename)
    target = job_dir / f"snapshot-{uuid.uuid4().hex}.h5"
    try:
        await anyio.to_thread.run_sync(cachefiles.snapshot, cache, target)
    except Exception as exc:
        target.unlink(missing_ok=True)
        raise ApiError(503, f"{REWRITING}: {exc}") from None
    return FileResponse(target, media_type="application/x-hdf5", filename=filename,
                        background=BackgroundTask(target.unlink, missing_ok=True))


@router.get(
    "/v1/jobs/{job_id}/usd", responses={**ERRORS, 200: {"content": {"model/vnd.usd": {}}}},
    summary="The cloth as USD, for a finished shot that asked for it (outputs.usd)", response_class=FileResponse,
)
async def get_usd(job_id: JobId, r: Store, owner: Owner, settings: Settings) -> FileResponse:
    h = await load_job(r, owner, job_id)
    path = settings.usd_path(settings.job_dir(job_id))
    if not path.exists():
        raise ApiError(404, f"job {job_id} has no USD file (state {h['state']}; it is written when a shot with "
                            "outputs.usd succeeds; or run `weft export CACHE --usd OUT.usd` on its cache)")
    return FileResponse(path, media_type="model/vnd.usd", filename=f"{h['name']}-{job_id[:8]}.usd")


@router.get(
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
    settings: Settings,
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
            raise ApiError(503, f"{REWRITING}: {exc}") from None
    if positions is None:
        raise ApiError(404, f"frame {frame} is not simulated yet (state {h['state']})")
    wants_npy = format == "npy" or (format is None and "application/x-npy" in request.headers.get("accept", ""))
    if wants_npy:
        buffer = io.BytesIO()
        np.save(buffer, positions, allow_pickle=False)
        return Response(buffer.getvalue(), media_type="application/x-npy")
    # JSON has no inf/NaN: non-finite coordinates (a diverging run's last frames) become null.
    values = np.where(np.isfinite(positions), positions, np.nan).tolist()
    rows = [tuple(None if v != v else v for v in row) for row in values]
    return JSONResponse(FramePositions(job_id=job_id, frame=frame, positions=rows).model_dump())
