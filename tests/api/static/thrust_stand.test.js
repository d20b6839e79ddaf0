// The Thrusters page's arithmetic (api/http/static/thrust_stand.js) without a browser: units,
// g/W, the thrust law and its inverse, and the figures a thrust stand prints.
import assert from "node:assert/strict";
import test from "node:test";
import {
  commandFor, gramsPerWatt, inThrustUnit, liveStand, liveStandCells, manualBlocked, manualLimitsText, standFigures, standSeries, thrust,
} from "../../../api/http/static/thrust_stand.js";

const LAW = {
  forward_dead_band: 0.05, forward_gain: 40, forward_exponent: 1.5,
  reverse_dead_band: 0.07, reverse_gain: 30, reverse_exponent: 1.6,
};

test("a thrust in N, kgf or lbf; none stays none", () => {
  assert.equal(inThrustUnit(9.80665, "kgf"), 1);
  assert.ok(Math.abs(inThrustUnit(4.4482216152605, "lbf") - 1) < 1e-12);
  assert.equal(inThrustUnit(12.5, "N"), 12.5);
  assert.equal(inThrustUnit(null, "kgf"), null);
});

test("efficiency in grams-force per watt", () => {
  assert.ok(Math.abs(gramsPerWatt(0.0980665) - 10) < 1e-9);
  assert.equal(gramsPerWatt(undefined), null);
});

test("the inverse map gives back the command, each direction past its dead band", () => {
  for (const u of [0.3, 0.8, -0.4, -0.9]) assert.ok(Math.abs(commandFor(LAW, thrust(LAW, u)) - u) < 1e-12, u);
  assert.equal(thrust(LAW, 0.04), 0); // inside the forward dead band
  assert.equal(thrust(LAW, -0.06), 0);
  assert.equal(commandFor(LAW, 0), 0);
});

const ROWS = [
  { command: 0.05, thrust_per_thruster_n: 0.2, efficiency_n_per_w: 0.5, rpm: 300, power_w: 0.4 }, // noisy near zero
  { command: 0.5, thrust_per_thruster_n: 10, efficiency_n_per_w: 0.2, rpm: 2500, current_a: 3, power_w: 50 },
  { command: 1, thrust_per_thruster_n: 30, efficiency_n_per_w: 0.15, rpm: 4100, current_a: 9.5, power_w: 200 },
  { command: -1, thrust_per_thruster_n: -20, efficiency_n_per_w: 0.12, rpm: -3900, power_w: 166 },
];

test("the stand's figures: largest thrusts, readings there, best efficiency where the thruster works, τ ± σ", () => {
  const figures = Object.fromEntries(
    standFigures({ table: ROWS, response: { time_constant_s: 0.151, std_s: 0.0013, settle_90_s: 0.347, transients: 6 } }, "N"),
  );
  assert.equal(figures["Largest forward thrust"], "30 N at command 1");
  assert.equal(figures["Largest reverse thrust"], "-20 N at command -1");
  assert.equal(figures["RPM at largest thrust"], "4100");
  assert.equal(figures["Current at largest thrust"], "9.5 A");
  assert.equal(figures["Electrical power at largest thrust"], "200 W");
  assert.equal(figures["Efficiency at largest thrust"], "15.3 g/W");
  // 0.5 N/W at 0.2 N is below 20 % of the largest thrust: the best is read at command 0.5
  assert.equal(figures["Best efficiency (≥ 20 % of largest thrust)"], "20.4 g/W at command 0.5");
  assert.equal(figures["Response time τ (first-order lag)"], "0.151 ± 0.0013 s (σ)");
  assert.equal(figures["90 % settling"], "0.347 s (τ·ln 10, from 6 steps)");
});

test("thrusts in the chosen unit; a calibration without steps says its response is not measured", () => {
  const figures = Object.fromEntries(standFigures({ table: ROWS }, "kgf"));
  assert.equal(figures["Largest forward thrust"], "3.059 kgf at command 1");
  assert.equal(figures["Response time"], "not measured (imported table, or too few steps)");
  assert.deepEqual(standFigures({ table: [] }, "N"), [["Response time", "not measured (imported table, or too few steps)"]]);
});

