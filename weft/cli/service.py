"""`weft up`, `weft submit`, `weft status`, `weft jobs`, `weft fetch`, `weft cancel`, `weft retry`,
`weft delete`, `weft logs`, `weft demo`:
the simulation service from the command line.

Client commands find the server through ``--server`` or ``WEFT_SERVER``, else the stack that
`weft up` started (``$WEFT_HOME/stack.json``, WEFT_HOME defaulting to ``~/.weft``), and send
the API key from ``WEFT_API_KEY``.
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import httpx
import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from weft.cli.common import console, fail, out, shot_errors

app = typer.Typer()

DEFAULT_PORT = 8421
ServerOption = Annotated[
    str | None, typer.Option("--server", envvar="WEFT_SERVER", help="API URL (default: the local stack)")
]


def weft_home() -> Path:
    return Path(os.environ.get("WEFT_HOME", Path.home() / ".weft"))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):
        return False
    return True


def default_server() -> str:
    stack_file = weft_home() / "stack.json"
    try:
        info = json.loads(stack_file.read_text())
        if _pid_alive(int(info["pid"])):
            return str(info["url"])
    except (OSError, ValueError, KeyError):
        pass
    return f"http://127.0.0.1:{DEFAULT_PORT}"


@contextmanager
def api(server: str | None) -> Iterator[httpx.Client]:
    url = (server or default_server()).rstrip("/")
    key = os.environ.get("WEFT_API_KEY")
    headers = {"Authorization": f"Bearer {key}"} if key else {}
    with httpx.Client(base_url=url, headers=headers, timeout=httpx.Timeout(60, connect=5)) as client:
        try:
            yield client
        except httpx.ConnectError:
            fail(f"cannot reach the weft server at {url} (is `weft up` running? set --server or WEFT_SERVER)")
        except httpx.HTTPError as exc:
            fail(f"request to {url} failed: {exc}")


def checked(response: httpx.Response) -> Any:
    if response.status_code < 400:
        return response.json()
    try:
        body = response.json()
        detail = body.get("detail", response.text)
        errors = [f"  {e.get('field') or '-'}: {e.get('problem')}" for e in body.get("errors", [])]
    except ValueError:
        detail, errors = response.text, []
    fail(f"HTTP {response.status_code}: {detail}" + ("\n" + "\n".join(errors) if len(errors) > 1 else ""))


def follow_job(client: httpx.Client, job_id: str, total: int, label: str) -> dict[str, Any]:
    """Follow the job's event stream with a progress bar; returns the final 'end' event's data.
    Reconnects with Last-Event-ID if the connection drops."""
    from httpx_sse import connect_sse

    progress = Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(), console=console,
    )
    last_id: str | None = None
    with progress:
        task = progress.add_task(label, total=total, info="queued")
        while True:
            headers = {"Last-Event-ID": last_id} if last_id else {}
            try:
                with connect_sse(client, "GET", f"/v1/jobs/{job_id}/events", headers=headers,
                                 timeout=httpx.Timeout(30, read=120)) as source:
                    if source.response.status_code >= 400:
                        source.response.read()
                        checked(source.response)
                    for sse in source.iter_sse():
                        if not sse.data:
                            continue
                        last_id = sse.id or last_id
                        data = json.loads(sse.data)
                        if sse.event == "frame":
                            progress.update(task, completed=data["index"] + 1,
                                            info=f"frame {data['frame']}  {data['total_seconds']:.3f} s")
                        elif sse.event == "resumed":
                            progress.update(task, info=f"resumed from frame {data['resumed_from_frame']}")
                        elif sse.event == "end":
                            return data  # type: ignore[no-any-return]
            except (httpx.ReadTimeout, httpx.RemoteProtocolError, httpx.ReadError):
                time.sleep(0.5)


def print_job(job: dict[str, Any]) -> None:
    table = Table(title=f"job {job['id']}", show_header=False, title_justify="left")
    table.add_row("shot", job["name"])
    table.add_row("state", job["state"])
    table.add_row("frames", f"{job['frames_done']} of {job['frames_total']} ({job['frame_range'][0]}-{job['frame_range'][1]})")
    table.add_row("vertices", str(job["vertices"]))
    table.add_row("worker", job["worker"] or "-")
    if job["resumed_from"] is not None:
        table.add_row("resumed from frame", str(job["resumed_from"]))
    if job["started"] and job["finished"]:
        table.add_row("wall time", f"{job['finished'] - job['started']:.2f} s")
    if job["timing"]:
        t = job["timing"]
        table.add_row(
            "mean s/frame",
            f"build {t['build_seconds']:.4f}  solve {t['solve_seconds']:.4f}  collision {t['collision_seconds']:.4f}  "
            f"GIA {t['gia_seconds']:.4f}  total {t['total_seconds']:.4f}",
        )
    if job["error"]:
        frame = job["error"]["frame"]
        table.add_row("error", (f"frame {frame}: " if frame is not None else "") + job["error"]["reason"])
    table.add_row("url", job["url"])
    out.print(table)


def submit_shot(client: httpx.Client, shot_path: Path, idempotency_key: str | None = None,
                params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Upload a shot file and the asset files it references (multipart); params: the job's
    priority, pool and tags (query parameters of POST /v1/jobs)."""
    import yaml

    from weft.assets import asset_paths
    from weft.shot import load_shot_file

    with shot_errors(shot_path):
        shot = load_shot_file(shot_path)
    document = yaml.safe_load(shot_path.read_text()) if shot_path.suffix.lower() in {".yaml", ".yml"} else json.loads(shot_path.read_text())
    files: list[tuple[str, Any]] = [("shot", ("shot.json", json.dumps(document, default=str), "application/json"))]
    handles = []
    try:
        for relative in sorted(asset_paths(shot)):
            path = shot_path.parent / relative
            if not path.is_file():
                fail(f"{shot_path}: asset {relative} not found next to the shot")
            handles.append(open(path, "rb"))  # noqa: SIM115 - closed below
            files.append(("assets", (relative, handles[-1], "application/octet-stream")))
        headers = {"Idempotency-Key": idempotency_key} if idempotency_key else {}
        return checked(client.post("/v1/jobs", files=files, headers=headers, params=params))  # type: ignore[no-any-return]
    finally:
        for h in handles:
            h.close()


