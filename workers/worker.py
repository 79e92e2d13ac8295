"""A weft worker: takes jobs (chosen by ``weft.scheduler``: priority, its pools, fair share) and
runs them frame by frame.

Each frame is appended to the job's HDF5 cache by ``ShotRunner`` and then published as an
event (see ``weft.jobstore``). A background thread heart-beats: it refreshes the worker's
record and re-claims the worker's stream entry so that its idle time stays short; an entry
whose worker died (no heartbeat) goes idle and is taken over by another worker, which resumes
the job from the solver state saved in the cache at the last finished frame.
"""

from __future__ import annotations

import json
import logging
import math
import os
import signal
import socket
import threading
import traceback
from typing import Any

import redis

from api_schemas import FrameTelemetry
from weft import jobstore, scheduler
from weft.body_shells import split_notes
from weft.jobstore import ServiceSettings
from weft.runner import FrameRecord, ShotRunner, SolverFailure
from weft.shot import ShotError, parse_shot
from weft.simulate import solver_threads, usable_cpus
from weft.solver_setup import resolve_scene

log = logging.getLogger("weft.worker")


class Requeue(Exception):
    """Raised between frames when the worker is shutting down: the job goes back to the queue."""


class Superseded(Exception):
    """Raised between frames when another worker took the job over (this one was presumed dead)."""


LOG_LINES_PER_JOB = 5000


