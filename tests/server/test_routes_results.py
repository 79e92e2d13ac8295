"""server/routes/results.py: telemetry, the HDF5 cache, one frame's positions."""

from __future__ import annotations

import io
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
from routes_support import MISSING_JOB, Api, assert_error

from weft.jobstore import ServiceSettings


# -- GET /v1/jobs/{id}/telemetry ----------------------------------------------------------------
def test_telemetry_rows_and_since(alice: Api, finished_job: str) -> None:
    page = alice.get(f"/v1/jobs/{finished_job}/telemetry").json()
    assert page["job_id"] == finished_job
    assert [row["frame"] for row in page["rows"]] == [1, 2, 3, 4, 5]
    assert all(row["substeps"] > 0 for row in page["rows"][1:])
    later = alice.get(f"/v1/jobs/{finished_job}/telemetry", params={"since": 3}).json()["rows"]
    assert [row["frame"] for row in later] == [4, 5]


def test_telemetry_of_a_queued_job_is_empty(alice: Api) -> None:
    job_id = alice.submit()
    assert alice.get(f"/v1/jobs/{job_id}/telemetry").json() == {"job_id": job_id, "rows": []}


def test_telemetry_bad_since_or_id(alice: Api, bob: Api) -> None:
    job_id = alice.submit()
    assert_error(alice.get(f"/v1/jobs/{job_id}/telemetry", params={"since": "yesterday"}), 422, "query.since")
    assert_error(alice.get(f"/v1/jobs/{job_id}/telemetry", params={"since": 10**30}), 422, "query.since")
    assert_error(alice.get("/v1/jobs/abc/telemetry"), 422, "path.job_id")
    assert_error(bob.get(f"/v1/jobs/{job_id}/telemetry"), 404, "no job")


def test_telemetry_needs_a_key(check_auth: Callable[..., None], finished_job: str) -> None:
    check_auth("GET", f"/v1/jobs/{finished_job}/telemetry")


# -- GET /v1/jobs/{id}/cache --------------------------------------------------------------------
def test_cache_of_a_finished_job(alice: Api, finished_job: str, tmp_path: Path) -> None:
    r = alice.get(f"/v1/jobs/{finished_job}/cache")
    assert r.status_code == 200 and r.headers["content-type"] == "application/x-hdf5"
    assert f'filename="done-{finished_job[:8]}.h5"' in r.headers["content-disposition"]
    (tmp_path / "c.h5").write_bytes(r.content)
    with h5py.File(tmp_path / "c.h5", "r") as f:
        assert f.attrs["status"] == "complete" and f["frames/positions"].shape == (5, 36, 3)


