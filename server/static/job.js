// One job: summary, shot and feature costs, and live per-frame charts fed by its event stream.
"use strict";

(() => {
  const { api, el, seconds, number } = weft;
  const jobId = decodeURIComponent(location.pathname.split("/").pop());
  const message = document.getElementById("message");
  const FINAL = new Set(["succeeded", "failed", "cancelled"]);

  // Per-frame rows by cache index (a resumed or retried job may send a frame again).
  const rows = new Map();
  let job = null;
  let charts = null;
  // For tests and the dashboard benchmark: what the page has drawn, and how long drawing took.
  const status = (window.weftDashboard = { jobId, framesShown: 0, renders: 0, lastRenderMs: null,
    publishedAt: {}, shownAt: {}, state: null, error: null, stream: null, streamHistory: [], charts: null });

  function fail(text) {
    status.error = text;
    message.replaceChildren(el("div", { class: "error", role: "alert" }, text, " ",
      el("a", { href: "/ui/jobs" }, "All jobs")));
    document.getElementById("charts").hidden = true;
    document.querySelector(".columns").hidden = true;
  }

  function makeCharts() {
    const c = (id) => document.getElementById(id);
    return {
      seconds: weft.chart(c("chart-seconds"), "Seconds per frame (stacked)",
        ["build", "solve", "collisions", "GIA", "other", "cache write"], { stacked: true, yLabel: "s" }),
      cg: weft.chart(c("chart-cg"), "CG iterations per frame", ["CG iterations", "unconverged substeps"]),
      contacts: weft.chart(c("chart-contacts"), "Contacts and CCD per frame (log)",
        ["contact constraints", "proximity pairs", "CCD candidates", "CCD hits", "broad-phase pairs"], { log: true }),
      intersections: weft.chart(c("chart-intersections"), "Intersections at frame end",
        ["intersecting triangle pairs", "unresolved pairs", "GIA coloured vertices"]),
      strain: weft.chart(c("chart-strain"), "Longest edge over its rest length at frame end", ["max edge strain"]),
      energy: weft.chart(c("chart-energy"), "Energy at frame end", ["kinetic", "potential"], { yLabel: "J" }),
    };
  }

  const column = (list, key) => list.map((r) => r[key]);

  function render() {
    const start = performance.now();
    const list = [...rows.values()].sort((a, b) => a.index - b.index);
    const x = column(list, "frame");
    if (!charts) charts = status.charts = makeCharts();
    const other = list.map((r) =>
      Math.max(0, (r.total_seconds ?? 0) - r.build_seconds - r.solve_seconds - r.collision_seconds - r.gia_seconds));
    charts.seconds.set(x, [column(list, "build_seconds"), column(list, "solve_seconds"),
      column(list, "collision_seconds"), column(list, "gia_seconds"), other, column(list, "io_seconds")]);
    charts.cg.set(x, [column(list, "cg_iterations"), column(list, "unconverged_substeps")]);
    charts.contacts.set(x, ["contact_constraints", "proximity_pairs", "ccd_candidates", "ccd_hits",
      "broad_phase_pairs"].map((k) => column(list, k)));
    charts.intersections.set(x, [list.map((r) => (r.intersections < 0 ? null : r.intersections)),
      column(list, "unresolved_collisions"), column(list, "gia_coloured_vertices")]);
    charts.strain.set(x, [column(list, "max_edge_strain")]);
    charts.energy.set(x, [column(list, "kinetic_energy"), column(list, "potential_energy")]);
    // A chart of physics the shot does not use (all zero: no contact, no intersection) is left
    // out, and the note says so.
    const unused = [];
    for (const [chart, title] of [[charts.contacts, "contacts and CCD"], [charts.intersections, "intersections"]]) {
      const silent = list.length > 0 && chart.plot.data.slice(1).every((col) => col.every((v) => v == null || v === 0));
      chart.plot.root.parentElement.hidden = silent;
      if (silent) unused.push(title);
    }
    const note = document.getElementById("no-frames");
    note.hidden = list.length > 0 && !unused.length;
    note.textContent = list.length === 0 ? "No frames yet: the charts fill in as the job runs."
      : `Not drawn, all zero in this shot: ${unused.join(", ")}.`;
    renderCosts(list);
    renderSummary();
    status.framesShown = list.length;
    status.renders += 1;
    status.lastRenderMs = performance.now() - start;
    status.lastRenderAt = performance.now(); // ms since the page's navigation started
    const now = Date.now() / 1000;
    for (const r of list) status.shownAt[r.index] ??= now;
  }

  let pending = false;
  function scheduleRender() {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => {
      pending = false;
      render();
    });
  }

  function mean(list, key) {
    const values = list.map((r) => r[key]).filter((v) => v != null && Number.isFinite(v));
    return values.length ? values.reduce((a, b) => a + b, 0) / values.length : null;
  }

  function renderSummary() {
    if (!job) return;
    const simulated = [...rows.values()].filter((r) => r.substeps > 0);
    const { rate, eta } = weft.progress(job);
    const percent = job.frames_total ? (100 * job.frames_done) / job.frames_total : 0;
    const card = (label, value, id) => el("div", { class: "card", "data-field": id }, el("span", { class: "label" }, label),
      el("span", { class: "value" }, value));
    const fill = el("div", { class: "fill", role: "progressbar", "aria-valuemin": 0, "aria-valuemax": 100,
      "aria-valuenow": percent.toFixed(1) });
    fill.style.width = `${percent}%`;
    const bar = el("div", { class: "bar" }, fill);
    const cards = [
      card("frames", `${job.frames_done} / ${job.frames_total}`, "frames"),
      card("s/frame (solver)", seconds(mean(simulated, "total_seconds")), "seconds_per_frame"),
      card("frames/s (wall)", rate ? number(rate, 2) : "–", "frames_per_second"),
      card("ETA", eta != null ? seconds(eta) : job.state === "running" ? "…" : "–", "eta"),
      card("CG iterations/frame", number(mean(simulated, "cg_iterations"), 1), "cg_iterations"),
      card("vertices", number(job.vertices), "vertices"),
      card("worker", job.worker ?? "–", "worker"),
      card("attempts", String(job.attempts), "attempts"),
      card("submitted", weft.time(job.created), "created"),
    ];
    if (job.error) cards.push(card("failure", `${job.error.kind ?? "error"}: ${job.error.reason}`, "failure"));
    const summary = document.getElementById("summary");
    summary.replaceChildren(el("div", { class: "progress" }, bar), ...cards);
    const state = document.getElementById("job-state");
    state.textContent = job.cancel_requested && job.state === "running" ? "cancelling" : job.state;
    state.className = `state state-${job.state}`;
    status.state = job.state;
  }

  // Mean seconds per simulated frame of each stage, and its share of the step.
  function renderCosts(list) {
    const simulated = list.filter((r) => r.substeps > 0);
    if (!simulated.length) return;
    const total = mean(simulated, "total_seconds") || 0;
    const line = (name, value, indent = false) => el("tr", { class: indent ? "sub" : null },
      el("th", { scope: "row" }, name), el("td", {}, seconds(value)),
      el("td", {}, total && value != null ? `${((100 * value) / total).toFixed(1)}%` : "–"));
    const table = el("table", { class: "costs" },
      el("thead", {}, el("tr", {}, el("th", {}, "stage"), el("th", {}, "per frame"), el("th", {}, "of step"))),
      el("tbody", {},
        line("build", mean(simulated, "build_seconds")),
        line("solve", mean(simulated, "solve_seconds")),
        line("preconditioner setup", mean(simulated, "setup_seconds"), true),
        line("collisions", mean(simulated, "collision_seconds")),
        line("broad phase", mean(simulated, "collision_broad_phase_seconds"), true),
        line("of which self-collision", mean(simulated, "self_collision_seconds"), true),
        line("proximity", mean(simulated, "collision_proximity_seconds"), true),
        line("of which contacts in the solve", mean(simulated, "contact_constraints_seconds"), true),
        line("CCD", mean(simulated, "collision_ccd_seconds"), true),
        line("impulses and impact zones", mean(simulated, "collision_response_seconds"), true),
        line("GIA", mean(simulated, "gia_seconds")),
        line("whole step", total),
        line("cache write (after the step)", mean(simulated, "io_seconds"))));
    const costs = document.getElementById("costs");
    costs.replaceChildren(el("h2", {}, "Features and what they cost"), featureList, table);
  }

  let featureList = el("p", { class: "muted" }, "loading the shot…");

  async function loadShot() {
    const shotPanel = document.getElementById("shot");
    try {
      const shot = await api(`/v1/jobs/${jobId}/shot`);
      document.title = `weft · ${shot.name}`;
      const dl = el("dl", {},
        el("dt", {}, "frames"), el("dd", {}, `${shot.frame_range[0]}–${shot.frame_range[1]} at ${shot.fps} fps`),
        el("dt", {}, "substeps"), el("dd", {}, String(shot.substeps)),
        el("dt", {}, "cloth"), el("dd", {}, `${shot.pieces.length} ${shot.pieces.length === 1 ? "piece" : "pieces"}, ${number(shot.vertices)} vertices: `
          + shot.pieces.map((p) => p.name).join(", ")),
        el("dt", {}, "bodies"), el("dd", {}, shot.bodies.length ? shot.bodies.join(", ") : "none"));
      shotPanel.replaceChildren(el("h2", {}, "Shot"), dl);
      featureList = el("ul", { class: "features" },
        Object.entries(shot.features).map(([name, value]) => el("li", {}, el("strong", {}, name), `: ${value}`)));
      const costs = document.getElementById("costs");
      costs.querySelector("p, ul")?.replaceWith(featureList);
    } catch (error) {
      shotPanel.replaceChildren(el("h2", {}, "Shot"), el("p", { class: "muted" }, error.message));
    }
  }

  async function refreshJob() {
    job = await api(`/v1/jobs/${jobId}`);
    document.getElementById("job-title").textContent = job.name;
    document.getElementById("download").hidden = job.frames_done === 0;
    renderSummary();
    return job;
  }

  async function download() {
    const button = document.getElementById("download");
    button.disabled = true;
    try {
      const response = await api(`/v1/jobs/${jobId}/cache`, { raw: true });
      const url = URL.createObjectURL(await response.blob());
      const link = el("a", { href: url, download: `${job.name}-${jobId.slice(0, 8)}.h5` });
      document.body.append(link);
      link.click();
      link.remove();
      setTimeout(() => URL.revokeObjectURL(url), 10000);
    } catch (error) {
      weft.showError(message, error);
    } finally {
      button.disabled = false;
    }
  }

  async function main() {
    if (!/^[0-9a-f]{32}$/.test(jobId)) {
      fail(`"${jobId}" is not a job id: a job id is 32 hexadecimal digits.`);
      return;
    }
    try {
      await refreshJob();
    } catch (error) {
      fail(error.status === 404
        ? `No job ${jobId}: it does not exist, or it belongs to another API key.`
        : `Could not load job ${jobId}: ${error.message}`);
      return;
    }
    document.getElementById("download").addEventListener("click", download);
    loadShot();
    const streamStatus = document.getElementById("stream-status");
    weft.followEvents(jobId, (event) => {
      if (event.type === "frame") {
        rows.set(event.data.index, event.data);
        status.publishedAt[event.data.index] = event.data.published_at;
        if (job && event.data.index + 1 > job.frames_done) job.frames_done = event.data.index + 1;
        scheduleRender();
      } else if (event.type === "end") {
        refreshJob().catch(() => {});
      }
    }, (state, error) => {
      streamStatus.textContent = { live: "● live", ended: "finished", reconnecting: "reconnecting…",
        error: `stream error: ${error?.message}` }[state] ?? state;
      streamStatus.className = `stream-status stream-${state}`;
      status.stream = state;
      status.streamHistory.push(state);
    });
    // The record (state, worker, attempts, timing) between frames: every 2 s until final.
    const poll = async () => {
      try {
        await refreshJob();
        message.replaceChildren();
      } catch (error) {
        weft.showError(message, error);
      }
      if (!FINAL.has(job?.state)) setTimeout(poll, 2000);
    };
    setTimeout(poll, 2000);
    scheduleRender();
  }

  main();
})();
