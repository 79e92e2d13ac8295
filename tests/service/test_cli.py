"""The client commands and `weft up`, as a user runs them (real processes, real HTTP)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import httpx
import trimesh
import yaml

from server.stack import Stack, free_port
from scenes.builders import grid_sheet

from .conftest import ALICE, slow_shot, small_shot, wait_for

WEFT = str(Path(sys.executable).with_name("weft"))


def shot_files(directory: Path, frames: int = 8) -> Path:
    """A shot file with its mesh in a sub-folder, as users write them."""
    vertices, faces = grid_sheet(6, 6, 0.4, 0.4)
    (directory / "meshes").mkdir(parents=True)
    trimesh.Trimesh(vertices, faces, process=False).export(directory / "meshes" / "sheet.obj")
    shot = small_shot("cli", frames=frames)
    shot["cloth"][0]["mesh"] = {"path": "meshes/sheet.obj"}
    shot["cloth"][0]["pins"] = [{"vertices": [0, 5]}]
    path = directory / "shot.yaml"
    path.write_text(yaml.safe_dump(shot))
    return path


def weft(*args: str, env: dict[str, str], timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run([WEFT, *args], env=env, capture_output=True, text=True, timeout=timeout)


def test_submit_wait_status_fetch_cancel(stack: Stack, tmp_path: Path) -> None:
    env = {**os.environ, "WEFT_SERVER": stack.url, "WEFT_API_KEY": ALICE, "COLUMNS": "200"}
    shot = shot_files(tmp_path)
    done = weft("submit", str(shot), "--wait", env=env)
    assert done.returncode == 0, done.stderr + done.stdout
    job_id = done.stdout.split()[1]
    assert "succeeded" in done.stdout and "mean s/frame" in done.stdout and "8 of 8" in done.stdout

    status = weft("status", job_id, "--json", env=env)
    assert status.returncode == 0 and json.loads(status.stdout)["state"] == "succeeded"
    fetched = weft("fetch", job_id, "-o", str(tmp_path / "out" / "cache.h5"), env=env)
    assert fetched.returncode == 0, fetched.stderr
    with h5py.File(tmp_path / "out" / "cache.h5", "r") as f:
        assert f["frames/positions"].shape == (8, 36, 3)
    late = weft("cancel", job_id, env=env)
    assert late.returncode != 0 and "already succeeded" in late.stderr

    running = httpx.post(stack.url + "/v1/jobs", json=slow_shot("cli-cancel", frames=300),
                         headers={"Authorization": f"Bearer {ALICE}"}).json()["id"]
    cancelled = weft("cancel", running, env=env)
    assert cancelled.returncode == 0 and running in cancelled.stdout
    wait_for(lambda: json.loads(weft("status", running, "--json", env=env).stdout)["state"] == "cancelled",
             what="the job to be cancelled")
    retried = weft("retry", running, env=env)
    assert retried.returncode == 0 and "continuing after frame" in retried.stdout, retried.stderr
    assert json.loads(weft("status", running, "--json", env=env).stdout)["state"] in ("queued", "running")
    assert weft("cancel", running, env=env).returncode == 0  # not left running for the other tests
    refused_retry = weft("retry", job_id, env=env)
    assert refused_retry.returncode != 0 and "only failed or cancelled" in refused_retry.stderr

    bad = weft("status", "f" * 32, env=env)
    assert bad.returncode != 0 and "HTTP 404" in bad.stderr
    nokey = weft("status", job_id, env={**env, "WEFT_API_KEY": "wrong"})
    assert nokey.returncode != 0 and "unknown API key" in nokey.stderr
    invalid = tmp_path / "invalid.json"
    invalid.write_text(json.dumps({**small_shot(), "fps": -1}))
    refused = weft("submit", str(invalid), env=env)
    assert refused.returncode != 0 and "fps" in refused.stderr


def test_a_batch_its_listing_logs_and_deletion(stack: Stack, tmp_path: Path) -> None:
    env = {**os.environ, "WEFT_SERVER": stack.url, "WEFT_API_KEY": ALICE, "COLUMNS": "80"}  # a narrow terminal
    shots = []
    for k in range(2):
        path = shot_files(tmp_path / f"shot{k}", frames=4)
        shots.append(path)
    done = weft("submit", *map(str, shots), "--batch", "seq010", "--tag", "show:coco", "--priority", "70", "--wait",
                env=env)
    assert done.returncode == 0, done.stderr + done.stdout
    assert "batch seq010: 2 jobs" in done.stdout
    listed = weft("jobs", "--tag", "batch:seq010", "--json", env=env)
    page = json.loads(listed.stdout)
    assert page["total"] == 2 and all(j["tags"] == ["batch:seq010", "show:coco"] and j["priority"] == 70
                                      for j in page["jobs"])
    ids = [j["id"] for j in page["jobs"]]
    table = weft("jobs", "--tag", "batch:seq010", env=env).stdout
    assert all(job_id in table for job_id in ids), "full ids, even on a narrow terminal"

    log = weft("logs", ids[0], env=env)
    assert log.returncode == 0 and f"job {ids[0]} started on worker" in log.stdout and "succeeded" in log.stdout
    deleted = weft("delete", ids[0], env=env)
    assert deleted.returncode == 0 and "deleted" in deleted.stdout
    assert json.loads(weft("jobs", "--tag", "batch:seq010", "--json", env=env).stdout)["total"] == 1
    again = weft("delete", ids[0], env=env)
    assert again.returncode != 0 and "HTTP 404" in again.stderr
    clash = weft("submit", *map(str, shots), "--idempotency-key", "k", env=env)
    assert clash.returncode != 0 and "--idempotency-key is for one shot" in clash.stderr


def test_weft_up_serves_and_stops_cleanly(tmp_path: Path) -> None:
    port = free_port()
    env = {**os.environ, "WEFT_HOME": str(tmp_path / "home"), "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}
    env.pop("WEFT_SERVER", None)
    env.pop("WEFT_API_KEY", None)
    # Started as a non-interactive shell starts a background job: with SIGINT ignored, which
    # Python would otherwise inherit (no KeyboardInterrupt); `weft up` must still stop on it.
    up = subprocess.Popen([WEFT, "up", "--workers", "1", "--port", str(port), "--storage", str(tmp_path / "svc")],
                          env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        assert up.stdout is not None
        first = up.stdout.readline()
        assert f"http://127.0.0.1:{port}" in first, first
        assert httpx.get(f"http://127.0.0.1:{port}/readyz").status_code == 200
        # Client commands find the local stack without --server, and local mode needs no key.
        done = weft("submit", str(shot_files(tmp_path / "shot", frames=5)), "--wait", env=env)
        assert done.returncode == 0 and "succeeded" in done.stdout, done.stderr
        assert (tmp_path / "home" / "stack.json").exists()
    finally:
        up.send_signal(signal.SIGINT)
        try:
            up.wait(timeout=30)
        except subprocess.TimeoutExpired:
            up.kill()
            raise AssertionError(f"weft up still ran 30 s after Ctrl-C; it printed:\n{up.communicate()[0]}") from None
    output = up.communicate()[0]
    assert up.returncode == 0, output
    assert "did not stop" not in output, output  # every process stopped on SIGTERM, none was killed
    assert not (tmp_path / "home" / "stack.json").exists()
    try:
        httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1)
        raise AssertionError("the API still answers after Ctrl-C")
    except httpx.ConnectError:
        pass
    # No child outlived it: nothing runs with the stack's storage folder on its command line.
    leftovers = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit():
            try:
                cmdline = (proc / "cmdline").read_bytes().replace(b"\0", b" ").decode()
            except OSError:
                continue
            if str(tmp_path / "svc") in cmdline:
                leftovers.append(cmdline)
    assert leftovers == []
