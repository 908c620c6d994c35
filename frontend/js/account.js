// One's own account: password and API tokens. A new token's secret is shown once, beside the form,
// until hidden or the token revoked; revoking asks first; the forms clear after they succeed.
import { api } from "./api.js";
import { html, render, $, $$ } from "./html.js";
import { confirmInline } from "./confirm.js";

// the token whose secret is on the page, if any
let shownToken = null;

const day = (iso) => (iso ? iso.slice(0, 16).replace("T", " ") : "–");

export async function accountPage(ctx, app) {
  render(
    app,
    html`<h2>Account</h2>
      <div class="card">
        <h3>API tokens</h3>
        <p class="hint">Send a token as <code>Authorization: Bearer …</code>. It is shown once, when created.</p>
        <table id="tokens">
          <thead>
            <tr>
              <th>name</th>
              <th>created</th>
              <th>expires</th>
              <th>last used</th>
              <th></th>
            </tr>
          </thead>
          <tbody></tbody>
        </table>
        <form id="token-form" class="row">
          <label>Name <input name="name" id="token-name" required maxlength="100" value="laptop" /></label>
          <label
            >Expires after (days, empty: never)
            <input name="days" id="token-days" type="number" min="1" max="3660" value="90"
          /></label>
          <button type="submit" id="token-create">Create token</button>
        </form>
        <div id="token-confirm"></div>
        <div id="token-msg" role="status" aria-live="polite"></div>
      </div>
      <div class="card narrow">
        <h3>Change password</h3>
        <form id="password-form">
          <label>Current password <input type="password" name="old" autocomplete="current-password" required /></label>
          <label
            >New password (8 characters or more)
            <input type="password" name="new" minlength="8" autocomplete="new-password" required
          /></label>
          <button type="submit" id="password-change">Change password</button>
        </form>
        <div id="password-msg"></div>
      </div>`,
  );
  // handlers first: a click while the token list loads must not submit the form natively (a page reload)
  $("#token-form").addEventListener("submit", async (e) => {
    e.preventDefault();
    const days = $("#token-days").value;
    try {
      const t = await api("/api/tokens", {
        method: "POST",
        json: { name: $("#token-name").value, expires_days: days === "" ? null : Number(days) },
      });
      e.target.reset(); // back to the defaults for the next one
      await refreshTokens(ctx); // the list holds the new token by the time its secret is shown
      shownToken = t.id;
      render(
        $("#token-msg"),
        html`<p class="ok">
          New token <b>${t.name}</b> (copy it now, it is not shown again): <code id="new-token">${t.token}</code>
          <button id="hide-token">Hide it</button>
        </p>`,
      );
      $("#hide-token").addEventListener("click", () => {
        shownToken = null;
        render($("#token-msg"), html`<p>The secret is hidden; it can not be shown again.</p>`);
      });
    } catch (err) {
      render($("#token-msg"), html`<p class="error">${err.message}</p>`);
    }
  });
  $("#password-form").addEventListener("submit", async (e) => {
    e.preventDefault();
    const fd = new FormData(e.target);
    try {
      await api("/api/password", {
        method: "POST",
        json: { old_password: fd.get("old"), new_password: fd.get("new") },
      });
      e.target.reset();
      render($("#password-msg"), html`<p class="ok">Password changed: log in again.</p>`);
      setTimeout(() => {
        location.hash = "#/login";
        location.reload();
      }, 800);
    } catch (err) {
      render($("#password-msg"), html`<p class="error">${err.message}</p>`);
    }
  });
  await refreshTokens(ctx);
}

// the newest request wins: the page's first load of the list may answer after a later refresh
let tokenListRequest = 0;

async function refreshTokens(ctx) {
  const request = ++tokenListRequest;
  const tokens = await api("/api/tokens");
  if (!ctx.alive || request !== tokenListRequest) return;
  const tb = $("#tokens tbody");
  render(
    tb,
    tokens.length
      ? tokens.map(
          (t) =>
            html`<tr data-token="${t.id}">
              <td>${t.name}</td>
              <td>${day(t.created_at)}</td>
              <td>
                ${t.expires_at ? day(t.expires_at) : "never"}
                ${t.expired ? html`<span class="badge warn">expired</span>` : ""}
              </td>
              <td>${day(t.last_used_at)}</td>
              <td><button class="danger" data-revoke="${t.id}" data-name="${t.name}">revoke…</button></td>
            </tr>`,
        )
      : html`<tr>
          <td colspan="5">No tokens.</td>
        </tr>`,
  );
  $$("[data-revoke]", tb).forEach((b) =>
    b.addEventListener("click", () =>
      confirmInline(
        $("#token-confirm"),
        `Revoke token “${b.dataset.name}”?`,
        "Every program sending it is refused from now on; this can not be undone.",
        "Revoke token",
        async () => {
          try {
            await api(`/api/tokens/${b.dataset.revoke}`, { method: "DELETE" });
          } catch (err) {
            render($("#token-msg"), html`<p class="error">${err.message}</p>`);
            return;
          }
          const wasShown = shownToken === Number(b.dataset.revoke);
          if (wasShown) shownToken = null; // a revoked token's secret does not stay on the page
          render(
            $("#token-msg"),
            html`<p class="ok">Token “${b.dataset.name}” revoked${wasShown ? "; its secret is hidden" : ""}.</p>`,
          );
          await refreshTokens(ctx);
        },
      ),
    ),
  );
}
