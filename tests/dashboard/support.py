"""Helpers of the dashboard's browser tests (tests/dashboard/conftest.py has the fixtures)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import httpx
from playwright.sync_api import Browser, BrowserContext, ConsoleMessage, Page

from scenes.builders import sheet_shot

ALICE, BOB = "alice-key-0123456789", "bob-key-9876543210"
SCREENSHOTS = Path(__file__).resolve().parents[2] / "out" / "dashboard"
CHROMIUM = os.environ.get("WEFT_CHROMIUM", "/usr/bin/chromium")
# As the machine's probe starts it: no sandbox (root), no GPU, and none of Chromium's own
# network traffic (the test machines reach only package registries).
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage"]
ENV = {
    "WEFT_HEARTBEAT_SECONDS": "0.3",
    "WEFT_CLAIM_AFTER_SECONDS": "2.0",
    "WEFT_SOLVER_THREADS": "1",
    "WEFT_QUEUE_SAMPLE_SECONDS": "0.5",
}


def running_shot(name: str, frames: int) -> dict[str, Any]:
    """About 30-50 ms a frame on one core: a shot the page can follow while it runs."""
    return sheet_shot(name, 16, 16, 0.5, 0.5, pins=[0, 15], frames=frames, substeps=8)


class PageLog:
    """Console errors and uncaught exceptions of a page."""

    def __init__(self, page: Page) -> None:
        self.errors: list[str] = []
        page.on("console", self._console)
        page.on("pageerror", lambda exc: self.errors.append(f"uncaught: {exc}"))

    def _console(self, message: ConsoleMessage) -> None:
        if message.type == "error":
            self.errors.append(message.text)


def context_with_key(browser: Browser, key: str | None) -> BrowserContext:
    """A browser context whose session already holds the key (as after the prompt)."""
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    if key is not None:
        context.add_init_script(f"sessionStorage.setItem('weft.apiKey', {key!r})")
    return context


def submit(c: httpx.Client, shot: dict[str, Any], **params: Any) -> str:
    r = c.post("/v1/jobs", json=shot, params=params)
    assert r.status_code == 201, r.text
    return str(r.json()["id"])


def screenshot(page: Page, name: str) -> Path:
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    path = SCREENSHOTS / f"{name}.png"
    page.screenshot(path=str(path), full_page=True)
    return path
