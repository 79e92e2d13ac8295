"""The service's job store: Redis layout, atomic job transitions and settings, shared by the API
server (``server``) and the workers (``workers``). Imports nothing from either.

Keys (all prefixed ``weft:``):

- ``weft:ready:{pool}:{owner}``, ``weft:ready:{pool}``, ``weft:doorbell:{pool}``: queued jobs
  waiting for a worker, the keys with jobs waiting in a pool, and the pool's wake-up list
  (``weft.scheduler``, which picks the next job: priority, pools, fair share, quotas).
- ``weft:queue``: the job stream. A worker gets an entry for the job the scheduler gave it,
  delivered to it at once (consumer group ``workers``). A worker acknowledges (XACK) an entry
  only once its job reached a final state or was handed back, so the entry of a worker that
  died stays pending and another worker takes it over with XAUTOCLAIM once it has been idle
  longer than the claim timeout. Live workers keep their entry fresh by re-claiming it (XCLAIM
  ... JUSTID) from their heartbeat thread.
- ``weft:job:{id}``: hash with the job record.
- ``weft:job:{id}:events``: stream of the job's events. Frame events use the explicit entry id
  ``{index + 1}-0`` (index: 0-based cache row), so publishing a frame twice is refused by Redis
  itself and every frame appears exactly once, in order. The final event uses
  ``{frames_total + 1}-0``.
- ``weft:job:{id}:log``: stream of the worker's log lines for the job.
- ``weft:owner:{owner}:jobs`` and ``weft:jobs``: sorted sets of a key's (every key's) job ids by
  creation time; ``weft:owner:{owner}:names``, ``weft:names``: id -> name;
  ``weft:owner:{owner}:tag:{tag}``, ``weft:tag:{tag}``: ids with a tag.
- ``weft:owner:{owner}:active``: set of the key's queued and running job ids (its share of the
  farm, bounded by ``max_active_jobs``).
- ``weft:state:{state}``: set of the job ids in each state; ``weft:queued_since`` (queued jobs
  by queue time) and ``weft:finished`` (final jobs by finish time, for retention).
- ``weft:idem:{owner}:{key}``: idempotency key -> job id (SET NX, with a TTL).
- ``weft:workers``: hash worker name -> JSON heartbeat record.
- ``weft:stats``, ``weft:failures``, ``weft:hist:*``: counters and histograms (``weft.jobmetrics``).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from weft import scheduler
from weft.jobmetrics import OBSERVE_LUA
from weft.scheduler import READY_LUA

PREFIX = "weft"
QUEUE = f"{PREFIX}:queue"
GROUP = "workers"
WORKERS = f"{PREFIX}:workers"
STATS = f"{PREFIX}:stats"
# Queued jobs by the time they joined the queue (submission, retry or hand-back): the longest
# wait without reading every queued job. Kept beside the state sets by the same transitions.
QUEUED_SINCE = f"{PREFIX}:queued_since"
# Every job of every key by submission time, and their names (what an admin key lists); jobs in
# a final state by the time they reached it (retention).
ALL_JOBS = f"{PREFIX}:jobs"
ALL_NAMES = f"{PREFIX}:names"
FINISHED = f"{PREFIX}:finished"
STATES = ("queued", "running", "succeeded", "failed", "cancelled")
FINAL_STATES = ("succeeded", "failed", "cancelled")
TIMING_KEYS = ("build", "solve", "collision", "gia", "total")


def job_key(job_id: str) -> str:
    return f"{PREFIX}:job:{job_id}"


def events_key(job_id: str) -> str:
    return f"{PREFIX}:job:{job_id}:events"


def owner_key(owner: str) -> str:
    return f"{PREFIX}:owner:{owner}:jobs"


def names_key(owner: str) -> str:
    """A key's job names (job id -> name): the job list's name filter reads this one hash."""
    return f"{PREFIX}:owner:{owner}:names"


def tag_key(owner: str | None, tag: str) -> str:
    """The jobs of a key (owner None: of every key) carrying a tag."""
    return f"{PREFIX}:owner:{owner}:tag:{tag}" if owner is not None else f"{PREFIX}:tag:{tag}"


def log_key(job_id: str) -> str:
    """Stream of the log lines workers wrote while running the job."""
    return f"{PREFIX}:job:{job_id}:log"


def active_key(owner: str) -> str:
    return f"{PREFIX}:owner:{owner}:active"


def state_key(state: str) -> str:
    return f"{PREFIX}:state:{state}"


def idempotency_key(owner: str, key: str) -> str:
    return f"{PREFIX}:idem:{owner}:{key}"


def final_event_id(frames_total: int) -> str:
    return f"{frames_total + 1}-0"


def frame_event_id(index: int) -> str:
    return f"{index + 1}-0"


# -- Lua scripts: each is one atomic transition ---------------------------------------------
# KEYS[1] job hash, KEYS[2] events stream. Set keys are built inside the scripts (single
# Redis instance; weft does not use Redis Cluster).

# ARGV: worker, now, job id, how the entry was taken ('claimed' from a dead worker, or 'new').
# Returns the job's state after the call ('running' if the worker may run it). Only a claimed
# entry may take over a running job; a new entry of a running job is a duplicate (a retry
# queued while the job's earlier entry was still unread) and returns 'duplicate'.
START_LUA = OBSERVE_LUA + """
local state = redis.call('HGET', KEYS[1], 'state')
if not state then return 'missing' end
if state ~= 'queued' and state ~= 'running' then return state end
if state == 'running' and ARGV[4] ~= 'claimed' then return 'duplicate' end
redis.call('SMOVE', 'weft:state:' .. state, 'weft:state:running', ARGV[3])
redis.call('ZREM', 'weft:queued_since', ARGV[3])
local fields = {'state', 'running', 'worker', ARGV[1], 'heartbeat', ARGV[2]}
if redis.call('HEXISTS', KEYS[1], 'started') == 0 then
  table.insert(fields, 'started'); table.insert(fields, ARGV[2])
  observe('job_wait_seconds', tonumber(ARGV[2]) - tonumber(redis.call('HGET', KEYS[1], 'created') or ARGV[2]))
