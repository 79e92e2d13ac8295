"""Retention of finished jobs: a policy by age (WEFT_RETENTION_DAYS) and by the size of the job
folders (WEFT_RETENTION_BYTES). The API processes sweep once a minute; whoever holds the lock
for the minute does it. A deleted job loses its record, events, log, indexes (DELETE_LUA),
uploaded assets and cache. Queued and running jobs are never touched."""

from __future__ import annotations

import asyncio
import shutil
from pathlib import Path
from typing import Any

import anyio
import redis

from weft import jobstore
from weft.jobstore import ServiceSettings

SWEEP_LOCK = f"{jobstore.PREFIX}:retention:lock"
SWEEP_SECONDS = 60.0


def folder_bytes(folder: Path) -> int:
    total = 0
    for path in folder.rglob("*"):
        try:
            if path.is_file():
                total += path.stat().st_size
        except OSError:
            pass  # removed meanwhile
    return total


async def sweep(r: Any, settings: ServiceSettings, delete_script: Any, now: float) -> list[str]:
    """Delete what the policy says must go; the ids deleted, oldest finished first."""
    doomed: list[str] = []
    if settings.retention_days > 0:
        doomed += await r.zrangebyscore(jobstore.FINISHED, "-inf", now - settings.retention_days * 86400)
    if settings.retention_bytes > 0:
        jobs_dir = settings.storage / "jobs"
        sizes = await anyio.to_thread.run_sync(
            lambda: {p.name: folder_bytes(p) for p in jobs_dir.iterdir() if p.is_dir()} if jobs_dir.is_dir() else {})
        total = sum(size for job_id, size in sizes.items() if job_id not in doomed)
        for job_id in await r.zrange(jobstore.FINISHED, 0, -1):  # oldest finished first
            if total <= settings.retention_bytes:
                break
            if job_id not in doomed:
                doomed.append(job_id)
                total -= sizes.get(job_id, 0)
    deleted = []
    for job_id in doomed:
        if await delete_script(keys=[jobstore.job_key(job_id)], args=[job_id]) in jobstore.FINAL_STATES:
            await anyio.to_thread.run_sync(lambda j=job_id: shutil.rmtree(settings.job_dir(j), ignore_errors=True))
            deleted.append(job_id)
    return deleted


async def sweep_until(stop: asyncio.Event, r: Any, settings: ServiceSettings, delete_script: Any,
                      period: float = SWEEP_SECONDS) -> None:
    """Sweep every period until stop is set, when a retention policy is set."""
    if settings.retention_days <= 0 and settings.retention_bytes <= 0:
        return
    while not stop.is_set():
        try:
            if await r.set(SWEEP_LOCK, "1", nx=True, px=max(int(period * 900), 1)):
                await sweep(r, settings, delete_script, jobstore.now())
        except (redis.RedisError, OSError):
            pass  # the next period tries again
        try:
            await asyncio.wait_for(stop.wait(), timeout=period)
        except TimeoutError:
            pass
