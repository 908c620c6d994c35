// ldv-survey dashboard: routes, the header and the session. Talks to the REST API only.
import { api, session, setSession } from "./api.js";
import { html, render, $ } from "./html.js";
import { newPage } from "./page.js";
import { logsPage } from "./logs.js";
import { logPage } from "./log.js";
import { jobPage } from "./job.js";
import { comparePage } from "./compare.js";
import { loginPage } from "./login.js";
import { accountPage } from "./account.js";
import { adminPage } from "./admin.js";
import "./import.js"; // foreign recordings dropped on the upload zone

const app = $("#app");
const ROUTES = [
  [/^#\/logs\/(\d+)$/, (ctx, m) => logPage(ctx, app, +m[1])],
  [/^#\/jobs\/(\d+)$/, (ctx, m) => jobPage(ctx, app, +m[1])],
  [/^#\/compare/, (ctx) => comparePage(ctx, app)],
  [/^#\/account/, (ctx) => accountPage(ctx, app)],
  [/^#\/admin/, (ctx) => adminPage(ctx, app)],
  [/^#\/login/, (ctx) => loginPage(ctx, app, onLogin)],
  [/^/, (ctx) => logsPage(ctx, app)],
];

function header() {
  const me = session.me;
  render(
    $("#who"),
    me && me.user
      ? html`<a href="#/account" id="account-link">${me.user}</a>
          ${me.demo ? html`<span class="badge">demo account</span>` : ""}
          ${me.admin ? html`<a href="#/admin" id="admin-link">Admin</a>` : ""}
          <button id="logout" class="link">Log out</button>`
      : html``,
  );
  const out = $("#logout");
  if (out) {
    out.addEventListener("click", async () => {
      await api("/api/logout", { method: "POST" }).catch(() => {});
      setSession(null);
      location.hash = "#/login";
      await boot();
    });
  }
}

async function route() {
  const ctx = newPage();
  const h = location.hash || "#/logs";
  if (session.me === null && !h.startsWith("#/login")) return loginPage(ctx, app, onLogin);
  for (const [re, show] of ROUTES) {
    const m = h.match(re);
    if (!m) continue;
    try {
      await show(ctx, m);
    } catch (e) {
      if (ctx.alive) {
        if (e.status === 401) {
          setSession(null);
          header();
          return loginPage(ctx, app, onLogin);
        }
        render(app, html`<p class="error">${e.message}</p>`);
      }
    }
    return;
  }
}

async function onLogin() {
  await boot();
  if (location.hash.startsWith("#/login") || !location.hash) location.hash = "#/logs";
  else await route();
}

async function boot() {
  try {
    setSession(await api("/api/me"));
  } catch (e) {
    setSession(null); // not logged in
  }
  header();
}

window.addEventListener("hashchange", route);
// Plotly (1.5 MB) is fetched by the pages that draw a chart only (plots.js), never for lists and forms
boot().then(route);
