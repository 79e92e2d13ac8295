"""Configuration shared by the API server and the workers, read from WEFT_* environment variables."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path


def _env_float(name: str, default: float) -> float:
    return float(os.environ.get(name, default))


def _env_int(name: str, default: int) -> int:
    return int(os.environ.get(name, default))


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
    # API keys (bearer tokens); empty with local=True: no authentication (loopback only).
    api_keys: tuple[str, ...] = field(default_factory=tuple)
    local: bool = False

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
            api_keys=keys,
            local=os.environ.get("WEFT_LOCAL", "") == "1",
        )

    def job_dir(self, job_id: str) -> Path:
        return self.storage / "jobs" / job_id

    @staticmethod
    def assets_dir(job_dir: Path) -> Path:
        return job_dir / "assets"

    @staticmethod
    def cache_path(job_dir: Path) -> Path:
        return job_dir / "cache.h5"
