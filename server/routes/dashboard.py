"""The dashboard: pages served by the API itself (``/ui/...``), no separate web server.

The pages are static HTML and JavaScript (``server/static/``, charts by the vendored uPlot);
they hold no data. Their scripts read everything from the JSON API and the job's event stream
with the same API key as any client (asked for once, kept in the browser's session storage;
not needed in local mode), so the pages see exactly what the key may see.
"""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, FastAPI
from fastapi.responses import FileResponse, RedirectResponse
from fastapi.staticfiles import StaticFiles

STATIC = Path(__file__).resolve().parent.parent / "static"

# Pages and their scripts come from this server only; the API is the only thing they connect to.
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; "
                               "script-src 'self'; connect-src 'self'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-cache",
}

router = APIRouter(include_in_schema=False)


def page(name: str) -> FileResponse:
    return FileResponse(STATIC / name, media_type="text/html", headers=SECURITY_HEADERS)


@router.get("/")
@router.get("/ui")
@router.get("/ui/")
@router.get("/dashboard")
async def dashboard_home() -> RedirectResponse:
    return RedirectResponse("/ui/jobs", status_code=307)


@router.get("/ui/jobs")
async def jobs_page() -> FileResponse:
    return page("jobs.html")


@router.get("/ui/jobs/{job_id}")
async def job_page(job_id: str) -> FileResponse:
    """Any id gets the page; its script asks the API and shows what it answers (an unknown or
    foreign job, a malformed id) as a message on the page."""
    return page("job.html")


@router.get("/ui/compare")
async def compare_page() -> FileResponse:
    return page("compare.html")


@router.get("/ui/workers")
async def workers_page() -> FileResponse:
    return page("workers.html")


@router.get("/favicon.ico")
async def favicon() -> FileResponse:
    return FileResponse(STATIC / "favicon.svg", media_type="image/svg+xml")


class _StaticFiles(StaticFiles):
    """Static files with the pages' security headers."""

    async def get_response(self, path: str, scope):  # type: ignore[no-untyped-def]
        response = await super().get_response(path, scope)
        response.headers.update(SECURITY_HEADERS)
        return response


def mount_static(app: FastAPI) -> None:
    app.mount("/ui/static", _StaticFiles(directory=STATIC), name="dashboard-static")