end
redis.call('HSET', KEYS[1], unpack(fields))
redis.call('HINCRBY', KEYS[1], 'attempts', 1)
return 'running'
"""

# KEYS[1] job hash, KEYS[2] queue stream. ARGV: worker, now, stream entry id, group.
# Keeps the worker's claim on its entry fresh, only while the job is still its own (a worker
# that was presumed dead and replaced must not take the entry back).
HEARTBEAT_LUA = """
if redis.call('HGET', KEYS[1], 'worker') ~= ARGV[1] then return 0 end
redis.call('HSET', KEYS[1], 'heartbeat', ARGV[2])
redis.call('XCLAIM', KEYS[2], ARGV[4], ARGV[1], 0, ARGV[3], 'JUSTID')
return 1
"""

# ARGV: new final state, now, payload JSON, final event id, job id, worker, then field/value
# pairs. Returns 1 if this call finished the job, 0 if it was already final, -1 if the job has
# been taken over by another worker.
FINISH_LUA = OBSERVE_LUA + """
local state = redis.call('HGET', KEYS[1], 'state')
if not state then return 0 end
if state == 'succeeded' or state == 'failed' or state == 'cancelled' then return 0 end
if redis.call('HGET', KEYS[1], 'worker') ~= ARGV[6] then return -1 end
redis.call('SMOVE', 'weft:state:' .. state, 'weft:state:' .. ARGV[1], ARGV[5])
redis.call('ZREM', 'weft:queued_since', ARGV[5])
redis.call('SREM', 'weft:owner:' .. redis.call('HGET', KEYS[1], 'owner') .. ':active', ARGV[5])
redis.call('HSET', KEYS[1], 'state', ARGV[1], 'finished', ARGV[2])
redis.call('ZADD', 'weft:finished', ARGV[2], ARGV[5])
for i = 7, #ARGV, 2 do redis.call('HSET', KEYS[1], ARGV[i], ARGV[i + 1]) end
redis.pcall('XADD', KEYS[2], ARGV[4], 'type', 'end', 'data', ARGV[3])
redis.call('HINCRBY', 'weft:stats', 'jobs_' .. ARGV[1], 1)
local started = redis.call('HGET', KEYS[1], 'started')
if started then observe('job_run_seconds', tonumber(ARGV[2]) - tonumber(started)) end
if ARGV[1] == 'failed' then
  redis.call('HINCRBY', 'weft:failures', redis.call('HGET', KEYS[1], 'failure_kind') or 'error', 1)
