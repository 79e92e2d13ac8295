"""Farm metrics kept in Redis: histograms and failure counts that workers record as part of the
job transitions (the Lua scripts of ``weft.jobstore``) and every API process renders for
Prometheus (``GET /metrics``).

Redis is the aggregation point because the observations happen in many worker processes on
many hosts: a histogram is one hash ``weft:hist:<name>`` with one field per bucket (the bucket's
upper bound, plain counts, not cumulative), ``count`` and ``sum``. The Lua function
``observe`` (``OBSERVE_LUA``) files a value into its bucket; the bounds are defined once, here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

PREFIX = "weft"
FAILURES = f"{PREFIX}:failures"


@dataclass(frozen=True)
class HistogramSpec:
    name: str  # Prometheus name without the weft_ prefix; also the Redis hash's suffix
    help: str
    bounds: tuple[float, ...]


HISTOGRAMS: dict[str, HistogramSpec] = {
    spec.name: spec
    for spec in (
        HistogramSpec("job_wait_seconds", "Seconds from submission to a worker's first start",
                      (0.1, 0.5, 1, 5, 15, 60, 300, 900, 3600, 4 * 3600, 24 * 3600)),
        HistogramSpec("job_run_seconds", "Seconds from a job's first start to its final state",
                      (1, 5, 15, 60, 300, 900, 3600, 4 * 3600, 12 * 3600, 48 * 3600)),
        HistogramSpec("frame_build_seconds", "Per simulated frame: force and matrix build seconds",
                      (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1, 3, 10, 30)),
        HistogramSpec("frame_solve_seconds", "Per simulated frame: linear solve seconds",
                      (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1, 3, 10, 30)),
        HistogramSpec("frame_collision_seconds", "Per simulated frame: collision stage seconds",
                      (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1, 3, 10, 30)),
        HistogramSpec("frame_total_seconds", "Per simulated frame: whole step seconds",
                      (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1, 3, 10, 30, 100)),
        HistogramSpec("frame_cg_iterations", "Per simulated frame: CG iterations over its substeps",
                      (10, 30, 100, 300, 1000, 3000, 10000, 30000)),
    )
}

# Why a job failed, as a bounded set of labels (the reason text itself is free-form).
FAILURE_KINDS = ("solver", "shot", "worker_lost", "error")


def histogram_key(name: str) -> str:
    return f"{PREFIX}:hist:{name}"


def _lua_number(value: float) -> str:
    return repr(float(value)) if not float(value).is_integer() else str(int(value))


def _bounds_table() -> str:
    rows = ", ".join(
        f"['{spec.name}'] = {{{', '.join(_lua_number(b) for b in spec.bounds)}}}" for spec in HISTOGRAMS.values()
    )
    return "{" + rows + "}"


# Prepended to the scripts that observe something. The bucket field is the bound exactly as
# written here (Lua's tostring of these numbers); parse_histogram reads them back as floats.
OBSERVE_LUA = f"""
local HIST_BOUNDS = {_bounds_table()}
local function observe(name, value)
  value = tonumber(value)
  if value == nil or value ~= value or value < 0 then return end
  local key = '{PREFIX}:hist:' .. name
  local bucket = '+Inf'
  for _, b in ipairs(HIST_BOUNDS[name]) do
    if value <= b then bucket = tostring(b); break end
  end
  redis.call('HINCRBY', key, bucket, 1)
  redis.call('HINCRBY', key, 'count', 1)
  redis.call('HINCRBYFLOAT', key, 'sum', value)
end
"""


@dataclass(frozen=True)
class HistogramValue:
    buckets: list[tuple[float, int]]  # (upper bound, cumulative count), ending with +Inf
    count: int
    total: float


def parse_histogram(spec: HistogramSpec, fields: dict[str, str]) -> HistogramValue:
    """The hash's plain bucket counts as Prometheus's cumulative buckets (every bound listed)."""
    plain: dict[float, int] = {}
    for key, value in fields.items():
        if key in ("count", "sum"):
            continue
        try:
            bound = math.inf if key == "+Inf" else float(key)
        except ValueError:
            continue
        plain[bound] = plain.get(bound, 0) + int(value)
    cumulative, running = [], 0
    for bound in (*spec.bounds, math.inf):
        running += plain.get(float(bound), 0)
        cumulative.append((float(bound), running))
    return HistogramValue(cumulative, int(fields.get("count", running)), float(fields.get("sum", 0.0)))
