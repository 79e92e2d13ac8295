"""Start and stop a complete local service: a Redis server, the API and N workers.

Used by `weft up`, `weft demo`, the service tests and the benchmark, so they all run the real
processes the same way. Redis runs with an append-only file (fsync on every write) in
``{storage}/redis`` so that a restart loses no job.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import httpx
import redis


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def redis_server_binary() -> str:
    found = shutil.which("redis-server") or ("/usr/bin/redis-server" if Path("/usr/bin/redis-server").exists() else None)
    if not found:
        raise RuntimeError("redis-server not found: install Debian's redis-server (make system-deps)")
    return found


def _wait_ready(
    ready: Callable[[], bool], proc: subprocess.Popen[bytes], errors: type[Exception], seconds: float, failure: str
) -> None:
    """Poll ``ready`` until it is true; RuntimeError(failure) if the process exits or time runs out."""
    deadline = time.monotonic() + seconds
    while True:
        try:
            if ready():
                return
        except errors:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(failure)
        time.sleep(0.05)


class Stack:
    def __init__(
        self,
        storage: Path,
        workers: int = 1,
        api_keys: list[str] | None = None,
        port: int | None = None,
        env: dict[str, str] | None = None,
        log_dir: Path | None = None,
    ) -> None:
        """api_keys None: local mode (no keys, loopback only)."""
        self.storage = Path(storage).resolve()
        self.worker_count = workers
        self.api_keys = api_keys
        self.port = port or free_port()
        self.redis_port = free_port()
        self.extra_env = env or {}
        self.log_dir = log_dir or self.storage / "logs"
        self.redis_proc: subprocess.Popen[bytes] | None = None
        self.api_proc: subprocess.Popen[bytes] | None = None
        self.workers: list[subprocess.Popen[bytes]] = []
        self._worker_serial = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def redis_url(self) -> str:
        return f"redis://127.0.0.1:{self.redis_port}/0"

    def env(self) -> dict[str, str]:
        env = dict(os.environ)
        env.update({"WEFT_REDIS_URL": self.redis_url, "WEFT_STORAGE": str(self.storage / "data")})
        if self.api_keys is not None:
            env["WEFT_API_KEYS"] = ",".join(self.api_keys)
        env.update(self.extra_env)
        return env

    def _log(self, name: str):  # type: ignore[no-untyped-def]
        self.log_dir.mkdir(parents=True, exist_ok=True)
        return open(self.log_dir / f"{name}.log", "ab")  # noqa: SIM115 - the child owns it

    # -- processes ----------------------------------------------------------------------------
    def start(self) -> Stack:
        self.start_redis()
        self.start_api()
        for _ in range(self.worker_count):
            self.start_worker()
        return self

    def start_redis(self) -> None:
        data = self.storage / "redis"
        data.mkdir(parents=True, exist_ok=True)
        self.redis_proc = subprocess.Popen(
            [
                redis_server_binary(), "--port", str(self.redis_port), "--bind", "127.0.0.1", "--dir", str(data),
                "--appendonly", "yes", "--appendfsync", "always", "--save", "", "--protected-mode", "yes",
                "--daemonize", "no", "--logfile", "",
            ],
            stdout=self._log("redis"), stderr=subprocess.STDOUT,
        )
        client = redis.Redis(port=self.redis_port, socket_connect_timeout=0.5)

        def ready() -> bool:  # answering, and done loading the append-only file
            return bool(client.ping()) and client.info("persistence").get("loading", 0) == 0

        _wait_ready(ready, self.redis_proc, redis.RedisError, 20, f"redis-server did not start (see {self.log_dir / 'redis.log'})")

    def kill_redis(self) -> None:
        assert self.redis_proc is not None
        self.redis_proc.kill()
        self.redis_proc.wait()

    def start_api(self) -> None:
        cmd = [sys.executable, "-m", "server", "--host", "127.0.0.1", "--port", str(self.port)]
        if self.api_keys is None:
            cmd.append("--local")
        self.api_proc = subprocess.Popen(cmd, env=self.env(), stdout=self._log("api"), stderr=subprocess.STDOUT)
        _wait_ready(lambda: httpx.get(self.url + "/readyz", timeout=1).status_code == 200, self.api_proc,
                    httpx.HTTPError, 30, f"the API did not start (see {self.log_dir / 'api.log'})")

    def start_worker(self) -> subprocess.Popen[bytes]:
        self._worker_serial += 1
        name = f"worker-{self.port}-{self._worker_serial}"
        env = self.env()
        env["WEFT_WORKER_NAME"] = name
        proc = subprocess.Popen([sys.executable, "-m", "workers"], env=env, stdout=self._log(name), stderr=subprocess.STDOUT)
        proc.name = name  # type: ignore[attr-defined]
        self.workers.append(proc)
        return proc

    def worker_named(self, name: str) -> subprocess.Popen[bytes]:
        return next(p for p in self.workers if getattr(p, "name", None) == name)

    def stop(self) -> None:
        procs = [p for p in self.workers if p.poll() is None]
        for p in procs:
            p.send_signal(signal.SIGTERM)
        if self.api_proc is not None and self.api_proc.poll() is None:
            self.api_proc.send_signal(signal.SIGTERM)
            procs.append(self.api_proc)
        for p in procs:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        if self.redis_proc is not None and self.redis_proc.poll() is None:
            self.redis_proc.send_signal(signal.SIGTERM)
            try:
                self.redis_proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.redis_proc.kill()
                self.redis_proc.wait()

    def __enter__(self) -> Stack:
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *_: object) -> None:
        self.stop()