end
return 1
"""

# ARGV: event id, payload JSON, frames_done, build, solve, collision, gia, total, simulated (0/1),
# worker, CG iterations. A simulated frame is filed into the per-frame histograms (jobmetrics). Returns 1 if the frame was published now, 0 if it had been published before, -1 if
# the job is no longer this worker's (fenced off: a worker presumed dead and replaced publishes
# nothing).
FRAME_LUA = OBSERVE_LUA + """
if redis.call('HGET', KEYS[1], 'worker') ~= ARGV[10] then return -1 end
local ok = redis.pcall('XADD', KEYS[2], ARGV[1], 'type', 'frame', 'data', ARGV[2])
if type(ok) == 'table' and ok.err then return 0 end
redis.call('HSET', KEYS[1], 'frames_done', ARGV[3])
if ARGV[9] == '1' then
  redis.call('HINCRBYFLOAT', KEYS[1], 'sum_build', ARGV[4])
  redis.call('HINCRBYFLOAT', KEYS[1], 'sum_solve', ARGV[5])
  redis.call('HINCRBYFLOAT', KEYS[1], 'sum_collision', ARGV[6])
  redis.call('HINCRBYFLOAT', KEYS[1], 'sum_gia', ARGV[7])
  redis.call('HINCRBYFLOAT', KEYS[1], 'sum_total', ARGV[8])
  redis.call('HINCRBY', KEYS[1], 'sim_frames', 1)
  redis.call('HINCRBY', 'weft:stats', 'frames_simulated', 1)
  observe('frame_build_seconds', ARGV[4])
  observe('frame_solve_seconds', ARGV[5])
  observe('frame_collision_seconds', ARGV[6])
  observe('frame_total_seconds', ARGV[8])
  observe('frame_cg_iterations', ARGV[11])
end
return 1
"""

# The job list's filters, inside Redis and read-only (no temporary keys: Redis runs with an
# append-only file). KEYS: the index to list (an owner's, or every job's), its name hash, a
# state's set, a tag's set. ARGV: the lower-case text a name must contain ('' for any; names
# are ASCII), '1' to keep only jobs in the state set, offset, limit, '1' to keep only jobs in
# the tag set, then the submission-time range (min, max; '-inf', '+inf' for any). Returns the
# number of matching jobs followed by the page's ids, newest first. A job missing from the
# name hash (submitted before it existed) is added from its record.
LIST_FILTER_LUA = """
local names = {}
if ARGV[1] ~= '' then
  local flat = redis.call('HGETALL', KEYS[2])
  for i = 1, #flat, 2 do names[flat[i]] = flat[i + 1] end
