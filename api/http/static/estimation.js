// The Estimation page: the runs to estimate from, the estimation job (polled and streamed),
// its result — coefficients, what the data determine well, effects, warnings, the uncertainty
// budget (uncertainty.js), the reverse test it asks for, the report's figures (full width,
// click for full size). One renderer draws every kind's result (renderEstimation).
import { api } from "./api.js";
import { $, $$, kv } from "./dom.js";
import { fmt } from "./format.js";
import { abortButton, showJob, shownState } from "./jobs.js";
import { emptyRow, esc } from "./markup.js";
import { onPage } from "./pages.js";
import { newPlot, purgePlot } from "./plots.js";
import { metadataBody } from "./run_metadata.js";
import { load, source, tags } from "./run_text.js";
import { axisUnits, ensureStartForms, estimatedKinds } from "./start_forms.js";
import { FINAL, state } from "./state.js";
import { onJob } from "./stream.js";
import { drawMethods, peaksChart, valuePm } from "./swing_sections.js";
import { renderUncertainty } from "./uncertainty.js";

async function loadEstimationRuns() {
  let runs = [];
  const search = $("#est-search").value.trim();
  const query = new URLSearchParams({ status: "completed", limit: 1000 });
  if (search) query.set("search", search);
  try {
    await ensureStartForms(); // the kinds: those with an estimator are listed
    runs = (await api("GET", `/api/runs?${query}`)).filter((r) => estimatedKinds().includes(r.kind));
  } catch (err) {
    return;
  }
  const checked = new Set($$("#est-runs input:checked").map((i) => i.value));
  $("#est-runs tbody").innerHTML = runs
    .map(
      (r) => `<tr><td><input type="checkbox" value="${esc(r.id)}" data-kind="${esc(r.kind)}" ${checked.has(r.id) ? "checked" : ""}></td>
      <td><code>${esc(r.id.slice(0, 8))}</code></td><td>${esc(r.kind)}</td><td>${esc(r.drive || "—")}</td><td>${esc(load(r))}</td>
      <td>${esc(new Date(r.started_at).toLocaleString())}</td><td>${esc(r.vehicle)}</td><td>${source(r)}</td><td>${tags(r)}</td></tr>`,
    )
    .join("") ||
    emptyRow(9, search ? "no completed run matches the search" : "no completed run to estimate yet: record a test on the Rig page, or import a record (rig import)");
}
$("#est-search").addEventListener("change", loadEstimationRuns);

let estimationJobId = null;
$("#est-run").onclick = async () => {
  const runIds = $$("#est-runs input:checked").map((i) => i.value);
  if (!runIds.length) return ($("#est-status").textContent = "Pick at least one run.");
  $("#est-status").textContent = "Starting…";
  try {
    const job = await api("POST", "/api/jobs/estimation", {
      run_ids: runIds,
      method: $("#est-method").value,
      search_effects: $("#est-effects").checked,
      exclude_outliers: $("#est-exclude").checked,
    });
    estimationJobId = job.id;
    showEstimationJob(job);
    pollEstimation(job.id);
  } catch (err) {
    $("#est-status").textContent = err.message;
  }
};

async function pollEstimation(jobId) {
  for (;;) {
    const job = await api("GET", `/api/jobs/${jobId}`);
    showEstimationJob(job);
    if (FINAL.includes(job.state)) return;
    await new Promise((res) => setTimeout(res, 500));
  }
}

// The job whose result is drawn: the poll and the event stream both report its completion,
// and a late second report must not redraw it (that would clear what the user started from it,
// e.g. the reverse button's status).
let estimationDrawn = null;

const freshResultListeners = [];

/** Calls `listener(result)` when a fresh estimation result has been drawn (results.js lists it). */
export function onFreshResult(listener) {
  freshResultListeners.push(listener);
}

