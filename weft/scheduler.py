"""Which queued job a worker runs next: priorities, pools, per-key running quotas and fair share
between keys, decided atomically inside Redis (``DISPATCH_LUA``).

Queued jobs wait in *ready sets*, one sorted set per pool and API key
(``weft:ready:{pool}:{owner}``), scored so that a lower score runs first::

    score = (101 - priority) * 1e10 + queued_since        priority 0..100, default 50

(``queued_since`` is a Unix time, below 1e10 s, so a higher priority always comes first and
equal priorities run oldest first). ``weft:ready:{pool}`` is the set of keys with jobs waiting
in that pool.

A free worker serving pools P1, P2, ... (in that order) runs ``DISPATCH_LUA``: for the first
pool with an eligible job it takes, among the keys below their running quota, the key whose
best job has the highest priority; between keys tied on priority, the one with fewer jobs
running (fair share), then the older job. The chosen job gets a fresh entry on the job stream
(``weft:queue``) that the script delivers to this worker at once (XREADGROUP inside the script,
which sees no other undelivered entry), so crash recovery is unchanged: a dead worker's entry
stays pending and is claimed by another worker after the claim timeout (``weft.jobstore``).

Every job that becomes ready rings its pool's doorbell (a list, ``weft:doorbell:{pool}``) so an
idle worker blocked on it (BLPOP) dispatches at once instead of polling.
"""

from __future__ import annotations

import re

PREFIX = "weft"
POOLS = f"{PREFIX}:pools"
DEFAULT_POOL = "default"
DEFAULT_PRIORITY = 50
POOL_NAME = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")
DOORBELL_LENGTH = 1000


def ready_key(pool: str, owner: str) -> str:
    return f"{PREFIX}:ready:{pool}:{owner}"


def ready_owners_key(pool: str) -> str:
    return f"{PREFIX}:ready:{pool}"


def doorbell_key(pool: str) -> str:
    return f"{PREFIX}:doorbell:{pool}"


def ready_score(priority: int, queued_since: float) -> float:
    return (101 - priority) * 1e10 + queued_since


def add_ready(pipe: object, job_id: str, owner: str, pool: str, priority: int, queued_since: float) -> None:
    """A new job joins its pool's ready set (a pipeline's commands, for submission)."""
    pipe.zadd(ready_key(pool, owner), {job_id: ready_score(priority, queued_since)})  # type: ignore[attr-defined]
    pipe.sadd(ready_owners_key(pool), owner)  # type: ignore[attr-defined]
    pipe.sadd(POOLS, pool)  # type: ignore[attr-defined]
    pipe.lpush(doorbell_key(pool), 1)  # type: ignore[attr-defined]
    pipe.ltrim(doorbell_key(pool), 0, DOORBELL_LENGTH - 1)  # type: ignore[attr-defined]


# Prepended to scripts that put a job back into, or take it out of, its ready set. The job's
# pool, owner and priority come from its record.
READY_LUA = f"""
local function ready_add(job_key, id, since)
  local pool = redis.call('HGET', job_key, 'pool') or '{DEFAULT_POOL}'
  local owner = redis.call('HGET', job_key, 'owner')
  local priority = tonumber(redis.call('HGET', job_key, 'priority') or '{DEFAULT_PRIORITY}')
  redis.call('ZADD', '{PREFIX}:ready:' .. pool .. ':' .. owner, (101 - priority) * 1e10 + tonumber(since), id)
  redis.call('SADD', '{PREFIX}:ready:' .. pool, owner)
  redis.call('SADD', '{POOLS}', pool)
  redis.call('LPUSH', '{PREFIX}:doorbell:' .. pool, 1)
  redis.call('LTRIM', '{PREFIX}:doorbell:' .. pool, 0, {DOORBELL_LENGTH - 1})
end
local function ready_remove(job_key, id)
  local pool = redis.call('HGET', job_key, 'pool') or '{DEFAULT_POOL}'
  local owner = redis.call('HGET', job_key, 'owner')
  local key = '{PREFIX}:ready:' .. pool .. ':' .. owner
  redis.call('ZREM', key, id)
  if redis.call('ZCARD', key) == 0 then redis.call('SREM', '{PREFIX}:ready:' .. pool, owner) end
end
"""

# KEYS[1] the job stream. ARGV: worker name, consumer group, running quota per key (0: none),
# then the worker's pools in order of preference. Returns {entry id, job id} or false.
DISPATCH_LUA = f"""
-- An entry queued by an earlier version (straight onto the stream) is served first.
local legacy = redis.call('XREADGROUP', 'GROUP', ARGV[2], ARGV[1], 'COUNT', 1, 'STREAMS', KEYS[1], '>')
if legacy then
  local entry = legacy[1][2][1]
  local fields = entry[2]
  for i = 1, #fields, 2 do
    if fields[i] == 'job' then return {{entry[1], fields[i + 1]}} end
  end
  redis.call('XACK', KEYS[1], ARGV[2], entry[1])
  return false
end
local quota = tonumber(ARGV[3])
for p = 4, #ARGV do
  local pool = ARGV[p]
  local owners_key = '{PREFIX}:ready:' .. pool
  local best, best_band, best_running, best_score = nil, 0, 0, 0
  for _, owner in ipairs(redis.call('SMEMBERS', owners_key)) do
    local head = redis.call('ZRANGE', owners_key .. ':' .. owner, 0, 0, 'WITHSCORES')
    if #head == 0 then
      redis.call('SREM', owners_key, owner)
    else
      local score = tonumber(head[2])
      local band = math.floor(score / 1e10)
      local running = redis.call('SINTERCARD', 2, '{PREFIX}:owner:' .. owner .. ':active', '{PREFIX}:state:running')
      if quota == 0 or running < quota then
        if best == nil or band < best_band or (band == best_band and (running < best_running
            or (running == best_running and score < best_score))) then
          best, best_band, best_running, best_score = owner, band, running, score
        end
      end
    end
  end
  if best then
    local key = owners_key .. ':' .. best
    local id = redis.call('ZRANGE', key, 0, 0)[1]
    redis.call('ZREM', key, id)
    if redis.call('ZCARD', key) == 0 then redis.call('SREM', owners_key, best) end
    local entry = redis.call('XADD', KEYS[1], '*', 'job', id)
    redis.call('XREADGROUP', 'GROUP', ARGV[2], ARGV[1], 'COUNT', 1, 'STREAMS', KEYS[1], '>')
    return {{entry, id}}
  end
end
return false
"""
