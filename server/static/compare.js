// Two or more jobs side by side (/ui/compare?jobs=ID,ID,...): the mean timing breakdown per
// job, speed and distance to the first job's cloth (speed against error for runs of one scene
// with other settings), whole-step seconds and CG iterations per frame on shared charts.
"use strict";

(() => {
  const { api, el, seconds, number } = weft;
  const message = document.getElementById("message");
  const status = (window.weftDashboard = { jobs: 0, error: null });
  const STAGES = [["build", "build_seconds"], ["solve", "solve_seconds"], ["collisions", "collision_seconds"],
    ["GIA", "gia_seconds"], ["whole step", "total_seconds"]];

  function mean(rows, key) {
    const values = rows.map((r) => r[key]).filter((v) => v != null && Number.isFinite(v));
    return values.length ? values.reduce((a, b) => a + b, 0) / values.length : null;
  }

  // One chart's data from several jobs whose frames may differ: the union of frame numbers.
  function aligned(sets, key) {
    const frames = [...new Set(sets.flatMap((rows) => rows.map((r) => r.frame)))].sort((a, b) => a - b);
    return [frames, sets.map((rows) => {
      const byFrame = new Map(rows.map((r) => [r.frame, r[key]]));
      return frames.map((f) => byFrame.get(f) ?? null);
    })];
  }

  // Speed against error: each job's cloth against the first job's at the last frame they all
  // have (jobs of one scene with other settings: substeps, tolerance, thickness). Root mean
  // square and largest vertex distance, in millimetres; null when the meshes differ.
  async function differences(jobs) {
    const [first] = jobs;
    if (jobs.some((j) => j.vertices !== first.vertices || j.frame_range[0] !== first.frame_range[0])) return null;
    const frame = Math.min(...jobs.map((j) => j.frame_range[0] + j.frames_done - 1));
    if (frame < first.frame_range[0]) return null;
    const frames = await Promise.all(jobs.map((j) => api(`/v1/jobs/${j.id}/frames/${frame}`)));
    const base = frames[0].positions;
    const text = frames.map(({ positions }) => {
      let sum = 0;
      let most = 0;
      positions.forEach((p, v) => {
        const d2 = (p[0] - base[v][0]) ** 2 + (p[1] - base[v][1]) ** 2 + (p[2] - base[v][2]) ** 2;
        sum += d2;
        most = Math.max(most, d2);
      });
      const rms = Math.sqrt(sum / positions.length) * 1e3;
      return `${weft.number(rms, 3)} / ${weft.number(Math.sqrt(most) * 1e3, 3)} mm`;
    });
    return { frame, text };
  }

  function fail(text) {
    status.error = text;
    message.replaceChildren(el("div", { class: "error", role: "alert" }, text, " ", el("a", { href: "/ui/jobs" }, "Pick jobs")));
  }

  async function main() {
    const ids = (new URLSearchParams(location.search).get("jobs") ?? "").split(",").map((s) => s.trim()).filter(Boolean);
    if (ids.length < 2) return fail("Choose two or more jobs to compare (/ui/compare?jobs=ID,ID).");
    const bad = ids.find((id) => !/^[0-9a-f]{32}$/.test(id));
    if (bad) return fail(`"${bad}" is not a job id: a job id is 32 hexadecimal digits.`);
    let loaded;
    try {
      loaded = await Promise.all(ids.map(async (id) => {
        const [job, telemetry] = await Promise.all([api(`/v1/jobs/${id}`), api(`/v1/jobs/${id}/telemetry`)]);
        return { job, rows: telemetry.rows.filter((r) => r.substeps > 0) };
      }));
    } catch (error) {
      return fail(error.status === 404 ? `${error.message}: it does not exist, or it belongs to another API key.` : error.message);
    }
    const names = loaded.map(({ job }) => `${job.name} (${job.id.slice(0, 8)})`);
    const accuracy = await differences(loaded.map(({ job }) => job));
    const reference = mean(loaded[0].rows, "total_seconds");
    const table = document.getElementById("compare");
    table.replaceChildren(
      el("thead", {}, el("tr", {}, el("th", {}, "job"), el("th", {}, "state"), el("th", {}, "frames"), el("th", {}, "vertices"),
        ...STAGES.map(([label]) => el("th", {}, label)), el("th", {}, "CG it./frame"), el("th", {}, "speed vs first"),
        el("th", {}, accuracy ? `RMS / max distance to first, frame ${accuracy.frame}` : "distance to first"))),
      el("tbody", {}, loaded.map(({ job, rows }, i) => {
        const total = mean(rows, "total_seconds");
        return el("tr", { "data-job": job.id },
          el("td", {}, el("a", { href: `/ui/jobs/${job.id}` }, names[i])),
          el("td", {}, el("span", { class: `state state-${job.state}` }, job.state)),
          el("td", { class: "num" }, String(rows.length)), el("td", { class: "num" }, number(job.vertices)),
          ...STAGES.map(([, key]) => el("td", { class: "num", "data-stage": key }, seconds(mean(rows, key)))),
          el("td", { class: "num" }, number(mean(rows, "cg_iterations"), 1)),
          el("td", { class: "num" }, reference && total ? `${(reference / total).toFixed(2)}x` : "–"),
          el("td", { class: "num", "data-distance": "" }, accuracy ? accuracy.text[i]
            : "– (different meshes or frame ranges)"));
      })));
    const sets = loaded.map(({ rows }) => rows);
    const totalChart = weft.chart(document.getElementById("chart-total"), "Whole step, seconds per frame", names, { yLabel: "s" });
    const [x, totals] = aligned(sets, "total_seconds");
    totalChart.set(x, totals);
    const cgChart = weft.chart(document.getElementById("chart-cg"), "CG iterations per frame", names);
    const [x2, cg] = aligned(sets, "cg_iterations");
    cgChart.set(x2, cg);
    status.jobs = loaded.length;
  }
  main();
})();