function showEstimationJob(job) {
  if (job.id !== estimationJobId) return;
  const shown = shownState(job);
  $("#est-status").innerHTML = `<span class="state ${esc(shown)}" id="est-state">${esc(shown)}</span> ${esc(job.progress.message)}${abortButton(job)}`;
  if (job.state !== "completed" || !job.outcome || estimationDrawn === job.id) return;
  estimationDrawn = job.id;
  renderEstimation(job.outcome);
  for (const listener of freshResultListeners) listener(job.outcome);
}

// What the record determines well beside the raw coefficients (terminal speed, period,
// damping ratio: docs/estimation.md), as rows under the coefficients, every kind alike.
export function wellDeterminedRows(res) {
  return (res.well_determined || [])
    .map((c) => `<tr class="est-known"><td><em>${esc(c.name)}</em>${c.unit ? ` (${esc(c.unit)})` : ""}</td><td>${esc(fmt(c.value, 5))}</td><td>${esc(c.std == null ? "not identified (no σ)" : `± ${fmt(c.std, 3)}`)}</td></tr>`)
    .join("");
}

// Every result document — a tow's, a spin's, a free decay's, a pendulum's — is drawn here by
// one renderer: the parts every document has (coefficients ± σ, what the record determines
// well, effects, RMSE, warnings, the budget), then each section the document carries (a decay's
// equivalent damping, a swing's methods and peaks, a tow's reverse run), never by its kind.
export async function renderEstimation(res) {
  renderUncertainty(res);
  $("#est-result").hidden = false;
  const units = res.units || {};
  // the position's unit: the document's own, else its axis's or dof's (start_forms.js)
  const unit = units.position || ((await axisUnits())[res.axis || res.dof] || {}).position || "";
  // the record-level bootstrap's spread beside the fit's σ, every kind that has one
  const boot = res.bootstrap && res.bootstrap.used ? res.bootstrap : null;
  $("#est-coefs thead tr").innerHTML =
    "<th>Coefficient</th><th>Value</th><th>± σ</th>" +
    (boot ? `<th title="each coefficient's spread over fits to runs drawn with replacement (docs/estimation.md)">Bootstrap σ [2.5–97.5 %] (${esc(boot.used)} of ${esc(boot.requested)} draws)</th>` : "");
  // the value before the search only where the search added an effect (a seed method's
  // result, or one with no effect found, has nothing "before" to show)
  const searched = (res.effects || []).length > 0;
  // each coefficient under its label where the key alone would mislead (a decay given the
  // body's own inertia: the added inertia)
  $("#est-coefs tbody").innerHTML = Object.entries(res.coefficients || {})
    .map(([k, c]) => {
      const before = searched ? (res.coefficients_before || {})[k] : null;
      return `<tr><td>${esc((res.labels || {})[k] || k)} (${esc(units[k] || c.unit || "")})</td><td>${esc(fmt(c.value, 5))}</td><td>${esc(c.std == null ? "not identified (no σ)" : `± ${fmt(c.std, 3)}`)}</td>
        ${boot ? `<td>${esc(bootstrapText(boot, k))}</td>` : ""}
        ${before ? `<td class="muted">before effects: ${esc(valuePm(before))}</td>` : ""}</tr>`;
    })
    .join("") + wellDeterminedRows(res);
  // the equivalent linear damping over the swings a decay covers (docs/estimation.md)
  const equivalent = res.equivalent_linear_damping || [];
  $("#est-equivalent").hidden = !equivalent.length;
  $("#est-equivalent tbody").innerHTML = equivalent
    .map((e) => `<tr><td>${esc(amplitudeText(e.amplitude, unit))}</td><td>${esc(fmt(e.value, 4))} ${esc(e.unit)}</td><td>${esc(e.std == null ? "σ not known" : `± ${fmt(e.std, 2)}`)}</td></tr>`)
    .join("");
  const diagnostics = res.diagnostics || {};
  const q = (w) => fmt((w || {}).q, 3);
  kv($("#est-rmse"), [
    ["Subject", res.subject || res.dof || res.axis || "—"],
    ["RMSE before", `${fmt(res.rmse_before, 3)} ${unit}`],
    ["RMSE after", `${fmt(res.rmse_after, 3)} ${unit}`],
    ["Ljung–Box Q (before → after)", `${q(diagnostics.ljung_box_before)} → ${q(diagnostics.ljung_box_after)}`],
    ["Runs", (res.runs || []).map((r) => r.slice(0, 8)).join(", ")],
  ]);
  $("#est-effects-list").innerHTML = (res.effects || []).length
    ? res.effects.map((e) => `<li><strong>${esc(e.name)}</strong>: ${esc(valuePm(e))} ${esc(e.unit)}</li>`).join("")
    : "<li>none (the base model explains the data)</li>";
  const amb = (res.ambiguous || []).map((g) => g.join(" ≈ "));
  $("#est-ambiguous").innerHTML =
    (amb.length ? `<p class="error">Ambiguous: ${esc(amb.join("; "))}</p>` : "") +
    (res.warnings || []).map((w) => `<p class="warning">${esc(w)}</p>`).join("") + // may be wrong
    (res.advice || []).map((w) => `<p class="muted">${esc(w)}</p>`).join(""); // what to run next
  drawMethods(res);
  showReverseButton(res.reverse_test);
  drawFitChart(res, unit);
  await showReportPlots(res.result_id);
}

