// One log: quality report, GNSS fix plot, start a pipeline, its jobs (polled while the page is shown).
import { api, names } from "./api.js";
import { html, render, $, $$ } from "./html.js";
import { fixed, num } from "./format.js";
import { draw } from "./plots.js";
import { checks } from "./import.js";
import { offerProjectTies } from "./ties.js";

// the import's cross-checks, kept in the manifest of an imported bundle
const importChecks = (prov) => (prov && prov.checks ? checks(prov.checks) : "");

const stream = (name, s, notes) =>
  html`<tr>
    <td>${name}</td>
    <td>${num(s.n)}</td>
    <td>${fixed(s.rate_hz, 1)} Hz</td>
    <td>${fixed(s.duration_s, 0)} s</td>
    <td>${num(s.gaps)}</td>
    <td>${fixed(s.longest_gap_s, 2)} s</td>
    <td>${notes}</td>
  </tr>`;

export async function logPage(ctx, app, id) {
  const [log, pipes] = await Promise.all([api(`/api/logs/${id}`), api(`/api/pipelines?log_id=${id}`)]);
  // offer only the pipelines that apply to this log; say why the others do not
  const usable = pipes.filter((p) => p.applicable !== false),
    refused = pipes.filter((p) => p.applicable === false);
  if (!ctx.alive) return;
  const q = log.quality || {},
    g = q.gnss;
  render(
    app,
    html`<h2>${log.name}</h2>
      <div class="card">
        <h3>Quality</h3>
        <table>
          <tr>
            <th>stream</th>
            <th>samples</th>
            <th>rate</th>
            <th>duration</th>
            <th>gaps</th>
            <th>longest gap</th>
            <th>notes</th>
          </tr>
          ${stream("IMU", q.imu, q.imu.rotating ? "rotating" : "fixed")}
          ${
            q.ldv
              ? stream("LDV", q.ldv, `${q.ldv.kind}, ${num(q.ldv.below_min_quality)} samples below min quality`)
              : html`<tr id="noldv">
                  <td>LDV</td>
                  <td colspan="6">no LDV (an INS/GNSS log)</td>
                </tr>`
          }
          ${
            g
              ? stream(
                  "GNSS",
                  g,
                  `${Object.entries(g.fix_time_share)
                    .map(([k, v]) => `${k} ${fixed(100 * v, 1)} %`)
                    .join(", ")}; ${num(g.bad_checksum)} bad checksums`,
                )
              : ""
          }
        </table>
        ${(q.warnings || []).map((w) => html`<p class="badge warn">${w}</p>`)}
        ${importChecks(((log.manifest || {}).import || {}).provenance)}
        ${g ? html`<div id="fixplot" class="plot short"></div>` : ""}
      </div>
      <div class="card">
        <h3>Run a pipeline</h3>
        <select id="pipe">
          ${usable.map((p) => html`<option value="${p.name}">${p.name} — ${p.description}</option>`)}
        </select>
        <div id="params"></div>
        <button id="start">Start</button> <span id="startmsg"></span> ${
          refused.length
            ? html`<details id="notapplicable">
                <summary>Not for this log: ${refused.map((p) => p.name).join(", ")}</summary>
                <ul>
                  ${refused.map((p) => html`<li data-na="${p.name}"><b>${p.name}</b>: ${p.reasons.join("; ")}</li>`)}
                </ul>
              </details>`
            : ""
        }
      </div>
      <div class="card">
        <h3>Jobs</h3>
        <table id="jobs" class="jobs">
          <tbody></tbody>
        </table>
      </div>
      <p>
        Original files:
        ${log.files.map(
          (f, i) => html`${i ? " · " : ""}<a href="/api/logs/${id}/files/${encodeURIComponent(f.name)}">${f.name}</a>`,
        )}
      </p>`,
  );
  if (g) names().then((n) => ctx.alive && fixPlot($("#fixplot"), g.fix_timeline, n.fix_quality));
  const sel = $("#pipe"),
    box = $("#params");
  const showParams = () => {
    const p = usable.find((x) => x.name === sel.value);
    if (!p) return render(box, html`<p>No pipeline applies to this log.</p>`);
    render(
      box,
      html`${Object.entries(p.schema.properties).map(([name, s]) =>
        paramInput(
          name,
          s,
          p.parameters.find((q) => q.name === name),
        ),
      )}
      ${
        p.multi_input ? html`<label>other log ids <input type="text" id="extra" placeholder="e.g. 3,4" /> </label>` : ""
      }`,
    );
    offerProjectTies($('[data-p="base_ties"]', box), log.project_id);
  };
  sel.addEventListener("change", showParams);
  showParams();
  $("#start").addEventListener("click", async () => {
    const parameters = {};
    $$("[data-p]", box).forEach((el) => {
      if (el.value !== "") parameters[el.dataset.p] = el.value;
    });
    const extra = $("#extra");
    const log_ids = extra && extra.value ? extra.value.split(",").map((x) => +x.trim()) : [];
    const msg = $("#startmsg");
    try {
      const j = await api(`/api/logs/${id}/jobs`, {
        method: "POST",
        json: { pipeline: sel.value, parameters, log_ids },
      });
      render(msg, html`job ${j.id} queued`);
      refreshJobs(ctx, id);
    } catch (e) {
      render(msg, html`<span class="error">${e.message}</span>`);
    }
  });
  await refreshJobs(ctx, id);
  ctx.every(() => refreshJobs(ctx, id), 1000);
}

