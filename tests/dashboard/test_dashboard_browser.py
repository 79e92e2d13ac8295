"""The dashboard pages in Chromium (issue 16): a job page follows a running shot and shows what
/telemetry says, the jobs page filters and compares, the workers page shows the farm, bad ids
and foreign jobs render clear messages, the key prompt, and the event stream coming back
after the API restarts."""

from __future__ import annotations

import re
import time
from pathlib import Path

import h5py
import httpx
import numpy as np
from playwright.sync_api import Browser, Page, expect

from scenes.builders import sheet_shot
from server.stack import Stack
from tests.dashboard.support import ALICE, BOB, PageLog, context_with_key, running_shot, screenshot, submit

FINAL = ("succeeded", "failed", "cancelled")


def wait_state(c: httpx.Client, job_id: str, states: tuple[str, ...], timeout: float = 120) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        job = c.get(f"/v1/jobs/{job_id}").json()
        if job["state"] in states:
            return job
        time.sleep(0.1)
    raise AssertionError(f"job {job_id} never reached {states}")


def card(page: Page, field: str) -> str:
    return page.locator(f'[data-field="{field}"] .value').inner_text()


def test_job_page_follows_a_running_shot_and_shows_its_telemetry(
    stack: Stack, alice: httpx.Client, alice_page: tuple[Page, PageLog], tmp_path: Path,
) -> None:
    page, log = alice_page
    frames = 200  # about 25 ms a frame: the page follows it for a few seconds
    job_id = submit(alice, running_shot("followed", frames))
    wait_state(alice, job_id, ("running",))
    page.goto(f"{stack.url}/ui/jobs/{job_id}")
    page.wait_for_function("() => window.weftDashboard.stream === 'live'")
    opened = time.time()
    page.wait_for_function(f"() => weftDashboard.state === 'succeeded' && weftDashboard.framesShown === {frames}",
                           timeout=120_000)
    rows = alice.get(f"/v1/jobs/{job_id}/telemetry").json()["rows"]
    assert len(rows) == frames

    # The charts hold exactly the telemetry's numbers.
    data = page.evaluate("""() => Object.fromEntries(Object.entries(weftDashboard.charts)
                                   .map(([name, chart]) => [name, chart.plot.data]))""")
    assert data["cg"][0] == [r["frame"] for r in rows]
    assert data["cg"][1] == [r["cg_iterations"] for r in rows]
    assert data["energy"][1] == [r["kinetic_energy"] for r in rows]
    build, solve = data["seconds"][1], data["seconds"][2]  # stacked: solve drawn on top of build
    assert build == [r["build_seconds"] for r in rows]
    assert np.allclose(np.subtract(solve, build), [r["solve_seconds"] for r in rows], atol=1e-12)
    whole = np.array(data["seconds"][5])  # build + solve + collisions + GIA + other = the step
    assert np.allclose(whole, [r["total_seconds"] for r in rows], rtol=1e-9, atol=1e-12)

    # The summary agrees with the job record and the telemetry.
    assert card(page, "frames") == f"{frames} / {frames}"
    simulated = [r for r in rows if r["substeps"] > 0]
    shown_cg = float(card(page, "cg_iterations").replace(",", ""))
    assert abs(shown_cg - np.mean([r["cg_iterations"] for r in simulated])) <= 0.05
    assert page.locator("#job-state").inner_text() == "succeeded"
    assert "self-collision" in page.locator("#costs").inner_text()
    assert page.locator("#costs table.costs tbody tr").count() == 13
    rows_shown = page.locator("#costs table.costs tbody th").all_inner_texts()
    assert "of which self-collision" in rows_shown and "of which contacts in the solve" in rows_shown

    # Frames published after the page opened were drawn within a second.
    published = page.evaluate("() => weftDashboard.publishedAt")
    shown = page.evaluate("() => weftDashboard.shownAt")
    delays = [shown[i] - t for i, t in published.items() if t > opened + 0.5]
    assert len(delays) >= 10 and max(delays) < 1.0, delays

    # The download button fetches the cache with the key: the same frames as the API's cache.
    with page.expect_download() as download:
        page.click("#download")
    saved = tmp_path / "downloaded.h5"
    download.value.save_as(saved)
    reference = tmp_path / "reference.h5"
    reference.write_bytes(alice.get(f"/v1/jobs/{job_id}/cache").content)
    with h5py.File(saved, "r") as a, h5py.File(reference, "r") as b:
        assert np.array_equal(a["frames/positions"][()], b["frames/positions"][()])

    screenshot(page, "job")
    assert log.errors == []


