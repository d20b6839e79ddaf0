// Analysis page: sensitivity of a vehicle's coefficients (seed 004) on the 6-DOF model:
// ranking by knock-out index, threshold sweep of the reduced model, AHP weights,
// identifiability of the plugged-in estimates and the next test to run.
import { api } from "./api.js";
import { $, $$ } from "./dom.js";
import { fmt, localTime } from "./format.js";
import { emptyRow, esc } from "./markup.js";
import { onPage } from "./pages.js";
import { reactPlot } from "./plots.js";

const analysis = { ready: false, responses: [] };
const ANALYSIS_PLOT = { responsive: true, displaylogo: false };

const pct = (x) => (x === null || x === undefined ? "∞" : x === 0 ? "0" : x < 1e-4 ? "<0.01 %" : `${fmt(100 * x, 3)} %`);

async function analysisLoad() {
  if (!analysis.ready) {
    try {
      const [vehicles, responses] = await Promise.all([
        api("GET", "/api/vehicles"),
        api("GET", "/api/analysis/responses"),
      ]);
      analysis.responses = responses;
      $("#an-vehicle").innerHTML = vehicles
        .map((v) => `<option value="${esc(v.name)}"${v.error ? " disabled" : ""}>${esc(v.name)}${v.error ? " (invalid file)" : ` — ${esc(v.vehicle)}`}</option>`)
        .join("");
      $("#an-responses").innerHTML = responses
        .map((r) => `<label title="${esc(r.description)}"><input type="checkbox" value="${esc(r.name)}"> ${esc(r.name)} (${esc(r.unit)})</label>`)
        .join("");
      $("#an-form").addEventListener("submit", analysisRun);
      analysis.ready = true;
    } catch (err) {
      $("#an-status").textContent = err.message;
      return;
    }
  }
  try {
    const results = await api("GET", "/api/results?kind=estimation");
    $("#an-estimates").innerHTML = results
      .filter((r) => (r.data || {}).dof || (r.data || {}).axis) // the line it moved along
      .slice(0, 20)
      .map((r) => `<label><input type="checkbox" value="${esc(r.id)}"> #${esc(r.id)} ${esc(r.subject || r.data.axis)} (${esc(localTime(r.created_at))})</label>`)
      .join("") || '<span class="muted">no stored estimation results</span>';
  } catch (err) {
    $("#an-estimates").textContent = err.message;
  }
}

function analysisBody() {
  const form = $("#an-form");
  const list = (text) => text.split(",").map((s) => s.trim()).filter(Boolean);
  const body = {
    vehicle: $("#an-vehicle").value,
    estimates: $$("#an-estimates input:checked").map((el) => Number(el.value)),
    thresholds: list(form.elements.thresholds.value).map(Number),
    keep: list(form.elements.keep.value),
    delta: Number(form.elements.delta.value || 0.01),
  };
  const responses = $$("#an-responses input:checked").map((el) => el.value);
  if (responses.length) body.responses = responses;
  const ahp = form.elements.ahp.value.trim();
  if (ahp) body.ahp = JSON.parse(ahp);
  return body;
}

async function analysisRun(ev) {
  ev.preventDefault();
  const status = $("#an-status");
  let body;
  try {
    body = analysisBody();
  } catch (err) {
    status.textContent = `AHP matrices: not valid JSON (${err.message})`;
    return;
  }
  status.textContent = "analysing…";
  try {
    const out = await api("POST", "/api/analysis/sensitivity", body);
    status.textContent = `${out.simulations} simulations in ${fmt(out.elapsed_s, 3)} s`;
    analysisShow(out);
  } catch (err) {
    status.textContent = err.message;
  }
}

