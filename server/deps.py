"""Dependencies of the routes: settings, the Redis client, the caller's identity (API key
auth); and ``load_job``, the caller's job or 404.

``load_job`` is called in the route bodies, not declared as a dependency: FastAPI solves
dependencies before it validates a route's own parameters, and a request with a bad parameter
must get its 422 whether or not the job exists (auth, a dependency, still comes first)."""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
from typing import Annotated

import redis.asyncio as aioredis
from fastapi import Depends, Request
from fastapi import Path as PathParam
from fastapi.security import HTTPBearer

from server.errors import ApiError
from weft import jobstore
from weft.jobstore import ServiceSettings

JOB_ID = r"^[0-9a-f]{32}$"
JobId = Annotated[str, PathParam(pattern=JOB_ID, description="Job id (32 hex digits).")]


def get_settings(request: Request) -> ServiceSettings:
    return request.app.state.settings  # type: ignore[no-any-return]


def store(request: Request) -> aioredis.Redis:
    return request.app.state.redis  # type: ignore[no-any-return]


Settings = Annotated[ServiceSettings, Depends(get_settings)]
Store = Annotated[aioredis.Redis, Depends(store)]


def owner_of_key(token: str) -> str:
    return hashlib.sha256(token.encode()).hexdigest()[:24]


class Caller(str):
    """The caller's owner id (a hash of its key; 'local' in local mode), used as a string
    everywhere; ``admin`` is true for a key of WEFT_ADMIN_KEYS, which sees and manages every
    key's jobs (its own submissions are still its own)."""

    admin: bool = False

    @classmethod
    def of(cls, owner: str, admin: bool = False) -> Caller:
        caller = cls(owner)
        caller.admin = admin
        return caller


# Declares bearer auth in the OpenAPI document (the 'Authorize' button of /docs); the checks
# are ours, so that each failure gets its own message.
bearer_scheme = HTTPBearer(auto_error=False, description="An API key of this service.")


async def caller(request: Request, settings: Settings, _: Annotated[object, Depends(bearer_scheme)] = None) -> Caller:
    """The owner id of the caller's API key ('local' in local mode)."""
    authorization = request.headers.get("authorization")
    if settings.local:
        host = request.client.host if request.client else ""
        try:
            loopback = ipaddress.ip_address(host).is_loopback
        except ValueError:
            loopback = host in {"testclient", "localhost"}
        if not loopback:
            raise ApiError(403, "local mode only serves loopback clients")
        return Caller.of("local", admin=True)  # one user: it sees everything
    if not authorization:
        raise ApiError(401, "missing API key: send 'Authorization: Bearer <key>'")
    scheme, _, token = authorization.partition(" ")
    if scheme.lower() != "bearer" or not token.strip():
        raise ApiError(401, "malformed Authorization header: expected 'Bearer <key>'")
    token = token.strip()
    admin = any(hmac.compare_digest(token.encode(), key.encode()) for key in settings.admin_keys)
    if not admin and not any(hmac.compare_digest(token.encode(), key.encode()) for key in settings.api_keys):
        raise ApiError(401, "unknown API key")
    return Caller.of(owner_of_key(token), admin)


Owner = Annotated[Caller, Depends(caller)]


async def load_job(r: aioredis.Redis, owner: str, job_id: str) -> dict[str, str]:
    """The job record; 404 when it does not exist or belongs to another key (indistinguishable),
    unless the caller is an admin."""
    h = await r.hgetall(jobstore.job_key(job_id))
    if not h or not (getattr(owner, "admin", False) or hmac.compare_digest(h.get("owner", ""), owner)):
        raise ApiError(404, f"no job {job_id}")
    return h  # type: ignore[no-any-return]

