// The sections of a result document that holds swings (a pendulum's free decay): its methods
// side by side and its peak amplitudes over time. estimation.js draws every result through one
// renderer and calls these for any document that carries `methods` or `peaks`, whatever its kind.
import { $ } from "./dom.js";
import { fmt } from "./format.js";
import { esc } from "./markup.js";

/** "value ± σ", the value alone without σ, "—" without a value; a seed method's row adds its
 * own U (95 %) with k and ν ("U 0.11, k 2.1, ν 17"), as its coefficients carry them. */
export function valuePm(e) {
  if (!e || e.value === null || e.value === undefined) return "—";
  const pm = e.std === null || e.std === undefined ? fmt(e.value, 5) : `${fmt(e.value, 5)} ± ${fmt(e.std, 2)}`;
  if (e.U === undefined) return pm;
  const nu = e.nu === null || e.nu >= 1e4 ? "∞" : fmt(e.nu, 3); // as the budget table shows ν_eff
  return e.U === null ? `${pm} (no U)` : `${pm} (U ${fmt(e.U, 2)}, k ${fmt(e.k, 3)}, ν ${nu})`;
}

/** The methods-side-by-side table before #est-ambiguous, or none when `res` has no methods. */
export function drawMethods(res) {
  const old = document.getElementById("est-methods");
  if (old) old.remove();
  if (!(res.methods || []).length) return;
  const box = Object.assign(document.createElement("div"), { id: "est-methods" });
  $("#est-ambiguous").before(box);
  box.innerHTML = `<h4>Methods side by side</h4>
    <table class="list"><thead><tr><th>Run</th><th>Method</th><th>α (kg) ± σ (U 95 %)</th><th>β (N·s/m) ± σ (U 95 %)</th><th>γ (kg/m) ± σ (U 95 %)</th><th>e (rad²)</th><th title="the row's largest z from the output-error row of its run; beyond 2 σ the warnings name it">vs output error</th></tr></thead><tbody>
    ${res.methods
      .map(
        (m) => `<tr><td><code>${esc(m.run_id.slice(0, 8))}</code></td><td>${esc(m.method)}</td><td>${esc(valuePm(m.added_mass))}</td>
        <td>${esc(valuePm(m.linear_damping))}</td><td>${esc(valuePm(m.quadratic_damping))}</td><td>${esc(fmt(m.mse, 3))}</td><td>${esc(m.vs_output_error ?? "—")}</td></tr>`,
      )
      .join("")}</tbody></table>`;
}

/** The peaks chart's traces and axes (time from each run's release, as the report), or null
 * when `res` has no peaks. */
export function peaksChart(res, unit) {
  const peaks = Object.entries(res.peaks || {});
  if (!peaks.length) return null;
  const traces = [];
  for (const [rid, p] of peaks) {
    const name = rid.slice(0, 8);
    const r = p.release_time_s ?? p.times[0];
    traces.push({ x: p.times.map((t) => t - r), y: p.amplitudes, mode: "markers", name: `${name} |peak|` });
    const t0 = p.times[0];
    const t1 = p.times[p.times.length - 1];
    const ts = Array.from({ length: 60 }, (_, i) => t0 + ((t1 - t0) * i) / 59);
    const x = ts.map((t) => t - r);
    traces.push({ x, y: ts.map((t) => p.exponential.c * Math.exp(-p.exponential.decay_rate * t)), mode: "lines", name: `${name} C·e^(−Kt)` });
    traces.push({ x, y: ts.map((t) => p.linear.a0 - p.linear.rate_per_s * t), mode: "lines", line: { dash: "dash" }, name: `${name} linear` });
  }
  const layout = {
    margin: { t: 20, r: 20, b: 50, l: 60 },
    xaxis: { title: { text: "time from release [s]" } },
    yaxis: { title: { text: `|peak − midline| [${unit}]` } },
  };
  return { traces, layout };
}
