"""The dashboard in a real browser: Debian's Chromium (/usr/bin/chromium, installed by
`make browser-deps`) driven by Playwright, against a real local stack (Redis, the API under
uvicorn, a worker process) with API keys, so the pages go through the key prompt and the
same auth as any client. Screenshots go to out/dashboard/ for people to look at."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Browser, Page, sync_playwright

from server.stack import Stack
from tests.dashboard.support import ALICE, BOB, CHROMIUM, CHROMIUM_ARGS, ENV, PageLog, context_with_key


@pytest.fixture(scope="module")
def stack(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Stack]:
    with Stack(tmp_path_factory.mktemp("dashboard"), workers=1, api_keys=[ALICE, BOB], env=ENV) as s:
        yield s


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    if not Path(CHROMIUM).exists() and not shutil.which(CHROMIUM):
        pytest.fail(f"no Chromium at {CHROMIUM}: run `make browser-deps` (Debian's chromium package)")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        yield b
        b.close()


@pytest.fixture()
def alice_page(browser: Browser) -> Iterator[tuple[Page, PageLog]]:
    context = context_with_key(browser, ALICE)
    page = context.new_page()
    yield page, PageLog(page)
    context.close()


@pytest.fixture()
def alice(stack: Stack) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=stack.url, headers={"Authorization": f"Bearer {ALICE}"}, timeout=30) as c:
        yield c
