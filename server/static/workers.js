// Workers with their heartbeat age and current job; the queue's depth now and over time
// (GET /v1/queue, sampled by the API every few seconds). Refreshed every 3 s.
"use strict";

(() => {
  const { api, el, seconds, number } = weft;
  const message = document.getElementById("message");
  const status = (window.weftDashboard = { workers: 0, samples: 0, loads: 0 });
  let chart = null;

  function card(label, value, id) {
    return el("div", { class: "card", "data-field": id }, el("span", { class: "label" }, label), el("span", { class: "value" }, value));
  }

  async function load() {
    try {
      const [queue, workers] = await Promise.all([api("/v1/queue"), api("/v1/workers")]);
      document.getElementById("queue").replaceChildren(
        card("queued", number(queue.jobs.queued), "queued"),
        card("running", number(queue.jobs.running), "running"),
        card("longest wait", queue.oldest_queued_seconds == null ? "–" : seconds(queue.oldest_queued_seconds), "oldest"),
        card("workers alive", number(queue.workers_alive), "workers_alive"),
        card("workers busy", number(queue.workers_busy), "workers_busy"),
        card("succeeded", number(queue.jobs.succeeded), "succeeded"),
        card("failed", number(queue.jobs.failed), "failed"),
        card("cancelled", number(queue.jobs.cancelled), "cancelled"));
      if (!chart) {
        chart = weft.chart(document.getElementById("chart-queue"), "Queue over time",
          ["queued", "running", "busy workers", "live workers"], { height: 240, xTime: true });
      }
      const h = queue.history;
      chart.plot.setData([h.map((s) => s.time), h.map((s) => s.queued), h.map((s) => s.running),
        h.map((s) => s.workers_busy), h.map((s) => s.workers_alive)]);
      const tbody = document.querySelector("#workers tbody");
      tbody.replaceChildren(...workers.workers.map((w) => el("tr", {},
        el("td", {}, w.name), el("td", {}, w.host), el("td", { class: "num" }, String(w.pid)),
        el("td", {}, el("span", { class: `state ${w.alive ? (w.job ? "state-running" : "state-idle") : "state-failed"}` },
          w.alive ? (w.job ? "busy" : "idle") : "silent")),
        el("td", {}, `${seconds(w.seconds_since_heartbeat)} ago`),
        el("td", {}, w.job ? el("a", { href: `/ui/jobs/${w.job}` }, w.job.slice(0, 12)) : "–"))));
      if (!workers.workers.length) {
        tbody.append(el("tr", {}, el("td", { colspan: 6, class: "muted" }, "No worker has reported in the last hour.")));
      }
      message.replaceChildren();
      Object.assign(status, { workers: workers.workers.length, samples: h.length });
      status.loads += 1;
    } catch (error) {
      weft.showError(message, error);
    }
    setTimeout(load, 3000);
  }
  load();
})();
