// One job as a report: state (kept current while it runs); when it succeeded the result first
// (headline figures with unit, floor, ratio and pass/fail against the user's specification, the
// per-line table), then downloads and charts, the full summary behind a disclosure; then
// parameters (labelled, with units), inputs with SHA-256, warnings and the stage log.
import { api } from "./api.js";
import { html, render, $ } from "./html.js";
import { num } from "./format.js";
import { draw } from "./plots.js";
import { basemap, isMap, mapOverlay, onBasemap } from "./maps.js";
import { bindSpecs, fields, summaryCard } from "./summary.js";

const ACTIVE = ["queued", "running"];

export async function jobPage(ctx, app, id) {
  let j = await api(`/api/jobs/${id}`);
  if (!ctx.alive) return;
  render(
    app,
    html`<h2>Job ${id}: ${j.pipeline} <span id="jobstatus"></span></h2>
      <p><a href="#/logs/${j.log_ids[0]}">back to the log</a></p>
      <div id="jobstate"></div>
      <div id="results"></div>
      <div id="jobinfo"></div>`,
  );
  showState(j);
  showInfo(j);
  if (j.status === "succeeded") return showResults(ctx, j);
  if (!ACTIVE.includes(j.status)) return;
  ctx.every(async () => {
    j = await api(`/api/jobs/${id}`);
    if (!ctx.alive) return false;
    showState(j);
    showInfo(j);
    if (j.status === "succeeded") await showResults(ctx, j);
    return ACTIVE.includes(j.status);
  }, 1000);
}

function showState(j) {
  render($("#jobstatus"), html`<span class="status-${j.status}">${j.status}</span>`);
  const running = ACTIVE.includes(j.status);
  const progress = html`<progress value="${j.progress}" max="100"></progress> <span id="jobstage">${j.stage}</span>`;
  render(
    $("#jobstate"),
    html`<div class="card" id="state">
      ${running ? progress : ""}
      ${j.status === "failed" ? html`<p class="error" id="joberror">${j.error || "failed"}</p>` : ""}
      ${
        j.status === "cancelled"
          ? html`<p>Cancelled${j.stage && j.stage !== "cancelled" ? html` (${j.stage})` : ""}. No results.</p>`
          : ""
      }
      ${
        j.status === "succeeded"
          ? html`<p class="ok">
              Finished ${j.finished_at ? j.finished_at.slice(0, 19) : ""} after ${j.attempts}
              attempt${j.attempts === 1 ? "" : "s"}.
            </p>`
          : ""
      }
    </div>`,
  );
}

function showInfo(j) {
  const params = (j.summary && j.summary.parameters) || j.parameters || {};
  render(
    $("#jobinfo"),
    html` <div class="card" id="job-parameters">
        <h3>Parameters</h3>
        ${Object.keys(params).length ? fields(params, new Set(), j.labels || {}) : html`<p>defaults</p>`}
      </div>
      <div class="card" id="job-inputs">
        <h3>Inputs</h3>
        <table>
          <tr>
            <th>log</th>
            <th>file</th>
            <th>bytes</th>
            <th>SHA-256</th>
          </tr>
          ${(j.inputs || []).map((i) =>
            i.files.map(
              (f) =>
                html`<tr>
                  <td>
                    <a href="#/logs/${i.log_id}">${i.name}</a>
                  </td>
                  <td>${f.name}</td>
                  <td>${num(f.size_bytes)}</td>
                  <td><code class="hash">${f.sha256}</code></td>
                </tr>`,
            ),
          )}
        </table>
      </div>
      <div class="card" id="job-warnings">
        <h3>Warnings</h3>
        ${
          (j.warnings || []).length
            ? html`<ul>
                ${j.warnings.map((w) => html`<li>${w}</li>`)}
              </ul>`
            : html`<p>none</p>`
        }
      </div>
      <div class="card" id="job-stages">
        <h3>Stage log</h3>
        <table>
          <tr>
            <th>attempt</th>
            <th>t (s)</th>
            <th>stage</th>
            <th>progress (%)</th>
          </tr>
          ${(j.stage_log || []).map(
            (e) =>
              html`<tr>
                <td>${e.attempt}</td>
                <td>${num(e.t_s, 4)}</td>
                <td>${e.stage}</td>
                <td>${num(e.progress)}</td>
              </tr>`,
          )}
        </table>
      </div>`,
  );
}

async function showResults(ctx, j) {
  const files = await api(`/api/jobs/${j.id}/files`);
  if (!ctx.alive) return;
  const views = j.views || []; // the server's view registry (api/views.py): name, title, units, files
  render(
    $("#results"),
    html`${summaryCard(j)}
      <div class="card" id="downloads">
        <a class="dl" id="report-download" download href="/api/jobs/${j.id}/report"
          ><button>Survey report (HTML, prints to PDF)</button></a
        >
        ${files.map(
          (f) =>
            html`<a class="dl" download href="/api/jobs/${j.id}/files/${encodeURIComponent(f.name)}"
              ><button>${f.name}</button></a
            > `,
        )}
      </div>
      ${views.map(
        (v) =>
          html`<div class="card">
            <div class="plot" id="view-${v.name}" data-view="${v.name}" aria-label="${v.title} (${v.units})"></div>
          </div>`,
      )}`,
  );
  bindSpecs($("#results"), j);
  await Promise.all(views.map((v) => drawView(ctx, j.id, v.name)));
}

async function drawView(ctx, id, v, x0, x1) {
  const q = x0 !== undefined ? `?x0=${x0}&x1=${x1}` : "";
  const el = $(`#view-${v}`);
  try {
    let fig = await api(`/api/jobs/${id}/views/${v}${q}`);
    if (isMap(fig)) {
      const bm = await basemap();
      if (bm.tile_url) {
        mapToggle(ctx, id, v, el);
        if (el.dataset.plain !== "1") fig = onBasemap(fig, bm, el.clientWidth || 900, 450);
      }
    }
    if (!ctx.alive) return;
    if (el.dataset.drawn && Boolean(fig.layout.map) !== (el.dataset.drawn === "map")) window.Plotly.purge(el);
    if (!(await draw(el, fig.data, fig.layout))) return;
    el.dataset.drawn = fig.layout.map ? "map" : "plain";
    if (fig.layout.map) mapOverlay(el);
    else if (el.parentNode.querySelector(".map-overlay")) render(el.parentNode.querySelector(".map-overlay"), "");
  } catch (e) {
    if (ctx.alive) render(el, html`<p class="error">The plot “${v}” could not be drawn: ${e.message}</p>`);
    return;
  }
  if (!el.dataset.bound && !el.layout.map) {
    el.dataset.bound = "1";
    el.on("plotly_relayout", (ev) => {
      // zoom: fetch detail for the visible range
      if (ev["xaxis.range[0]"] !== undefined) drawView(ctx, id, v, ev["xaxis.range[0]"], ev["xaxis.range[1]"]);
      else if (ev["xaxis.autorange"]) drawView(ctx, id, v);
    });
  }
}

// a map view on a basemap can be switched to the plain projected map in metres (and back)
function mapToggle(ctx, id, v, el) {
  if (el.parentNode.querySelector(".map-toggle")) return;
  const lab = document.createElement("label");
  lab.className = "map-toggle";
  render(lab, html`<input type="checkbox" checked /> basemap (off: plain map in metres)`);
  lab.querySelector("input").addEventListener("change", (e) => {
    el.dataset.plain = e.target.checked ? "" : "1";
    drawView(ctx, id, v);
  });
  el.parentNode.appendChild(lab);
}
