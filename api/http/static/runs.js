// The Runs page: the stored runs (filtered, paged by the API), a run's details and metadata
// (editable), its events, its results (results.js), its export, and a plot of any of its
// channels against time or another channel with other runs overlaid (run_plot.js).
import { api, download } from "./api.js";
import { $, $$, kv } from "./dom.js";
import { fmt, TIME_ZONE } from "./format.js";
import { emptyRow, esc } from "./markup.js";
import { onPage } from "./pages.js";
import { unitRowsPlot } from "./plots.js";
import { showRunResults } from "./results.js";
import { TIME_AXIS, channelLabel, runName, runPlotSeries, shownUnit, withUnit } from "./run_plot.js";
import { load, source, tags } from "./run_text.js";
import { metadataGiven, metadataKeys } from "./run_metadata.js";
import { ensureStartForms, loadKinds } from "./start_forms.js";
import { FINAL, state } from "./state.js";
import { onJob } from "./stream.js";

const RUNS_PAGE = 50;
state.runsOffset = 0;

export async function loadRuns() {
  const params = new URLSearchParams({ limit: RUNS_PAGE, offset: state.runsOffset, tz: TIME_ZONE });
  for (const el of $("#runs-filter").elements) {
    if (el.name && el.value) params.set(el.name, el.value);  // days: the API takes them in tz
  }
  const meta = {};
  try {
    [state.runs] = await Promise.all([api("GET", `/api/runs?${params}`, undefined, meta), loadKinds()]);
  } catch (err) {
    $("#runs-count").textContent = err.message;
    return;
  }
  const total = Number(meta.headers.get("X-Total-Count") || 0);
  const first = state.runs.length ? state.runsOffset + 1 : 0;
  $("#runs-count").textContent = `${first}–${state.runsOffset + state.runs.length} of ${total}`;
  $("#runs-prev").disabled = state.runsOffset === 0;
  $("#runs-next").disabled = !meta.headers.get("X-Next-Offset");
  $("#runs-table tbody").innerHTML = state.runs
    .map(
      (r) => `<tr data-run="${esc(r.id)}"><td><code>${esc(r.id.slice(0, 8))}</code></td><td>${esc(r.kind)}</td><td>${esc(r.drive || "—")}</td><td>${esc(load(r))}</td>
      <td><span class="state ${esc(r.status)}">${esc(r.status)}</span>${r.reason ? ` <span class="muted">${esc(r.reason)}</span>` : ""}</td>
      <td>${esc(new Date(r.started_at).toLocaleString())}</td><td>${esc(fmt(r.duration_s, 3))} s</td><td>${esc(r.sample_count)}</td><td>${esc(r.vehicle)}</td>
      <td>${source(r)}</td><td>${tags(r)}</td></tr>`,
    )
    .join("") ||
    emptyRow(11, [...params.keys()].some((k) => !["limit", "offset", "tz"].includes(k)) ? "no stored run matches these filters" : "no run stored yet: record a test on the Rig page, or import a record (rig import)");
  $$("#runs-table tbody tr[data-run]").forEach((tr) => (tr.onclick = () => openRun(tr.dataset.run)));
}
$("#runs-filter").addEventListener("submit", (ev) => {
  ev.preventDefault();
  state.runsOffset = 0;
  loadRuns();
});
$("#runs-prev").onclick = () => {
  state.runsOffset = Math.max(0, state.runsOffset - RUNS_PAGE);
  loadRuns();
};
$("#runs-next").onclick = () => {
  state.runsOffset += RUNS_PAGE;
  loadRuns();
};

// A known metadata key's row label ("Water temperature": its title without the unit) and
// its value with the unit ("18.5 °C"), or "—".
function keyLabel(prop) {
  return prop.unit ? prop.title.replace(` (${prop.unit})`, "") : prop.title;
}

function keyValue(value, prop) {
  if (value === undefined || value === null || (Array.isArray(value) && !value.length)) return "—";
  return Array.isArray(value) ? value.join(", ") : `${value}${prop.unit ? ` ${prop.unit}` : ""}`;
}

