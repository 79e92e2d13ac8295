"""A job's server-sent event stream."""

from __future__ import annotations

import asyncio
import re
from collections.abc import AsyncIterator
from typing import Annotated

import redis
from fastapi import APIRouter, Header, Request
from fastapi.responses import StreamingResponse
from starlette.background import BackgroundTask

from server.deps import JobId, Owner, Store, load_job
from server.errors import ERRORS, ApiError
from server.streams import StreamLimits
from weft import jobstore

router = APIRouter()

EVENT_ID = re.compile(r"^\d{1,19}-\d{1,19}$")
EVENT_BATCH_SECONDS = 0.1


@router.get(
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
    if not EVENT_ID.match(start):
        raise ApiError(400, "Last-Event-ID must be an event id like '12-0'")
    limits: StreamLimits = request.app.state.stream_limits
    release, lease, why_not = await limits.acquire(r, owner)
    if release is None or lease is None:
        raise ApiError(429, why_not)
    r = request.app.state.stream_redis  # the streams' own pool: they cannot starve other requests

    async def stream() -> AsyncIterator[str]:
        last = start
        yield "retry: 1000\n\n"
        while not await request.is_disconnected():
            try:
                await lease.renew()  # the key's share counts this stream while it runs
                found = await r.xread({jobstore.events_key(job_id): last}, count=1000, block=2000)
            except redis.ConnectionError:  # Redis restarting: keep the client, retry
                yield ": job store unavailable, retrying\n\n"
                await asyncio.sleep(0.5)
                continue
            if not found:
                yield ": keep-alive\n\n"
                continue
            chunk, ended = [], False
            for _, entries in found:
                for event_id, fields in entries:
                    last = event_id
                    chunk.append(f"id: {event_id}\nevent: {fields['type']}\ndata: {fields['data']}\n\n")
                    ended = fields["type"] == "end"
                    if ended:
                        break
            yield "".join(chunk)  # one write per batch of events
            if ended:
                return
            # Events that come faster than this go out together: a shot of short frames costs
            # the API one write per period, not one per frame (a frame is shown at most this late).
            await asyncio.sleep(EVENT_BATCH_SECONDS)

    # The slot is given back once the response ends, whether the events ran out, the client
    # left, or it left before the first one (then the generator never ran its own cleanup).
    return StreamingResponse(stream(), media_type="text/event-stream", headers={"Cache-Control": "no-cache"},
                             background=BackgroundTask(release))