// One coefficient's bootstrap: "± σ [low … high]", "—" where the draws gave none.
function bootstrapText(boot, name) {
  const std = (boot.std || {})[name];
  if (std === null || std === undefined) return "—";
  const low = (boot.percentile_2_5 || {})[name];
  const high = (boot.percentile_97_5 || {})[name];
  return `± ${fmt(std, 3)} [${fmt(low, 4)} … ${fmt(high, 4)}]`;
}

// A swing's amplitude in its unit, and in degrees when that is rad (the damping ratios are
// named in degrees, as report.md gives both).
function amplitudeText(amplitude, unit) {
  const degrees = unit === "rad" && Number.isFinite(amplitude) ? ` (${fmt((amplitude * 180) / Math.PI, 3)}°)` : "";
  return `${fmt(amplitude, 3)} ${unit}${degrees}`;
}

// The chart above the report's figures: a swing's peaks where the document has them, else the
// residual RMSE per run where it has that; hidden otherwise (no empty chart).
function drawFitChart(res, unit) {
  const peaks = peaksChart(res, unit);
  const perRun = Object.keys(res.rmse_per_run_before || {});
  $("#est-fit-plot").hidden = !peaks && !perRun.length;
  if (peaks) {
    newPlot("est-fit-plot", peaks.traces, peaks.layout, { responsive: true, displaylogo: false });
    return;
  }
  if (!perRun.length) return purgePlot("est-fit-plot");
  // the report figures' labels: "run 1 (a1b2c3d4)" in the result's run order
  const runLabels = perRun.map((r) => `run ${(res.runs || []).indexOf(r) + 1} (${r.slice(0, 8)})`);
  newPlot(
    "est-fit-plot",
    [
      { x: runLabels, y: perRun.map((r) => res.rmse_per_run_before[r]), type: "bar", name: "RMSE before" },
      { x: runLabels, y: perRun.map((r) => (res.rmse_per_run_after || {})[r]), type: "bar", name: "RMSE after" },
    ],
    { title: { text: "Residual RMSE per run (the fits themselves are in the report figures below)" }, margin: { t: 40, r: 20, b: 60, l: 60 }, yaxis: { title: { text: `residual RMSE (${unit})` } }, barmode: "group" },
    { responsive: true, displaylogo: false },
  );
}