function showRunMeta(run) {
  const m = run.metadata || {};
  const known = Object.keys(metadataKeys); // run_metadata.js: the metadata object's keys
  kv($("#run-meta"), [
    ["Kind", run.kind],
    ["Status", run.summary || run.status + (run.reason ? ` (${run.reason})` : "")],
    ["Drive", run.drive || "—"],
    ["Load", load(run)],
    ["Source", run.source === "imported" ? `imported ${new Date(run.imported_at).toLocaleString()} from ${run.source_file}` : "recorded"],
    ...(run.parameters_labelled || []).map((p) => [p.label[0].toUpperCase() + p.label.slice(1), p.shown]),
    ["Recorded at", new Date(run.started_at).toLocaleString()],
    ["Duration", `${fmt(run.duration_s, 4)} s`],
    ["Samples", run.sample_count],
    ["Rig / vehicle", `${run.rig_name} / ${run.vehicle}`],
    ...Object.entries(metadataKeys).map(([name, prop]) => [keyLabel(prop), keyValue(m[name], prop)]),
    ...Object.entries(m).filter(([k]) => !known.includes(k)).map(([k, v]) => [k, String(v)]),
  ]);
  const form = $("#run-annotate");
  for (const name of known) form.elements[name].value = Array.isArray(m[name]) ? m[name].join(", ") : (m[name] ?? "");
}

$("#run-annotate").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const run = state.selectedRun;
  if (!run) return;
  const body = metadataGiven(ev.target); // a key left empty is null: PATCH removes it
  try {
    state.selectedRun = await api("PATCH", `/api/runs/${run.id}/metadata`, body);
    showRunMeta(state.selectedRun);
    $("#run-annotate-status").textContent = "saved";
    loadRuns();
  } catch (err) {
    $("#run-annotate-status").textContent = err.message;
  }
});

// The run detail plots any of the run's channels, with units, one row per unit, against time
// from each run's release or against another channel, with other runs overlaid and named in
// the legend (run_plot.js builds the series). It opens on the first channel its kind's live
// plot shows (GET /api/kinds), against time.
state.runPlot = { runs: [], channels: [], x: TIME_AXIS }; // [{run, samples, release, name}], y channels, x

async function runSeries(runId) {
  const [run, samples, events] = await Promise.all([
    api("GET", `/api/runs/${runId}`),
    api("GET", `/api/runs/${runId}/samples?limit=100000`),
    api("GET", `/api/runs/${runId}/events`),
  ]);
  const released = events.find((e) => e.data && e.data.action === "release" && e.data.t_mono !== undefined);
  return { run, samples, events, release: released ? released.data.t_mono : null, name: runName(run, load(run)) };
}

export async function openRun(runId) {
  location.hash = "#runs";
  // start_forms.js: the kinds, and the metadata form's inputs made from them
  const [shown, kinds] = await Promise.all([runSeries(runId), loadKinds(), ensureStartForms()]);
  const { run, events } = shown;
  state.selectedRun = run;
  $("#run-detail").hidden = false;
  loadExportFormats();
  $("#run-detail-id").textContent = run.id;
  $$("#runs-table tbody tr").forEach((tr) => tr.classList.toggle("selected", tr.dataset.run === run.id));
  showRunMeta(run);
  $("#run-annotate-status").textContent = "";
  const names = Object.keys(shown.samples.channels);
  const first = (kinds.find((k) => k.kind === run.kind) || kinds[0]).live[0];
  state.runPlot = { runs: [shown], channels: [names.includes(first) ? first : names[0]].filter(Boolean), x: TIME_AXIS };
  const unitOf = (k) => shownUnit(shown.samples.units[k]);
  $("#run-channels").innerHTML = names
    .map((k) => {
      const on = state.runPlot.channels.includes(k) ? "checked" : "";
      return `<label class="chip"><input type="checkbox" value="${esc(k)}" ${esc(on)}>${esc(channelLabel(k))} <span class="muted">${esc(unitOf(k))}</span></label>`;
    })
    .join("");
  $("#run-x").innerHTML = `<option value="${esc(TIME_AXIS)}">time [s]</option>` + names
    .map((k) => `<option value="${esc(k)}">${esc(withUnit(channelLabel(k), unitOf(k)))}</option>`)
    .join("");
  $("#run-overlay-pick").innerHTML = `<option value="">—</option>` + state.runs
    .filter((r) => r.id !== run.id)
    .map((r) => `<option value="${esc(r.id)}">${esc(runName(r, load(r)))}</option>`)
    .join("");
  drawRunPlot();
  $("#run-events").innerHTML = events
    .map((e) => `<li><span class="tag">${esc(e.kind)}</span>${esc(new Date(e.time).toLocaleTimeString())} — ${esc(e.message)}</li>`)
    .join("");
  showRunResults(run.id);
}

