// Cross-check page: two stored estimation results (or runs estimated now), the coefficients
// side by side with z and verdict, the common factor, the diagnosis and an error-bar plot.
import { api } from "./api.js";
import { $, $$, kv } from "./dom.js";
import { fmt, localTime } from "./format.js";
import { emptyRow, esc } from "./markup.js";
import { abortButton, shownState } from "./jobs.js";
import { onPage } from "./pages.js";
import { reactPlot } from "./plots.js";
import { load } from "./run_text.js";
import { axisUnits, loadKinds } from "./start_forms.js";
import { FINAL } from "./state.js";

// What a cross-check compares (GET /api/kinds): runs of the kinds both a weight and the
// thrusters drive, and estimation results of those kinds (a result names its kind; one stored
// before schema 2 named only its axis, and a pendulum's its analysis: a swing may be a surge).
export function crosscheckKinds(kinds) {
  const both = kinds.filter((k) => ["weight", "thrusters"].every((d) => k.drives.includes(d)));
  return {
    kinds: both.map((k) => k.kind),
    axes: both.map((k) => k.axis),
    estimators: both.map((k) => k.estimator),
  };
}

async function crosscheckLoad() {
  try {
    const cc = crosscheckKinds(await loadKinds()); // start_forms.js
    const ofKinds = (d) => (d.kind ? cc.kinds.includes(d.kind) : cc.axes.includes(d.axis) && (!d.analysis || cc.estimators.includes(d.analysis)));
    const results = (await api("GET", "/api/results?kind=estimation")).filter((r) => ofKinds(r.data || {}));
    const option = (r) => {
      const draws = ((r.data.uncertainty || {}).calibration_draws || 0) > 0;
      return `<option value="${esc(r.id)}" data-thrusters="${esc(draws)}">#${esc(r.id)} ${esc(r.data.axis)}, ${r.data.runs.length} run(s)${draws ? ", thruster-driven" : ""} — ${esc(localTime(r.created_at))}</option>`;
    };
    const weight = results.filter((r) => !((r.data.uncertainty || {}).calibration_draws > 0));
    const thrusters = results.filter((r) => (r.data.uncertainty || {}).calibration_draws > 0);
    const none = '<option value="">no stored estimation result yet</option>'; // not an empty box
    $("#cc-weight").innerHTML = (weight.length ? weight : results).map(option).join("") || none;
    $("#cc-thrusters").innerHTML = (thrusters.length ? thrusters : results).map(option).join("") || none;
    const runs = (await api("GET", "/api/runs?status=completed&limit=200")).filter((r) => cc.kinds.includes(r.kind));
    $("#cc-runs tbody").innerHTML = runs
      .map((r) => {
        const drive = (r.parameters || {}).drive || "weight";
        return `<tr><td><input type="checkbox" name="cc-w" value="${esc(r.id)}"></td><td><input type="checkbox" name="cc-t" value="${esc(r.id)}"></td>
        <td><code>${esc(r.id.slice(0, 8))}</code></td><td>${esc(r.kind)}</td><td>${esc(drive)}</td><td>${esc(load(r))}</td></tr>`;
      })
      .join("") || emptyRow(6, `no completed ${cc.kinds.join(" or ")} run yet`);
  } catch (err) {
    $("#cc-status").textContent = err.message;
  }
}

$("#cc-compare").onclick = async () => {
  const w = Number($("#cc-weight").value);
  const t = Number($("#cc-thrusters").value);
  if (!w || !t) return ($("#cc-status").textContent = "Pick two stored estimation results.");
  $("#cc-status").textContent = "Comparing…";
  try {
    await crosscheckRender(await api("POST", "/api/crosscheck", { weight_result_id: w, thruster_result_id: t }));
    $("#cc-status").textContent = "";
  } catch (err) {
    $("#cc-status").textContent = err.message;
  }
};

$("#cc-estimate").onclick = async () => {
  const weight = $$('#cc-runs input[name="cc-w"]:checked').map((i) => i.value);
  const thrusters = $$('#cc-runs input[name="cc-t"]:checked').map((i) => i.value);
  if (!weight.length || !thrusters.length) return ($("#cc-status").textContent = "Tick at least one weight-driven and one thruster-driven run.");
  $("#cc-status").textContent = "Starting…";
  try {
    let job = await api("POST", "/api/jobs/crosscheck", { weight_runs: weight, thruster_runs: thrusters });
    while (!FINAL.includes(job.state)) {
      const shown = shownState(job);
      $("#cc-status").innerHTML = `<span class="state ${esc(shown)}">${esc(shown)}</span> ${esc(job.progress.message)}${abortButton(job)}`;
      await new Promise((res) => setTimeout(res, 500));
      job = await api("GET", `/api/jobs/${job.id}`);
    }
    $("#cc-status").innerHTML = `<span class="state ${esc(shownState(job))}" id="cc-state">${esc(shownState(job))}</span> ${esc(job.error || job.progress.message)}`;
    if (job.state === "completed") {
      await crosscheckRender(job.outcome);
      crosscheckLoad();
    }
  } catch (err) {
    $("#cc-status").textContent = err.message;
  }
};

