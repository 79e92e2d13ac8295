"""A worker's health check (container HEALTHCHECK, monitoring): ``python -m workers.health``.

Healthy when a worker on this host (its record's ``host`` is this host name; in a container,
the container's) has heart-beaten within the claim timeout, the time after which the farm would
take its job away. Exit status 0 healthy, 1 not, with one line saying why.
"""

from __future__ import annotations

import json
import socket
import sys

import redis

from weft import jobstore
from weft.jobstore import ServiceSettings


def check(settings: ServiceSettings, host: str) -> tuple[bool, str]:
    try:
        client = redis.Redis.from_url(settings.redis_url, decode_responses=True, socket_timeout=3)
        records = [json.loads(v) for v in client.hvals(jobstore.WORKERS)]
    except redis.RedisError as exc:
        return False, f"job store unavailable: {exc}"
    ours = [w for w in records if w.get("host") == host]
    if not ours:
        return False, f"no worker of host {host} has registered"
    age = min(jobstore.now() - float(w["heartbeat"]) for w in ours)
    if age > settings.claim_after_seconds:
        return False, f"last heartbeat of host {host} {age:.0f} s ago (limit {settings.claim_after_seconds:.0f} s)"
    busy = [w["name"] for w in ours if w.get("job")]
    return True, f"{len(ours)} worker(s) on {host}, last heartbeat {age:.1f} s ago, {len(busy)} busy"


def main() -> None:
    healthy, why = check(ServiceSettings.from_env(), socket.gethostname())
    print(why)
    sys.exit(0 if healthy else 1)


if __name__ == "__main__":
    main()
