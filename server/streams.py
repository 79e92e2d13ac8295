"""Event streams' share of the service. Each open stream holds a connection of its API process's
streams pool while it waits for events, so:

- per API key, across every API process: at most ``per_key`` open streams, counted in Redis
  (a sorted set of stream tokens per key, each with an expiry its stream pushes forward every
  time it wakes, at least every few seconds, so a stream whose API process died stops counting
  within ``STREAM_LEASE_SECONDS``);
- per API process: at most ``total`` open streams (its pool's size), counted in the process.

A key over its share gets 429 instead of starving the others (or the process's other requests,
which use another pool)."""

from __future__ import annotations

import threading
import time
import uuid
from collections.abc import Awaitable, Callable
from typing import Any

from weft import jobstore

# A stream wakes at least every 2 s (its XREAD blocks 2 s); its lease is pushed forward then.
STREAM_LEASE_SECONDS = 15.0

# KEYS[1] the key's stream set. ARGV: now, lease end, token, per-key limit. Drops expired
# leases, then takes one if the key has fewer than the limit: -1, else the number open.
ACQUIRE_LUA = """
redis.call('ZREMRANGEBYSCORE', KEYS[1], '-inf', ARGV[1])
local open = redis.call('ZCARD', KEYS[1])
if open >= tonumber(ARGV[4]) then return open end
redis.call('ZADD', KEYS[1], ARGV[2], ARGV[3])
redis.call('PEXPIRE', KEYS[1], math.ceil((tonumber(ARGV[2]) - tonumber(ARGV[1])) * 2000))
return -1
"""


def streams_key(owner: str) -> str:
    return f"{jobstore.PREFIX}:owner:{owner}:streams"


class StreamLease:
    """One open stream's place in its key's share (Redis); renew() while it runs, release() once."""

    def __init__(self, r: Any, owner: str, token: str) -> None:
        self.r, self.key, self.token = r, streams_key(owner), token

    async def renew(self) -> None:
        await self.r.zadd(self.key, {self.token: time.time() + STREAM_LEASE_SECONDS}, xx=True)

    async def release(self) -> None:
        await self.r.zrem(self.key, self.token)


async def lease_stream(r: Any, owner: str, per_key: int) -> tuple[StreamLease | None, int]:
    """A lease on one of the key's `per_key` streams, or None and how many it has open."""
    token = uuid.uuid4().hex
    now = time.time()
    open_count = int(await r.eval(ACQUIRE_LUA, 1, streams_key(owner), now, now + STREAM_LEASE_SECONDS, token, per_key))
    if open_count >= 0:
        return None, open_count
    return StreamLease(r, owner, token), per_key


class StreamLimits:
    """The process's share: at most `total` streams open in this API process."""

    def __init__(self, per_key: int, total: int) -> None:
        self.per_key = per_key
        self.total = total
        self._open = 0
        self._lock = threading.Lock()

    def open_count(self) -> int:
        with self._lock:
            return self._open

    async def acquire(self, r: Any, owner: str) -> tuple[Callable[[], Awaitable[None]] | None, StreamLease | None, str]:
        """(release, lease, "") for one more stream of `owner`, or (None, None, why not). release
        is idempotent and gives back both the process's slot and the key's lease."""
        with self._lock:
            if self._open >= self.total:
                return None, None, f"the server has {self.total} event streams open, its limit: retry later"
            self._open += 1
        try:
            lease, open_count = await lease_stream(r, owner, self.per_key)
        except BaseException:
            self._give_back()
            raise
        if lease is None:
            self._give_back()
            return None, None, (f"this API key has {open_count} event streams open, the limit is "
                                f"{self.per_key}: close one, or poll GET /v1/jobs/{{id}}")
        released = False

        async def release() -> None:
            nonlocal released
            if released:
                return
            released = True
            self._give_back()
            try:
                await lease.release()
            except Exception:  # noqa: BLE001 - Redis away: the lease expires by itself
                pass

        return release, lease, ""

    def _give_back(self) -> None:
        with self._lock:
            self._open -= 1
