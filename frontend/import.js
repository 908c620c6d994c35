// Foreign recordings (NovAtel, u-blox, KF-GINS, NMEA, CSV) dropped on the upload zone:
// preview what the server recognised (formats, time span, rates, GNSS track), then confirm the import.
const BUNDLE_FILES = new Set(["manifest.json", "imu.csv", "ldv.csv", "gnss.nmea"]);
const esc = (s) => String(s ?? "").replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
const num = (x, d) => (x === null || x === undefined) ? "–" : Number(x).toFixed(d);

/** True when the dropped files are a bundle already (one .zip, or the bundle's own files). */
export function isBundle(files) {
  if (files.length === 1 && /\.zip$/i.test(files[0].name)) return true;
  return files.every((f) => BUNDLE_FILES.has(f.name)) && files.some((f) => f.name === "imu.csv");
}

function formData(files, manifestText) {
  const fd = new FormData();
  files.forEach((f) => fd.append("files", f, f.name));
  if (manifestText && manifestText.trim()) fd.append("manifest", manifestText);
  return fd;
}

async function post(path, fd) {
  const r = await fetch(path, { method: "POST", body: fd, credentials: "same-origin",
    headers: window.CSRF ? { "X-CSRF-Token": window.CSRF } : {} });
  let body = {}; try { body = await r.json(); } catch (e) { /* not JSON */ }
  return { ok: r.ok, status: r.status, body };
}

function errorHtml(status, body) {
  const e = body.error || {};
  return `<div class="error" id="upload-error">Import refused (${status}): ${esc(body.detail || "")}
${e.file ? "file: " + esc(e.file) : ""}${e.line ? ", line " + esc(e.line) : ""}${e.field ? ", field " + esc(e.field) : ""}</div>`;
}

function hms(t) {
  const s = ((t % 86400) + 86400) % 86400, day = Math.floor(t / 86400);
  const p = (x) => String(Math.floor(x)).padStart(2, "0");
  return `${p(s / 3600)}:${p((s % 3600) / 60)}:${p(s % 60)} UTC${day ? ` (+${day} d)` : ""}`;
}

/** Preview, then import on confirmation. `msg` is the element for messages, `done` refreshes the log list. */
export async function importFlow(files, msg, done) {
  const jsonFile = files.find((f) => /\.json$/i.test(f.name));
  const recordings = files.filter((f) => f !== jsonFile);
  const manifestText = jsonFile ? await jsonFile.text() : "";
  msg.innerHTML = "Recognising the recordings…";
  const pv = await post("/api/imports/preview", formData(recordings, manifestText));
  if (!pv.ok) { msg.innerHTML = errorHtml(pv.status, pv.body); return; }
  const p = pv.body, [t0, t1] = p.time_span_s, r = p.rates_hz;
  msg.innerHTML = `<div class="card" id="import-preview"><h3>Import foreign recordings</h3>
   <table id="import-files"><tr><th>file</th><th>format</th><th>data</th></tr>
   ${p.files.map((f) => `<tr><td>${esc(f.name)}</td><td class="fmt">${esc(f.format)}</td><td>${esc(f.role)}</td></tr>`).join("")}</table>
   <p id="import-span">Date ${esc(p.date)}, ${hms(t0)} to ${hms(t1)}: ${num((t1 - t0) / 60, 1)} min (t ${num(t0, 3)}–${num(t1, 3)} s)</p>
   <p id="import-rates">Rates: IMU ${num(r.imu, 1)} Hz · LDV ${num(r.ldv, 1)} Hz · GNSS ${r.gnss === null ? "none" : num(r.gnss, 2) + " Hz"}
    · IMU axes ${esc(p.imu_axes)} (static tilt ${num(p.static_tilt_deg, 2)}°)</p>
   ${p.warnings.length ? `<ul class="warn" id="import-warnings">${p.warnings.map((w) => `<li>${esc(w)}</li>`).join("")}</ul>` : ""}
   <div id="import-track" style="height:320px"></div>
   <button id="import-confirm">Confirm import</button> <button id="import-cancel">Cancel</button></div>`;
  if (p.gnss_track.length && window.Plotly) {
    const lon = p.gnss_track.map((c) => c[0]), lat = p.gnss_track.map((c) => c[1]);
    const lat0 = lat.reduce((a, b) => a + b, 0) / lat.length;
    window.Plotly.newPlot("import-track", [{ x: lon, y: lat, mode: "lines", name: "GNSS track" }],
      { margin: { t: 20, r: 10, b: 40, l: 60 }, xaxis: { title: "longitude (°)" },
        yaxis: { title: "latitude (°)", scaleanchor: "x", scaleratio: 1 / Math.cos((lat0 * Math.PI) / 180) } },
      { displaylogo: false, responsive: true });
  } else {
    document.getElementById("import-track").outerHTML = `<p id="import-track">No GNSS recording: no track to show.</p>`;
  }
  document.getElementById("import-cancel").addEventListener("click", () => { msg.innerHTML = ""; });
  document.getElementById("import-confirm").addEventListener("click", async () => {
    document.getElementById("import-confirm").disabled = true;
    const res = await post("/api/imports", formData(recordings, manifestText));
    if (!res.ok) { msg.innerHTML = errorHtml(res.status, res.body); return; }
    msg.innerHTML = `<p class="ok" id="upload-ok">${res.body.duplicate ? "Already stored" : "Imported and stored"}:
      <a href="#/logs/${res.body.id}">${esc(res.body.name)}</a> (originals kept beside the bundle)</p>`;
    if (done) done();
  });
}