@app.command()
def submit(
    shots: Annotated[list[Path], typer.Argument(help="Shot files (.json/.yaml); their assets are uploaded with them")],
    wait: Annotated[bool, typer.Option("--wait", help="Follow the jobs to the end with a progress bar")] = False,
    priority: Annotated[int, typer.Option("--priority", min=0, max=100, help="0-100, higher runs first")] = 50,
    pool: Annotated[str, typer.Option("--pool", help="Worker pool to run on (workers serve WEFT_POOLS)")] = "default",
    tags: Annotated[list[str] | None, typer.Option("--tag", help="Tag to find the jobs by (repeatable), e.g. show:coco")]
    = None,
    batch: Annotated[str | None, typer.Option("--batch", help="Batch name: tags every job batch:NAME (several shots "
                                                              "get a generated one)")] = None,
    idempotency_key: Annotated[str | None, typer.Option("--idempotency-key", help="Makes a resubmit safe (one shot)")]
    = None,
    server: ServerOption = None,
) -> None:
    """Submit one or more shots to the simulation service (several: one batch)."""
    import uuid

    if idempotency_key and len(shots) > 1:
        fail("--idempotency-key is for one shot; a batch gets one key per shot from --batch")
    if batch is None and len(shots) > 1:
        batch = uuid.uuid4().hex[:8]
    all_tags = sorted(set(tags or []) | ({f"batch:{batch}"} if batch else set()))
    params = {"priority": priority, "pool": pool, "tag": all_tags}
    ids: list[str] = []
    with api(server) as client:
        for number, shot in enumerate(shots):
            key = idempotency_key or (f"batch-{batch}-{number}" if batch else None)
            created = submit_shot(client, shot, key, params)
            ids.append(created["id"])
            out.print(f"job {created['id']} {'(existing) ' if created.get('duplicate') else ''}{created['url']}")
        if batch:
            out.print(f"batch {batch}: {len(ids)} jobs (weft jobs --tag batch:{batch})")
        if not wait:
            return
        failed = False
        for job_id in ids:
            job = checked(client.get(f"/v1/jobs/{job_id}"))
            end = follow_job(client, job_id, job["frames_total"], job["name"])
            print_job(checked(client.get(f"/v1/jobs/{job_id}")))
            failed |= end["state"] != "succeeded"
        if failed:
            raise typer.Exit(1)


