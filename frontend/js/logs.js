// The logs list: filters (project, platform, survey dates), upload, delete.
import { api, session } from "./api.js";
import { html, render, $, $$ } from "./html.js";
import { fixed, pct } from "./format.js";
import { dropZone } from "./upload.js";
import { tiesPanel } from "./ties.js";

export async function logsPage(ctx, app) {
  const projects = (session.me && session.me.project_list) || [];
  const q = new URLSearchParams(location.hash.split("?")[1] || "");
  render(
    app,
    html`<h2>Drive logs</h2>
      <div id="upload"></div>
      <p class="hint">An upload goes to the project chosen in the filter below, or to your own project.</p>
      <form id="filters" class="row">
        <label
          >Project
          <select id="f-project">
            <option value="">all</option>
            ${projects.map(
              (p) =>
                html`<option value="${p.id}" ${q.get("project") === String(p.id) ? "selected" : ""}>${p.name}</option>`,
            )}
          </select></label
        >
        <label
          >Platform
          <select id="f-platform">
            <option value="">all</option>
            ${["vehicle", "vessel"].map((p) => platformOption(p, q))}
          </select></label
        >
        <label>Surveyed from <input type="date" id="f-from" value="${q.get("from") || ""}" /></label>
        <label>to <input type="date" id="f-to" value="${q.get("to") || ""}" /></label>
        <span id="project-report"></span>
      </form>
      <table id="logs">
        <thead>
          <tr>
            <th>name</th>
            <th>project</th>
            <th>date</th>
            <th>duration</th>
            <th>platform</th>
            <th>LDV</th>
            <th>quality</th>
            <th></th>
          </tr>
        </thead>
        <tbody>
          <tr>
            <td colspan="8">Loading…</td>
          </tr>
        </tbody>
      </table>
      <div id="project-ties"></div>`,
  );
  const names = Object.fromEntries(projects.map((p) => [p.id, p.name]));
  const ties = () => tiesPanel($("#project-ties"), $("#f-project").value, names[$("#f-project").value]);
  const refresh = () => (projectReport(names), ties(), refreshLogs(ctx, names));
  dropZone($("#upload"), { projectId: () => $("#f-project").value || null, done: refresh });
  $("#filters").addEventListener("change", () => {
    const p = new URLSearchParams();
    [
      ["project", "#f-project"],
      ["platform", "#f-platform"],
      ["from", "#f-from"],
      ["to", "#f-to"],
    ].forEach(([k, sel]) => {
      if ($(sel).value) p.set(k, $(sel).value);
    });
    history.replaceState(null, "", `#/logs${p.toString() ? "?" + p : ""}`);
    refresh();
  });
  await refresh();
}

// the chosen project's survey report (one HTML file: its logs, a map, its finished jobs)
function projectReport(names) {
  const id = $("#f-project").value;
  render(
    $("#project-report"),
    id
      ? html`<a id="project-report-download" download href="/api/projects/${id}/report"
          >Survey report of ${names[id] || `project ${id}`} (HTML)</a
        >`
      : "",
  );
}

async function refreshLogs(ctx, names) {
  const p = new URLSearchParams();
  if ($("#f-project").value) p.set("project_id", $("#f-project").value);
  if ($("#f-platform").value) p.set("platform", $("#f-platform").value);
  if ($("#f-from").value) p.set("date_from", $("#f-from").value);
  if ($("#f-to").value) p.set("date_to", $("#f-to").value);
  const logs = await api(`/api/logs?${p}`);
  if (!ctx.alive) return;
  const tb = $("#logs tbody");
  render(
    tb,
    logs.length
      ? logs.map((l) => row(l, names))
      : html`<tr>
          <td colspan="8">No logs${p.toString() ? " match the filters" : " yet"}.</td>
        </tr>`,
  );
  $$("button.del", tb).forEach((btn) =>
    btn.addEventListener("click", async () => {
      if (!confirm("Delete this log, its files and results?")) return;
      await api(`/api/logs/${btn.dataset.id}`, { method: "DELETE" });
      refreshLogs(ctx, names);
    }),
  );
}

function platformOption(p, q) {
  return html`<option ${q.get("platform") === p ? "selected" : ""}>${p}</option>`;
}

const lowqBadge = (lowq) => html`<span class="badge ${lowq > 0.05 ? "warn" : ""}">LDV low-q ${pct(lowq)}</span>`;

function row(l, names) {
  const b = l.badges || {};
  const lowq = b.ldv_below_min_quality_share;
  return html`<tr data-id="${l.id}">
    <td><a href="#/logs/${l.id}">${l.name || "(unnamed)"}</a></td>
    <td>${names[l.project_id] || "–"}</td>
    <td>${l.survey_date}</td>
    <td>${fixed(l.duration_s / 60, 1)} min</td>
    <td>${l.platform}</td>
    <td>${l.ldv_kind === "none" ? "no LDV" : l.ldv_kind}${l.imu_rotating ? " · rotating IMU" : ""}</td>
    <td>
      <span class="badge ${b.imu_gaps ? "warn" : ""}">IMU gaps ${b.imu_gaps ?? "–"}</span>
      <span class="badge">RTK ${pct(b.gnss_rtk_fixed_share, 0)}</span>
      ${l.ldv_kind === "none" ? "" : lowqBadge(lowq)}
      ${b.warnings ? html`<span class="badge warn">${b.warnings} warnings</span>` : ""}
    </td>
    <td>
      ${
        session.me && session.me.demo
          ? "" /* the demo account is read-only for what it did not create: the API says 403 */
          : html`<button class="del" data-id="${l.id}">delete</button>`
      }
    </td>
  </tr>`;
}