def test_cache_of_a_running_job_is_a_snapshot(alice: Api, finished_job: str, settings: ServiceSettings,
                                             redis_db, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from weft import jobstore

    redis_db.hset(jobstore.job_key(finished_job), "state", "running")  # as seen mid-run
    r = alice.get(f"/v1/jobs/{finished_job}/cache")
    assert r.status_code == 200
    (tmp_path / "s.h5").write_bytes(r.content)
    with h5py.File(tmp_path / "s.h5", "r") as f:
        assert list(f["frames/frame"][()]) == [1, 2, 3, 4, 5] and int(f["state/frame_index"][0]) == 4
    assert list(settings.job_dir(finished_job).glob("snapshot-*.h5")) == [], "the snapshot is deleted once sent"


def test_cache_missing_bad_id_or_foreign(alice: Api, bob: Api, finished_job: str) -> None:
    queued = alice.submit()
    assert_error(alice.get(f"/v1/jobs/{queued}/cache"), 404, "no cached frames yet", "")
    assert_error(alice.get(f"/v1/jobs/{'g' * 32}/cache"), 422, "path.job_id")
    assert_error(bob.get(f"/v1/jobs/{finished_job}/cache"), 404, f"no job {finished_job}")
    assert_error(alice.get(f"/v1/jobs/{MISSING_JOB}/cache"), 404, "no job")


def test_cache_needs_a_key(check_auth: Callable[..., None], finished_job: str) -> None:
    check_auth("GET", f"/v1/jobs/{finished_job}/cache")


# -- GET /v1/jobs/{id}/frames/{n} ---------------------------------------------------------------
def test_frame_as_json_and_npy(alice: Api, finished_job: str, settings: ServiceSettings) -> None:
    with h5py.File(settings.cache_path(settings.job_dir(finished_job)), "r") as f:
        expected = f["frames/positions"][2]
    as_json = alice.get(f"/v1/jobs/{finished_job}/frames/3")
    assert as_json.status_code == 200 and as_json.json()["frame"] == 3
    assert np.array_equal(np.asarray(as_json.json()["positions"], dtype=np.float32), expected)
    for kw in ({"params": {"format": "npy"}}, {"headers": {"Accept": "application/x-npy"}}):
        as_npy = alice.get(f"/v1/jobs/{finished_job}/frames/3", **kw)
        assert as_npy.headers["content-type"] == "application/x-npy"
        assert np.array_equal(np.load(io.BytesIO(as_npy.content)), expected)


def test_frame_out_of_range_unsimulated_or_bad_field(alice: Api, bob: Api, finished_job: str) -> None:
    assert_error(alice.get(f"/v1/jobs/{finished_job}/frames/6"), 404, "outside the shot's frame range [1, 5]")
    assert_error(alice.get(f"/v1/jobs/{finished_job}/frames/0"), 404, "outside the shot's frame range")
    assert_error(alice.get(f"/v1/jobs/{alice.submit()}/frames/1"), 404, "not simulated yet (state queued)")
    assert_error(alice.get(f"/v1/jobs/{finished_job}/frames/first"), 422, "path.frame")
    assert_error(alice.get(f"/v1/jobs/{finished_job}/frames/1", params={"format": "exe"}), 422, "query.format")
    assert_error(bob.get(f"/v1/jobs/{finished_job}/frames/1"), 404, "no job")


def test_frame_needs_a_key(check_auth: Callable[..., None], finished_job: str) -> None:
    check_auth("GET", f"/v1/jobs/{finished_job}/frames/1")


def test_telemetry_with_a_non_finite_value_is_null_as_its_schema_says(alice: Api, settings: ServiceSettings,
                                                                     client) -> None:
    """Issue 15: /telemetry answered null where its schema said number (and, once events became
    strict JSON, a non-finite value would have failed the response). A diverged residual is
    null in the row, and the published schema allows null for the float fields."""

    from api_schemas import FrameTelemetry
    from weft import jobstore
    from workers.worker import Worker

    job_id = alice.submit()
    worker = Worker(settings, name="w-publisher")
    worker.redis.hset(jobstore.job_key(job_id), mapping={"state": "running", "worker": worker.name})
    values = {**{name: 0 for name in FrameTelemetry.model_fields}, "frame": 1, "substeps": 1}
    worker._publish(job_id, 0, 5, FrameTelemetry(**{**values, "final_residual": float("inf")}))
    worker.redis.close()
    page = alice.get(f"/v1/jobs/{job_id}/telemetry")
    assert page.status_code == 200 and page.json()["rows"][0]["final_residual"] is None
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    row = schemas["FrameTelemetryJson"]["properties"]
    assert {"type": "null"} in row["final_residual"]["anyOf"] and row["frame"]["type"] == "integer"


def test_a_shot_that_asks_for_usd_gets_it_from_its_worker(alice, bob, run_worker, settings, tmp_path) -> None:
    """outputs.usd (issue 18): the worker writes cache.usd when the shot succeeds; the API serves it."""
    from pxr import Usd, UsdGeom
    from routes_support import small_shot

    plain = alice.submit(small_shot("no-usd", frames=3))
    assert run_worker() == plain
    r = alice.get(f"/v1/jobs/{plain}/usd")
    assert r.status_code == 404 and "outputs.usd" in r.json()["detail"]
    job_id = alice.submit({**small_shot("with-usd", frames=3), "outputs": {"usd": True}})
    assert run_worker() == job_id
    assert bob.get(f"/v1/jobs/{job_id}/usd").status_code == 404
    r = alice.get(f"/v1/jobs/{job_id}/usd")
    assert r.status_code == 200 and r.headers["content-type"].startswith("model/vnd.usd")
    (tmp_path / "got.usd").write_bytes(r.content)
    stage = Usd.Stage.Open(str(tmp_path / "got.usd"))
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/weft/cloth/sheet"))
    assert mesh.GetPointsAttr().GetTimeSamples() == [1.0, 2.0, 3.0]
    log = [line["message"] for line in alice.get(f"/v1/jobs/{job_id}/log").json()["lines"]]
    assert any("wrote USD, frames 1-3" in m for m in log)