// One form field from a parameter's JSON schema (pydantic): a choice list for enums and booleans, a
// number input with the model's bounds for numbers, text for lists ("1,2,3") and strings. Left empty,
// the parameter is not sent and the server's default applies. Labelled with the parameter's label and
// unit (GET /api/pipelines: pipelines/labels.py), its model's description beside it, its key (what
// `ldv-survey run --set` and the API take) in the tooltip.
function paramInput(name, schema, info) {
  const s = (schema.anyOf || [schema]).find((a) => a.type !== "null") || schema;
  const dflt = schema.default;
  const title = info && info.label ? info.label : name.replace(/_/g, " ");
  const unit = info && info.unit ? ` (${info.unit})` : "";
  const label = (field) =>
    html`<label class="param" title="${name}: ${schema.description || ""}"
      ><span class="param-label">${title}${unit}</span> ${field}
      <small class="hint">${schema.description || ""}</small></label
    >`;
  if (s.enum || s.type === "boolean") {
    const opts = s.enum || [true, false];
    return label(
      html`<select data-p="${name}">
        ${opts.map((c) => html`<option value="${String(c)}" ${c === dflt ? "selected" : ""}>${String(c)}</option>`)}
      </select>`,
    );
  }
  if (s.type === "number" || s.type === "integer") {
    const lo = s.minimum ?? s.exclusiveMinimum,
      hi = s.maximum ?? s.exclusiveMaximum;
    return label(
      html`<input
        type="number"
        data-p="${name}"
        step="${s.type === "integer" ? 1 : "any"}"
        ${lo !== undefined ? html`min="${lo}"` : ""}
        ${hi !== undefined ? html`max="${hi}"` : ""}
        placeholder="${dflt ?? ""}"
        value=""
      />`,
    );
  }
  const text = Array.isArray(dflt) ? dflt.join(",") : (dflt ?? "");
  return label(html`<input type="text" data-p="${name}" placeholder="${text}" value="" />`);
}

async function refreshJobs(ctx, id) {
  const jobs = await api(`/api/jobs?log_id=${id}`);
  if (!ctx.alive) return; // another page is shown now: its table is not ours
  const tb = $("#jobs tbody");
  render(
    tb,
    jobs.length
      ? jobs.map(
          (j) =>
            html`<tr data-job="${j.id}">
              <td><a href="#/jobs/${j.id}">job ${j.id}</a></td>
              <td>${j.pipeline}</td>
              <td class="status-${j.status}">${j.status}</td>
              <td><progress value="${j.progress}" max="100"></progress> ${j.stage}</td>
              <td class="err">${j.error ? html`<span class="error">${j.error}</span>` : ""}</td>
              <td>
                ${["queued", "running"].includes(j.status) ? html`<button data-c="${j.id}">cancel</button>` : ""}
                ${["failed", "cancelled"].includes(j.status) ? html`<button data-r="${j.id}">retry</button>` : ""}
              </td>
            </tr>`,
        )
      : html`<tr>
          <td>No jobs yet.</td>
        </tr>`,
  );
  $$("[data-c]", tb).forEach((b) =>
    b.addEventListener("click", () =>
      api(`/api/jobs/${b.dataset.c}/cancel`, { method: "POST" }).then(() => refreshJobs(ctx, id)),
    ),
  );
  $$("[data-r]", tb).forEach((b) =>
    b.addEventListener("click", () =>
      api(`/api/jobs/${b.dataset.r}/retry`, { method: "POST" }).then(() => refreshJobs(ctx, id)),
    ),
  );
}

// GNSS fix quality over time: one trace (and legend entry) per fix value
function fixPlot(el, timeline, fixNames) {
  const values = [...new Set(timeline.map((r) => r.fix))].sort((a, b) => a - b);
  const traces = values.map((v) => {
    const x = [],
      y = [];
    timeline
      .filter((r) => r.fix === v)
      .forEach((r) => {
        x.push(r.t_start_s, r.t_end_s, null);
        y.push(v, v, null);
      });
    return { type: "scatter", mode: "lines", name: fixNames[v] || `fix ${v}`, x, y, line: { width: 8 } };
  });
  draw(el, traces, {
    title: { text: "GNSS fix quality" },
    margin: { t: 40, b: 50, r: 20 },
    xaxis: { title: { text: "t (s of day)" } },
    yaxis: { title: { text: "fix quality" }, tickvals: values, ticktext: values.map(String), range: [-0.5, 6.5] },
    legend: { title: { text: "fix" } },
  });
}