def test_jobs_page_filters_and_compares(stack: Stack, alice: httpx.Client, alice_page: tuple[Page, PageLog]) -> None:
    page, log = alice_page
    # One scene (a sheet falling from horizontal, held at two corners) at 8 and at 2 substeps.
    ids = [submit(alice, sheet_shot(name, 16, 16, 0.5, 0.5, plane="xz", pins=[0, 15], frames=6, substeps=n),
                  tag=tag, priority=priority)
           for name, n, tag, priority in (("compare-one", 8, "take:a", 70), ("compare-two", 2, "take:b", 50))]
    with httpx.Client(base_url=stack.url, headers={"Authorization": f"Bearer {BOB}"}) as bob:
        secret = submit(bob, running_shot("bobs-secret", 3))
    for job_id in ids:
        wait_state(alice, job_id, FINAL)
    page.goto(f"{stack.url}/ui/jobs")
    table = page.locator("#jobs tbody")
    expect(table.locator(f'tr[data-job="{ids[0]}"]')).to_be_visible()
    assert table.locator(f'tr[data-job="{secret}"]').count() == 0  # another key's job is not listed

    page.fill("#filter-name", "compare-ONE")
    expect(table.locator("tr")).to_have_count(1)
    expect(table.locator("tr").first).to_contain_text("compare-one")
    assert "name=compare-ONE" in page.url
    page.fill("#filter-name", "")
    page.select_option("#filter-state", "succeeded")
    expect(table.locator(f'tr[data-job="{ids[1]}"]')).to_be_visible()
    states = table.locator(".state").all_inner_texts()
    assert states and set(states) == {"succeeded"}
    page.fill("#filter-tag", "take:a")
    expect(table.locator("tr")).to_have_count(1)
    expect(table.locator("tr").first).to_contain_text("compare-one")
    expect(table.locator("tr").first).to_contain_text("70 · default")
    page.fill("#filter-tag", "")
    page.fill("#filter-name", "no-job-has-this-name")
    expect(table).to_contain_text("No job matches these filters.")
    page.fill("#filter-name", "compare-")
    expect(table.locator("tr")).to_have_count(2)
    screenshot(page, "jobs")

    for job_id in ids:
        table.locator(f'tr[data-job="{job_id}"] input[type=checkbox]').check()
    page.click("#compare")
    page.wait_for_url(re.compile(r"/ui/compare\?jobs="))
    page.wait_for_function("() => weftDashboard.jobs === 2")
    compared = page.locator("#compare tbody tr")
    expect(compared).to_have_count(2)
    first_id = page.url.split("jobs=")[1].split(",")[0]
    assert compared.first.get_attribute("data-job") == first_id
    expect(compared.first).to_contain_text("1.00x")
    # Distance to the first job's cloth at the last common frame, as the API's positions give it.
    frames = [np.array(alice.get(f"/v1/jobs/{job_id}/frames/6").json()["positions"]) for job_id in ids]
    if first_id != ids[0]:
        frames.reverse()
    distance = np.linalg.norm(frames[1] - frames[0], axis=1) * 1e3
    cells = compared.locator("td[data-distance]").all_inner_texts()
    assert cells[0] == "0 / 0 mm"
    rms, most = (float(v) for v in re.match(r"([\d.]+) / ([\d.]+) mm", cells[1].replace(",", "")).groups())  # type: ignore[union-attr]
    assert rms > 1 and abs(rms - np.sqrt(np.mean(distance**2))) < 1e-3 and abs(most - distance.max()) < 1e-3
    totals = page.evaluate("() => document.querySelectorAll('#chart-total .u-legend .u-series').length")
    assert totals == 3  # the frame axis and one series per job
    screenshot(page, "compare")
    assert log.errors == []


def test_workers_page_shows_workers_and_the_queue_over_time(stack: Stack, alice_page: tuple[Page, PageLog]) -> None:
    page, log = alice_page
    page.goto(f"{stack.url}/ui/workers")
    page.wait_for_function("() => weftDashboard.workers >= 1 && weftDashboard.samples >= 2", timeout=30_000)
    worker = stack.workers[0].name  # type: ignore[attr-defined]
    expect(page.locator("#workers tbody")).to_contain_text(worker)
    assert int(card(page, "workers_alive")) >= 1
    screenshot(page, "workers")
    assert log.errors == []