async function crosscheckRender(res) {
  const units = (await axisUnits())[res.axis] || {}; // start_forms.js
  $("#cc-result").hidden = false;
  $("#cc-title").textContent = `${res.axis}: weight result #${res.weight_result_id} vs thruster result #${res.thruster_result_id} — ${res.verdict}`;
  const pm = (s) => `${fmt(s.value, 5)}${s.std == null ? " (σ not known)" : ` ± ${fmt(s.std, 2)}`}`;
  // Stored cross-checks from before "combined" / "undecided" existed have neither key.
  const rows = { ...res.coefficients, ...(res.combined || {}) };
  // The label is the API's (one spelling with the report); a stored cross-check from before it
  // existed has the coefficient's key only.
  const label = (k, c) => c.label || k;
  // An undecided coefficient's z is computed, not judged: shown in parentheses, reason on hover.
  $("#cc-table tbody").innerHTML = Object.entries(rows)
    .map(
      ([k, c]) => `<tr><td>${esc(label(k, c))} (${esc(units[k] || "")})</td><td>${esc(pm(c.weight))}</td><td>${esc(pm(c.thruster))}</td>
      <td>${esc(fmt(c.difference, 3))}</td><td>${esc(c.verdict === "undecided" ? `(${fmt(c.z, 3)})` : fmt(c.z, 3))}</td>
      <td class="verdict ${esc(c.verdict)}" title="${esc(c.reason || "")}">${c.verdict === "undecided" ? "<b>undecided</b>" : esc(c.verdict)}</td></tr>`,
    )
    .join("");
  const f = res.common_factor;
  const v = res.supply_voltage_v || {};
  kv($("#cc-kv"), [
    ["Common factor k (thrusters / weight)", f ? `${fmt(f.k, 4)} ± ${fmt(f.std, 2)} (χ² p = ${fmt(f.p_value, 2)})` : "—"],
    ["Delivered / calibrated thrust (1/k)", f ? `${fmt(f.thrust_factor, 4)} ± ${fmt(f.thrust_factor_std, 2)}` : "—"],
    ["Supply voltage at calibration / during runs", `${fmt(v.calibration, 4)} V / ${fmt(v.runs, 4)} V`],
    ["RMSE weight (before → after effects)", `${fmt(res.rmse.weight.before, 3)} → ${fmt(res.rmse.weight.after, 3)}`],
    ["RMSE thrusters (before → after effects)", `${fmt(res.rmse.thruster.before, 3)} → ${fmt(res.rmse.thruster.after, 3)}`],
    ["Stored as result", `#${res.result_id}`],
  ]);
  $("#cc-diagnosis").innerHTML = [...res.diagnosis, ...res.warnings.map((w) => `warning: ${w}`)]
    .map((d) => `<li>${esc(d)}</li>`)
    .join("");
  const names = Object.keys(rows);
  const traces = ["weight", "thruster"].map((side) => ({
    name: side === "weight" ? "weight-driven" : "thruster-driven",
    type: "scatter",
    mode: "markers",
    x: names.map((k) => label(k, rows[k]) + (rows[k].verdict === "undecided" ? " (undecided)" : "")),
    y: names.map((k) => rows[k][side].value / rows[k].weight.value),
    error_y: { type: "data", array: names.map((k) => (rows[k][side].std || 0) / rows[k].weight.value) },
  }));
  reactPlot(
    "cc-plot",
    traces,
    {
      title: { text: "Coefficients relative to the weight-driven value (±1σ_total)" },
      // The labels are the table's (a combined damping names its speed): the axis makes room.
      xaxis: { automargin: true },
      yaxis: { title: { text: "value / weight-driven value" } },
      margin: { t: 60 },
      legend: { orientation: "h", x: 0, y: 1.0, yanchor: "bottom" },
    },
    { responsive: true, displaylogo: false },
  );
}

onPage("crosscheck", crosscheckLoad);
