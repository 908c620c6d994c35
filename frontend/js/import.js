// Foreign recordings (NovAtel, u-blox, KF-GINS, NMEA, CSV) dropped on the upload zone:
// preview what the server recognised (formats, time span, rates, GNSS track), then confirm the import.
import { session } from "./api.js";
import { html, render, $ } from "./html.js";
import { draw } from "./plots.js";
import { onNonBundleFiles } from "./upload.js";

const num = (x, d) => (x === null || x === undefined ? "–" : Number(x).toFixed(d));

function formData(files, manifestText, projectId, axes) {
  const fd = new FormData();
  files.forEach((f) => fd.append("files", f, f.name));
  if (manifestText && manifestText.trim()) fd.append("manifest", manifestText);
  if (projectId) fd.append("project_id", projectId);
  if (axes) fd.append("axes", axes);
  return fd;
}

async function post(path, fd) {
  const r = await fetch(path, {
    method: "POST",
    body: fd,
    credentials: "same-origin",
    headers: session.csrf ? { "X-CSRF-Token": session.csrf } : {},
  });
  let body = {};
  try {
    body = await r.json();
  } catch (e) {
    /* not JSON */
  }
  return { ok: r.ok, status: r.status, body };
}

function refused(status, body) {
  const e = body.error || {};
  return html`<div class="error" id="upload-error">
    Import refused (${status}): ${body.detail || e.message || ""}
    ${e.file ? html`file: ${e.file}` : ""}${e.line ? html`, line ${e.line}` : ""}
    ${e.field ? html`, field ${e.field}` : ""}
  </div>`;
}

function hms(t) {
  const s = ((t % 86400) + 86400) % 86400,
    day = Math.floor(t / 86400);
  const p = (x) => String(Math.floor(x)).padStart(2, "0");
  return `${p(s / 3600)}:${p((s % 3600) / 60)}:${p(s % 60)} UTC${day ? ` (+${day} d)` : ""}`;
}

export function checks(c) {
  if (!c) return "";
  const g = c.static_gravity || {},
    o = c.overlap,
    tb = (c.imu_source || {}).time_base;
  const parts = [];
  if (g.normal_mps2 !== undefined)
    parts.push(
      `at rest |f| ${num(g.measured_mps2, 4)} m/s² vs normal gravity ${num(g.normal_mps2, 4)} m/s² ` +
        `(${num(100 * g.error_rel, 2)} %), ` +
        `|ω| ${num(g.omega_dph, 3)} °/h vs Earth rate ${num(g.earth_rate_dph, 3)} °/h`,
    );
  if (c.imu_rate) parts.push(`IMU rate ${num(c.imu_rate.measured_hz, 3)} Hz measured`);
  if (o) parts.push(`GNSS covers ${num(100 * o.share, 1)} % of the IMU span`);
  if (tb)
    parts.push(
      `${tb.message} time base from ${tb.anchors} ${tb.source} epochs: ${num(tb.tag_rate_hz, 1)} ticks/s ± ` +
        `${num(100 * tb.tag_rate_3sigma_rel, 2)} % (3σ), offset ± ${num(tb.offset_uncertainty_ms, 1)} ms`,
    );
  return parts.length ? html`<p id="import-checks">Checks: ${parts.join(" · ")}</p>` : "";
}

