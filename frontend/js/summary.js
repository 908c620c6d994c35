// A job's summary as tables: every field, nested ones included; units in the names are kept.
import { html } from "./html.js";
import { fixed, quantity } from "./format.js";

const SKIP = new Set(["inputs", "warnings", "parameters"]); // shown in their own sections of the job page

function value(key, v) {
  if (v === null || v === undefined) return html`–`;
  if (Array.isArray(v)) {
    if (v.length && v.every((x) => x && typeof x === "object" && !Array.isArray(x))) return table(v);
    return html`${v.map((x) => quantity(key, x)).join(", ")}`;
  }
  if (typeof v === "object") return fields(v);
  if (typeof v === "boolean") return html`${v ? "yes" : "no"}`;
  return html`${quantity(key, v)}`;
}

function table(rows) {
  const keys = [...new Set(rows.flatMap((r) => Object.keys(r)))];
  return html`<table class="nested">
    <tr>
      ${keys.map((k) => html`<th>${k}</th>`)}
    </tr>
    ${rows.map(
      (r) =>
        html`<tr>
          ${keys.map((k) => html`<td>${value(k, r[k])}</td>`)}
        </tr>`,
    )}
  </table>`;
}

export function fields(obj, skip = new Set()) {
  return html`<table class="summary">
    ${Object.entries(obj)
      .filter(([k]) => !skip.has(k))
      .map(
        ([k, v]) =>
          html`<tr data-key="${k}">
            <th>${k}</th>
            <td>${value(k, v)}</td>
          </tr>`,
      )}
  </table>`;
}

export function summaryCard(j) {
  const s = j.summary || {};
  let extra = "";
  if (j.pipeline === "gravity") {
    const block = (b, title) =>
      b
        ? html`<h4>
              ${title} — total ±${fixed(b.total_mgal, 3)} mGal (FIR ${b.fir_length_s} s, half-wavelength resolution
              ${fixed(b.resolution_m, 0)} m)
            </h4>
            <table class="coincidence">
              <tr>
                <th>line</th>
                <th>max (mGal)</th>
                <th>min (mGal)</th>
                <th>RMS (mGal)</th>
              </tr>
              ${(b.lines || []).map(
                (l) =>
                  html`<tr>
                    <td>${l.name}</td>
                    <td>${fixed(l.max_mgal)}</td>
                    <td>${fixed(l.min_mgal)}</td>
                    <td>${fixed(l.rms_mgal)}</td>
                  </tr>`,
              )}
            </table>`
        : "";
    const main = s.aiding === "gnss" ? "SINS/GNSS internal coincidence (no LDV)" : "SINS/LDV internal coincidence";
    extra = html`${block(s, main)}${block(s.gnss_comparison, "SINS/GNSS")}`;
  }
  return html`<div class="card" id="summary">
    <h3>Summary</h3>
    ${extra}${fields(s, SKIP)}
  </div>`;
}
