// The jobs table: live (refreshed every 2 s), filtered by name, tag and state, paginated on
// the server (GET /v1/jobs?name=&tag=&state=&offset=&limit=), with a selection to compare.
// An admin key sees every key's jobs, with their owner.
"use strict";

(() => {
  const { api, el, seconds, number } = weft;
  const PAGE = 50;
  const params = new URLSearchParams(location.search);
  const view = { name: params.get("name") ?? "", tag: params.get("tag") ?? "", state: params.get("state") ?? "",
    offset: Number(params.get("offset")) || 0 };
  const selected = new Set();
  const tbody = document.querySelector("#jobs tbody");
  const message = document.getElementById("message");
  const status = (window.weftDashboard = { rows: 0, total: null, lastLoadMs: null, loads: 0 });
  let timer = null;

  document.getElementById("filter-name").value = view.name;
  document.getElementById("filter-tag").value = view.tag;
  document.getElementById("filter-state").value = view.state;

  function row(job) {
    const { rate, eta, secondsPerFrame } = weft.progress(job);
    const percent = job.frames_total ? (100 * job.frames_done) / job.frames_total : 0;
    const fill = el("div", { class: "fill" });
    fill.style.width = `${percent}%`;
    const box = el("input", { type: "checkbox", "aria-label": `select ${job.name}`, checked: selected.has(job.id) });
    box.addEventListener("change", () => {
      if (box.checked) selected.add(job.id);
      else selected.delete(job.id);
      document.getElementById("compare").disabled = selected.size < 2;
    });
    const state = job.cancel_requested && job.state === "running" ? "cancelling" : job.state;
    return el("tr", { "data-job": job.id },
      el("td", {}, box),
      el("td", {}, el("a", { href: `/ui/jobs/${job.id}` }, job.name), el("div", { class: "id" }, job.id),
        job.owner ? el("div", { class: "id" }, `owner ${job.owner}`) : null,
        job.tags.length ? el("div", { class: "tags" }, job.tags.map((t) => el("span", { class: "tag" }, t))) : null),
      el("td", {}, el("span", { class: `state state-${job.state}` }, state)),
      el("td", { class: "num" }, `${job.priority} · ${job.pool}`),
      el("td", {}, el("div", { class: "bar" }, fill), `${job.frames_done} / ${job.frames_total}`),
      el("td", { class: "num" }, rate ? number(rate, 2) : "–"),
      el("td", { class: "num" }, seconds(secondsPerFrame)),
      el("td", { class: "num" }, eta != null ? seconds(eta) : "–"),
      el("td", {}, job.worker ?? "–"),
      el("td", {}, weft.time(job.created)),
      el("td", { class: "failure" }, job.error ? `${job.error.kind ?? "error"}: ${job.error.reason}` : ""));
  }

  async function load() {
    clearTimeout(timer);
    const query = new URLSearchParams({ offset: view.offset, limit: PAGE });
    if (view.name) query.set("name", view.name);
    if (view.tag) query.set("tag", view.tag);
    if (view.state) query.set("state", view.state);
    const start = performance.now();
    try {
      const page = await api(`/v1/jobs?${query}`);
      tbody.replaceChildren(...page.jobs.map(row));
      if (!page.jobs.length) {
        tbody.append(el("tr", {}, el("td", { colspan: 11, class: "muted" },
          view.name || view.state || view.tag ? "No job matches these filters." : "No jobs yet: submit a shot (weft submit SHOT.yaml).")));
      }
      const last = Math.min(page.offset + page.jobs.length, page.total);
      document.getElementById("count").textContent = `${number(page.total)} jobs`;
      document.getElementById("page").textContent = page.total ? `${page.offset + 1}–${last} of ${number(page.total)}` : "";
      document.getElementById("prev").disabled = page.offset === 0;
      document.getElementById("next").disabled = page.next_offset == null;
      message.replaceChildren();
      Object.assign(status, { rows: page.jobs.length, total: page.total, lastLoadMs: performance.now() - start });
      status.loads += 1;
    } catch (error) {
      weft.showError(message, error);
    }
    timer = setTimeout(load, 2000);
  }

  function navigate() {
    const query = new URLSearchParams();
    if (view.name) query.set("name", view.name);
    if (view.tag) query.set("tag", view.tag);
    if (view.state) query.set("state", view.state);
    if (view.offset) query.set("offset", view.offset);
    history.replaceState(null, "", `/ui/jobs${query.size ? `?${query}` : ""}`);
    load();
  }

  const typing = {};
  for (const field of ["name", "tag"]) {
    document.getElementById(`filter-${field}`).addEventListener("input", (event) => {
      clearTimeout(typing[field]);
      typing[field] = setTimeout(() => {
        view[field] = event.target.value.trim();
        view.offset = 0;
        navigate();
      }, 250);
    });
  }
  document.getElementById("filter-state").addEventListener("change", (event) => {
    view.state = event.target.value;
    view.offset = 0;
    navigate();
  });
  document.getElementById("filters").addEventListener("submit", (event) => event.preventDefault());
  document.getElementById("prev").addEventListener("click", () => {
    view.offset = Math.max(0, view.offset - PAGE);
    navigate();
  });
  document.getElementById("next").addEventListener("click", () => {
    view.offset += PAGE;
    navigate();
  });
  document.getElementById("compare").addEventListener("click", () => {
    location.href = `/ui/compare?jobs=${[...selected].join(",")}`;
  });
  load();
})();
