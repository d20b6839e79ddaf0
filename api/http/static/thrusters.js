// The Thrusters page as a thrust stand: the newest calibration (GET /api/calibration/latest)
// as a Tyto user reads it — RPM, electrical power, efficiency (g/W) and the response time
// with its σ; thrust against command, RPM and power in N, kgf or lbf; the fitted curve and
// its inverse map; every calibration stored.
import { api } from "./api.js";
import { $, $$, kv } from "./dom.js";
import { fmt, localTime, voltageText } from "./format.js";
import { esc } from "./markup.js";
import { onPage } from "./pages.js";
import { state } from "./state.js";
import { onSample } from "./stream.js";

const STANDARD_GRAVITY = 9.80665; // m/s², kgf → N
//: Thrust units offered: newtons per unit, and the label.
const THRUST_UNITS = { N: 1, kgf: STANDARD_GRAVITY, lbf: 4.4482216152605 };
const stand = { cal: null, unit: localStorage.getItem("rig-thrust-unit") || "N" };
if (!(stand.unit in THRUST_UNITS)) stand.unit = "N";

const inUnit = (newtons) => (newtons === null || newtons === undefined ? null : newtons / THRUST_UNITS[stand.unit]);
// Efficiency as a thrust stand prints it: grams-force per watt, from N/W.
const gramsPerWatt = (nPerW) => (nPerW === null || nPerW === undefined ? null : (nPerW / STANDARD_GRAVITY) * 1000);

function thrust(p, u) {
  const fwd = Math.max(u - p.forward_dead_band, 0);
  const rev = Math.max(-u - p.reverse_dead_band, 0);
  return p.forward_gain * fwd ** p.forward_exponent - p.reverse_gain * rev ** p.reverse_exponent;
}
function commandFor(p, f) {
  if (f > 0) return p.forward_dead_band + (f / p.forward_gain) ** (1 / p.forward_exponent);
  if (f < 0) return -(p.reverse_dead_band + (-f / p.reverse_gain) ** (1 / p.reverse_exponent));
  return 0;
}

// voltageText (format.js): a calibration's supply voltages once.

// The figures a thrust stand prints, from the calibration's rows and response.
function standFigures(data) {
  const rows = data.table || [];
  const at = (pick) => rows.reduce((best, r) => (best === null || pick(r, best) ? r : best), null);
  const fwd = at((r, b) => r.thrust_per_thruster_n > b.thrust_per_thruster_n);
  const rev = at((r, b) => r.thrust_per_thruster_n < b.thrust_per_thruster_n);
  // near zero thrust |F|/P divides two small noisy numbers (hundreds of g/W at command 0):
  // the best efficiency is read where the thruster works, at ≥ 20 % of its largest thrust
  const largest = Math.max(...rows.map((r) => Math.abs(r.thrust_per_thruster_n)));
  const working = rows.filter((r) => typeof r.efficiency_n_per_w === "number" && Math.abs(r.thrust_per_thruster_n) >= 0.2 * largest);
  const best = working.reduce((b, r) => (b === null || r.efficiency_n_per_w > b.efficiency_n_per_w ? r : b), null);
  const out = [];
  const unit = stand.unit;
  if (fwd) out.push(["Largest forward thrust", `${fmt(inUnit(fwd.thrust_per_thruster_n), 4)} ${unit} at command ${fmt(fwd.command, 3)}`]);
  if (rev && rev.thrust_per_thruster_n < 0) out.push(["Largest reverse thrust", `${fmt(inUnit(rev.thrust_per_thruster_n), 4)} ${unit} at command ${fmt(rev.command, 3)}`]);
  if (fwd && typeof fwd.rpm === "number") out.push(["RPM at largest thrust", fmt(fwd.rpm, 4)]);
  if (fwd && typeof fwd.current_a === "number") out.push(["Current at largest thrust", `${fmt(fwd.current_a, 3)} A`]);
  if (fwd && typeof fwd.power_w === "number") out.push(["Electrical power at largest thrust", `${fmt(fwd.power_w, 4)} W`]);
  if (fwd && typeof fwd.efficiency_n_per_w === "number") out.push(["Efficiency at largest thrust", `${fmt(gramsPerWatt(fwd.efficiency_n_per_w), 3)} g/W`]);
  if (best) out.push(["Best efficiency (≥ 20 % of largest thrust)", `${fmt(gramsPerWatt(best.efficiency_n_per_w), 3)} g/W at command ${fmt(best.command, 3)}`]);
  const resp = data.response;
  if (resp && typeof resp.time_constant_s === "number") {
    out.push(["Response time τ (first-order lag)", `${fmt(resp.time_constant_s, 3)} ± ${fmt(resp.std_s, 2)} s (σ)`]);
    out.push(["90 % settling", `${fmt(resp.settle_90_s, 3)} s (τ·ln 10, from ${resp.transients} steps)`]);
  } else {
    out.push(["Response time", "not measured (imported table, or too few steps)"]);
  }
  return out;
}

async function loadCalibration() {
  let cal;
  try {
    cal = await api("GET", "/api/calibration/latest");
  } catch (err) {
    $("#cal-status").textContent = err.status === 404 ? "No thrust calibration yet: start one on the Rig page." : err.message;
    return;
  }
  stand.cal = cal;
  const volts = voltageText(cal.voltages_v);
  $("#cal-status").textContent = `Newest calibration: ${cal.label} of ${localTime(cal.created_at)}${volts ? ` at ${volts}` : ""}.`;
  drawStand();
  loadCalibrationList();
}

