// Gravity lines of several jobs compared on the server: plot, statistics, CSV.
import { api } from "./api.js";
import { html, render, $, $$ } from "./html.js";
import { num } from "./format.js";
import { draw } from "./plots.js";

export async function comparePage(ctx, app) {
  const jobs = (await api("/api/jobs")).filter((j) => j.pipeline === "gravity" && j.status === "succeeded");
  if (!ctx.alive) return;
  render(
    app,
    html`<h2>Compare gravity lines</h2>
      <p class="hint">The first ticked job is the reference; the others are interpolated onto its points.</p>
      <p id="cmp-jobs">
        ${
          jobs.length
            ? jobs.map(
                (j) =>
                  html`<label
                    ><input type="checkbox" value="${j.id}" checked /> job ${j.id} (logs ${j.log_ids.join(", ")})</label
                  >`,
              )
            : "No finished gravity jobs."
        }
      </p>
      <div class="card"><div class="plot tall" id="cmp"></div></div>
      <div class="card">
        <h3>Differences to the reference</h3>
        <div id="cmp-stats"></div>
        <p id="cmp-csv"></p>
      </div>`,
  );
  const run = async () => {
    const ids = $$("#cmp-jobs input:checked").map((x) => x.value);
    if (!ids.length) return;
    const q = `jobs=${ids.join(",")}`;
    const [fig, res] = await Promise.all([api(`/api/compare/view?${q}`), api(`/api/compare?${q}`)]);
    if (!ctx.alive) return;
    await draw($("#cmp"), fig.data, fig.layout);
    render(
      $("#cmp-stats"),
      res.statistics.length
        ? html`<table id="cmp-table">
            <tr>
              <th>job</th>
              <th>line</th>
              <th>common points</th>
              <th>mean (mGal)</th>
              <th>std (mGal)</th>
              <th>RMS (mGal)</th>
              <th>max |Δ| (mGal)</th>
            </tr>
            ${res.statistics.map(
              (s) =>
                html`<tr>
                  <td>${s.job}</td>
                  <td>${s.line}</td>
                  <td>${num(s.n_common)}</td>
                  <td>${num(s.mean_mgal, 4)}</td>
                  <td>${num(s.std_mgal, 4)}</td>
                  <td>${num(s.rms_mgal, 4)}</td>
                  <td>${num(s.max_abs_mgal, 4)}</td>
                </tr>`,
            )}
          </table>`
        : html`<p>Tick two jobs or more.</p>`,
    );
    render(
      $("#cmp-csv"),
      html`<a id="cmp-download" download href="/api/compare/csv?${q}">common points and differences (CSV)</a>`,
    );
  };
  $$("#cmp-jobs input").forEach((c) => c.addEventListener("change", run));
  if (jobs.length) await run();
}
