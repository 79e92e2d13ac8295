"""Models of the simulation service's HTTP API (`server/`), shared with the CLI client."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from api_schemas.telemetry import FrameTelemetryJson

JobState = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class ApiModel(BaseModel):
    model_config = ConfigDict(extra="forbid")


class TimingSummary(ApiModel):
    """Mean wall seconds per simulated frame (the initial frame is not simulated)."""

    frames: int = Field(description="Simulated frames the means are over.")
    build_seconds: float
    solve_seconds: float
    collision_seconds: float
    gia_seconds: float
    total_seconds: float


class JobError(ApiModel):
    frame: int | None = Field(None, description="Frame at which the solver failed, if it did.")
    reason: str


class Job(ApiModel):
    id: str
    url: str
    name: str
    state: JobState
    frames_done: int
    frames_total: int
    frame_range: tuple[int, int]
    vertices: int
    worker: str | None = None
    attempts: int = Field(0, description="How many times a worker started (or resumed) the job.")
    resumed_from: int | None = Field(None, description="Last finished frame a resumed run continued from.")
    cancel_requested: bool = False
    created: float
    started: float | None = None
    finished: float | None = None
    timing: TimingSummary | None = None
    error: JobError | None = None


class JobCreated(ApiModel):
    id: str
    url: str
    state: JobState
    duplicate: bool = Field(False, description="True when an earlier submission with the same idempotency key is returned.")


class JobList(ApiModel):
    jobs: list[Job]
    total: int = Field(description="Jobs matching the filter.")
    offset: int
    limit: int
    next_offset: int | None


class TelemetryPage(ApiModel):
    job_id: str
    rows: list[FrameTelemetryJson]  # type: ignore[valid-type]


class WorkerInfo(ApiModel):
    name: str
    host: str
    pid: int
    alive: bool
    heartbeat: float
    seconds_since_heartbeat: float
    job: str | None = Field(None, description="Current job id (only shown for the caller's own jobs).")


class WorkerList(ApiModel):
    workers: list[WorkerInfo]


class FramePositions(ApiModel):
    job_id: str
    frame: int
    positions: list[tuple[float | None, float | None, float | None]] = Field(
        description="Per-vertex positions (float32 precision); null where a coordinate is not finite."
    )


class ErrorDetail(ApiModel):
    field: str | None = None
    problem: str


class ErrorResponse(ApiModel):
    detail: str
    errors: list[ErrorDetail] = Field(default_factory=list)