function analysisShow(out) {
  $("#an-result").hidden = false;
  const names = Object.keys(out.weights);
  const short = names.map((n, i) => `R${i + 1}`);
  $("#an-reference tbody").innerHTML = names
    .map((n, i) => {
      const r = out.reference[n];
      return `<tr><td>${esc(short[i])}</td><td>${esc(n)}</td><td>${esc(fmt(r.value))} ${esc(r.unit)}</td>
        <td>${esc(fmt(out.weights[n], 3))}</td><td>${esc(r.mode)}</td></tr>`;
    })
    .join("");
  $("#an-ahp").textContent = out.ahp
    ? `AHP weights, consistency ratio CR = ${fmt(out.ahp.cr, 3)} (accepted below 0.1)`
    : "equal weights (no AHP matrices given)";
  $("#an-ranking thead").innerHTML = `<tr><th>Coefficient</th><th>Value</th><th>σ</th><th>Composite</th>
    ${short.map((s) => `<th>S ${esc(s)}</th>`).join("")}${short.map((s) => `<th>Sc ${esc(s)}</th>`).join("")}</tr>`;
  $("#an-ranking tbody").innerHTML = out.ranking
    .map((row) => `<tr><td>${esc(row.name)}${row.keep ? " <span class=\"muted\">(keep)</span>" : ""}</td>
      <td>${esc(fmt(row.value))}</td><td>${esc(row.sigma === null ? "—" : fmt(row.sigma, 3))}</td><td>${esc(pct(row.composite))}</td>
      ${names.map((n) => `<td>${esc(row.s[n] === null ? "—" : fmt(row.s[n], 3))}</td>`).join("")}
      ${names.map((n) => `<td>${esc(pct(row.sc[n]))}</td>`).join("")}</tr>`)
    .join("");
  $("#an-zero").textContent = out.zero.length ? `Already zero (not candidates): ${out.zero.join(", ")}` : "";
  $("#an-sweep thead").innerHTML = `<tr><th>Criterion</th><th>Threshold</th><th>Removed</th><th>Max error</th><th>Worst</th>
    ${short.map((s) => `<th>${esc(s)}</th>`).join("")}</tr>`;
  $("#an-sweep tbody").innerHTML = out.sweep
    .map((s) => `<tr title="${esc(s.removed.join(", "))}"><td>${esc(s.criterion)}</td><td>${esc(fmt(s.threshold, 4))}</td>
      <td>${esc(s.n_removed)}</td><td>${esc(pct(s.max_error))}</td><td>${esc(s.worst_response)}</td>
      ${names.map((n) => `<td>${esc(pct(s.errors[n]))}</td>`).join("")}</tr>`)
    .join("");
  // bar chart: each coefficient's composite index split into its per-response parts Sc·Y
  const coefs = out.ranking.map((r) => r.name);
  const traces = names.map((n) => ({
    type: "bar",
    orientation: "h",
    name: n,
    y: coefs,
    x: out.ranking.map((r) => (r.sc[n] === null ? null : 100 * r.sc[n] * out.weights[n])),
  }));
  reactPlot("an-bars", traces, {
    barmode: "stack",
    title: { text: "Composite knock-out index Σ Sc·Y (%)" },
    xaxis: { title: { text: "Sc·Y (%)" }, type: "log" },
    yaxis: { autorange: "reversed", automargin: true },
    height: 80 + 22 * coefs.length,
    legend: { orientation: "h", y: -0.15 },
    margin: { t: 40 },
  }, ANALYSIS_PLOT);
  const ident = out.identifiability || {};
  const next = ident.next_test || {};
  $("#an-next").innerHTML = next.coefficient
    ? `<p><strong>Next test:</strong> ${esc(next.test)}</p><p class="muted">${esc(next.reason)}</p>`
    : `<p class="muted">${esc(next.reason || "")}</p>`;
  if (next.unmeasured) $("#an-next").innerHTML += `<p class="muted">${esc(next.unmeasured)}</p>`;
  $("#an-ident tbody").innerHTML = (ident.coefficients || [])
    .map((c) => `<tr><td>${esc(c.name)}</td><td>${esc(fmt(c.value))}</td><td>${esc(fmt(c.sigma, 3))}</td>
      <td>${esc(pct(c.relative_sigma))}</td><td>${esc(pct(c.weighted))}</td></tr>`)
    .join("") || emptyRow(5, "no σ: plug in estimation results");
  $("#an-correlations").innerHTML = (ident.correlations || [])
    .map((c) => `<li>${esc(c.a)} ↔ ${esc(c.b)}: ρ = ${esc(fmt(c.rho, 3))}</li>`)
    .join("");
  const flips = out.weight_stability || [];
  $("#an-stability").innerHTML = flips.length
    ? `<p>Doubling or halving one response's weight changes these removals (composite rule):</p><ul>${flips
      .map((f) => `<li>${esc(f.response)} ×${esc(fmt(f.factor, 2))} at ${esc(fmt(f.threshold, 4))}: ${esc([
        ...f.now_removed.map((n) => `+${n}`), ...f.now_kept.map((n) => `−${n}`)].join(", "))}</li>`)
      .join("")}</ul>`
    : "<p class=\"muted\">Doubling or halving any response's weight changes no removal.</p>";
  $("#an-notes").innerHTML = out.notes.map((n) => `<li>${esc(n)}</li>`).join("");
}

onPage("analysis", analysisLoad);
