// ldv-survey dashboard: plain ES module, talks to the REST API only.
import { importFlow, isBundle } from "./import.js";
const app = document.getElementById("app");
const api = async (path, opts = {}) => {
  const r = await fetch(path, { credentials: "same-origin", ...opts,
    headers: { ...(opts.headers || {}), ...(window.CSRF ? { "X-CSRF-Token": window.CSRF } : {}) } });
  if (!r.ok) {
    let body = {}; try { body = await r.json(); } catch (e) { /* not JSON */ }
    const err = new Error(body.detail && typeof body.detail === "string" ? body.detail : `${r.status} ${r.statusText}`);
    err.body = body; err.status = r.status; throw err;
  }
  const ct = r.headers.get("content-type") || "";
  return ct.includes("json") ? r.json() : r.text();
};
const esc = (s) => String(s ?? "").replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
const fmt = (x, d = 2) => (x === null || x === undefined || Number.isNaN(x)) ? "–" : Number(x).toFixed(d);
const VIEWS = { height: ["height", "height_error"], tilt: ["attitude"], navigate: ["trajectory"], calibrate: ["calibration_track"],
  gravity: ["gravity_lines", "gravity_residuals", "gravity_compare_gnss"], dov: ["dov_deflection", "dov_error"], damping: ["damping"] };
let timers = [];
const clearTimers = () => { timers.forEach(clearInterval); timers = []; };

