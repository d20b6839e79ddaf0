// The repeats table of the Estimation page (api/http/static/uncertainty.js), every kind's
// repeats document alike: a decay's (dimensionless δ) and a tow set's (m/s), an outlier kept
// or left out of the fit, as issue 31 item 2 has the page say it.
import test from "node:test";
import assert from "node:assert/strict";
import { repeatsMarkup } from "../../../api/http/static/uncertainty.js";

const RUNS = ["aaaaaaaa-1", "bbbbbbbb-2", "cccccccc-3", "dddddddd-4", "eeeeeeee-5"];
const decay = (excluded) => ({
  quantity: "logarithmic decrement over the first 3 cycles",
  outlier_test: "Chauvenet",
  conditions: [
    {
      condition: "heave free decay, released 0.05 m from equilibrium",
      runs: RUNS,
      n: 5,
      values: [0.2522, 0.2505, 0.3257, 0.2497, 0.2512],
      unit: "1",
      mean: 0.26586,
      repeatability_95: 0.0416,
      outliers: ["cccccccc-3"],
    },
  ],
  outliers: ["cccccccc-3"],
  excluded,
});

test("a decay's outlier is marked kept, its value beside the others', no unit for δ", () => {
  const html = repeatsMarkup(decay([]));
  assert.match(html, /logarithmic decrement over the first 3 cycles, each repeat/);
  assert.match(html, /<strong class="est-kept-outlier"><code title="cccccccc-3">cccccccc<\/code> 0\.3257 \(outlier, kept in the fit\)<\/strong>/);
  assert.match(html, /<code title="aaaaaaaa-1">aaaaaaaa<\/code> 0\.2522,/);
  assert.match(html, /<td>0\.26586<\/td><td>0\.0416<\/td>/);
  assert.match(html, /Flagged but kept in the fit: <code title="cccccccc-3">cccccccc<\/code>/);
  assert.doesNotMatch(html, /left out/);
});

test("a left-out outlier is marked so and named below the table", () => {
  const html = repeatsMarkup(decay(["cccccccc-3"]));
  assert.match(html, /class="est-left-out"><code title="cccccccc-3">cccccccc<\/code> 0\.3257 \(outlier, left out of the fit\)/);
  assert.match(html, /Left out of the fit at the user's request: <code title="cccccccc-3">cccccccc<\/code>/);
  assert.doesNotMatch(html, /kept in the fit/);
});

test("a tow set's terminal speeds carry their unit; no repeated condition draws nothing", () => {
  const tow = decay([]);
  tow.quantity = "terminal speed";
  tow.conditions[0].unit = "m/s";
  const html = repeatsMarkup(tow);
  assert.match(html, /<td>0\.26586 m\/s<\/td><td>0\.0416 m\/s<\/td>/);
  const single = { ...tow, conditions: [{ ...tow.conditions[0], n: 1, runs: [RUNS[0]], values: [0.25], outliers: [] }] };
  assert.equal(repeatsMarkup(single), "");
  assert.equal(repeatsMarkup(null), "");
});
