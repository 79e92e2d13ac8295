"""A farm of three hosts (issue 17): Redis and the API on one, a worker on each of two others,
each host in its own network namespace with one address on a bridge (tests/deploy/netns.py) and
the caches on shared storage. Two shots are submitted; the host running one of them dies
(processes killed, link down) mid-shot; the other host finishes its own shot and takes the dead
host's over, and both caches are bitwise identical to runs on one machine."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import h5py
import httpx
import numpy as np
import pytest

from scenes.builders import sheet_shot
from server.stack import redis_server_binary
from tests.deploy.netns import Network
from weft.runner import ShotRunner
from weft.shot import parse_shot
from weft.solver_setup import resolve_scene

KEY = "farm-key-0123456789"
REDIS_PORT, API_PORT = 6390, 8421


def wait_for(what: str, predicate: Any, timeout: float = 60.0) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            value = predicate()
        except httpx.HTTPError:
            value = None
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def local_run(shot: dict[str, Any], path: Path) -> Path:
    scene = resolve_scene(parse_shot(shot), path.parent)
    ShotRunner(scene, path, threads=1).run()
    return path


@pytest.fixture()
def farm(tmp_path: Path) -> Any:
    if os.geteuid() != 0:
        pytest.fail("the multi-host test needs root (network namespaces); the test machines run it as root")
    with Network(["server", "host-a", "host-b"]) as net:
        yield net


def test_a_dead_host_s_job_resumes_on_another_host_bitwise(farm: Network, tmp_path: Path) -> None:
    server, host_a, host_b = farm.hosts["server"], farm.hosts["host-a"], farm.hosts["host-b"]
    storage, logs = tmp_path / "shared-storage", tmp_path / "logs"
    env = {**os.environ, "WEFT_REDIS_URL": f"redis://{server.address}:{REDIS_PORT}/0", "WEFT_STORAGE": str(storage),
           "WEFT_API_KEYS": KEY, "WEFT_HEARTBEAT_SECONDS": "0.3", "WEFT_CLAIM_AFTER_SECONDS": "2.0",
           "WEFT_SOLVER_THREADS": "1"}
    for proxy in ("http_proxy", "https_proxy", "HTTP_PROXY", "HTTPS_PROXY", "all_proxy", "ALL_PROXY"):
        env.pop(proxy, None)
    (tmp_path / "redis").mkdir()
    server.start([redis_server_binary(), "--port", str(REDIS_PORT), "--bind", server.address, "--protected-mode", "no",
                  "--dir", str(tmp_path / "redis"), "--appendonly", "yes", "--appendfsync", "always", "--save", ""],
                 env, logs / "redis.log")
    server.start([sys.executable, "-m", "server", "--host", server.address, "--port", str(API_PORT)], env,
                 logs / "api.log")
    api = httpx.Client(base_url=f"http://{server.address}:{API_PORT}", headers={"Authorization": f"Bearer {KEY}"},
                       timeout=10, trust_env=False)
    wait_for("the API on the server host", lambda: api.get("/readyz").status_code == 200)
    for host in (host_a, host_b):
        host.start([sys.executable, "-m", "workers"], {**env, "WEFT_WORKER_NAME": host.name}, logs / f"{host.name}.log")
    wait_for("both workers", lambda: {w["name"] for w in api.get("/v1/workers").json()["workers"]} == {"host-a", "host-b"})

    # The hosts reach the server and nothing else: no route out of the bridge's subnet.
    assert "default" not in farm_routes(host_a.namespace)

    shots = [sheet_shot(f"farm-{k}", 16, 16, 0.5, 0.5, plane="xz", pins=[0, 15], frames=160, substeps=8)
             for k in range(2)]
    ids = [api.post("/v1/jobs", json=shot).json()["id"] for shot in shots]
    jobs = wait_for("both shots running on the two hosts", lambda: (
        js := [api.get(f"/v1/jobs/{i}").json() for i in ids])
        and all(j["state"] == "running" and j["frames_done"] >= 5 for j in js)
        and {j["worker"] for j in js} == {"host-a", "host-b"} and js)
    victim_job = next(j for j in jobs if j["worker"] == "host-a")
    host_a.power_off()
    killed_at = api.get(f"/v1/jobs/{victim_job['id']}").json()["frames_done"]
    assert killed_at < 160, "host-a must die mid-shot"

    finished = wait_for("both shots to finish", lambda: (
        js := [api.get(f"/v1/jobs/{i}").json() for i in ids]) and all(j["state"] == "succeeded" for j in js) and js,
        timeout=240)
    taken_over = next(j for j in finished if j["id"] == victim_job["id"])
    assert taken_over["worker"] == "host-b" and taken_over["attempts"] == 2
    assert taken_over["resumed_from"] is not None and taken_over["resumed_from"] >= killed_at
    workers = {w["name"]: w for w in api.get("/v1/workers").json()["workers"]}
    assert workers["host-a"]["alive"] is False and workers["host-b"]["alive"] is True

    for shot, job_id in zip(shots, ids, strict=True):
        reference = local_run(shot, tmp_path / f"local-{job_id}.h5")
        farm_cache = storage / "jobs" / job_id / "cache.h5"
        with h5py.File(farm_cache, "r") as a, h5py.File(reference, "r") as b:
            assert a.attrs["status"] == "complete"
            for name in ("frames/positions", "frames/velocities", "state/positions", "state/velocities"):
                assert np.array_equal(a[name][()], b[name][()]), f"{job_id} {name}"
    api.close()


def farm_routes(namespace: str) -> str:
    return subprocess.run(["ip", "netns", "exec", namespace, "ip", "route"], capture_output=True, text=True,
                          check=True).stdout