@app.command()
def status(
    job_id: Annotated[str, typer.Argument(help="Job id")],
    as_json: Annotated[bool, typer.Option("--json", help="Machine-readable output")] = False,
    server: ServerOption = None,
) -> None:
    """Show a job's state, progress and timing."""
    with api(server) as client:
        job = checked(client.get(f"/v1/jobs/{job_id}"))
    if as_json:
        out.print_json(json.dumps(job))
    else:
        print_job(job)


@app.command()
def jobs(
    state: Annotated[str | None, typer.Option("--state", help="queued, running, succeeded, failed, cancelled")] = None,
    name: Annotated[str | None, typer.Option("--name", help="Name contains this text")] = None,
    tag: Annotated[str | None, typer.Option("--tag", help="Has this tag (a batch: batch:NAME)")] = None,
    limit: Annotated[int, typer.Option("--limit", min=1, max=500)] = 20,
    offset: Annotated[int, typer.Option("--offset", min=0)] = 0,
    as_json: Annotated[bool, typer.Option("--json", help="The API's JSON page (full records)")] = False,
    server: ServerOption = None,
) -> None:
    """List your jobs (an admin key: everyone's), newest first."""
    params: dict[str, Any] = {"limit": limit, "offset": offset}
    for key, value in (("state", state), ("name", name), ("tag", tag)):
        if value:
            params[key] = value
    with api(server) as client:
        listing = checked(client.get("/v1/jobs", params=params))
    if as_json:
        out.print_json(json.dumps(listing))
        return
    table = Table(title=f"{listing['total']} jobs", title_justify="left")
    table.add_column("id", no_wrap=True, min_width=32)
    for column in ("shot", "state", "frames", "priority", "pool", "worker", "tags"):
        table.add_column(column)
    for job in listing["jobs"]:
        table.add_row(job["id"], job["name"], job["state"], f"{job['frames_done']}/{job['frames_total']}",
                      str(job["priority"]), job["pool"], job["worker"] or "-", " ".join(job["tags"]))
    out.print(table)


@app.command()
def delete(job_id: Annotated[str, typer.Argument(help="Job id")], server: ServerOption = None) -> None:
    """Delete a finished job: its record, events, log, assets and cache."""
    with api(server) as client:
        response = client.delete(f"/v1/jobs/{job_id}")
        if response.status_code != 204:
            checked(response)
    out.print(f"job {job_id} deleted")


@app.command()
def logs(job_id: Annotated[str, typer.Argument(help="Job id")], server: ServerOption = None) -> None:
    """The log lines workers wrote while running the job."""
    with api(server) as client:
        lines = checked(client.get(f"/v1/jobs/{job_id}/log", params={"limit": 10_000}))["lines"]
    for line in lines:
        stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(line["time"]))
        typer.echo(f"{stamp} {line['worker']} {line['level']}: {line['message']}")  # plain lines, for grep


