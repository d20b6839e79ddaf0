// The Thrusters page's arithmetic (api/http/static/thrust_stand.js) without a browser: units,
// g/W, the thrust law and its inverse, and the figures a thrust stand prints.
import assert from "node:assert/strict";
import test from "node:test";
import { commandFor, gramsPerWatt, inThrustUnit, standFigures, thrust } from "../../../api/http/static/thrust_stand.js";

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
