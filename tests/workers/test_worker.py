"""workers/worker.py with the job store's transitions: one job from the queue to its end."""

from __future__ import annotations

import json
from collections.abc import Callable

import h5py
import pytest
import redis

from weft import jobstore, scheduler
from weft.jobstore import ServiceSettings
from workers.worker import Worker


def pending(redis_db: redis.Redis) -> int:
    return int(redis_db.xpending(jobstore.QUEUE, jobstore.GROUP)["pending"])


def in_state(redis_db: redis.Redis, state: str) -> set[str]:
    return redis_db.smembers(jobstore.state_key(state))  # type: ignore[return-value]


def events(redis_db: redis.Redis, job_id: str) -> list[tuple[str, str, dict]]:  # type: ignore[type-arg]
    return [(i, f["type"], json.loads(f["data"])) for i, f in redis_db.xrange(jobstore.events_key(job_id))]


def test_empty_queue(worker: Worker, redis_db: redis.Redis) -> None:
    assert worker.process_next() is None
    assert redis_db.exists(jobstore.QUEUE) and pending(redis_db) == 0


def test_runs_a_job_to_success(worker: Worker, queue_job: Callable[..., str], redis_db: redis.Redis,
                               settings: ServiceSettings) -> None:
    job_id = queue_job(frames=4)
    assert worker.process_next() == job_id
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert job["state"] == "succeeded" and job["frames_done"] == "4" and job["worker"] == "w-test"
    assert job["attempts"] == "1" and job["sim_frames"] == "3" and float(job["sum_solve"]) > 0
    assert [(i, t) for i, t, _ in events(redis_db, job_id)] == [("1-0", "frame"), ("2-0", "frame"), ("3-0", "frame"),
                                                          ("4-0", "frame"), ("5-0", "end")]
    end = {"state": "succeeded", "frames_done": 4, "error_frame": None, "error_reason": None}
    assert events(redis_db, job_id)[-1][2] == end
    assert in_state(redis_db, "succeeded") == {job_id} and in_state(redis_db, "running") == set()
    assert pending(redis_db) == 0, "the entry is acknowledged once the job is final"
    assert redis_db.hget(jobstore.STATS, "frames_simulated") == "3"
    with h5py.File(settings.cache_path(settings.job_dir(job_id)), "r") as f:
        assert f["frames/positions"].shape == (4, 36, 3)
    assert json.loads(redis_db.hget(jobstore.WORKERS, "w-test"))["job"] is None


def test_drops_a_job_cancelled_while_queued(worker: Worker, queue_job: Callable[..., str], redis_db: redis.Redis,
                                            settings: ServiceSettings) -> None:
    job_id = queue_job(state="cancelled")
    redis_db.smove(jobstore.state_key("queued"), jobstore.state_key("cancelled"), job_id)
    assert worker.process_next() == job_id
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert job["state"] == "cancelled" and job["attempts"] == "0", "dropped without starting"
    assert pending(redis_db) == 0 and not settings.cache_path(settings.job_dir(job_id)).exists()


def test_honours_a_cancel_requested_before_a_restart(worker: Worker, queue_job: Callable[..., str],
                                                     redis_db: redis.Redis) -> None:
    job_id = queue_job(cancel_requested="1")
    worker.process_next()
    assert redis_db.hget(jobstore.job_key(job_id), "state") == "cancelled"
    assert events(redis_db, job_id)[-1][1:] == ("end", {"state": "cancelled", "frames_done": 0, "error_frame": None,
                                                  "error_reason": None})


def test_gives_up_after_max_attempts(worker: Worker, queue_job: Callable[..., str], redis_db: redis.Redis) -> None:
    job_id = queue_job(attempts=2)  # max_attempts is 2: this start is the third
    worker.process_next()
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert job["state"] == "failed" and job["error_reason"] == "gave up after 2 attempts (workers died)"
    assert redis_db.hget(jobstore.STATS, "jobs_failed") == "1" and pending(redis_db) == 0


def test_fails_a_job_whose_shot_cannot_be_loaded(worker: Worker, queue_job: Callable[..., str], redis_db: redis.Redis,
                                                 settings: ServiceSettings) -> None:
    job_id = queue_job()
    (settings.job_dir(job_id) / "shot.json").write_text("{not json")
    worker.process_next()
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert job["state"] == "failed" and job["error_reason"].startswith("cannot load the shot")


