// The one escaping template helper: every interpolated value is escaped unless it is raw(...)
// or another html`...` result. Arrays are joined; null and undefined render as nothing.
class Safe {
  constructor(s) {
    this.s = s;
  }
  toString() {
    return this.s;
  }
}
const ESC = { "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" };
const escape = (v) => String(v).replace(/[&<>"']/g, (c) => ESC[c]);
const part = (v) => {
  if (v === null || v === undefined || v === false) return "";
  if (v instanceof Safe) return v.s;
  if (Array.isArray(v)) return v.map(part).join("");
  return escape(v);
};
export const html = (strings, ...values) =>
  new Safe(strings.reduce((out, s, i) => out + s + (i < values.length ? part(values[i]) : ""), ""));
export const raw = (s) => new Safe(String(s));
// fragment: html`...`, an array of them, or plain text (escaped)
export const render = (el, fragment) => {
  el.innerHTML = part(fragment);
  return el;
};
export const $ = (sel, root = document) => root.querySelector(sel);
export const $$ = (sel, root = document) => [...root.querySelectorAll(sel)];
