// Pendulum free-decay results on the estimation page (result JSON with analysis "pendulum").
// Registered in estimation.js's resultViews, so renderEstimation hands such results here.
import { $, kv } from "./dom.js";
import { resultViews, showReportPlots, wellDeterminedRows } from "./estimation.js";
import { fmt } from "./format.js";
import { esc } from "./markup.js";

function pendulumPm(e) {
  if (!e || e.value === null || e.value === undefined) return "—";
  return e.std === null || e.std === undefined ? fmt(e.value, 5) : `${fmt(e.value, 5)} ± ${fmt(e.std, 2)}`;
}

function pendulumBox(id) {
  let box = document.getElementById(id);
  if (!box) {
    box = Object.assign(document.createElement("div"), { id });
    $("#est-ambiguous").before(box);
  }
  return box;
}

async function renderPendulumEstimation(res) {
  $("#est-result").hidden = false;
  const units = res.units || {};
  $("#est-coefs tbody").innerHTML = Object.entries(res.coefficients || {})
    .map(([k, c]) => {
      const before = (res.coefficients_before || {})[k];
      return `<tr><td>${esc(k)} (${esc(units[k] || "")})</td><td>${esc(fmt(c.value, 5))}</td><td>± ${esc(fmt(c.std, 3))}</td>
        ${before ? `<td class="muted">before effects: ${esc(pendulumPm(before))}</td>` : ""}</tr>`;
    })
    .join("") + wellDeterminedRows(res); // estimation.js
  const lb = (res.diagnostics || {});
  kv($("#est-rmse"), [
    ["Analysis / headline", `pendulum free decay, ${res.axis} / ${res.method}`],
    ["RMSE before", `${fmt(res.rmse_before, 3)} rad`],
    ["RMSE after", `${fmt(res.rmse_after, 3)} rad`],
    ["Ljung–Box Q", `${fmt((lb.ljung_box_before || {}).q, 3)} → ${fmt((lb.ljung_box_after || {}).q, 3)}`],
    ["Runs", (res.runs || []).map((r) => r.slice(0, 8)).join(", ")],
  ]);
  $("#est-effects-list").innerHTML = (res.effects || []).length
    ? res.effects.map((e) => `<li><strong>${esc(e.name)}</strong>: ${esc(pendulumPm(e))} ${esc(e.unit)}</li>`).join("")
    : "<li>none (the base model explains the data)</li>";
  pendulumBox("est-pendulum-methods").innerHTML = `<h4>Methods side by side</h4>
    <table class="list"><thead><tr><th>Run</th><th>Method</th><th>α (kg)</th><th>β (N·s/m)</th><th>γ (kg/m)</th><th>e (rad²)</th></tr></thead><tbody>
    ${(res.methods || [])
      .map(
        (m) => `<tr><td><code>${esc(m.run_id.slice(0, 8))}</code></td><td>${esc(m.method)}</td><td>${esc(pendulumPm(m.added_mass))}</td>
        <td>${esc(pendulumPm(m.linear_damping))}</td><td>${esc(pendulumPm(m.quadratic_damping))}</td><td>${esc(fmt(m.mse, 3))}</td></tr>`,
      )
      .join("")}</tbody></table>`;
  const amb = (res.ambiguous || []).map((g) => g.join(" ≈ "));
  $("#est-ambiguous").innerHTML =
    (amb.length ? `<p class="error">Ambiguous: ${esc(amb.join("; "))}</p>` : "") +
    [...(res.warnings || []), ...(res.advice || [])].map((w) => `<p class="muted">${esc(w)}</p>`).join("");
  const traces = [];
  for (const [rid, p] of Object.entries(res.peaks || {})) {
    const name = rid.slice(0, 8);
    // time from the release, as the report shows it (the fits are on the run's clock)
    const r = p.release_time_s ?? p.times[0];
    traces.push({ x: p.times.map((t) => t - r), y: p.amplitudes, mode: "markers", name: `${name} |peak|` });
    const t0 = p.times[0];
    const t1 = p.times[p.times.length - 1];
    const ts = Array.from({ length: 60 }, (_, i) => t0 + ((t1 - t0) * i) / 59);
    const x = ts.map((t) => t - r);
    traces.push({ x, y: ts.map((t) => p.exponential.c * Math.exp(-p.exponential.decay_rate * t)), mode: "lines", name: `${name} C·e^(−Kt)` });
    traces.push({ x, y: ts.map((t) => p.linear.a0 - p.linear.rate_per_s * t), mode: "lines", line: { dash: "dash" }, name: `${name} linear` });
  }
  Plotly.newPlot(
    "est-fit-plot",
    traces,
    { margin: { t: 20, r: 20, b: 50, l: 60 }, xaxis: { title: { text: "time from release [s]" } }, yaxis: { title: { text: "|peak − midline| [rad]" } } },
    { responsive: true, displaylogo: false },
  );
  await showReportPlots(res.result_id);
}

function clearPendulumEstimation() {
  const box = document.getElementById("est-pendulum-methods");
  if (box) box.remove();
}

resultViews.pendulum = { render: renderPendulumEstimation, clear: clearPendulumEstimation };
