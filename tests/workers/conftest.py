"""In-process worker tests: a real ``Worker`` against a real redis-server on a free port
(the ``server.testing`` fixtures), jobs queued with the job store's own submission transition."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import redis

from server.stack import RedisServer
from server.testing import redis_db, redis_server  # noqa: F401 (fixtures)
from weft import jobstore
from weft.jobstore import ServiceSettings
from weft.shot import parse_shot
from scenes.builders import sheet_shot
from workers.worker import Worker


@pytest.fixture()
def settings(redis_db: redis.Redis, redis_server: RedisServer, tmp_path: Path) -> ServiceSettings:
    return ServiceSettings(redis_url=redis_server.url, storage=tmp_path / "storage", max_attempts=2)


@pytest.fixture()
def worker(settings: ServiceSettings) -> Iterator[Worker]:
    w = Worker(settings, name="w-test")
    yield w
    w.redis.close()


@pytest.fixture()
def queue_job(settings: ServiceSettings, redis_db: redis.Redis) -> Callable[..., str]:
    """Queue a job as the API does (shot.json in its folder, then ``jobstore.queue_new_job``)."""

    def queue(frames: int = 4, **fields: Any) -> str:
        shot = parse_shot(sheet_shot("w", 6, 6, 0.5, 0.5, pins=[0, 5], frames=frames))
        job_id = f"{len(redis_db.keys(jobstore.job_key('*'))) + 1:032x}"
        job_dir = settings.job_dir(job_id)
        settings.assets_dir(job_dir).mkdir(parents=True)
        (job_dir / "shot.json").write_text(shot.model_dump_json())
        record = {
            "id": job_id, "owner": "o", "name": shot.name, "state": "queued", "frames_done": 0,
            "frames_total": shot.frame_count, "frame_first": shot.frame_range[0], "frame_last": shot.frame_range[1],
            "vertices": 36, "created": jobstore.now(), "attempts": 0, **fields,
        }
        pipe = redis_db.pipeline(transaction=True)
        jobstore.queue_new_job(pipe, record)
        pipe.execute()
        return job_id

    return queue