async function route() {
  clearTimers();
  const h = location.hash || "#/logs";
  const m = h.match(/^#\/logs\/(\d+)$/), j = h.match(/^#\/jobs\/(\d+)$/);
  try {
    if (m) return await logPage(+m[1]);
    if (j) return await jobPage(+j[1]);
    if (h.startsWith("#/compare")) return await comparePage();
    return await logsPage();
  } catch (e) { app.innerHTML = `<p class="error">${esc(e.message)}</p>`; }
}
window.addEventListener("hashchange", route);

// ---------- logs: upload and list ----------
async function logsPage() {
  app.innerHTML = `<h2>Drive logs</h2>
  <div class="drop" id="drop">Drop a bundle here (one <code>.zip</code>, or manifest.json + imu.csv + ldv.csv [+ gnss.nmea])
   <br>or <input type="file" id="pick" multiple></div>
  <progress id="upprog" value="0" max="100" hidden></progress><div id="upmsg"></div>
  <table id="logs"><thead><tr><th>name</th><th>date</th><th>duration</th><th>platform</th><th>LDV</th><th>quality</th><th></th></tr></thead><tbody></tbody></table>`;
  const drop = document.getElementById("drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => { e.preventDefault(); drop.classList.remove("over"); upload([...e.dataTransfer.files]); });
  document.getElementById("pick").addEventListener("change", (e) => upload([...e.target.files]));
  await refreshLogs();
}

async function refreshLogs() {
  const logs = await api("/api/logs");
  const tb = document.querySelector("#logs tbody");
  tb.innerHTML = logs.map((l) => {
    const b = l.badges || {};
    const q = [`<span class="badge ${b.imu_gaps ? "warn" : ""}">IMU gaps ${b.imu_gaps ?? "–"}</span>`,
      `<span class="badge">RTK ${b.gnss_rtk_fixed_share === null || b.gnss_rtk_fixed_share === undefined ? "–" : fmt(100 * b.gnss_rtk_fixed_share, 0) + " %"}</span>`,
      `<span class="badge ${b.ldv_below_min_quality_share > 0.05 ? "warn" : ""}">LDV low-q ${b.ldv_below_min_quality_share === null || b.ldv_below_min_quality_share === undefined ? "–" : fmt(100 * b.ldv_below_min_quality_share, 1) + " %"}</span>`].join("");
    return `<tr data-id="${l.id}"><td><a href="#/logs/${l.id}">${esc(l.name || "(unnamed)")}</a></td><td>${esc(l.survey_date)}</td>
      <td>${fmt(l.duration_s / 60, 1)} min</td><td>${esc(l.platform)}</td><td>${esc(l.ldv_kind)}${l.imu_rotating ? " · rotating IMU" : ""}</td>
      <td>${q}</td><td><button class="del" data-id="${l.id}">delete</button></td></tr>`;
  }).join("") || `<tr><td colspan="7">No logs yet.</td></tr>`;
  tb.querySelectorAll("button.del").forEach((btn) => btn.addEventListener("click", async () => {
    if (!confirm("Delete this log, its files and results?")) return;
    await api(`/api/logs/${btn.dataset.id}`, { method: "DELETE" }); refreshLogs();
  }));
}

function upload(files) {
  const msg = document.getElementById("upmsg"), prog = document.getElementById("upprog");
  if (!files.length) return;
  if (!isBundle(files)) return importFlow(files, msg, refreshLogs); // foreign recordings: preview, then confirm
  const fd = new FormData(); files.forEach((f) => fd.append("files", f, f.name));
  const xhr = new XMLHttpRequest();
  xhr.open("POST", "/api/logs");
  if (window.CSRF) xhr.setRequestHeader("X-CSRF-Token", window.CSRF);
  prog.hidden = false; prog.value = 0; msg.innerHTML = "Uploading…";
  xhr.upload.onprogress = (e) => { if (e.lengthComputable) prog.value = (100 * e.loaded) / e.total; };
  xhr.onload = () => {
    prog.value = 100;
    let body = {}; try { body = JSON.parse(xhr.responseText); } catch (e) { /* not JSON */ }
    if (xhr.status >= 200 && xhr.status < 300) {
      msg.innerHTML = `<p class="ok" id="upload-ok">${body.duplicate ? "Already stored" : "Stored"}: <a href="#/logs/${body.id}">${esc(body.name)}</a></p>`;
      refreshLogs();
    } else {
      const e = body.error || {};
      msg.innerHTML = `<div class="error" id="upload-error">Upload refused (${xhr.status}): ${esc(body.detail || xhr.statusText)}
${e.file ? "file: " + esc(e.file) : ""}${e.line ? ", line " + esc(e.line) : ""}${e.field ? ", field " + esc(e.field) : ""}</div>`;
    }
  };
  xhr.onerror = () => { msg.innerHTML = `<div class="error" id="upload-error">Upload failed: network error</div>`; };
  xhr.send(fd);
}

// ---------- one log: quality, pipelines, jobs ----------
async function logPage(id) {
  const [log, pipes] = await Promise.all([api(`/api/logs/${id}`), api("/api/pipelines")]);
  const q = log.quality || {}, g = q.gnss;
  app.innerHTML = `<h2>${esc(log.name)}</h2>
  <div class="card"><h3>Quality</h3><table>
   <tr><th>stream</th><th>samples</th><th>rate</th><th>duration</th><th>gaps</th><th>longest gap</th><th>notes</th></tr>
   <tr><td>IMU</td><td>${q.imu.n}</td><td>${fmt(q.imu.rate_hz, 1)} Hz</td><td>${fmt(q.imu.duration_s, 0)} s</td><td>${q.imu.gaps}</td><td>${fmt(q.imu.longest_gap_s, 2)} s</td><td>${q.imu.rotating ? "rotating" : "fixed"}</td></tr>
   <tr><td>LDV</td><td>${q.ldv.n}</td><td>${fmt(q.ldv.rate_hz, 1)} Hz</td><td>${fmt(q.ldv.duration_s, 0)} s</td><td>${q.ldv.gaps}</td><td>${fmt(q.ldv.longest_gap_s, 2)} s</td>
     <td>${q.ldv.kind}, ${q.ldv.below_min_quality ?? "–"} samples below min quality</td></tr>
   ${g ? `<tr><td>GNSS</td><td>${g.n}</td><td>${fmt(g.rate_hz, 1)} Hz</td><td>${fmt(g.duration_s, 0)} s</td><td>${g.gaps}</td><td>${fmt(g.longest_gap_s, 1)} s</td>
     <td>${Object.entries(g.fix_time_share).map(([k, v]) => `${k} ${fmt(100 * v, 1)} %`).join(", ")}; ${g.bad_checksum} bad checksums</td></tr>` : ""}
  </table>${(q.warnings || []).map((w) => `<p class="badge warn">${esc(w)}</p>`).join("")}
  ${g ? `<div id="fixplot" class="plot" style="height:160px"></div>` : ""}</div>
  <div class="card"><h3>Run a pipeline</h3><select id="pipe">${pipes.map((p) => `<option value="${p.name}">${p.name} — ${esc(p.description)}</option>`).join("")}</select>
   <div id="params"></div><button id="start">Start</button> <span id="startmsg"></span></div>
  <div class="card"><h3>Jobs</h3><table id="jobs"><tbody></tbody></table></div>
  <p>Original files: ${log.files.map((f) => `<a href="/api/logs/${id}/files/${encodeURIComponent(f.name)}">${esc(f.name)}</a>`).join(" · ")}</p>`;
  if (g) {
    const tl = g.fix_timeline;
    Plotly.newPlot("fixplot", [{ type: "scatter", mode: "lines", line: { shape: "hv" }, name: "fix",
      x: tl.flatMap((r) => [r.t_start_s, r.t_end_s]), y: tl.flatMap((r) => [r.fix, r.fix]) }],
      { title: { text: "GNSS fix quality" }, margin: { t: 30, b: 30 }, yaxis: { dtick: 1 } }, { responsive: true });
  }
  const sel = document.getElementById("pipe"), box = document.getElementById("params");
  const showParams = () => {
    const p = pipes.find((x) => x.name === sel.value);
    box.innerHTML = p.parameters.map((a) => `<label title="${esc(a.help)}">${a.name}
      ${a.choices ? `<select data-p="${a.name}">${a.choices.map((c) => `<option ${c === a.default ? "selected" : ""}>${c}</option>`).join("")}</select>`
        : `<input type="text" data-p="${a.name}" placeholder="${esc(a.default ?? "")}" value="">`}</label>`).join("")
      + (p.multi_input ? `<label>other log ids <input type="text" id="extra" placeholder="e.g. 3,4"></label>` : "");
  };
  sel.addEventListener("change", showParams); showParams();
  document.getElementById("start").addEventListener("click", async () => {
    const parameters = {};
    box.querySelectorAll("[data-p]").forEach((el) => { if (el.value !== "") parameters[el.dataset.p] = el.value; });
    const extra = document.getElementById("extra");
    const log_ids = extra && extra.value ? extra.value.split(",").map((x) => +x.trim()) : [];
    const msg = document.getElementById("startmsg");
    try { const j = await api(`/api/logs/${id}/jobs`, { method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ pipeline: sel.value, parameters, log_ids }) }); msg.textContent = `job ${j.id} queued`; refreshJobs(id); }
    catch (e) { msg.innerHTML = `<span class="error">${esc(e.message)}</span>`; }
  });
  await refreshJobs(id);
  timers.push(setInterval(() => refreshJobs(id), 1000));
}

