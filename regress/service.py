"""Regression scenes through a running service: each scene's shot uploaded with its assets
(with an idempotency key, so a retried submission never runs twice), followed through its event
stream, its HDF5 cache fetched."""

from __future__ import annotations

import uuid
from pathlib import Path

from regress.runs import Run, read_cache


def run_through_service(server: str, names: list[str], shots: dict[str, Path], work: Path) -> dict[str, Run]:
    """Submits every scene first (the workers take them in parallel), then follows each to its
    end and fetches its cache into `work/<scene>.h5`."""
    from weft.cli.service import api, checked, follow_job, submit_shot

    batch = uuid.uuid4().hex[:12]
    runs: dict[str, Run] = {}
    with api(server) as client:
        jobs = {name: submit_shot(client, shots[name], idempotency_key=f"regress-{batch}-{name}")["id"]
                for name in names}
        for name in names:
            job = checked(client.get(f"/v1/jobs/{jobs[name]}"))
            follow_job(client, jobs[name], job["frames_total"], name)
            cache = work / f"{name}.h5"
            with client.stream("GET", f"/v1/jobs/{jobs[name]}/cache") as response:
                if response.status_code >= 400:
                    response.read()
                    checked(response)
                with open(cache, "wb") as f:
                    for chunk in response.iter_bytes():
                        f.write(chunk)
            runs[name] = read_cache(cache)
            job = checked(client.get(f"/v1/jobs/{jobs[name]}"))
            if job["state"] != "succeeded" and runs[name].failure is None:
                error = job.get("error") or {}
                runs[name].failure = f"job {job['state']}: {error.get('reason', '')}"
    return runs