const UNITS = { load_cell: "N", supply_voltage: "V", thruster1_rpm: "rpm", thruster1_current: "A" };

test("live readout: each thruster's RPM, current, the supply and P = V·I, formatted once", () => {
  const sample = {
    channels: { supply_voltage: 15.711000000000002, load_cell: 9.9, thruster1_rpm: 2480.4, thruster1_current: 3.2149, thruster2_rpm: 0, thruster2_current: 0 },
    thrusters: [0.30000000000000004, 0],
  };
  const rows = liveStand(sample, UNITS, 2);
  assert.ok(Math.abs(rows[0].power_w - 15.711 * 3.2149) < 1e-9);
  assert.deepEqual(liveStandCells(rows[0]), ["thruster 1", "0.3", "2480 rpm", "3.21 A", "15.7 V", "50.5 W"]);
  assert.deepEqual(liveStandCells(rows[1]), ["thruster 2", "0", "0 rpm", "0 A", "15.7 V", "0 W"]);
  // the supply as every voltage of the page: to 0.1 V (voltageText), "16.0 V", not "16 V"
  assert.equal(liveStandCells(liveStand({ channels: { supply_voltage: 16.01 } }, UNITS, 1)[0])[4], "16.0 V");
});

test("live readout outside a logged run: no telemetry, no power, never NaN", () => {
  const rows = liveStand({ channels: { supply_voltage: 16, thruster1_rpm: null }, thrusters: [0] }, UNITS, 1);
  assert.deepEqual(liveStandCells(rows[0]), ["thruster 1", "0", "—", "—", "16.0 V", "—"]);
  const bare = liveStand({ channels: {} }, {}, 1);
  assert.deepEqual(liveStandCells(bare[0]), ["thruster 1", "—", "—", "—", "—", "—"]);
});

const READY = { armed: true, current_job: null, guard: { estop: null } };

test("manual control: off with the reason, on only for an operator on an armed, free rig", () => {
  assert.equal(manualBlocked(READY, "operator", { available: true }), "");
  assert.match(manualBlocked(READY, "viewer", { available: true }), /role viewer: driving a thruster needs role operator/);
  assert.match(manualBlocked({ ...READY, armed: false }, "operator"), /disarmed: arm them first/);
  assert.match(manualBlocked({ ...READY, current_job: { label: "thrust calibration" } }, "operator"), /busy: thrust calibration/);
  assert.match(manualBlocked({ ...READY, guard: { estop: { at: "x" } } }, "operator"), /emergency stop is not acknowledged/);
  assert.match(manualBlocked(READY, "operator", { available: false, reason: "needs a [thrusters] section" }), /cannot: needs a \[thrusters\] section/);
  assert.match(manualBlocked(null, "operator"), /Waiting/);
});

test("manual control states the rig's limits", () => {
  const text = manualLimitsText({ command: { max: 0.8, min: -0.8 }, duration_s: { max: 60 }, thruster: { max: 2 } });
  assert.equal(text, "Limits: command -0.8 … 0.8 (fraction of full thrust, the rig's max_thruster_command); duration up to 60 s.");
  assert.equal(manualLimitsText(undefined), "");
});

test("the live stand plot: each thruster's RPM and power against time, one row per unit", () => {
  const at = (t, rpm, amps) => ({ t, rows: liveStand({ channels: { supply_voltage: 16, thruster1_rpm: rpm, thruster1_current: amps } }, UNITS, 1) });
  const series = standSeries([at(0, 0, 0), at(0.1, 1200, 2), at(0.2, null, null)], 1);
  assert.deepEqual(series.map((s) => [s.name, s.unit]), [["thruster 1 RPM [rpm]", "rpm"], ["thruster 1 power [W]", "W"]]);
  assert.deepEqual(series[0].x, [0, 0.1, 0.2]);
  assert.deepEqual(series[0].y, [0, 1200, null]);
  assert.deepEqual(series[1].y, [0, 32, null]); // 16 V × 2 A; a gap stays a gap
  assert.deepEqual(standSeries([], 0), []);
});