async function refreshJobs(id) {
  const jobs = await api(`/api/jobs?log_id=${id}`);
  const tb = document.querySelector("#jobs tbody");
  if (!tb) return;
  tb.innerHTML = jobs.map((j) => `<tr data-job="${j.id}"><td><a href="#/jobs/${j.id}">job ${j.id}</a></td><td>${j.pipeline}</td>
    <td class="status-${j.status}">${j.status}</td><td><progress value="${j.progress}" max="100"></progress> ${esc(j.stage)}</td>
    <td>${j.error ? `<span class="error">${esc(j.error)}</span>` : ""}</td>
    <td>${["queued", "running"].includes(j.status) ? `<button data-c="${j.id}">cancel</button>` : ""}
        ${["failed", "cancelled"].includes(j.status) ? `<button data-r="${j.id}">retry</button>` : ""}</td></tr>`).join("")
    || `<tr><td>No jobs yet.</td></tr>`;
  tb.querySelectorAll("[data-c]").forEach((b) => b.addEventListener("click", () => api(`/api/jobs/${b.dataset.c}/cancel`, { method: "POST" }).then(() => refreshJobs(id))));
  tb.querySelectorAll("[data-r]").forEach((b) => b.addEventListener("click", () => api(`/api/jobs/${b.dataset.r}/retry`, { method: "POST" }).then(() => refreshJobs(id))));
}

// ---------- one job: views, tables, downloads ----------
async function jobPage(id) {
  const j = await api(`/api/jobs/${id}`);
  app.innerHTML = `<h2>Job ${id}: ${j.pipeline} <span class="status-${j.status}" id="jobstatus">${j.status}</span></h2>
    <p><a href="#/logs/${j.log_ids[0]}">back to the log</a></p><div id="jobbody"></div>`;
  if (j.status !== "succeeded") {
    document.getElementById("jobbody").innerHTML = `<progress value="${j.progress}" max="100"></progress> ${esc(j.stage)} ${j.error ? `<p class="error">${esc(j.error)}</p>` : ""}`;
    if (["queued", "running"].includes(j.status)) timers.push(setInterval(async () => {
      const k = await api(`/api/jobs/${id}`); if (k.status !== j.status || k.progress !== j.progress) route(); }, 1000));
    return;
  }
  const files = await api(`/api/jobs/${id}/files`);
  const body = document.getElementById("jobbody");
  body.innerHTML = `<div class="card" id="downloads">${files.map((f) => `<a class="dl" download href="/api/jobs/${id}/files/${encodeURIComponent(f.name)}"><button>${esc(f.name)}</button></a>`).join(" ")}</div>
    ${summaryTable(j)}${(VIEWS[j.pipeline] || []).map((v) => `<div class="card"><div class="plot" id="view-${v}" data-view="${v}"></div></div>`).join("")}`;
  await Promise.all((VIEWS[j.pipeline] || []).map((v) => drawView(id, v)));  // in parallel
}

