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
from typing import Self

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


def _stop_processes(procs: list[subprocess.Popen[bytes] | None], grace_seconds: float = 15.0) -> None:
    """SIGTERM the live ones at once, then wait for them all under one deadline; any still
    running after ``grace_seconds`` is SIGKILLed and named on stderr (so stopping a stack takes
    at most about grace_seconds, however many processes it has)."""
    live = [p for p in procs if p is not None and p.poll() is None]
    for p in live:
        p.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + grace_seconds
    for p in live:
        try:
            p.wait(timeout=max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            command = p.args if isinstance(p.args, list) else [p.args]
            name = getattr(p, "name", None) or " ".join(map(str, command[:3]))
            print(f"weft: {name} (pid {p.pid}) did not stop within {grace_seconds:g} s of SIGTERM; killed",
                  file=sys.stderr)
            p.kill()
            p.wait()


class _Started:
    """``with`` support for something that starts and stops: stopped on exit, and also when
    starting it fails half-way."""

    def start(self) -> Self:
        raise NotImplementedError

    def stop(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        try:
            return self.start()
        except BaseException:
            self.stop()
            raise

    def __exit__(self, *_: object) -> None:
        self.stop()


class RedisServer(_Started):
    """A redis-server on a free loopback port, with its append-only file (fsync on every write)
    in ``data``, so that a kill loses nothing acknowledged. Also the tests' real Redis."""

    def __init__(self, data: Path, log: Path, port: int | None = None) -> None:
        self.data = data
        self.log = log
        self.port = port or free_port()
        self.proc: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self) -> RedisServer:
        self.data.mkdir(parents=True, exist_ok=True)
        self.log.parent.mkdir(parents=True, exist_ok=True)
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [
                    redis_server_binary(), "--port", str(self.port), "--bind", "127.0.0.1", "--dir", str(self.data),
                    "--appendonly", "yes", "--appendfsync", "always", "--save", "", "--protected-mode", "yes",
                    "--daemonize", "no", "--logfile", "",
                ],
                stdout=log, stderr=subprocess.STDOUT,
            )
        client = redis.Redis(port=self.port, socket_connect_timeout=0.5)

        def ready() -> bool:  # answering, and done loading the append-only file
            return bool(client.ping()) and client.info("persistence").get("loading", 0) == 0

        try:
            _wait_ready(ready, self.proc, redis.RedisError, 20, f"redis-server did not start (see {self.log})")
        finally:
            client.close()
        return self

    def kill(self) -> None:
        """SIGKILL: no chance to save anything beyond the append-only file."""
        assert self.proc is not None
        self.proc.kill()
        self.proc.wait()

    def stop(self) -> None:
        _stop_processes([self.proc])


class Stack(_Started):
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
        self.extra_env = env or {}
        self.log_dir = log_dir or self.storage / "logs"
        self.redis = RedisServer(self.storage / "redis", self.log_dir / "redis.log")
        self.api_proc: subprocess.Popen[bytes] | None = None
        self.workers: list[subprocess.Popen[bytes]] = []
        self._worker_serial = 0

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def redis_url(self) -> str:
        return self.redis.url

    @property
    def redis_proc(self) -> subprocess.Popen[bytes] | None:
        return self.redis.proc

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
        self.redis.start()

    def kill_redis(self) -> None:
        self.redis.kill()

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
        _stop_processes([*self.workers, self.api_proc])
        self.redis.stop()  # last: the API and workers may still write on their way out
