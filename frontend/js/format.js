// Numbers and results as people read them.
export const ARCSEC_PER_RAD = (180 * 3600) / Math.PI;

export function num(x, digits = 6) {
  if (x === null || x === undefined || x === "") return "–";
  const v = Number(x);
  if (Number.isNaN(v)) return "–";
  if (!Number.isFinite(v)) return v > 0 ? "∞" : "−∞";
  if (Number.isInteger(v)) return String(v);
  // large values keep three decimals (e.g. seconds of day); trailing zeros are dropped
  const p = Math.min(15, Math.max(digits, Math.floor(Math.log10(Math.abs(v))) + 4));
  return String(Number(v.toPrecision(p)));
}

export const fixed = (x, d = 2) =>
  x === null || x === undefined || Number.isNaN(Number(x)) ? "–" : Number(x).toFixed(d);

export const pct = (share, d = 1) => (share === null || share === undefined ? "–" : `${fixed(100 * share, d)} %`);

// a summary value with its unit spelt out; angles in radians also in arcseconds
export function quantity(key, v) {
  if (typeof v !== "number") return String(v);
  if (/_rad$/.test(key)) return `${num(v)} rad (${num(v * ARCSEC_PER_RAD, 4)}″)`;
  return num(v);
}