@app.command()
def fetch(
    job_id: Annotated[str, typer.Argument(help="Job id")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Where to write the HDF5 cache")],
    server: ServerOption = None,
) -> None:
    """Download a job's HDF5 cache (while running: the frames finished so far)."""
    with api(server) as client, client.stream("GET", f"/v1/jobs/{job_id}/cache") as response:
        if response.status_code >= 400:
            response.read()
            checked(response)
        output.parent.mkdir(parents=True, exist_ok=True)
        partial = output.with_name(output.name + ".download")
        with open(partial, "wb") as f:
            for chunk in response.iter_bytes():
                f.write(chunk)
        partial.replace(output)
    out.print(f"wrote {output}")


@app.command()
def cancel(job_id: Annotated[str, typer.Argument(help="Job id")], server: ServerOption = None) -> None:
    """Cancel a job (a running job stops after its current frame)."""
    with api(server) as client:
        job = checked(client.post(f"/v1/jobs/{job_id}/cancel"))
    out.print(f"job {job_id}: {'cancelling' if job['state'] == 'running' else job['state']}")


@app.command()
def retry(job_id: Annotated[str, typer.Argument(help="Job id")], server: ServerOption = None) -> None:
    """Queue a failed or cancelled job again; it continues from its last finished frame."""
    with api(server) as client:
        job = checked(client.post(f"/v1/jobs/{job_id}/retry"))
    out.print(f"job {job_id}: {job['state']}, continuing after frame {job['frames_done']} of {job['frames_total']}")


def _start_stack(storage: Path | None, workers: int, port: int | None):  # type: ignore[no-untyped-def]
    from server.stack import Stack, free_port

    storage = storage or weft_home() / "service"
    if port is None:
        import socket

        with socket.socket() as s:
            port = DEFAULT_PORT if s.connect_ex(("127.0.0.1", DEFAULT_PORT)) != 0 else free_port()
    stack = Stack(storage, workers=workers, api_keys=None, port=port)
    try:
        stack.start()
    except BaseException:
        stack.stop()
        raise
    return stack


@app.command()
def up(
    workers: Annotated[int, typer.Option("--workers", min=0, max=64, help="Worker processes")] = 1,
    storage: Annotated[Path | None, typer.Option("--storage", help="Caches, uploads and Redis data (default: $WEFT_HOME/service)")] = None,
    port: Annotated[int | None, typer.Option("--port", help=f"API port (default {DEFAULT_PORT}, or a free one)")] = None,
) -> None:
    """Start the local service (Redis, the API in local mode on loopback, N workers) until Ctrl-C."""
    try:
        stack = _start_stack(storage, workers, port)
    except RuntimeError as exc:
        fail(str(exc))
    stack_file = weft_home() / "stack.json"
    stack_file.parent.mkdir(parents=True, exist_ok=True)
    stack_file.write_text(json.dumps({"url": stack.url, "pid": os.getpid(), "storage": str(stack.storage)}))
    out.print(f"weft service up: API {stack.url}  (docs {stack.url}/docs)  workers {workers}  storage {stack.storage}")
    out.print("press Ctrl-C to stop", style="dim")
    stopping: list[int] = []
    # Ctrl-C and SIGTERM both stop the stack. SIGINT gets its handler explicitly: a process
    # started in the background by a non-interactive shell inherits SIGINT ignored, and Python
    # then raises no KeyboardInterrupt (`kill -INT` would do nothing).
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(1))
    signal.signal(signal.SIGINT, lambda *_: stopping.append(1))
    try:
        while not stopping:
            if stack.api_proc is not None and stack.api_proc.poll() is not None:
                console.print("[red]the API process exited[/]")
                break
            if stack.redis_proc is not None and stack.redis_proc.poll() is not None:
                console.print("[red]redis-server exited[/]")
                break
            for proc in list(stack.workers):
                if proc.poll() is not None:  # a dead worker is replaced; its job resumes elsewhere
                    stack.workers.remove(proc)
                    stack.start_worker()
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        console.print("stopping the weft service...")
        stack.stop()
        stack_file.unlink(missing_ok=True)


@app.command()
def demo(
    workers: Annotated[int, typer.Option("--workers", min=1, max=16)] = 1,
    output: Annotated[Path, typer.Option("-o", "--output", help="Where to write the demo's cache")] = Path("out/demo_flag.h5"),
    shot: Annotated[Path, typer.Option("--shot")] = Path("scenes/generated/demo_flag.yaml"),
) -> None:
    """Start a local stack, submit the demo shot, follow it to the end, print its timing, stop."""
    stack = _start_stack(Path("out/service"), workers, None)
    try:
        out.print(f"weft service up: API {stack.url}  workers {workers}")
        with api(stack.url) as client:
            created = submit_shot(client, shot)
            job = checked(client.get(f"/v1/jobs/{created['id']}"))
            end = follow_job(client, job["id"], job["frames_total"], job["name"])
            print_job(checked(client.get(f"/v1/jobs/{job['id']}")))
            with client.stream("GET", f"/v1/jobs/{job['id']}/cache") as response:
                output.parent.mkdir(parents=True, exist_ok=True)
                with open(output, "wb") as f:
                    for chunk in response.iter_bytes():
                        f.write(chunk)
            out.print(f"cache: {output}")
        if end["state"] != "succeeded":
            raise typer.Exit(1)
    finally:
        stack.stop()
