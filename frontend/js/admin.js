// Admins: users, projects and memberships. Each form clears after a create and says so beside
// itself; deleting a user or a project asks first, saying what happens to the logs.
import { api, session } from "./api.js";
import { html, render, $, $$ } from "./html.js";
import { confirmInline } from "./confirm.js";

// what deleting does to the data (the server says the same: store/users.py *_DELETE_EFFECT)
const USER_EFFECT =
  "Their sessions, API tokens and memberships are deleted; the logs they uploaded and the jobs they " +
  "started stay in their projects. To keep the account but stop its access, disable it instead.";
const projectEffect = (n) =>
  `Its ${n} log${n === 1 ? "" : "s"} ${n === 1 ? "is" : "are"} deleted with the stored files and every job ` +
  "computed from them (results included). Its members keep their accounts.";

export async function adminPage(ctx, app) {
  render(
    app,
    html`<div id="admin">
      <h2>Admin</h2>
      <div class="card">
        <h3>Projects</h3>
        <table id="projects">
          <thead>
            <tr>
              <th>project</th>
              <th>logs</th>
              <th>members</th>
              <th>add a member</th>
              <th></th>
            </tr>
          </thead>
          <tbody></tbody>
        </table>
        <form id="project-form" class="row">
          <label>New project <input id="project-name" required maxlength="200" /> </label
          ><button type="submit" id="project-create">Create project</button>
        </form>
        <div id="project-confirm"></div>
        <div id="project-msg" role="status" aria-live="polite"></div>
      </div>
      <div class="card">
        <h3>Users</h3>
        <table id="users">
          <thead>
            <tr>
              <th>user</th>
              <th>role</th>
              <th>projects</th>
              <th>state</th>
              <th></th>
            </tr>
          </thead>
          <tbody></tbody>
        </table>
        <form id="user-form" class="row">
          <label>User name <input id="user-name" required maxlength="100" autocomplete="off" /></label>
          <label
            >Password <input id="user-password" type="password" minlength="8" required autocomplete="new-password"
          /></label>
          <label
            >Project
            <select id="user-project"></select
          ></label>
          <label><input type="checkbox" id="user-admin" /> admin</label>
          <button type="submit" id="user-create">Create user</button>
        </form>
        <div id="user-confirm"></div>
        <div id="user-msg" role="status" aria-live="polite"></div>
      </div>
      <div class="card">
        <h3>Storage</h3>
        <p id="storage"></p>
      </div>
    </div>`,
  );
  // the message shows beside the form or table it is about ("project" or "user")
  const msg = (where, m, ok) => render($(`#${where}-msg`), html`<p class="${ok ? "ok" : "error"}">${m}</p>`);
  const act = async (where, fn, done, form) => {
    try {
      const out = await fn();
      if (form) form.reset(); // nothing typed stays behind, the password least of all
      msg(where, typeof done === "function" ? done(out) : done, true);
      await refresh(ctx);
    } catch (e) {
      msg(where, e.message, false);
    }
  };
  $("#project-form").addEventListener("submit", (e) => {
    e.preventDefault();
    const name = $("#project-name").value;
    act(
      "project",
      () => api("/api/admin/projects", { method: "POST", json: { name } }),
      `Project “${name}” created.`,
      e.target,
    );
  });
  $("#user-form").addEventListener("submit", (e) => {
    e.preventDefault();
    const pid = $("#user-project").value;
    const body = {
      username: $("#user-name").value,
      password: $("#user-password").value,
      is_admin: $("#user-admin").checked,
      project_ids: pid ? [Number(pid)] : [],
    };
    act(
      "user",
      () => api("/api/admin/users", { method: "POST", json: body }),
      `User “${body.username}” created.`,
      e.target,
    );
  });
  $("#admin").addEventListener("click", (e) => {
    const t = e.target;
    if (t.dataset.disable) {
      const disabled = t.dataset.state !== "disabled";
      act(
        "user",
        () => api(`/api/admin/users/${t.dataset.disable}`, { method: "PATCH", json: { disabled } }),
        disabled
          ? `User “${t.dataset.name}” disabled: they can not log in and their tokens stop working.`
          : `User “${t.dataset.name}” enabled.`,
      );
    } else if (t.dataset.deluser) {
      confirmInline($("#user-confirm"), `Delete user “${t.dataset.name}”?`, USER_EFFECT, "Delete user", () =>
        act(
          "user",
          () => api(`/api/admin/users/${t.dataset.deluser}`, { method: "DELETE" }),
          (out) => `User “${out.deleted}” deleted (${out.tokens_deleted} API tokens with them); their logs stay.`,
        ),
      );
    } else if (t.dataset.delproject) {
      confirmInline(
        $("#project-confirm"),
        `Delete project “${t.dataset.name}”?`,
        projectEffect(Number(t.dataset.logs)),
        "Delete project and its logs",
        () =>
          act(
            "project",
            () => api(`/api/admin/projects/${t.dataset.delproject}`, { method: "DELETE" }),
            (out) => `Project “${out.deleted}” deleted with ${out.logs_deleted} logs and ${out.jobs_deleted} jobs.`,
          ),
      );
    } else if (t.dataset.addmember) {
      const uid = $(`select[data-member-of="${t.dataset.addmember}"]`).value;
      if (uid)
        act(
          "project",
          () => api(`/api/admin/projects/${t.dataset.addmember}/members/${uid}`, { method: "PUT" }),
          "Member added.",
        );
    } else if (t.dataset.rmproject) {
      act(
        "project",
        () => api(`/api/admin/projects/${t.dataset.rmproject}/members/${t.dataset.rmuser}`, { method: "DELETE" }),
        "Member removed.",
      );
    }
  });
  await refresh(ctx);
}