def test_bad_ids_foreign_jobs_and_jobs_without_frames_render_clear_pages(
    stack: Stack, alice: httpx.Client, alice_page: tuple[Page, PageLog],
) -> None:
    page, log = alice_page
    page.goto(f"{stack.url}/ui/jobs/not-a-job")
    expect(page.get_by_role("alert")).to_contain_text('"not-a-job" is not a job id')
    missing = "0" * 32
    page.goto(f"{stack.url}/ui/jobs/{missing}")
    expect(page.get_by_role("alert")).to_contain_text(f"No job {missing}: it does not exist, or it belongs to another")
    with httpx.Client(base_url=stack.url, headers={"Authorization": f"Bearer {BOB}"}) as bob:
        foreign = submit(bob, running_shot("bobs", 3))
    page.goto(f"{stack.url}/ui/jobs/{foreign}")
    expect(page.get_by_role("alert")).to_contain_text(f"No job {foreign}")
    page.goto(f"{stack.url}/ui/compare?jobs={missing}")
    expect(page.get_by_role("alert")).to_contain_text("Choose two or more jobs")
    page.goto(f"{stack.url}/ui/compare?jobs={missing},xyz")
    expect(page.get_by_role("alert")).to_contain_text('"xyz" is not a job id')

    # A queued job (the one worker is busy) has no frames yet: the page says so, no chart error.
    busy = submit(alice, running_shot("keeps-the-worker-busy", 2000))
    wait_state(alice, busy, ("running",))
    waiting = submit(alice, running_shot("waiting", 5))
    page.goto(f"{stack.url}/ui/jobs/{waiting}")
    expect(page.locator("#job-state")).to_have_text("queued")
    expect(page.locator("#no-frames")).to_be_visible()
    screenshot(page, "queued-job")
    for job_id in (waiting, busy):
        alice.post(f"/v1/jobs/{job_id}/cancel")
    expect(page.locator("#job-state")).to_have_text("cancelled", timeout=10_000)
    wait_state(alice, busy, FINAL)
    # Only the API's own 404 answers were logged (as the browser logs any failed request).
    assert log.errors and all("404" in e for e in log.errors), log.errors


def test_key_prompt_refuses_a_wrong_key_and_takes_a_good_one(stack: Stack, browser: Browser) -> None:
    context = context_with_key(browser, None)
    page = context.new_page()
    log = PageLog(page)
    page.goto(f"{stack.url}/ui/jobs")
    dialog = page.locator("dialog.key-prompt")
    expect(dialog).to_be_visible()
    expect(dialog).to_contain_text("missing API key")
    dialog.locator("input").fill("not-a-key")
    dialog.locator("button").click()
    expect(dialog).to_contain_text("unknown API key")
    dialog.locator("input").fill(ALICE)
    dialog.locator("button").click()
    page.wait_for_function("() => weftDashboard.loads >= 1")
    expect(dialog).to_have_count(0)
    assert page.evaluate("() => sessionStorage.getItem('weft.apiKey')") == ALICE
    assert log.errors and all("401" in e for e in log.errors), log.errors
    context.close()


def test_job_page_reconnects_after_the_api_restarts(
    stack: Stack, alice: httpx.Client, alice_page: tuple[Page, PageLog],
) -> None:
    page, _ = alice_page
    job_id = submit(alice, running_shot("through-a-restart", 5000))
    page.goto(f"{stack.url}/ui/jobs/{job_id}")
    page.wait_for_function("() => weftDashboard.framesShown >= 5", timeout=60_000)
    assert stack.api_proc is not None
    stack.api_proc.kill()  # the API dies mid-stream; the worker goes on
    stack.api_proc.wait(timeout=30)
    page.wait_for_function("() => weftDashboard.streamHistory.includes('reconnecting')", timeout=30_000)
    before = page.evaluate("() => weftDashboard.framesShown")
    stack.start_api()  # same port, a new process
    page.wait_for_function(f"() => weftDashboard.framesShown > {before} + 20 && weftDashboard.stream === 'live'",
                           timeout=60_000)
    alice.post(f"/v1/jobs/{job_id}/cancel")
    page.wait_for_function("() => weftDashboard.state === 'cancelled' && weftDashboard.stream === 'ended'",
                           timeout=60_000)
    done = alice.get(f"/v1/jobs/{job_id}").json()["frames_done"]
    shown = page.evaluate("() => weftDashboard.charts.cg.plot.data[0]")
    assert shown == list(range(1, done + 1))  # every frame once, none lost across the restart