class JobLogHandler(logging.Handler):
    """Copies the log records of the thread running a job into the job's log stream
    (``GET /v1/jobs/{id}/log``), keeping its newest LOG_LINES_PER_JOB lines."""

    def __init__(self, client: redis.Redis, job_id: str, worker: str) -> None:
        super().__init__(logging.INFO)
        self.client, self.key, self.worker = client, jobstore.log_key(job_id), worker
        self.thread = threading.get_ident()
        self.setFormatter(logging.Formatter("%(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        if record.thread != self.thread:
            return
        try:
            self.client.xadd(self.key, {"time": record.created, "level": record.levelname, "worker": self.worker,
                                        "message": self.format(record)}, maxlen=LOG_LINES_PER_JOB, approximate=True)
        except redis.RedisError:
            pass  # the log is best effort; the job's state and frames are not


class Worker:
    def __init__(self, settings: ServiceSettings, name: str | None = None) -> None:
        self.settings = settings
        self.name = name or f"{socket.gethostname()}-{os.getpid()}"
        self.redis = redis.Redis.from_url(settings.redis_url, decode_responses=True, socket_timeout=30)
        self.start_script = self.redis.register_script(jobstore.START_LUA)
        self.finish_script = self.redis.register_script(jobstore.FINISH_LUA)
        self.frame_script = self.redis.register_script(jobstore.FRAME_LUA)
        self.heartbeat_script = self.redis.register_script(jobstore.HEARTBEAT_LUA)
        self.dispatch_script = self.redis.register_script(scheduler.DISPATCH_LUA)
        self.requeue_script = self.redis.register_script(jobstore.REQUEUE_LUA)
        self.stopping = threading.Event()
        self._lock = threading.Lock()
        self._current: tuple[str, str] | None = None  # (stream entry id, job id)
        self._started = jobstore.now()

    # -- lifecycle --------------------------------------------------------------------------
    def run_forever(self) -> None:
        beat = threading.Thread(target=self._heartbeat_loop, name="heartbeat", daemon=True)
        beat.start()
        log.info("worker %s started (redis %s)", self.name, self.settings.redis_url)
        if solver_threads(self.settings.solver_threads) < self.settings.solver_threads:
            log.warning("WEFT_SOLVER_THREADS=%d but this worker may run on %d CPU(s): its runs use %d thread(s)",
                        self.settings.solver_threads, usable_cpus(), solver_threads(self.settings.solver_threads))
        while not self.stopping.is_set():
            try:
                self.process_next()
            except redis.RedisError as exc:
                log.warning("redis unavailable (%s); retrying", exc)
                self.stopping.wait(0.5)
        self._deregister()

    def process_next(self) -> str | None:
        """Take one queue entry (waiting up to a second for one) and process it to its end;
        the job id, or None if the queue was empty. Redis errors propagate."""
        self._ensure_group()
        entry = self._next_entry()
        if entry is None:
            return None
        self._process(*entry)
        return entry[1]

    def stop(self, *_: Any) -> None:
        self.stopping.set()

    def _ensure_group(self) -> None:
        try:
            self.redis.xgroup_create(jobstore.QUEUE, jobstore.GROUP, id="0", mkstream=True)
        except redis.ResponseError as exc:
            if "BUSYGROUP" not in str(exc):
                raise

    def _next_entry(self) -> tuple[str, str, bool] | None:
        """A stale entry of a dead worker first, else the job the scheduler gives this worker
        (waiting up to one second on the doorbells of its pools): (entry id, job id, whether it
        was claimed from another worker)."""
        claim_ms = int(self.settings.claim_after_seconds * 1000)
        _, claimed, _ = self.redis.xautoclaim(jobstore.QUEUE, jobstore.GROUP, self.name, claim_ms, "0-0", count=1)
        for entry_id, fields in claimed:
            if fields:  # an entry trimmed from the stream comes back without fields
                return entry_id, fields["job"], True
            self.redis.xack(jobstore.QUEUE, jobstore.GROUP, entry_id)
        for attempt in range(2):
            dispatched = self.dispatch_script(
                keys=[jobstore.QUEUE],
                args=[self.name, jobstore.GROUP, self.settings.max_running_jobs, *self.settings.pools])
            if dispatched:
                return dispatched[0], dispatched[1], False
            if attempt == 0:
                self.redis.blpop([scheduler.doorbell_key(pool) for pool in self.settings.pools], timeout=1)
        return None

    # -- heartbeat --------------------------------------------------------------------------
    def _heartbeat_loop(self) -> None:
        while not self.stopping.is_set():
            try:
                self._beat()
            except redis.RedisError:
                pass
            self.stopping.wait(self.settings.heartbeat_seconds)

    def _beat(self) -> None:
        with self._lock:
            current = self._current
        record = {
            "name": self.name, "pid": os.getpid(), "host": socket.gethostname(), "started": self._started,
            "heartbeat": jobstore.now(), "job": current[1] if current else None,
        }
        pipe = self.redis.pipeline(transaction=False)
        pipe.hset(jobstore.WORKERS, self.name, json.dumps(record))
        pipe.execute()
        if current is not None:
            # Re-claiming our own entry resets its idle time: it is not taken over while we live.
            self.heartbeat_script(
                keys=[jobstore.job_key(current[1]), jobstore.QUEUE], args=[self.name, record["heartbeat"], current[0], jobstore.GROUP]
            )

    def _deregister(self) -> None:
        try:
            self.redis.hdel(jobstore.WORKERS, self.name)
        except redis.RedisError:
            pass

    # -- one job ----------------------------------------------------------------------------
    def _process(self, entry_id: str, job_id: str, claimed: bool = False) -> None:
        key = jobstore.job_key(job_id)
        state = self.start_script(keys=[key, jobstore.events_key(job_id)],
                                  args=[self.name, jobstore.now(), job_id, "claimed" if claimed else "new"])
        if state != "running":
            log.info("job %s is %s; dropping its queue entry", job_id, state)
            self.redis.xack(jobstore.QUEUE, jobstore.GROUP, entry_id)
            return
        with self._lock:
            self._current = (entry_id, job_id)
        job_log = JobLogHandler(self.redis, job_id, self.name)
        weft_logger = logging.getLogger("weft")
        if weft_logger.getEffectiveLevel() > logging.INFO:  # the job's log has its INFO lines
            weft_logger.setLevel(logging.INFO)
        weft_logger.addHandler(job_log)
        try:
            self._beat()
            job = self.redis.hgetall(key)
            log.info("job %s started on worker %s (host %s, attempt %s%s; pool %s, priority %s)", job_id, self.name,
                     socket.gethostname(), job.get("attempts"), ", taken over from a silent worker" if claimed else "",
                     job.get("pool", scheduler.DEFAULT_POOL), job.get("priority", scheduler.DEFAULT_PRIORITY))
            if jobstore.failed_attempts(job) > self.settings.max_attempts:
                reason = f"gave up after {self.settings.max_attempts} attempts (workers died)"
                self._finish(entry_id, job_id, "failed", error_reason=reason, failure_kind="worker_lost")
            elif job.get("cancel_requested") == "1":  # cancelled while its previous worker was dying
                self._finish(entry_id, job_id, "cancelled")
            else:
                self._run(entry_id, job_id, job)
        except Requeue:
            # Shutting down: hand the job back to the queue at once (no claim timeout).
            log.info("worker %s stopping: job handed back to the queue", self.name)
            self.requeue_script(keys=[jobstore.job_key(job_id), jobstore.QUEUE],
                                args=[jobstore.now(), job_id, entry_id, jobstore.GROUP, self.name])
        except Superseded:
            log.warning("job %s was taken over by another worker; leaving it", job_id)
        finally:
            weft_logger.removeHandler(job_log)
            with self._lock:
                self._current = None
            try:
                self._beat()
            except redis.RedisError:
                pass

    def _run(self, entry_id: str, job_id: str, job: dict[str, str]) -> None:
        job_dir = self.settings.job_dir(job_id)
        cache = self.settings.cache_path(job_dir)
        try:
            shot = parse_shot(json.loads((job_dir / "shot.json").read_text()))
            scene = resolve_scene(shot, self.settings.assets_dir(job_dir))
        except (OSError, ValueError, ShotError) as exc:
            self._finish(entry_id, job_id, "failed", error_reason=f"cannot load the shot: {exc}", failure_kind="shot")
            return
        frames_total = scene.frame_count
        published = int(job.get("frames_done", 0))
        if cache.exists():
            self._backfill(job_id, cache, published, frames_total)
        first_index: list[int] = []

        def on_frame(record: FrameRecord) -> None:
            if not first_index:
                first_index.append(record.index)
                if record.index > 0:
                    self._mark_resumed(job_id, record.index - 1 + shot.frame_range[0], record.index)
            self._publish(job_id, record.index, frames_total, record.telemetry, record.write_seconds)
            if (record.index + 1) % max(frames_total // 10, 1) == 0 or record.index + 1 == frames_total:
                log.info("frame %d (%d of %d): %.3f s solver, %d CG iterations", record.frame, record.index + 1,
                         frames_total, record.telemetry.total_seconds, record.telemetry.cg_iterations)

        def should_stop() -> bool:
            if self.stopping.is_set():
                raise Requeue
            cancel, worker = self.redis.hmget(jobstore.job_key(job_id), ["cancel_requested", "worker"])
            if worker != self.name:
                raise Superseded
            return cancel == "1"

        runner = ShotRunner(scene, cache, threads=self.settings.solver_threads, resume=True)
        for line in split_notes([b.name for b in scene.bodies], scene.solver_bodies):
            log.info("%s", line.removeprefix("note: "))
        try:
            summary = runner.run(on_frame=on_frame, should_stop=should_stop)
        except SolverFailure as exc:
            self._finish(entry_id, job_id, "failed", error_frame=exc.frame, error_reason=exc.reason,
                         failure_kind="solver")
            return
        except (Requeue, Superseded, redis.RedisError):
            raise
        except Exception as exc:  # a bad cache or an unexpected error fails this job, not the worker
            log.error("job %s: %s", job_id, traceback.format_exc())
            self._finish(entry_id, job_id, "failed", error_reason=f"{type(exc).__name__}: {exc}")
            return
        state = "cancelled" if summary.status == "cancelled" else "succeeded"
        if state == "succeeded" and shot.outputs.usd:
            try:
                self._write_usd(job_id, cache)
            except Exception as exc:  # the frames are in the cache; the USD the shot asked for is not
                self._finish(entry_id, job_id, "failed", error_reason=f"writing USD: {type(exc).__name__}: {exc}")
                return
        self._finish(entry_id, job_id, state)

    def _write_usd(self, job_id: str, cache: Any) -> None:
        """The shot asked for USD: the finished cache as cache.usd beside it (written whole, then
        renamed). A failure here fails the job: the user asked for the file."""
        from weft.export import export_usd

        summary = export_usd(cache, self.settings.usd_path(self.settings.job_dir(job_id)))
        log.info("job %s: wrote USD, frames %d-%d", job_id, *summary.frames)

    def _publish(self, job_id: str, index: int, frames_total: int, t: FrameTelemetry,
                 io_seconds: float | None = None) -> None:
        # Strict JSON (browsers' EventSource and most parsers reject NaN and Infinity): a
        # non-finite value (a diverged residual) is sent as null. io_seconds: the frame's cache
        # write (null for frames a dead worker wrote, published again by _backfill).
        values = {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in t.model_dump().items()}
        payload = json.dumps({"index": index, "frames_total": frames_total, "published_at": jobstore.now(),
                              "io_seconds": io_seconds, **values}, allow_nan=False)
        published = self.frame_script(
            keys=[jobstore.job_key(job_id), jobstore.events_key(job_id)],
            args=[
                jobstore.frame_event_id(index), payload, index + 1, t.build_seconds, t.solve_seconds,
                t.collision_seconds, t.gia_seconds, t.total_seconds, 1 if t.substeps > 0 else 0, self.name,
                t.cg_iterations,
            ],
        )
        if published == -1:
            raise Superseded

    def _backfill(self, job_id: str, cache: Any, published: int, frames_total: int) -> None:
        """Publish frames a dead worker wrote to the cache but did not get to announce."""
        from weft.cache import CacheError, open_cache_reader, saved_state_group

        try:
            with open_cache_reader(cache) as f:
                rows = int(f[saved_state_group(f)]["frame_index"][0]) + 1
                telemetry = f["telemetry"][:rows]
        except (CacheError, KeyError, OSError):
            return
        for index in range(published, rows):
            row = telemetry[index]
            t = FrameTelemetry(**{name: row[name].item() for name in row.dtype.names})
            self._publish(job_id, index, frames_total, t)

    def _mark_resumed(self, job_id: str, frame: int, index: int) -> None:
        payload = json.dumps({"resumed_from_frame": frame, "worker": self.name})
        pipe = self.redis.pipeline(transaction=True)
        pipe.hset(jobstore.job_key(job_id), mapping={"resumed_from": frame})
        pipe.xadd(jobstore.events_key(job_id), {"type": "resumed", "data": payload}, id=f"{index}-*")
        pipe.execute()

    def _finish(self, entry_id: str, job_id: str, state: str, error_frame: int | None = None, error_reason: str = "",
                failure_kind: str = "error") -> None:
        """failure_kind (for a failed job): one of jobmetrics.FAILURE_KINDS, the label of
        weft_job_failures_total."""
        key = jobstore.job_key(job_id)
        fields: list[Any] = ["failure_kind", failure_kind] if state == "failed" else []
        if error_frame is not None:
            fields += ["error_frame", error_frame]
        if error_reason:
            fields += ["error_reason", error_reason]
        job = self.redis.hgetall(key)
        frames_total = int(job.get("frames_total", 0))
        payload = json.dumps({
            "state": state, "frames_done": int(job.get("frames_done", 0)),
            "error_frame": error_frame, "error_reason": error_reason or None,
        })
        done = self.finish_script(
            keys=[key, jobstore.events_key(job_id)],
            args=[state, jobstore.now(), payload, jobstore.final_event_id(frames_total), job_id, self.name, *fields],
        )
        if done == -1:
            raise Superseded
        self.redis.xack(jobstore.QUEUE, jobstore.GROUP, entry_id)
        log.info("job %s %s%s", job_id, state, f": {error_reason}" if error_reason else "")


def main() -> None:
    logging.basicConfig(level=os.environ.get("WEFT_LOG_LEVEL", "INFO"), format="%(asctime)s %(name)s %(message)s")
    worker = Worker(ServiceSettings.from_env(), os.environ.get("WEFT_WORKER_NAME") or None)
    signal.signal(signal.SIGTERM, worker.stop)
    signal.signal(signal.SIGINT, worker.stop)
    worker.run_forever()


if __name__ == "__main__":
    main()