function preview(p) {
  const [t0, t1] = p.time_span_s,
    r = p.rates_hz;
  const gnss = r.gnss === null ? "none" : `${num(r.gnss, 2)} Hz`;
  return html`<div class="card" id="import-preview">
    <h3>Import foreign recordings</h3>
    <table id="import-files">
      <tr>
        <th>file</th>
        <th>format</th>
        <th>data</th>
      </tr>
      ${p.files.map(
        (f) =>
          html`<tr>
            <td>${f.name}</td>
            <td class="fmt">${f.format}</td>
            <td>${f.role}</td>
          </tr>`,
      )}
    </table>
    <p id="import-span">
      Date ${p.date}, ${hms(t0)} to ${hms(t1)}: ${num((t1 - t0) / 60, 1)} min (t ${num(t0, 3)}–${num(t1, 3)} s)
    </p>
    <p id="import-rates">
      Rates: IMU ${num(r.imu, 1)} Hz · LDV ${r.ldv == null ? "none" : num(r.ldv, 1) + " Hz"} · GNSS ${gnss} · IMU axes
      ${p.imu_axes} (static tilt ${num(p.static_tilt_deg, 2)}°)
    </p>
    ${checks(p.checks)}
    ${
      p.warnings.length
        ? html`<ul class="warn" id="import-warnings">
            ${p.warnings.map((w) => html`<li>${w}</li>`)}
          </ul>`
        : ""
    }
    ${
      p.gnss_track.length
        ? html`<div id="import-track" class="plot"></div>`
        : html`<p id="import-track">No GNSS recording: no track to show.</p>`
    }
    <button id="import-confirm">Confirm import</button> <button id="import-cancel">Cancel</button>
  </div>`;
}

function drawTrack(track) {
  const lon = track.map((c) => c[0]),
    lat = track.map((c) => c[1]);
  const lat0 = lat.reduce((a, b) => a + b, 0) / lat.length;
  return draw($("#import-track"), [{ x: lon, y: lat, mode: "lines", name: "GNSS track" }], {
    margin: { t: 20, r: 10, b: 40, l: 60 },
    height: 320,
    xaxis: { title: { text: "longitude (°)" } },
    yaxis: { title: { text: "latitude (°)" }, scaleanchor: "x", scaleratio: 1 / Math.cos((lat0 * Math.PI) / 180) },
  });
}

/** Preview, then import on confirmation; `message` renders into the upload zone, `done` refreshes the list. */
export async function importFlow(files, { projectId, message, done }) {
  const jsonFile = files.find((f) => /\.json$/i.test(f.name));
  const recordings = files.filter((f) => f !== jsonFile);
  const manifestText = jsonFile ? await jsonFile.text() : "";
  message(html`Recognising the recordings…`);
  let axes = "";
  let pv = await post("/api/imports/preview", formData(recordings, manifestText));
  // a recording without a fixed sensor frame (u-blox): ask for the axes the refusal talks about, then retry
  while (!pv.ok && ((pv.body || {}).error || {}).field === "axes") {
    message(
      html`${refused(pv.status, pv.body)}
        <p id="axes-ask">
          IMU sensor axes (where x, y, z point: F/B, R/L, U/D):
          <input id="axes-input" size="4" placeholder="FLU" value="${axes}" />
          <button id="axes-retry">Preview with these axes</button>
        </p>`,
    );
    axes = await new Promise((resolve) =>
      $("#axes-retry").addEventListener("click", () => resolve($("#axes-input").value.trim())),
    );
    message(html`Recognising the recordings…`);
    pv = await post("/api/imports/preview", formData(recordings, manifestText, null, axes));
  }
  if (!pv.ok) {
    message(refused(pv.status, pv.body));
    return;
  }
  message(preview(pv.body));
  if (pv.body.gnss_track.length) drawTrack(pv.body.gnss_track).catch(() => {});
  $("#import-cancel").addEventListener("click", () => message(""));
  $("#import-confirm").addEventListener("click", async () => {
    $("#import-confirm").disabled = true;
    const res = await post("/api/imports", formData(recordings, manifestText, projectId, axes));
    if (!res.ok) {
      message(refused(res.status, res.body));
      return;
    }
    message(
      html`<p class="ok" id="upload-ok">
        ${res.body.duplicate ? "Already stored" : "Imported and stored"}:
        <a href="#/logs/${res.body.id}">${res.body.name}</a> (originals kept beside the bundle)
      </p>`,
    );
    if (done) done();
  });
}

onNonBundleFiles(importFlow);
