// weft dashboard: what every page shares. The API client (with the key prompt), the job event
// stream (server-sent events read with fetch, so the key can go in a header, resumed by event
// id after a dropped connection or a server restart), formatting, and uPlot chart helpers.
"use strict";

const weft = (() => {
  const KEY_STORAGE = "weft.apiKey";

  class ApiError extends Error {
    constructor(status, detail) {
      super(detail);
      this.status = status;
    }
  }

  function apiKey() {
    return sessionStorage.getItem(KEY_STORAGE);
  }

  function authHeaders(extra = {}) {
    const key = apiKey();
    return key ? { ...extra, Authorization: `Bearer ${key}` } : extra;
  }

  // The key prompt: shown when the API answers 401 (a server that is not in local mode).
  let keyPrompt = null;
  function askForKey(message) {
    if (keyPrompt) return keyPrompt;
    keyPrompt = new Promise((resolve) => {
      const dialog = document.createElement("dialog");
      dialog.className = "key-prompt";
      dialog.innerHTML = `<form method="dialog">
          <h2>API key</h2>
          <p class="why"></p>
          <label>Key <input name="key" type="password" autocomplete="off" required autofocus></label>
          <button type="submit">Use this key</button>
        </form>`;
      dialog.querySelector(".why").textContent = message;
      document.body.append(dialog);
      dialog.addEventListener("close", () => {
        const value = dialog.querySelector("input").value.trim();
        if (value) sessionStorage.setItem(KEY_STORAGE, value);
        dialog.remove();
        keyPrompt = null;
        resolve();
      });
      dialog.showModal();
    });
    return keyPrompt;
  }

  async function errorDetail(response) {
    try {
      const body = await response.json();
      if (typeof body.detail === "string") return body.detail;
      return JSON.stringify(body.detail ?? body);
    } catch {
      return `${response.status} ${response.statusText}`;
    }
  }

  // GET or POST the JSON API. A 401 asks for a key once and tries again; any other error is
  // thrown as an ApiError carrying the API's own message.
  async function api(path, options = {}) {
    for (let attempt = 0; ; attempt++) {
      const response = await fetch(path, { ...options, headers: authHeaders(options.headers) });
      if (response.status === 401 && attempt < 3) {
        await askForKey(await errorDetail(response));
        continue;
      }
      if (!response.ok) throw new ApiError(response.status, await errorDetail(response));
      return options.raw ? response : response.json();
    }
  }

  // A job's events: calls onEvent({id, type, data}) for each, resumes after the last id when
  // the connection drops (server restart, network), and stops after the 'end' event or stop().
  function followEvents(jobId, onEvent, onStatus = () => {}) {
    let lastId = "0-0";
    let stopped = false;
    let controller = null;
    const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

    async function readOnce() {
      controller = new AbortController();
      const response = await fetch(`/v1/jobs/${jobId}/events`, {
        headers: authHeaders({ "Last-Event-ID": lastId, Accept: "text/event-stream" }),
        signal: controller.signal,
      });
      if (response.status === 401) {
        await askForKey(await errorDetail(response));
        return "again";
      }
      if (!response.ok) throw new ApiError(response.status, await errorDetail(response));
      onStatus("live");
      const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
      let buffer = "";
      for (;;) {
        const { value, done } = await reader.read();
        if (done) return "dropped";
        buffer += value;
        let cut;
        while ((cut = buffer.indexOf("\n\n")) >= 0) {
          const block = buffer.slice(0, cut);
          buffer = buffer.slice(cut + 2);
          const event = { id: null, type: "message", data: "" };
          for (const line of block.split("\n")) {
            if (line.startsWith("id: ")) event.id = line.slice(4);
            else if (line.startsWith("event: ")) event.type = line.slice(7);
            else if (line.startsWith("data: ")) event.data += line.slice(6);
          }
          if (!event.id) continue; // retry hint, keep-alive comment
          lastId = event.id;
          onEvent({ ...event, data: JSON.parse(event.data) });
          if (event.type === "end") return "end";
        }
      }
    }

    (async () => {
      while (!stopped) {
        try {
          const how = await readOnce();
          if (how === "end") {
            onStatus("ended");
            return;
          }
        } catch (error) {
          if (stopped) return;
          if (error instanceof ApiError && error.status !== 429 && error.status < 500) {
            onStatus("error", error);
            return;
          }
          onStatus("reconnecting", error);
        }
        if (!stopped) await sleep(1000);
      }
    })();
    return {
      stop() {
        stopped = true;
        if (controller) controller.abort();
      },
    };
  }

  // -- formatting --------------------------------------------------------------------------
  function seconds(value) {
    if (value == null || !Number.isFinite(value)) return "–";
    if (value < 1e-3) return `${(value * 1e6).toFixed(0)} µs`;
    if (value < 1) return `${(value * 1e3).toFixed(value < 0.01 ? 2 : 1)} ms`;
    if (value < 120) return `${value.toFixed(2)} s`;
    if (value < 7200) return `${Math.floor(value / 60)} min ${Math.round(value % 60)} s`;
    return `${Math.floor(value / 3600)} h ${Math.round((value % 3600) / 60)} min`;
  }
  const number = (value, digits = 0) =>
    value == null || !Number.isFinite(value) ? "–" : value.toLocaleString("en-US", { maximumFractionDigits: digits });
  const time = (unix) => (unix ? new Date(unix * 1000).toLocaleString() : "–");

  // Wall-clock rate and remaining time of a job from its record.
  function progress(job) {
    const now = Date.now() / 1000;
    const end = job.finished ?? now;
    const resumedFrom = job.resumed_from == null ? 0 : job.resumed_from - job.frame_range[0] + 1;
    const frames = job.frames_done - Math.max(resumedFrom, 0);
    const elapsed = job.started ? end - job.started : null;
    const rate = elapsed && frames > 0 ? frames / elapsed : null;
    const left = job.frames_total - job.frames_done;
    const eta = job.state === "running" && rate ? left / rate : null;
    return { rate, eta, secondsPerFrame: job.timing ? job.timing.total_seconds : null };
  }

  function el(tag, attributes = {}, ...children) {
    const node = document.createElement(tag);
    for (const [name, value] of Object.entries(attributes)) {
      if (value == null || value === false) continue;
      if (name === "class") node.className = value;
      else node.setAttribute(name, value === true ? "" : value);
    }
    node.append(...children.flat().filter((child) => child != null));
    return node;
  }

  function showError(target, error) {
    target.replaceChildren(el("div", { class: "error", role: "alert" }, error.message || String(error)));
  }

  // -- charts ------------------------------------------------------------------------------
  const FRAME_STEPS = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000, 100000, 1e6];
  const PALETTE = ["#3b6fb6", "#e07b39", "#4f9d69", "#b54a8c", "#8c6d31", "#6b6ecf", "#999999", "#c03d3d"];

  // A chart of series over frames (or over time: xTime, x in Unix seconds). stacked: each series drawn on top of the ones before it
  // (the tooltip still shows each one's own value). log: logarithmic y (zeros left out).
  function chart(container, title, names, { stacked = false, log = false, height = 220, yLabel = "", xTime = false } = {}) {
    const width = () => Math.max(container.clientWidth - 8, 300);
    const series = [{ label: xTime ? "time" : "frame" }];
    names.forEach((name, i) => {
      const color = PALETTE[i % PALETTE.length];
      series.push({
        label: name,
        stroke: color,
        fill: stacked ? `${color}55` : undefined,
        width: 1.5,
        points: { show: false },
        value: stacked ? (u, v, s, idx) => fmtTick(ownValues[s - 1]?.[idx]) : (u, v) => fmtTick(v),
      });
    });
    let ownValues = [];
    const options = {
      title,
      width: width(),
      height,
      series,
      scales: { x: { time: xTime }, y: log ? { distr: 3 } : {} },
      axes: [xTime ? {} : { label: "frame", incrs: FRAME_STEPS }, { label: yLabel, size: 60, values: (u, ticks) => ticks.map(fmtTick) }],
      legend: { live: true },
      cursor: { drag: { x: true, y: false } },
    };
    if (stacked) options.bands = names.slice(1).map((_, i) => ({ series: [i + 2, i + 1] }));
    const plot = new uPlot(options, [[], ...names.map(() => [])], container);
    new ResizeObserver(() => plot.setSize({ width: width(), height })).observe(container);
    return {
      plot,
      // x: frame numbers; columns: one array per series, same length as x.
      set(x, columns) {
        ownValues = columns;
        let data = columns;
        if (log) data = columns.map((col) => col.map((v) => (v > 0 ? v : null)));
        if (stacked) {
          const running = new Array(x.length).fill(0);
          data = columns.map((col) => col.map((v, i) => (running[i] += v ?? 0)));
        }
        plot.setData([x, ...data]);
      },
    };
  }

  function fmtTick(v) {
    if (v == null || !Number.isFinite(v)) return "–";
    const a = Math.abs(v);
    if (a !== 0 && (a < 1e-2 || a >= 1e5)) return v.toExponential(1);
    return Number(v.toPrecision(4)).toString();
  }

  return { api, ApiError, askForKey, apiKey, authHeaders, followEvents, seconds, number, time, progress, el,
    showError, chart };
})();
