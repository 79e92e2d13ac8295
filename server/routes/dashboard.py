"""The dashboard: pages served by the API itself (``/ui/...``), no separate web server.

The pages are HTML (``server/static/pages/``, each page's ``<main>``, put into
``server/static/layout.html``) and JavaScript (``server/static/``, charts by the vendored uPlot);
they hold no data. Their scripts read everything from the JSON API and the job's event stream
with the same API key as any client (asked for once, kept in the browser's session storage;
not needed in local mode), so the pages see exactly what the key may see.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from string import Template

from fastapi import APIRouter, FastAPI
from fastapi.responses import FileResponse, HTMLResponse, RedirectResponse
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


@dataclass(frozen=True)
class Page:
    title: str
    nav: str  # the navigation entry it belongs to
    charts: bool  # loads uPlot
    script: str


PAGES = {
    "jobs": Page("jobs", "jobs", False, "jobs.js"),
    "job": Page("job", "jobs", True, "job.js"),
    "compare": Page("compare", "jobs", True, "compare.js"),
    "workers": Page("workers and queue", "workers", True, "workers.js"),
}
NAV = {"jobs": ("/ui/jobs", "Jobs"), "workers": ("/ui/workers", "Workers &amp; queue")}


@lru_cache(maxsize=None)
def render(name: str) -> str:
    """A page: the shared layout (head, navigation, scripts) around the page's own <main>."""
    page = PAGES[name]
    current = ' aria-current="page"'
    links = " ".join(f'<a href="{href}"{current if key == page.nav else ""}>{label}</a>'
                     for key, (href, label) in NAV.items())
    scripts = (["/ui/static/vendor/uplot/uPlot.iife.min.js"] if page.charts else []) + \
        ["/ui/static/common.js", f"/ui/static/{page.script}"]
    return Template((STATIC / "layout.html").read_text()).substitute(
        title=page.title,
        styles='  <link rel="stylesheet" href="/ui/static/vendor/uplot/uPlot.min.css">' if page.charts else "",
        links=links,
        main="\n".join(f"  {line}" if line else line for line in (STATIC / "pages" / f"{name}.html").read_text().splitlines()),
        scripts="\n".join(f'  <script src="{src}"></script>' for src in scripts),
    )


def page(name: str) -> HTMLResponse:
    return HTMLResponse(render(name), headers=SECURITY_HEADERS)


@router.get("/")
@router.get("/ui")
@router.get("/ui/")
@router.get("/dashboard")
async def dashboard_home() -> RedirectResponse:
    return RedirectResponse("/ui/jobs", status_code=307)


@router.get("/ui/jobs")
async def jobs_page() -> HTMLResponse:
    return page("jobs")


@router.get("/ui/jobs/{job_id}")
async def job_page(job_id: str) -> HTMLResponse:
    """Any id gets the page; its script asks the API and shows what it answers (an unknown or
    foreign job, a malformed id) as a message on the page."""
    return page("job")


@router.get("/ui/compare")
async def compare_page() -> HTMLResponse:
    return page("compare")


@router.get("/ui/workers")
async def workers_page() -> HTMLResponse:
    return page("workers")


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
