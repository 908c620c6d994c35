// REST calls with the session's CSRF token; errors carry the server's message.
export const session = { csrf: null, me: null };

export async function api(path, opts = {}) {
  const headers = { ...(opts.headers || {}) };
  if (session.csrf) headers["X-CSRF-Token"] = session.csrf;
  if (opts.json !== undefined) {
    headers["Content-Type"] = "application/json";
    opts = { ...opts, body: JSON.stringify(opts.json) };
  }
  const r = await fetch(path, { credentials: "same-origin", ...opts, headers });
  if (!r.ok) {
    let body = {};
    try {
      body = await r.json();
    } catch (e) {
      /* not JSON */
    }
    const d = body.detail;
    const msg =
      typeof d === "string"
        ? d
        : Array.isArray(d)
          ? d.map((x) => `${(x.loc || []).slice(1).join(".")}: ${x.msg}`).join("; ")
          : `${r.status} ${r.statusText}`;
    const err = new Error(msg);
    err.body = body;
    err.status = r.status;
    throw err;
  }
  if (r.status === 204) return null;
  const ct = r.headers.get("content-type") || "";
  return ct.includes("json") ? r.json() : r.text();
}

// names shared with the server (GNSS fix qualities): one list, served by GET /api/names, fetched once
let shared = null;
export function names() {
  if (!shared) shared = api("/api/names").catch((e) => ((shared = null), Promise.reject(e)));
  return shared;
}

export function setSession(me) {
  session.me = me;
  session.csrf = me ? me.csrf : null;
  window.CSRF = session.csrf; // for pages added by other modules (e.g. the importer)
}