const mb = (bytes) => `${(bytes / 1e6).toFixed(1)} MB`;

// disable/enable and delete (never offered on one's own row: the server refuses both)
function userActions(u) {
  const state = u.disabled ? "disabled" : "active";
  return html`<button data-disable="${u.id}" data-name="${u.username}" data-state="${state}">
      ${u.disabled ? "enable" : "disable"}
    </button>
    ${u.is_demo ? "" : html`<button class="danger" data-deluser="${u.id}" data-name="${u.username}">delete…</button>`}`;
}

async function refresh(ctx) {
  const [users, projects, storage] = await Promise.all([
    api("/api/admin/users"),
    api("/api/admin/projects"),
    api("/api/admin/storage"),
  ]);
  if (!ctx.alive) return;
  const gone = storage.leftovers_removed;
  const now = storage.leftovers_now;
  render(
    $("#storage"),
    html`Stored logs: <b>${mb(storage.stored_bytes)}</b> of original files. Left by uploads that stopped mid-way (a
      killed process) and removed since the server started:
      <b id="leftovers-removed"
        >${gone.staging_folders} staging folders and ${gone.part_blobs} partial files, ${mb(gone.bytes)}</b
      >. In progress now: ${now.staging_folders} uploads, ${now.part_blobs} files being written.`,
  );
  const ids = Object.fromEntries(users.map((u) => [u.username, u.id]));
  render(
    $("#projects tbody"),
    projects.map(
      (p) =>
        html`<tr data-project="${p.name}">
          <td>${p.name}</td>
          <td>${p.n_logs}</td>
          <td>
            ${p.members.map(
              (m) =>
                html`<span class="chip"
                  >${m}<button class="link" data-rmproject="${p.id}" data-rmuser="${ids[m]}" title="remove">
                    ×
                  </button></span
                >`,
            )}
          </td>
          <td>
            <select data-member-of="${p.id}">
              <option value="">user…</option>
              ${users
                .filter((u) => !p.members.includes(u.username))
                .map((u) => html`<option value="${u.id}">${u.username}</option>`)}
            </select>
            <button data-addmember="${p.id}">add</button>
          </td>
          <td>
            <button class="danger" data-delproject="${p.id}" data-name="${p.name}" data-logs="${p.n_logs}">
              delete…
            </button>
          </td>
        </tr>`,
    ),
  );
  render(
    $("#users tbody"),
    users.map(
      (u) =>
        html`<tr data-user="${u.username}">
          <td>${u.username}</td>
          <td>${u.is_admin ? "admin" : u.is_demo ? "demo" : "member"}</td>
          <td>${u.projects.map((p) => p.name).join(", ") || "–"}</td>
          <td>${u.disabled ? "disabled" : "active"}</td>
          <td>
            ${u.username === (session.me && session.me.user) ? html`<span class="hint">you</span>` : userActions(u)}
          </td>
        </tr>`,
    ),
  );
  render(
    $("#user-project"),
    html`<option value="">(none)</option>
      ${projects.map((p) => html`<option value="${p.id}">${p.name}</option>`)}`,
  );
}
