"""The deployment files (issue 17): docker/compose.yaml, docker/Dockerfile, the systemd units,
and the worker health check they use. No Docker engine runs on the test machines, so the files
are checked for what would break a deployment: settings that do not exist, packages the image
would miss, commands that are not the project's, restart policies and health checks."""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
import tomllib
from pathlib import Path

import redis
import yaml

from server.stack import RedisServer
from weft import jobstore
from weft.jobstore import ServiceSettings
from workers.health import check

ROOT = Path(__file__).resolve().parents[2]
DOCKER = ROOT / "docker"


def known_settings() -> set[str]:
    source = (ROOT / "weft" / "jobstore.py").read_text()
    return set(re.findall(r'"(WEFT_[A-Z_]+)"', source)) | {"WEFT_WORKER_NAME", "WEFT_LOG_LEVEL"}


def test_compose_runs_redis_api_and_workers_with_health_checks_and_restarts() -> None:
    compose = yaml.safe_load((DOCKER / "compose.yaml").read_text())
    services = compose["services"]
    assert set(services) == {"redis", "api", "worker"}
    assert "--appendonly" in services["redis"]["command"] and "yes" in services["redis"]["command"]
    for name, service in services.items():
        assert service["restart"] in ("unless-stopped", "always"), name
        assert "healthcheck" in service, name
    assert services["api"]["build"]["dockerfile"] == "docker/Dockerfile"
    assert (DOCKER / services["api"]["build"]["context"] / services["api"]["build"]["dockerfile"]).exists()
    assert services["worker"]["command"] == ["python", "-m", "workers"]
    assert services["worker"]["healthcheck"]["test"] == ["CMD", "python", "-m", "workers.health"]
    # API and workers share the cache volume and the Redis, and name only real settings.
    for name in ("api", "worker"):
        assert "weft-data:/data" in services[name]["volumes"]
        env = services[name]["environment"]
        assert env["WEFT_REDIS_URL"] == "redis://redis:6379/0" and env["WEFT_STORAGE"] == "/data"
        assert set(env) <= known_settings(), set(env) - known_settings()
    assert services["api"]["depends_on"]["redis"]["condition"] == "service_healthy"


def test_dockerfile_builds_every_package_the_project_ships() -> None:
    dockerfile = (DOCKER / "Dockerfile").read_text()
    assert "COPY . ." in dockerfile and "scripts/install-system-deps.sh" in dockerfile
    ignored = (ROOT / ".dockerignore").read_text().split()
    packages = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["scikit-build"]["wheel"]["packages"]
    assert packages and not set(packages) & set(ignored)  # the image has every package
    assert "solver_cpp" not in ignored and "pyproject.toml" not in ignored
    assert ".venv" in ignored and "docker/api_keys.txt" in ignored  # no local venv, no secrets in the image
    assert re.search(r"^HEALTHCHECK .*/readyz", dockerfile, re.M)
    assert re.search(r"^USER weft$", dockerfile, re.M)


def test_systemd_units_run_the_project_and_restart_it() -> None:
    api = (DOCKER / "systemd" / "weft-api.service").read_text()
    worker = (DOCKER / "systemd" / "weft-worker@.service").read_text()
    assert re.search(r"^ExecStart=\S+python -m server ", api, re.M)
    assert re.search(r"^ExecStart=\S+python -m workers$", worker, re.M)
    for unit in (api, worker):
        assert "Restart=always" in unit and "EnvironmentFile=/etc/weft/weft.env" in unit
    assert "KillSignal=SIGTERM" in worker  # a stopped worker hands its job back
    env = (DOCKER / "systemd" / "weft.env.example").read_text()
    names = set(re.findall(r"^(WEFT_[A-Z_]+)=", env, re.M))
    assert names and names <= known_settings()


def test_worker_health_check_follows_the_heartbeat(redis_db: redis.Redis, redis_server: RedisServer,
                                                  tmp_path: Path) -> None:
    settings = ServiceSettings(redis_url=redis_server.url, storage=tmp_path, claim_after_seconds=30)
    host = socket.gethostname()
    healthy, why = check(settings, host)
    assert not healthy and "no worker of host" in why
    record = {"name": "w1", "host": host, "pid": 1, "started": 0, "heartbeat": jobstore.now(), "job": None}
    redis_db.hset(jobstore.WORKERS, "w1", json.dumps(record))
    healthy, why = check(settings, host)
    assert healthy and "1 worker(s)" in why
    redis_db.hset(jobstore.WORKERS, "w1", json.dumps({**record, "heartbeat": jobstore.now() - 60}))
    healthy, why = check(settings, host)
    assert not healthy and "last heartbeat" in why
    down = ServiceSettings(redis_url="redis://127.0.0.1:1/0", storage=tmp_path)
    assert check(down, host) == (False, check(down, host)[1]) and "unavailable" in check(down, host)[1]
    # The command's exit status, as Docker's HEALTHCHECK sees it.
    run = subprocess.run([sys.executable, "-m", "workers.health"], env={"WEFT_REDIS_URL": redis_server.url,
                         "PATH": "/usr/bin:/bin"}, capture_output=True, text=True, timeout=30)
    assert run.returncode == 1 and "last heartbeat" in run.stdout
