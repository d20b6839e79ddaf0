// The Thrusters page as a thrust stand: live RPM, current, supply and power per thruster; the
// newest calibration (GET /api/calibration/latest) as a Tyto user reads it — RPM, electrical
// power, efficiency (g/W) and the response time with its σ; thrust against command, RPM and
// power in N, kgf or lbf; the fitted curve and its inverse map; every calibration stored; and
// one thruster under manual control (manual_thrust.js).
import { api } from "./api.js";
import { $, $$, everyFrame, kv, setHtml } from "./dom.js";
import { fmt, localTime, voltageText } from "./format.js";
import { esc } from "./markup.js";
import { onPage } from "./pages.js";
import { state } from "./state.js";
import { onSample } from "./stream.js";
import { unitRowsPlot, newPlot } from "./plots.js";
import { THRUST_UNITS, commandFor, gramsPerWatt, inThrustUnit, liveStand, liveStandCells, standFigures, standSeries, thrust } from "./thrust_stand.js";
import "./manual_thrust.js";

const stand = { cal: null, unit: localStorage.getItem("rig-thrust-unit") || "N" };
if (!(stand.unit in THRUST_UNITS)) stand.unit = "N";
const inUnit = (newtons) => inThrustUnit(newtons, stand.unit);

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
  kv($("#cal-stand-table"), standFigures(data, stand.unit));
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
    newPlot("cal-inverse-plot", [{ x: forces.map(inUnit), y: forces.map((f) => commandFor(p, f)), mode: "lines", name: "inverse map" }], inverse, config);
  }
  newPlot("cal-plot", traces, layout("Thrust against command", "command (fraction)"), config);
  // thrust against RPM and against electrical power: only rows that carry them
  const against = (key) => table.filter((r) => typeof r[key] === "number");
  const plotAgainst = (id, key, title, xTitle) => {
    const rows = against(key);
    $(`#${id}`).hidden = !rows.length;
    if (rows.length) newPlot(id, [{ x: rows.map((r) => r[key]), y: rows.map((r) => inUnit(r.thrust_per_thruster_n)), mode: "markers" }], layout(title, xTitle), config);
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

// Live readouts while the page is shown (the stream's samples, stream.js): the rig's
// channels in volts (supply) and newtons (load cell, in the chosen unit), and per thruster
// its command, the RPM and current its controller reports while a run logs them (a
// calibration's sweep, a manual run) and the electrical power V·I (thrust_stand.js), as
// numbers and as a plot of the last minute.
const LIVE_POINTS = 600; // one minute at 10 Hz
const LIVE_REDRAW_MS = 500;
const live = { buffer: [], t0: null, timer: null, sample: null };

function onStandSample(sample) {
  const units = (state.rig && state.rig.units) || {};
  const count = ((state.rig && state.rig.thrusters && state.rig.thrusters.output) || []).length;
  if (live.t0 === null) live.t0 = sample.t_mono;
  live.buffer.push({ t: sample.t_mono - live.t0, rows: liveStand(sample, units, count) });
  if (live.buffer.length > LIVE_POINTS) live.buffer.splice(0, live.buffer.length - LIVE_POINTS);
  live.sample = sample;
  if ($("#page-thrusters").hidden) return;
  if (live.timer === null) live.timer = setTimeout(drawLive, LIVE_REDRAW_MS);
  showReadings();
}

// The newest sample's readings, once a frame (at most at the stream's 10 Hz); a table whose
// values did not change is not rewritten.
const showReadings = everyFrame(() => {
  if ($("#page-thrusters").hidden || !live.sample) return;
  const units = (state.rig && state.rig.units) || {};
  const readings = [];
  for (const [name, value] of Object.entries(live.sample.channels || {})) {
    if (typeof value !== "number") continue;
    const label = name.replace(/_/g, " ");
    if (units[name] === "V") readings.push([label, voltageText([value])]);
    else if (units[name] === "N") readings.push([label, `${fmt(inUnit(value), 4)} ${stand.unit}`]);
  }
  setHtml($("#stand-live"), `Live: ${readings.map(([label, text]) => `<span class="reading">${esc(label)} ${esc(text)}</span>`).join("")}`);
  const rows = live.buffer[live.buffer.length - 1].rows;
  $("#stand-live-table").hidden = !rows.length;
  const cells = (row) => liveStandCells(row).map((text) => `<td>${esc(text)}</td>`).join("");
  setHtml($("#stand-live-table tbody"), rows.map((row) => `<tr>${cells(row)}</tr>`).join(""));
});

// The last minute's RPM and power per thruster, redrawn at most every LIVE_REDRAW_MS; no
// blank plot while no run logs the telemetry (outside a sweep or a manual run).
function drawLive() {
  live.timer = null;
  if ($("#page-thrusters").hidden) return;
  const count = live.buffer.length ? live.buffer[live.buffer.length - 1].rows.length : 0;
  const logged = live.buffer.some((p) => p.rows.some((r) => r.rpm !== null));
  $("#stand-live-plot").hidden = !count || !logged;
  if (count && logged) unitRowsPlot("stand-live-plot", standSeries(live.buffer, count), { xTitle: "time [s]", revision: "stand-live" });
}

onSample(onStandSample);
onPage("thrusters", loadCalibration);