async function drawView(id, v, x0, x1) {
  const q = x0 !== undefined ? `?x0=${x0}&x1=${x1}` : "";
  const fig = await api(`/api/jobs/${id}/views/${v}${q}`);
  const el = document.getElementById(`view-${v}`);
  await Plotly.react(el, fig.data, fig.layout, { responsive: true });
  if (!el.dataset.bound) {
    el.dataset.bound = "1";
    el.on("plotly_relayout", (ev) => {  // zoom: fetch detail for the visible range
      if (ev["xaxis.range[0]"] !== undefined) drawView(id, v, ev["xaxis.range[0]"], ev["xaxis.range[1]"]);
      else if (ev["xaxis.autorange"]) drawView(id, v);
    });
  }
}

function summaryTable(j) {
  const s = j.summary || {};
  if (j.pipeline === "gravity") {
    const block = (b, title) => b ? `<h4>${title} — total ±${fmt(b.total_mgal, 3)} mGal (FIR ${b.fir_length_s} s, half-wavelength resolution ${fmt(b.resolution_m, 0)} m)</h4>
      <table class="coincidence"><tr><th>line</th><th>max (mGal)</th><th>min (mGal)</th><th>RMS (mGal)</th></tr>
      ${b.lines.map((l) => `<tr><td>${esc(l.name)}</td><td>${fmt(l.max_mgal)}</td><td>${fmt(l.min_mgal)}</td><td>${fmt(l.rms_mgal)}</td></tr>`).join("")}</table>` : "";
    return `<div class="card">${block(s, "SINS/LDV internal coincidence")}${block(s.gnss_comparison, "SINS/GNSS")}</div>`;
  }
  const rows = Object.entries(s).filter(([k, v]) => typeof v === "number" || typeof v === "string").filter(([k]) => !["started_at", "format_version", "software_version"].includes(k));
  return `<div class="card"><table class="summary">${rows.map(([k, v]) => `<tr><th>${esc(k)}</th><td>${typeof v === "number" ? Number(v).toPrecision(6) : esc(v)}</td></tr>`).join("")}</table></div>`;
}

// ---------- compare gravity lines from several jobs ----------
async function comparePage() {
  const jobs = (await api("/api/jobs")).filter((j) => j.pipeline === "gravity" && j.status === "succeeded");
  app.innerHTML = `<h2>Compare gravity lines</h2><p>${jobs.map((j) => `<label><input type="checkbox" value="${j.id}" checked> job ${j.id} (logs ${j.log_ids.join(", ")})</label>`).join("") || "No finished gravity jobs."}</p>
    <div class="card"><div class="plot" id="cmp"></div></div>`;
  const draw = async () => {
    const ids = [...document.querySelectorAll("input[type=checkbox]:checked")].map((x) => x.value);
    const traces = [];
    for (const id of ids) {
      const csv = await api(`/api/jobs/${id}/files/coincidence.csv`);
      const rows = csv.trim().split("\n").slice(1).map((r) => r.split(","));
      const lines = [...new Set(rows.map((r) => r[0]))];
      for (const ln of lines) { const rr = rows.filter((r) => r[0] === ln);
        traces.push({ type: "scattergl", mode: "lines", name: `job ${id} ${ln}`, x: rr.map((r) => +r[1]), y: rr.map((r) => +r[2]) }); }
    }
    Plotly.react("cmp", traces, { title: { text: "δg against along-track distance" }, xaxis: { title: { text: "distance (m)" } }, yaxis: { title: { text: "mGal" } } }, { responsive: true });
  };
  document.querySelectorAll("input[type=checkbox]").forEach((c) => c.addEventListener("change", draw));
  if (jobs.length) await draw();
}

fetch("/api/me").then((r) => (r.ok ? r.json() : null)).then((me) => {
  if (me) { window.CSRF = me.csrf; document.getElementById("who").textContent = me.user ? `${me.user}${me.demo ? " (demo account)" : ""}` : ""; }
}).catch(() => {}).finally(route);