end
local first, last = tonumber(ARGV[3]) + 1, tonumber(ARGV[3]) + tonumber(ARGV[4])
local out, total = {0}, 0
for _, id in ipairs(redis.call('ZREVRANGEBYSCORE', KEYS[1], ARGV[7], ARGV[6])) do
  local keep = (ARGV[2] ~= '1' or redis.call('SISMEMBER', KEYS[3], id) == 1)
    and (ARGV[5] ~= '1' or redis.call('SISMEMBER', KEYS[4], id) == 1)
  if keep and ARGV[1] ~= '' then
    local name = names[id]
    if not name then
      name = redis.call('HGET', 'weft:job:' .. id, 'name')
      if name then redis.call('HSET', KEYS[2], id, name) end
    end
    keep = name and string.find(string.lower(name), ARGV[1], 1, true)
  end
  if keep then
    total = total + 1
    if total >= first and total <= last then out[#out + 1] = id end
  end
end
out[1] = total
return out
"""

# ARGV: now, payload JSON, final event id, job id.
# Returns the state after the call: 'cancelled' (was queued), 'cancelling' (running), or the
# final state it already had.
CANCEL_LUA = READY_LUA + """
local state = redis.call('HGET', KEYS[1], 'state')
if not state then return 'missing' end
if state == 'queued' then
  redis.call('SMOVE', 'weft:state:queued', 'weft:state:cancelled', ARGV[4])
  redis.call('ZREM', 'weft:queued_since', ARGV[4])
  ready_remove(KEYS[1], ARGV[4])
  redis.call('ZADD', 'weft:finished', ARGV[1], ARGV[4])
  redis.call('SREM', 'weft:owner:' .. redis.call('HGET', KEYS[1], 'owner') .. ':active', ARGV[4])
  redis.call('HSET', KEYS[1], 'state', 'cancelled', 'finished', ARGV[1], 'cancel_requested', '1')
  redis.pcall('XADD', KEYS[2], ARGV[3], 'type', 'end', 'data', ARGV[2])
  redis.call('HINCRBY', 'weft:stats', 'jobs_cancelled', 1)
  return 'cancelled'
end
if state == 'running' then
  redis.call('HSET', KEYS[1], 'cancel_requested', '1')
  return 'cancelling'
end
return state
"""


# KEYS[1] job hash, KEYS[2] events stream. ARGV: now, job id, payload JSON, the owner's limit of
# active jobs. A failed or cancelled job goes back to its ready set (weft.scheduler) to continue
# from its last finished frame, unless its owner already has that many jobs queued or running
# ('limit', checked in the same script: exact under concurrent submissions):
# its final event is removed (the stream's last id set back to its newest remaining entry, so
# the frames still to come keep their ids {index + 1}-0), a 'retried' event follows the frames
# published so far, and the attempt counters, cancel flag and error start afresh. Returns
# 'queued', or the state the job had if it was not failed or cancelled ('missing' if none).
RETRY_LUA = READY_LUA + """
local state = redis.call('HGET', KEYS[1], 'state')
if not state then return 'missing' end
if state ~= 'failed' and state ~= 'cancelled' then return state end
local active = 'weft:owner:' .. redis.call('HGET', KEYS[1], 'owner') .. ':active'
if redis.call('SCARD', active) >= tonumber(ARGV[4]) then return 'limit' end
local frames_done = tonumber(redis.call('HGET', KEYS[1], 'frames_done') or '0')
local final_id = (tonumber(redis.call('HGET', KEYS[1], 'frames_total')) + 1) .. '-0'
redis.call('XDEL', KEYS[2], final_id)
local top = redis.call('XREVRANGE', KEYS[2], '+', '-', 'COUNT', 1)
redis.call('XSETID', KEYS[2], #top > 0 and top[1][1] or '0-0')
redis.call('XADD', KEYS[2], frames_done .. '-*', 'type', 'retried', 'data', ARGV[3])
redis.call('SMOVE', 'weft:state:' .. state, 'weft:state:queued', ARGV[2])
redis.call('ZADD', 'weft:queued_since', ARGV[1], ARGV[2])
redis.call('SADD', active, ARGV[2])
redis.call('HDEL', KEYS[1], 'finished', 'error_reason', 'error_frame', 'failure_kind', 'cancel_requested', 'worker')
redis.call('HSET', KEYS[1], 'state', 'queued', 'attempts', 0, 'interruptions', 0, 'retried', ARGV[1])
redis.call('HINCRBY', KEYS[1], 'retries', 1)
redis.call('ZREM', 'weft:finished', ARGV[2])
ready_add(KEYS[1], ARGV[2], ARGV[1])
return 'queued'
"""


# A stopping worker hands its running job back: queued again in its ready set (it keeps its
# priority; its wait starts now), the worker's stream entry acknowledged. The interruption is
# counted apart from the attempts: a graceful stop (a rolling restart) is not a failure and
# never makes a job give up (see ``failed_attempts``). KEYS[1] job hash, KEYS[2] queue stream.
# ARGV: now, job id, entry id, group, worker. Returns 1, or 0 if the job is not this worker's.
REQUEUE_LUA = READY_LUA + """
if redis.call('HGET', KEYS[1], 'worker') ~= ARGV[5] or redis.call('HGET', KEYS[1], 'state') ~= 'running' then
  redis.call('XACK', KEYS[2], ARGV[4], ARGV[3])
  return 0
end
redis.call('HSET', KEYS[1], 'state', 'queued', 'worker', '')
redis.call('HINCRBY', KEYS[1], 'interruptions', 1)
redis.call('SMOVE', 'weft:state:running', 'weft:state:queued', ARGV[2])
redis.call('ZADD', 'weft:queued_since', ARGV[1], ARGV[2])
ready_add(KEYS[1], ARGV[2], ARGV[1])
redis.call('XACK', KEYS[2], ARGV[4], ARGV[3])
return 1
"""

# Deleting a job in a final state: its record, events, log and every index. KEYS[1] job hash.
# ARGV: job id. Returns the state it had ('missing' if none); deletes only a final job.
DELETE_LUA = """
local state = redis.call('HGET', KEYS[1], 'state')
if not state then return 'missing' end
if state ~= 'succeeded' and state ~= 'failed' and state ~= 'cancelled' then return state end
local id = ARGV[1]
local owner = redis.call('HGET', KEYS[1], 'owner')
local tags = cjson.decode(redis.call('HGET', KEYS[1], 'tags') or '[]')
for _, tag in ipairs(tags) do
  redis.call('SREM', 'weft:owner:' .. owner .. ':tag:' .. tag, id)
  redis.call('SREM', 'weft:tag:' .. tag, id)
end
redis.call('ZREM', 'weft:owner:' .. owner .. ':jobs', id)
redis.call('HDEL', 'weft:owner:' .. owner .. ':names', id)
redis.call('ZREM', 'weft:jobs', id)
redis.call('HDEL', 'weft:names', id)
redis.call('SREM', 'weft:state:' .. state, id)
redis.call('ZREM', 'weft:finished', id)
redis.call('DEL', KEYS[1], KEYS[1] .. ':events', KEYS[1] .. ':log')
return state
"""


def now() -> float:
    return time.time()


# -- multi-command transitions (queued into a MULTI pipeline, sync or asyncio client) ---------
def queue_new_job(pipe: Any, record: dict[str, Any], tags: list[str] | tuple[str, ...] = ()) -> None:
    """Submission: the job record, the indexes (the owner's and every key's: by time, names,
    tags), the queued set, and its pool's ready set (weft.scheduler; a worker dispatches it)."""
    job_id, owner = record["id"], record["owner"]
    pipe.hset(job_key(job_id), mapping=record)
    pipe.zadd(owner_key(owner), {job_id: record["created"]})
    pipe.hset(names_key(owner), job_id, record["name"])
    pipe.zadd(ALL_JOBS, {job_id: record["created"]})
    pipe.hset(ALL_NAMES, job_id, record["name"])
    for tag in tags:
        pipe.sadd(tag_key(owner, tag), job_id)
        pipe.sadd(tag_key(None, tag), job_id)
    pipe.sadd(active_key(owner), job_id)
    pipe.sadd(state_key("queued"), job_id)
    pipe.zadd(QUEUED_SINCE, {job_id: record["created"]})
    scheduler.add_ready(pipe, job_id, owner, record.get("pool", scheduler.DEFAULT_POOL),
                        int(record.get("priority", scheduler.DEFAULT_PRIORITY)), record["created"])


async def index_all_jobs(r: Any) -> int:
    """Jobs submitted before every job was indexed in ``weft:jobs`` (what admin keys list) are
    added from the owners' indexes, once: a store with an empty ``weft:jobs`` and some owner
    index. Returns the number of jobs indexed."""
    if await r.exists(ALL_JOBS):
        return 0
    owners = [key async for key in r.scan_iter(match=f"{PREFIX}:owner:*:jobs", count=1000)]
    if not owners:
        return 0
    return int(await r.zunionstore(ALL_JOBS, owners, aggregate="MIN"))


def failed_attempts(job: dict[str, str]) -> int:
    """Runs of a job that ended without handing it back: its worker died or froze. Graceful
    interruptions (``requeue``) do not count."""
    return int(job.get("attempts", 0)) - int(job.get("interruptions", 0))


# -- settings (WEFT_* environment variables) ------------------------------------------------
def _env_float(name: str, default: float) -> float:
    return float(os.environ.get(name, default))


def _env_int(name: str, default: int) -> int:
    return int(os.environ.get(name, default))


def _env_list(name: str) -> tuple[str, ...]:
    return tuple(item.strip() for item in os.environ.get(name, "").split(",") if item.strip())


@dataclass(frozen=True)
class ServiceSettings:
    redis_url: str = "redis://127.0.0.1:6379/0"
    storage: Path = Path("weft-storage")
    # Worker liveness: heartbeat period, and the idle time after which a job whose worker
    # stopped heart-beating is taken over by another worker.
    heartbeat_seconds: float = 2.0
    claim_after_seconds: float = 30.0
    max_attempts: int = 5
    solver_threads: int = 1
    # Request limits.
    max_upload_bytes: int = 512 * 1024 * 1024
    max_json_bytes: int = 64 * 1024 * 1024
    max_vertices: int = 2_000_000
    max_frames: int = 100_000
    max_files: int = 64
    # Cost budget of one job: cloth vertices x simulated frames x substeps ("vertex-substeps";
    # about 5 microseconds each on one core for plain cloth, more with contact): 1e9 is a 100k
    # vertex garment over 1,000 frames at 10 substeps.
    max_cost: int = 1_000_000_000
    # A key's share: its queued and running jobs, and its open event streams per API process
    # (each holds a Redis connection of the streams' own pool, max_streams in all).
    max_active_jobs: int = 200
    max_streams_per_key: int = 16
    max_streams: int = 256
    # Redis connections of an API process for everything but event streams (requests wait for
    # a free one rather than fail).
    max_redis_connections: int = 64
    # Validation of submissions (server/bounded.py): processes, address space of each, seconds
    # per submission.
    validation_processes: int = 2
    validation_memory_bytes: int = 4 * 1024**3
    validation_seconds: float = 120.0
    # API keys (bearer tokens); empty with local=True: no authentication (loopback only).
    api_keys: tuple[str, ...] = field(default_factory=tuple)
    local: bool = False
    # Operations: /metrics behind an API key; the period of the queue history's samples.
    metrics_require_key: bool = False
    queue_sample_seconds: float = 5.0
    # Keys that see and manage every key's jobs (and are API keys themselves).
    admin_keys: tuple[str, ...] = field(default_factory=tuple)
    # Scheduling (weft.scheduler): the pools a worker serves, in order of preference; how many
    # jobs one key may have running at once (0: no limit).
    pools: tuple[str, ...] = ("default",)
    max_running_jobs: int = 0
    # Retention of finished jobs (record, events, log, assets and cache): delete those finished
    # more than retention_days ago, and the oldest finished ones while the job folders take more
    # than retention_bytes (0: keep).
    retention_days: float = 0.0
    retention_bytes: int = 0

    @classmethod
    def from_env(cls) -> ServiceSettings:
        keys = tuple(k.strip() for k in os.environ.get("WEFT_API_KEYS", "").split(",") if k.strip())
        keys_file = os.environ.get("WEFT_API_KEYS_FILE")
        if keys_file:
            lines = Path(keys_file).read_text().splitlines()
            keys += tuple(line.strip() for line in lines if line.strip() and not line.startswith("#"))
        return cls(
            redis_url=os.environ.get("WEFT_REDIS_URL", cls.redis_url),
            storage=Path(os.environ.get("WEFT_STORAGE", str(cls.storage))),
            heartbeat_seconds=_env_float("WEFT_HEARTBEAT_SECONDS", cls.heartbeat_seconds),
            claim_after_seconds=_env_float("WEFT_CLAIM_AFTER_SECONDS", cls.claim_after_seconds),
            max_attempts=_env_int("WEFT_MAX_ATTEMPTS", cls.max_attempts),
            solver_threads=_env_int("WEFT_SOLVER_THREADS", cls.solver_threads),
            max_upload_bytes=_env_int("WEFT_MAX_UPLOAD_BYTES", cls.max_upload_bytes),
            max_json_bytes=_env_int("WEFT_MAX_JSON_BYTES", cls.max_json_bytes),
            max_vertices=_env_int("WEFT_MAX_VERTICES", cls.max_vertices),
            max_frames=_env_int("WEFT_MAX_FRAMES", cls.max_frames),
            max_files=_env_int("WEFT_MAX_FILES", cls.max_files),
            max_cost=_env_int("WEFT_MAX_COST", cls.max_cost),
            max_active_jobs=_env_int("WEFT_MAX_ACTIVE_JOBS", cls.max_active_jobs),
            max_streams_per_key=_env_int("WEFT_MAX_STREAMS_PER_KEY", cls.max_streams_per_key),
            max_streams=_env_int("WEFT_MAX_STREAMS", cls.max_streams),
            max_redis_connections=_env_int("WEFT_MAX_REDIS_CONNECTIONS", cls.max_redis_connections),
            validation_processes=_env_int("WEFT_VALIDATION_PROCESSES", cls.validation_processes),
            validation_memory_bytes=_env_int("WEFT_VALIDATION_MEMORY_BYTES", cls.validation_memory_bytes),
            validation_seconds=_env_float("WEFT_VALIDATION_SECONDS", cls.validation_seconds),
            api_keys=keys,
            local=os.environ.get("WEFT_LOCAL", "") == "1",
            metrics_require_key=os.environ.get("WEFT_METRICS_REQUIRE_KEY", "") == "1",
            queue_sample_seconds=_env_float("WEFT_QUEUE_SAMPLE_SECONDS", cls.queue_sample_seconds),
            admin_keys=_env_list("WEFT_ADMIN_KEYS"),
            pools=_env_list("WEFT_POOLS") or cls.pools,
            max_running_jobs=_env_int("WEFT_MAX_RUNNING_JOBS", cls.max_running_jobs),
            retention_days=_env_float("WEFT_RETENTION_DAYS", cls.retention_days),
            retention_bytes=_env_int("WEFT_RETENTION_BYTES", cls.retention_bytes),
        )

    def job_dir(self, job_id: str) -> Path:
        return self.storage / "jobs" / job_id

    @staticmethod
    def assets_dir(job_dir: Path) -> Path:
        return job_dir / "assets"

    @staticmethod
    def cache_path(job_dir: Path) -> Path:
        return job_dir / "cache.h5"

    @staticmethod
    def usd_path(job_dir: Path) -> Path:
        return job_dir / "cache.usd"
