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


FailureKind = Literal["solver", "shot", "worker_lost", "error"]


class JobError(ApiModel):
    frame: int | None = Field(None, description="Frame at which the solver failed, if it did.")
    reason: str
    kind: FailureKind | None = Field(
        None, description="solver: the solve failed (diverged, non-finite); shot: its inputs could not be loaded; "
                          "worker_lost: its workers kept dying; error: anything else.")


class Job(ApiModel):
    id: str
    url: str
    name: str
    state: JobState
    priority: int = Field(50, description="0-100; a higher priority runs first.")
    pool: str = Field("default", description="The worker pool that runs it.")
    tags: list[str] = Field(default_factory=list)
    owner: str | None = Field(None, description="The submitting key's owner id (shown to admin keys only).")
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


class QueueSample(ApiModel):
    time: float = Field(description="Unix time of the sample.")
    queued: int
    running: int
    workers_alive: int
    workers_busy: int


class QueueStatus(ApiModel):
    """The farm's queue: counts over every key (no job of another key is named)."""

    jobs: dict[str, int] = Field(description="Jobs by state.")
    oldest_queued_seconds: float | None = Field(
        None, description="How long the longest-waiting queued job has waited (since submission or retry).")
    workers_alive: int
    workers_busy: int
    history: list[QueueSample] = Field(
        description="Samples taken every few seconds by the API (WEFT_QUEUE_SAMPLE_SECONDS), oldest first.")


class PieceSummary(ApiModel):
    name: str
    collide: bool = Field(description="Collides with the bodies.")
    self_collide: bool = Field(description="Takes part in cloth/cloth collision.")


class ShotSummary(ApiModel):
    """What a job's shot asks for, without its meshes: the dashboard's shot panel."""

    job_id: str
    name: str
    fps: float
    substeps: int
    frame_range: tuple[int, int]
    vertices: int
    pieces: list[PieceSummary]
    bodies: list[str] = Field(description="Collidable bodies.")
    features: dict[str, str] = Field(
        description="Each physics feature and whether the shot turns it on ('on', 'off', or 'auto: ...' when the "
                    "solver decides at setup).")


class LogLine(ApiModel):
    id: str = Field(description="Line id: pass it as 'since' to get only later lines.")
    time: float
    level: str
    worker: str
    message: str


class JobLog(ApiModel):
    job_id: str
    lines: list[LogLine]