// The reverse tow/spin the estimator asks for (friction ≈ bias), as a button that starts it
// when the rig can run it: the service runs a rig whose PLC answers, and the rig's
// capabilities (GET /api/rig) offer that kind with that drive. Otherwise: why not.
function reverseBlocker(test) {
  const r = state.rig;
  if (!r || !r.running || !r.connected || r.device_lost) return "the rig is not connected";
  const cap = (r.capabilities || {})[test.kind];
  if (!cap) return `this rig cannot run a ${test.kind}`;
  if (!cap.available) return cap.reason;
  const drive = (cap.drives || {})[test.request.drive];
  if (drive && !drive.available) return drive.reason;
  return null;
}

function showReverseButton(test) {
  const box = $("#est-reverse");
  box.innerHTML = "";
  if (!test) return;
  const blocker = reverseBlocker(test);
  if (blocker) {
    box.innerHTML = `<p class="muted">Reverse ${esc(test.kind)} to record: <code>${esc(test.command)}</code> (not offered here: ${esc(blocker)}).</p>`;
    return;
  }
  box.innerHTML = `<button id="est-reverse-btn" title="POST ${esc(test.route)}">Run the reverse ${esc(test.kind)}</button>
    <code>${esc(test.command)}</code> <span id="est-reverse-status" class="muted"></span>`;
  $("#est-reverse-btn").onclick = async () => {
    const body = { ...test.request };
    const metadata = metadataBody();
    if (metadata) body.metadata = metadata;
    try {
      const job = await api("POST", test.route, body);
      $("#est-reverse-status").textContent = `started: ${job.label}`;
      showJob(job);
    } catch (err) {
      $("#est-reverse-status").textContent = err.message;
    }
  };
}

// The stored result's report figures into #est-plots, full width (fetched with the token):
// click a figure to see it at its natural size; links open the PNG and the SVG on their own.
// Each call draws its result's figures in report order; a later call (the job's update and
// its final result arrive close together) supersedes an earlier one still fetching.
let reportPlotsCall = 0;
export async function showReportPlots(resultId) {
  const call = ++reportPlotsCall;
  const box = $("#est-plots");
  box.innerHTML = "";
  if (resultId === undefined || resultId === null) return;
  try {
    const stored = await api("GET", `/api/results/${resultId}`);
    for (const name of stored.report_plots) {
      const png = await reportBlob(resultId, `${name}.png`);
      const svg = png && (await reportBlob(resultId, `${name}.svg`));
      if (call !== reportPlotsCall) return;
      if (!png) continue;
      const fig = document.createElement("figure");
      fig.className = "report-figure";
      fig.innerHTML = `<img alt="report figure ${esc(name)}" title="click to view at full size">
        <figcaption>${esc(name)} — <a class="report-png" target="_blank" rel="noopener">PNG</a>${svg ? ` · <a class="report-svg" target="_blank" rel="noopener">SVG</a>` : ""}</figcaption>`;
      fig.querySelector("img").src = png;
      fig.querySelector("img").addEventListener("click", () => openLightbox(png, name));
      fig.querySelector(".report-png").href = png;
      if (svg) fig.querySelector(".report-svg").href = svg;
      box.append(fig);
    }
  } catch (err) {
    console.warn(err);
  }
}

async function reportBlob(resultId, file) {
  const r = await fetch(`/api/results/${resultId}/report/${file}`, { headers: { Authorization: `Bearer ${state.token}` } });
  return r.ok ? URL.createObjectURL(await r.blob()) : null;
}

// A report figure at its natural size over the page; click or Escape closes it.
function openLightbox(src, name) {
  const box = $("#lightbox");
  box.querySelector("img").src = src;
  box.querySelector("img").alt = `report figure ${name}`;
  box.hidden = false;
}
function closeLightbox() {
  $("#lightbox").hidden = true;
}
$("#lightbox").addEventListener("click", closeLightbox);
document.addEventListener("keydown", (e) => {
  if (e.key === "Escape") closeLightbox();
});

onJob((job) => {
  if (job.kind === "estimation") showEstimationJob(job);
});
onPage("estimation", loadEstimationRuns);