function drawStand() {
  const cal = stand.cal;
  if (!cal) return;
  const data = cal.data;
  const table = data.table || [];
  const unit = stand.unit;
  $$("#cal-units input").forEach((i) => (i.checked = i.value === unit));
  $$(".thrust-unit").forEach((el) => (el.textContent = unit));
  $("#cal-stand").hidden = false;
  kv($("#cal-stand-table"), standFigures(data));
  const cell = (v, digits) => (v === undefined || v === null ? "—" : fmt(v, digits));
  $("#cal-table tbody").innerHTML = table
    .map((r) => `<tr><td>${esc(fmt(r.command, 3))}</td><td>${esc(r.direction || "—")}</td><td>${esc(fmt(inUnit(r.thrust_per_thruster_n), 4))}</td><td>${esc(cell(r.supply_voltage_v, 3))}</td><td>${esc(cell(r.current_a, 4))}</td><td>${esc(cell(r.rpm, 4))}</td><td>${esc(cell(r.power_w, 4))}</td><td>${esc(cell(gramsPerWatt(r.efficiency_n_per_w), 3))}</td></tr>`)
    .join("");
  const fit = data.fit && data.fit.parameters;
  $("#cal-params tbody").innerHTML = Object.entries(fit || {})
    .map(([k, v]) => `<tr><td>${esc(k)}${v.unit ? ` (${esc(v.unit)})` : ""}</td><td>${esc(fmt(v.value, 5))}</td><td>± ${esc(fmt(v.std, 3))}</td></tr>`)
    .join("") + (data.fit ? `<tr><td>RMSE (N)</td><td>${esc(fmt(data.fit.rmse_n, 3))}</td><td></td></tr>` : "");
  const ys = table.map((r) => inUnit(r.thrust_per_thruster_n));
  const yTitle = `thrust per thruster (${unit})`;
  const layout = (title, xTitle) => ({ title: { text: title }, margin: { t: 40, r: 20, b: 45, l: 60 }, xaxis: { title: { text: xTitle } }, yaxis: { title: { text: yTitle } }, showlegend: false });
  const config = { responsive: true, displaylogo: false };
  const traces = [{ x: table.map((r) => r.command), y: ys, mode: "markers", name: "measured" }];
  const p = fit ? Object.fromEntries(Object.entries(fit).map(([k, v]) => [k, v.value])) : null;
  if (p) {
    const [lo, hi] = data.fit.command_range || [-1, 1];
    const us = Array.from({ length: 201 }, (_, i) => lo + ((hi - lo) * i) / 200);
    traces.push({ x: us, y: us.map((u) => inUnit(thrust(p, u))), mode: "lines", name: "fit" });
    const fs = us.map((u) => thrust(p, u));
    const fmin = Math.min(...fs);
    const fmax = Math.max(...fs);
    const forces = Array.from({ length: 201 }, (_, i) => fmin + ((fmax - fmin) * i) / 200);
    const inverse = layout("Inverse map: thrust → command", yTitle);
    inverse.yaxis = { title: { text: "command (fraction)" } };
    Plotly.newPlot("cal-inverse-plot", [{ x: forces.map(inUnit), y: forces.map((f) => commandFor(p, f)), mode: "lines", name: "inverse map" }], inverse, config);
  }
  Plotly.newPlot("cal-plot", traces, layout("Thrust against command", "command (fraction)"), config);
  // thrust against RPM and against electrical power: only rows that carry them
  const against = (key) => table.filter((r) => typeof r[key] === "number");
  const plotAgainst = (id, key, title, xTitle) => {
    const rows = against(key);
    $(`#${id}`).hidden = !rows.length;
    if (rows.length) Plotly.newPlot(id, [{ x: rows.map((r) => r[key]), y: rows.map((r) => inUnit(r.thrust_per_thruster_n)), mode: "markers" }], layout(title, xTitle), config);
  };
  plotAgainst("cal-rpm-plot", "rpm", "Thrust against RPM", "RPM (mean over thrusters)");
  plotAgainst("cal-power-plot", "power_w", "Thrust against electrical power", "electrical power per thruster (W)");
}

$("#cal-units").addEventListener("change", (ev) => {
  stand.unit = ev.target.value;
  localStorage.setItem("rig-thrust-unit", stand.unit);
  drawStand();
});

async function loadCalibrationList() {
  const all = await api("GET", "/api/calibrations");
  $("#cal-list tbody").innerHTML = all
    .map((c) => `<tr><td>${esc(c.label)}</td><td>${c.source === "run" ? "measured" : "imported"}</td><td>${esc(localTime(c.created_at))}</td><td>${esc(c.rows)}</td><td>${esc(voltageText(c.voltages_v)) || "—"}</td><td>${esc(c.channels.join(", ")) || "—"}</td></tr>`)
    .join("");
}

// Live readouts while the page is shown (the stream's samples, stream.js): the
// rig's channels in volts (supply) and newtons (load cell, in the chosen unit) and each
// thruster's command. RPM and current are not streamed: the controller reports them at each
// calibration step, and the table holds them.
function onStandSample(sample) {
  if ($("#page-thrusters").hidden) return;
  const units = (state.rig && state.rig.units) || {};
  const readings = [];
  for (const [name, value] of Object.entries(sample.channels || {})) {
    if (typeof value !== "number") continue;
    const label = name.replace(/_/g, " ");
    if (units[name] === "V") readings.push([label, `${value.toFixed(2)} V`]);
    else if (units[name] === "N") readings.push([label, `${fmt(inUnit(value), 4)} ${stand.unit}`]);
  }
  (sample.thrusters || []).forEach((u, i) => readings.push([`thruster ${i + 1} command`, fmt(u, 3)]));
  const box = $("#stand-live");
  box.textContent = "Live: ";
  for (const [label, text] of readings) {
    const span = document.createElement("span");
    span.className = "reading";
    span.textContent = `${label} ${text}`;
    box.append(span);
  }
}

onSample(onStandSample);
onPage("thrusters", loadCalibration);