function drawRunPlot() {
  const { runs, channels, x } = state.runPlot;
  const { series, xTitle, mode, missing } = runPlotSeries(runs, channels, x);
  $("#run-overlays").innerHTML = runs
    .slice(1)
    .map((r) => `<span class="tag">${esc(r.name)} <button type="button" data-drop="${esc(r.run.id)}" title="Remove the overlay">×</button></span>`)
    .join("");
  for (const box of $$("#run-channels input")) {
    box.disabled = box.value === x; // the x axis is not also a y
    box.closest("label").title = box.disabled ? "on the X axis" : "";
  }
  $("#run-plot-note").textContent = missing.length ? `Not plotted (no ${channelLabel(x)} channel): ${missing.join(", ")}` : "";
  unitRowsPlot("run-plot", series, { xTitle, mode, empty: "Choose channels above", revision: `${runs[0] && runs[0].run.id}:${x}` });
}

$("#run-channels").addEventListener("change", () => {
  state.runPlot.channels = $$("#run-channels input:checked").map((i) => i.value);
  drawRunPlot();
});
$("#run-x").addEventListener("change", (ev) => {
  state.runPlot.x = ev.target.value;
  drawRunPlot();
});
$("#run-overlay-pick").addEventListener("change", async (ev) => {
  const id = ev.target.value;
  ev.target.value = "";
  if (!id || state.runPlot.runs.some((r) => r.run.id === id)) return;
  state.runPlot.runs.push(await runSeries(id));
  drawRunPlot();
});
$("#run-overlays").addEventListener("click", (ev) => {
  const id = ev.target.dataset && ev.target.dataset.drop;
  if (!id) return;
  state.runPlot.runs = state.runPlot.runs.filter((r) => r.run.id !== id);
  drawRunPlot();
});
// The export menu: the formats of GET /api/export-formats (daq/export_formats.py), once.
let exportFormats = null;
async function loadExportFormats() {
  if (exportFormats) return;
  exportFormats = await api("GET", "/api/export-formats");
  $("#export-format").innerHTML = exportFormats
    .map((f) => `<option value="${esc(f.name)}" title="${esc(f.help)}">${esc(f.label)}</option>`)
    .join("");
}
$("#export-run").onclick = () => {
  const run = state.selectedRun, format = $("#export-format").value;
  const spec = (exportFormats || []).find((f) => f.name === format);
  if (run && spec) download(`/api/runs/${run.id}/export?format=${format}`, `run-${run.id.slice(0, 8)}${spec.suffix}`);
};

// A run link anywhere on the page (the job panel's runs) opens the run.
document.addEventListener("click", (ev) => {
  const link = ev.target.closest && ev.target.closest("a[data-run]");
  if (link) setTimeout(() => openRun(link.dataset.run), 100);
});

// A test that ended while the Runs page is shown appears in it.
onJob((job) => {
  if (job.kind === "estimation" || job.kind === "campaign") return;
  if (FINAL.includes(job.state) && !$("#page-runs").hidden) loadRuns();
});

onPage("runs", loadRuns);