def test_a_stopping_worker_hands_the_job_back(worker: Worker, queue_job: Callable[..., str], redis_db: redis.Redis,
                                              settings: ServiceSettings) -> None:
    job_id = queue_job(frames=6)
    worker.stopping.set()  # as after SIGTERM: the runner stops after the frame it is on (the first)
    assert worker.process_next() == job_id
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert (job["state"], job["worker"], job["attempts"], job["frames_done"]) == ("queued", "", "1", "1")
    assert in_state(redis_db, "queued") == {job_id} and in_state(redis_db, "running") == set()
    owner = job["owner"]
    assert redis_db.zrange(scheduler.ready_key("default", owner), 0, -1) == [job_id], "ready to run again"
    assert pending(redis_db) == 0, "the old entry acknowledged"

    successor = Worker(settings, name="w-next")
    assert successor.process_next() == job_id
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert job["state"] == "succeeded" and job["attempts"] == "2" and job["worker"] == "w-next"
    assert job["resumed_from"] == "1", "continued from the cache, after frame 1"
    assert [d["frame"] for _, t, d in events(redis_db, job_id) if t == "frame"] == [1, 2, 3, 4, 5, 6]
    successor.redis.close()


def test_rolling_restarts_never_fail_a_healthy_job(worker: Worker, queue_job: Callable[..., str],
                                                   redis_db: redis.Redis, settings: ServiceSettings) -> None:
    """Issue 15: five graceful restarts (a rolling deploy) made a healthy job give up after
    max_attempts "workers died". Graceful hand-backs are interruptions, not failed attempts."""
    job_id = queue_job(frames=8)
    restarts = settings.max_attempts + 3
    for k in range(restarts):
        stopping = Worker(settings, name=f"w-rolling-{k}")
        stopping.stopping.set()  # SIGTERM: hands the job back after its first frame
        assert stopping.process_next() == job_id
        stopping.redis.close()
        job = redis_db.hgetall(jobstore.job_key(job_id))
        assert job["state"] == "queued", job
    worker.process_next()
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert job["state"] == "succeeded", job.get("error_reason")
    assert (job["attempts"], job["interruptions"]) == (str(restarts + 1), str(restarts))
    assert [d["frame"] for _, t, d in events(redis_db, job_id) if t == "frame"] == list(range(1, 9))


def test_a_replaced_worker_publishes_no_frame(worker: Worker, queue_job: Callable[..., str],
                                              redis_db: redis.Redis) -> None:
    """A worker presumed dead and replaced (the job's worker is another one now) is fenced off:
    its frame events are refused and it stops (Superseded) instead of publishing."""
    from api_schemas import FrameTelemetry
    from workers.worker import Superseded

    job_id = queue_job(frames=4)
    redis_db.hset(jobstore.job_key(job_id), mapping={"state": "running", "worker": "w-successor"})
    telemetry = FrameTelemetry(**{**{name: 0 for name in FrameTelemetry.model_fields}, "frame": 2, "substeps": 1})
    with pytest.raises(Superseded):
        worker._publish(job_id, 1, 4, telemetry)
    assert events(redis_db, job_id) == [] and redis_db.hget(jobstore.job_key(job_id), "frames_done") == "0"
    redis_db.hset(jobstore.job_key(job_id), "worker", worker.name)
    worker._publish(job_id, 1, 4, telemetry)
    assert [t for _, t, _ in events(redis_db, job_id)] == ["frame"]


def test_frame_events_are_strict_json(worker: Worker, queue_job: Callable[..., str], redis_db: redis.Redis) -> None:
    """Issue 15: a non-finite telemetry value (a diverged residual) went out as `Infinity`,
    which is not JSON: browsers' EventSource parsers reject the event."""
    from api_schemas import FrameTelemetry

    job_id = queue_job(frames=4)
    redis_db.hset(jobstore.job_key(job_id), mapping={"state": "running", "worker": worker.name})
    values = {**{name: 0 for name in FrameTelemetry.model_fields}, "frame": 2, "substeps": 1}
    worker._publish(job_id, 1, 4, FrameTelemetry(**{**values, "final_residual": float("inf")}))
    (_, data), = [(f["type"], f["data"]) for _, f in redis_db.xrange(jobstore.events_key(job_id))]
    parsed = json.loads(data, parse_constant=lambda c: pytest.fail(f"non-JSON constant {c}"))
    assert parsed["final_residual"] is None and parsed["frame"] == 2


def test_a_second_entry_of_a_running_job_is_dropped(worker: Worker, queue_job: Callable[..., str],
                                                    redis_db: redis.Redis) -> None:
    """A retry queued while the job's earlier entry was still unread leaves two entries: the
    one read second finds the job running and must not start a second run of it (only an entry
    claimed from a dead worker may take a running job over)."""
    job_id = queue_job(frames=4)
    redis_db.hset(jobstore.job_key(job_id), mapping={"state": "running", "worker": "w-other", "attempts": 1})
    assert worker.process_next() == job_id
    job = redis_db.hgetall(jobstore.job_key(job_id))
    assert (job["state"], job["worker"], job["attempts"]) == ("running", "w-other", "1")
    assert pending(redis_db) == 0, "the duplicate entry is acknowledged"
