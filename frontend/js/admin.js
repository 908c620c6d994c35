// Admins: users, projects and memberships; what the server stores and what it cleaned up.
import { api } from "./api.js";
import { html, render, $, $$ } from "./html.js";

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
              <th>members</th>
              <th>add a member</th>
            </tr>
          </thead>
          <tbody></tbody>
        </table>
        <form id="project-form" class="row">
          <label>New project <input id="project-name" required maxlength="200" /> </label
          ><button type="submit" id="project-create">Create project</button>
        </form>
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
      </div>
      <div class="card">
        <h3>Storage</h3>
        <p id="storage"></p>
      </div>
      <div id="admin-msg"></div>
    </div>`,
  );
  const msg = (m, ok) => render($("#admin-msg"), html`<p class="${ok ? "ok" : "error"}">${m}</p>`);
  const act = async (fn, done) => {
    try {
      await fn();
      msg(done, true);
      await refresh(ctx);
    } catch (e) {
      msg(e.message, false);
    }
  };
  $("#project-form").addEventListener("submit", (e) => {
    e.preventDefault();
    const name = $("#project-name").value;
    act(() => api("/api/admin/projects", { method: "POST", json: { name } }), `Project “${name}” created.`);
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
    act(() => api("/api/admin/users", { method: "POST", json: body }), `User “${body.username}” created.`);
  });
  $("#admin").addEventListener("click", (e) => {
    const t = e.target;
    if (t.dataset.disable) {
      const disabled = t.dataset.state !== "disabled";
      act(
        () => api(`/api/admin/users/${t.dataset.disable}`, { method: "PATCH", json: { disabled } }),
        disabled ? "User disabled." : "User enabled.",
      );
    } else if (t.dataset.addmember) {
      const uid = $(`select[data-member-of="${t.dataset.addmember}"]`).value;
      if (uid)
        act(() => api(`/api/admin/projects/${t.dataset.addmember}/members/${uid}`, { method: "PUT" }), "Member added.");
    } else if (t.dataset.rmproject) {
      act(
        () => api(`/api/admin/projects/${t.dataset.rmproject}/members/${t.dataset.rmuser}`, { method: "DELETE" }),
        "Member removed.",
      );
    }
  });
  await refresh(ctx);
}

const mb = (bytes) => `${(bytes / 1e6).toFixed(1)} MB`;

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
            <button data-disable="${u.id}" data-state="${u.disabled ? "disabled" : "active"}">
              ${u.disabled ? "enable" : "disable"}
            </button>
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
