// A job's result as a report: the headline figures (unit, floor, ratio, pass/fail against the
// user's specification), the per-line table, and the whole summary.json behind a disclosure with
// human labels and units (the server's labels: GET /api/jobs/{id} → labels, headlines).
import { html, render } from "./html.js";
import { fixed, quantity } from "./format.js";

const SKIP = new Set(["inputs", "warnings", "parameters"]); // shown in their own sections of the job page

// "fir_length_s" → "Fir length (s)" unless the server labelled it
function heading(key, labels) {
  const l = labels && labels[key];
  const text = l ? l.label : key.replace(/_/g, " ");
  return l && l.unit ? `${text} (${l.unit})` : text;
}

function value(key, v, labels) {
  if (v === null || v === undefined) return html`–`;
  if (Array.isArray(v)) {
    if (v.length && v.every((x) => x && typeof x === "object" && !Array.isArray(x))) return table(v, labels);
    return html`${v.map((x) => quantity(key, x)).join(", ")}`;
  }
  if (typeof v === "object") return fields(v, new Set(), labels);
  if (typeof v === "boolean") return html`${v ? "yes" : "no"}`;
  return html`${quantity(key, v)}`;
}

function table(rows, labels) {
  const keys = [...new Set(rows.flatMap((r) => Object.keys(r)))];
  return html`<table class="nested">
    <tr>
      ${keys.map((k) => html`<th>${heading(k, labels)}</th>`)}
    </tr>
    ${rows.map(
      (r) =>
        html`<tr>
          ${keys.map((k) => html`<td>${value(k, r[k], labels)}</td>`)}
        </tr>`,
    )}
  </table>`;
}

// every field of an object as label (unit) | value rows; nested objects and lists of rows as tables
export function fields(obj, skip = new Set(), labels = {}) {
  return html`<table class="summary">
    ${Object.entries(obj)
      .filter(([k]) => !skip.has(k))
      .map(
        ([k, v]) =>
          html`<tr data-key="${k}">
            <th>${heading(k, labels)}</th>
            <td>${value(k, v, labels)}</td>
          </tr>`,
      )}
  </table>`;
}

// a user's specification of a headline figure, kept in this browser per pipeline and figure
const specKey = (pipeline, key) => `ldvs-spec:${pipeline}:${key}`;
export const getSpec = (pipeline, key) => {
  const v = localStorage.getItem(specKey(pipeline, key));
  return v === null || v === "" || !Number.isFinite(Number(v)) ? null : Number(v);
};
export function setSpec(pipeline, key, v) {
  if (v === "" || v === null) localStorage.removeItem(specKey(pipeline, key));
  else localStorage.setItem(specKey(pipeline, key), String(v));
}
// |value| ≤ specification passes
export function verdict(h, spec) {
  if (spec === null || typeof h.value !== "number") return html`<span class="muted">–</span>`;
  return Math.abs(h.value) <= spec
    ? html`<span class="verdict pass">pass</span>`
    : html`<span class="verdict fail">fail</span>`;
}

function headlineTable(j) {
  const hs = j.headlines || [];
  if (!hs.length) return "";
  const anySpec = hs.some((h) => h.specifiable);
  return html`<table id="headlines" class="headlines">
    <tr>
      <th>figure</th>
      <th class="num">value</th>
      ${
        anySpec
          ? html`<th>your specification</th>
              <th>verdict</th>`
          : ""
      }
    </tr>
    ${hs.map((h) => {
      const spec = getSpec(j.pipeline, h.key);
      return html`<tr data-headline="${h.key}">
        <td>${h.label}</td>
        <td class="num"><b>${h.text}</b></td>
        ${
          anySpec
            ? h.specifiable
              ? html`<td>
                    <label
                      >≤
                      <input
                        class="spec"
                        type="number"
                        min="0"
                        step="any"
                        data-spec="${h.key}"
                        value="${spec === null ? "" : spec}"
                        aria-label="your specification for: ${h.label}"
                      />
                      ${h.unit}</label
                    >
                  </td>
                  <td data-verdict="${h.key}">${verdict(h, spec)}</td>`
              : html`<td></td>
                  <td></td>`
            : ""
        }
      </tr>`;
    })}
  </table>`;
}

function perLine(j) {
  const s = j.summary || {};
  if (j.pipeline !== "gravity") return "";
  const block = (b, title) =>
    b
      ? html`<h4>
            ${title} — total ±${fixed(b.total_mgal, 3)} mGal (FIR ${b.fir_length_s} s, half-wavelength resolution
            ${fixed(b.resolution_m, 0)} m)
          </h4>
          <table class="coincidence">
            <tr>
              <th>line</th>
              <th class="num">RMS (mGal)</th>
              <th class="num">1σ (mGal)</th>
              <th class="num">max (mGal)</th>
              <th class="num">min (mGal)</th>
              <th class="num">bridged (s)</th>
            </tr>
            ${(b.lines || []).map(
              (l) =>
                html`<tr>
                  <td>${l.name}</td>
                  <td class="num">${fixed(l.rms_mgal)}</td>
                  <td class="num">${fixed(l.std_mgal)}</td>
                  <td class="num">${fixed(l.max_mgal)}</td>
                  <td class="num">${fixed(l.min_mgal)}</td>
                  <td class="num">${fixed(l.bridged_s, 1)}</td>
                </tr>`,
            )}
          </table>`
      : "";
  return html`<div id="lines">
    ${block(s, s.aiding === "gnss" ? "SINS/GNSS internal coincidence (no LDV)" : "SINS/LDV internal coincidence")}
    ${block(s.gnss_comparison, "SINS/GNSS")}
  </div>`;
}

// the card the job page leads with
export function summaryCard(j) {
  const s = j.summary || {};
  const nw = (j.warnings || []).length;
  return html`<div class="card" id="summary">
    <h3>Result</h3>
    ${headlineTable(j)}
    ${
      nw
        ? html`<p class="warn" id="warning-count">
            <a href="#job-warnings">${nw} warning${nw === 1 ? "" : "s"}</a> (below) qualify these figures.
          </p>`
        : ""
    }
    ${perLine(j)}
    <details id="summary-all">
      <summary>Full summary (summary.json), ${Object.keys(s).length} entries</summary>
      ${fields(s, SKIP, j.labels || {})}
    </details>
  </div>`;
}

// the verdicts follow the specification as it is typed (and are kept for this browser)
export function bindSpecs(root, j) {
  root.querySelectorAll("input[data-spec]").forEach((el) =>
    el.addEventListener("input", () => {
      const h = j.headlines.find((x) => x.key === el.dataset.spec);
      const v = el.value === "" || !Number.isFinite(Number(el.value)) ? null : Number(el.value);
      setSpec(j.pipeline, h.key, v === null ? "" : v);
      render(root.querySelector(`[data-verdict="${CSS.escape(h.key)}"]`), verdict(h, v));
    }),
  );
}
