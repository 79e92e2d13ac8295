"""The weft simulation service: a FastAPI app over Redis (job records, queue, events) and a
storage directory (uploaded assets and HDF5 caches). Run with ``python -m server``.

``create_app(settings)`` builds the app; the routes live in ``server/routes/`` (one router per
resource), their dependencies (settings, Redis, auth, the caller's job) in ``server/deps.py``.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import redis
import redis.asyncio as aioredis
from fastapi import FastAPI
from redis.asyncio.retry import Retry
from redis.backoff import ExponentialBackoff

from api_schemas import Shot
from server.errors import install_error_handlers
from server.routes import dashboard, events, jobs, ops, results
from server import retention
from server.bounded import BoundedValidator
from server.streams import StreamLimits
from server.uploads import remove_orphaned_uploads
from weft import jobstore
from weft.jobstore import ServiceSettings


def redis_pool(url: str, max_connections: int) -> aioredis.BlockingConnectionPool:
    """A pool whose commands retry a lost connection a few times (about 0.5 s in all) before the
    error reaches the caller as a 503: after Redis restarts, every idle connection in the pool is
    stale, and without a retry each of them would fail one request before it reconnects."""
    return aioredis.BlockingConnectionPool.from_url(
        url, decode_responses=True, max_connections=max_connections, timeout=10,
        retry=Retry(ExponentialBackoff(cap=0.25, base=0.02), retries=4),
        retry_on_error=[redis.ConnectionError, redis.TimeoutError])


@asynccontextmanager
async def lifespan(app: FastAPI) -> AsyncIterator[None]:
    settings: ServiceSettings = app.state.settings
    # Two pools: requests wait (up to 10 s) for one of max_redis_connections rather than fail;
    # event streams, which hold a connection while they wait for events, have their own, as
    # large as the number of streams StreamLimits lets open.
    app.state.redis = aioredis.Redis(connection_pool=redis_pool(settings.redis_url, settings.max_redis_connections))
    app.state.stream_redis = aioredis.Redis(connection_pool=redis_pool(settings.redis_url, settings.max_streams))
    app.state.stream_limits = StreamLimits(settings.max_streams_per_key, settings.max_streams)
    app.state.validator = BoundedValidator(settings.validation_processes, settings.validation_memory_bytes,
                                           settings.validation_seconds)
    app.state.scripts = {
        "cancel": app.state.redis.register_script(jobstore.CANCEL_LUA),
        "retry": app.state.redis.register_script(jobstore.RETRY_LUA),
        "list_filter": app.state.redis.register_script(jobstore.LIST_FILTER_LUA),
        "delete": app.state.redis.register_script(jobstore.DELETE_LUA),
    }
    settings.storage.mkdir(parents=True, exist_ok=True)
    try:
        await app.state.redis.xgroup_create(jobstore.QUEUE, jobstore.GROUP, id="0", mkstream=True)
    except redis.RedisError:
        pass  # exists already, or Redis is not up yet (the workers create it too)
    try:  # uploads an earlier API process never finished (crashed mid-request)
        async def has_record(job_id: str) -> bool:
            return bool(await app.state.redis.exists(jobstore.job_key(job_id)))

        await remove_orphaned_uploads(settings.storage / "jobs", has_record, time.time())
    except redis.RedisError:
        pass  # Redis not up: nothing can be told apart from an orphan now; the next start does it
    try:
        await jobstore.index_all_jobs(app.state.redis)
    except redis.RedisError:
        pass  # the next start does it
    stop_housekeeping = asyncio.Event()
    housekeeping = [
        asyncio.create_task(ops.sample_queue_until(stop_housekeeping, app.state.redis, settings)),
        asyncio.create_task(retention.sweep_until(stop_housekeeping, app.state.redis, settings,
                                                  app.state.scripts["delete"])),
    ]
    yield
    stop_housekeeping.set()
    for task in housekeeping:
        try:
            await asyncio.wait_for(task, timeout=15)
        except (TimeoutError, asyncio.CancelledError):
            task.cancel()
    await app.state.redis.aclose()
    await app.state.stream_redis.aclose()
    app.state.validator.close()


def create_app(settings: ServiceSettings | None = None) -> FastAPI:
    """The API app; settings from the WEFT_* environment when not given."""
    app = FastAPI(
        title="weft simulation service",
        version="1",
        description="Submit cloth shots, follow them frame by frame, fetch their HDF5 caches. See docs/service.md.",
        lifespan=lifespan,
    )
    app.state.settings = settings or ServiceSettings.from_env()
    install_error_handlers(app)
    ops.install_request_metrics(app)
    for module in (jobs, results, events, ops, dashboard):
        app.include_router(module.router)
    dashboard.mount_static(app)

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
