// The login form.
import { api } from "./api.js";
import { html, render, $ } from "./html.js";

export async function loginPage(ctx, app, onLogin) {
  render(
    app,
    html`<div class="card narrow">
      <h2>Log in</h2>
      <form id="login-form">
        <label>User name <input name="username" id="login-user" autocomplete="username" required /></label>
        <label
          >Password <input name="password" id="login-password" type="password" autocomplete="current-password" required
        /></label>
        <button type="submit" id="login-submit">Log in</button>
      </form>
      <div id="login-msg"></div>
      <p class="hint">No account yet? An admin creates one (<code>ldv-survey user add NAME</code>).</p>
    </div>`,
  );
  const form = $("#login-form");
  form.addEventListener("submit", async (e) => {
    e.preventDefault();
    const fd = new FormData(form);
    try {
      await api("/api/login", { method: "POST", json: { username: fd.get("username"), password: fd.get("password") } });
      await onLogin();
    } catch (err) {
      if (ctx.alive) render($("#login-msg"), html`<p class="error" id="login-error">${err.message}</p>`);
    }
  });
  $("#login-user").focus();
}
