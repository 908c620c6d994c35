// The drop zone: a bundle (one .zip, or manifest.json + imu.csv [+ ldv.csv] [+ gnss.nmea]) goes to /api/logs.
import { session } from "./api.js";
import { html, render, $ } from "./html.js";

const BUNDLE_FILES = ["manifest.json", "imu.csv", "ldv.csv", "gnss.nmea"];
let nonBundleHook = null;

// Other modules may take files that are not a bundle (e.g. a vendor format to import):
// fn(files, {projectId, message, done}) is called instead of the bundle upload.
export function onNonBundleFiles(fn) {
  nonBundleHook = fn;
}

export const isBundle = (files) =>
  (files.length === 1 && /\.zip$/i.test(files[0].name)) ||
  files.some((f) => f.name === "manifest.json") ||
  files.every((f) => BUNDLE_FILES.includes(f.name));

export function dropZone(el, { projectId, done }) {
  render(
    el,
    html`<div class="drop" id="drop">
        Drop a bundle here (one <code>.zip</code>, or manifest.json + imu.csv [+ ldv.csv] [+ gnss.nmea])<br />or
        <input type="file" id="pick" multiple />
      </div>
      <progress id="upprog" value="0" max="100" hidden></progress>
      <div id="upmsg"></div>`,
  );
  const drop = $("#drop", el);
  const take = (files) => {
    if (!files.length) return;
    const msg = $("#upmsg", el);
    if (nonBundleHook && !isBundle(files)) {
      return nonBundleHook(files, { projectId: projectId(), message: (frag) => render(msg, frag), done });
    }
    upload(files, el, projectId(), done);
  };
  drop.addEventListener("dragover", (e) => {
    e.preventDefault();
    drop.classList.add("over");
  });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    take([...e.dataTransfer.files]);
  });
  $("#pick", el).addEventListener("change", (e) => take([...e.target.files]));
}

function upload(files, el, projectId, done) {
  const msg = $("#upmsg", el),
    prog = $("#upprog", el);
  const fd = new FormData();
  files.forEach((f) => fd.append("files", f, f.name));
  if (projectId) fd.append("project_id", projectId);
  const xhr = new XMLHttpRequest();
  xhr.open("POST", "/api/logs");
  if (session.csrf) xhr.setRequestHeader("X-CSRF-Token", session.csrf);
  prog.hidden = false;
  prog.value = 0;
  render(msg, html`Uploading…`);
  xhr.upload.onprogress = (e) => {
    if (e.lengthComputable) prog.value = (100 * e.loaded) / e.total;
  };
  xhr.onload = () => {
    prog.value = 100;
    let body = {};
    try {
      body = JSON.parse(xhr.responseText);
    } catch (e) {
      /* not JSON */
    }
    if (xhr.status >= 200 && xhr.status < 300) {
      render(
        msg,
        html`<p class="ok" id="upload-ok">
          ${body.duplicate ? "Already stored" : "Stored"}: <a href="#/logs/${body.id}">${body.name}</a>
        </p>`,
      );
      done();
    } else {
      const e = body.error || {};
      render(
        msg,
        html`<div class="error" id="upload-error">
          Upload refused (${xhr.status}): ${body.detail || xhr.statusText}
          ${e.file ? html`<br />file: ${e.file}` : ""}${e.line ? html`, line ${e.line}` : ""}${
            e.field ? html`, field ${e.field}` : ""
          }
        </div>`,
      );
    }
  };
  xhr.onerror = () => render(msg, html`<div class="error" id="upload-error">Upload failed: network error</div>`);
  xhr.send(fd);
}
