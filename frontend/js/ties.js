// A project's base stations (absolute gravity ties): listed, entered, changed and removed on the
// project's logs list; offered to the gravity job form as its base_ties (the server writes the text).
import { api } from "./api.js";
import { html, render, $, $$ } from "./html.js";
import { confirmInline } from "./confirm.js";
import { fixed } from "./format.js";

const FIELDS = [
  ["name", "name", "text", ""],
  ["lat_deg", "latitude (deg)", "number", "-90 to 90"],
  ["lon_deg", "longitude (deg)", "number", "-180 to 360"],
  ["h_m", "ellipsoidal height (m)", "number", "not orthometric"],
  ["g_mgal", "absolute g (mGal)", "number", "976000 to 984000"],
  ["sigma_mgal", "1-σ of g (mGal)", "number", "more than 0, at most 100"],
  ["note", "note / source", "text", "optional"],
];

const row = (t, k) =>
  html`<tr data-tie="${t.id}">
    <td>T${k + 1}</td>
    <td>${t.name}</td>
    <td>${fixed(t.lat_deg, 7)}</td>
    <td>${fixed(t.lon_deg, 7)}</td>
    <td>${fixed(t.h_m, 3)}</td>
    <td>${fixed(t.g_mgal, 3)}</td>
    <td>${t.sigma_mgal}</td>
    <td>${t.note}</td>
    <td><button data-edit="${t.id}">Edit</button> <button class="danger" data-del="${t.id}">Delete</button></td>
  </tr>`;

// the panel of project `id` (named `name`) in element `el`; nothing without a project
export async function tiesPanel(el, id, name) {
  if (!id) return render(el, "");
  let list;
  try {
    list = await api(`/api/projects/${id}/ties`);
  } catch (e) {
    return render(el, html`<p class="error">${e.message}</p>`);
  }
  render(
    el,
    html`<div class="card" id="ties">
      <h3>Base stations of ${name}</h3>
      <p class="hint">
        Absolute gravity ties, entered once for the project; the gravity job form fills base_ties with them (the n-th
        station is the job's Tn). Heights are ellipsoidal (WGS-84).
      </p>
      <table>
        <thead>
          <tr>
            <th></th>
            ${FIELDS.map(([, label]) => html`<th>${label}</th>`)}
            <th></th>
          </tr>
        </thead>
        <tbody>
          ${
            list.ties.length
              ? list.ties.map(row)
              : html`<tr>
                  <td colspan="9">No station yet.</td>
                </tr>`
          }
        </tbody>
      </table>
      <form id="tie-form" class="row">
        <input type="hidden" id="tie-id" value="" />
        ${FIELDS.map(
          ([k, label, type, hint]) =>
            html`<label
              >${label}
              <input id="tie-${k}" type="${type}" ${type === "number" ? html`step="any"` : ""} placeholder="${hint}"
            /></label>`,
        )}
        <button type="submit" id="tie-save">Add station</button>
      </form>
      <p id="tie-msg"></p>
    </div>`,
  );
  const reload = () => tiesPanel(el, id, name);
  const msg = $("#tie-msg", el);
  $("#tie-form", el).addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const body = {};
    for (const [k, , type] of FIELDS) {
      const v = $(`#tie-${k}`, el).value;
      body[k] = type === "number" ? (v === "" ? null : Number(v)) : v;
    }
    const tid = $("#tie-id", el).value;
    try {
      await api(`/api/projects/${id}/ties${tid ? `/${tid}` : ""}`, { method: tid ? "PUT" : "POST", json: body });
      await reload();
    } catch (e) {
      const f = e.body && e.body.error && e.body.error.field;
      render(msg, html`<span class="error">${e.message}</span>`);
      if (f && $(`#tie-${f}`, el)) $(`#tie-${f}`, el).focus();
    }
  });
  $$("[data-edit]", el).forEach((b) =>
    b.addEventListener("click", () => {
      const t = list.ties.find((x) => String(x.id) === b.dataset.edit);
      for (const [k] of FIELDS) $(`#tie-${k}`, el).value = t[k];
      $("#tie-id", el).value = t.id;
      render($("#tie-save", el), `Save ${t.name}`);
    }),
  );
  $$("[data-del]", el).forEach((b) =>
    b.addEventListener("click", () => {
      const t = list.ties.find((x) => String(x.id) === b.dataset.del);
      confirmInline(msg, `Delete station ${t.name}?`, "Jobs already run keep their values.", "Delete", async () => {
        try {
          await api(`/api/projects/${id}/ties/${t.id}`, { method: "DELETE" });
          await reload();
        } catch (e) {
          render(msg, html`<span class="error">${e.message}</span>`);
        }
      });
    }),
  );
}

// beside the base_ties field of a job form: a button filling it with the project's stations
export async function offerProjectTies(input, projectId) {
  if (!input || !projectId) return;
  const list = await api(`/api/projects/${projectId}/ties`).catch(() => null);
  if (!list || !list.base_ties || !input.isConnected) return;
  const b = document.createElement("button");
  b.type = "button";
  b.id = "use-project-ties";
  b.textContent = `Use the project's ties (${list.ties.map((t, k) => `T${k + 1} ${t.name}`).join(", ")})`;
  b.addEventListener("click", () => {
    input.value = list.base_ties;
  });
  input.after(b);
}
