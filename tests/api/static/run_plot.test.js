// The run plot's series (api/http/static/run_plot.js) without a browser: Y against X with
// units on the axes, overlaid runs named in the legend, time from each run's release.
import test from "node:test";
import assert from "node:assert/strict";
import { TIME_AXIS, channelLabel, runName, runPlotSeries, withUnit, shownUnit } from "../../../api/http/static/run_plot.js";

function shown(id, kind, rpm, thrust, release = null) {
  const t = rpm.map((_, i) => 100 + i * 0.1);
  return {
    run: { id, kind },
    samples: { t_mono: t, channels: { rpm, thrust, ratio: rpm.map(() => 1) }, units: { rpm: "rpm", thrust: "N", ratio: "1" } },
    release,
    name: runName({ id, kind }, "0.5"),
  };
}

test("a run is named by its short id, kind and load", () => {
  assert.equal(runName({ id: "0123456789abcdef", kind: "tow" }, "30 N"), "01234567 tow 30 N");
  assert.equal(runName({ id: "0123456789abcdef", kind: "spin" }), "01234567 spin");
});

test("units: none for the dimensionless 1, in brackets otherwise", () => {
  assert.equal(withUnit("thrust", shownUnit("N")), "thrust [N]");
  assert.equal(withUnit("ratio", shownUnit("1")), "ratio");
  assert.equal(withUnit("state", shownUnit(undefined)), "state");
});

test("one channel against another: the x channel's values and unit, markers", () => {
  const a = shown("aaaaaaaa1", "calibration", [1000, 2000, 3000], [1, 4, 9]);
  const plot = runPlotSeries([a], ["thrust"], "rpm");
  assert.equal(plot.xTitle, "rpm [rpm]");
  assert.equal(plot.mode, "markers");
  assert.deepEqual(plot.series.map((s) => [s.name, s.unit, s.x, s.y]), [["thrust [N]", "N", [1000, 2000, 3000], [1, 4, 9]]]);
});

test("the x channel is not also plotted against itself", () => {
  const a = shown("aaaaaaaa1", "calibration", [1, 2], [3, 4]);
  assert.deepEqual(runPlotSeries([a], ["rpm", "thrust"], "rpm").series.map((s) => s.label), ["thrust"]);
});

test("overlaid runs are each named in the legend", () => {
  const a = shown("aaaaaaaa1", "calibration", [1, 2], [3, 4]);
  const b = shown("bbbbbbbb2", "calibration", [1, 2], [5, 6]);
  const names = runPlotSeries([a, b], ["thrust"], "rpm").series.map((s) => s.name);
  assert.deepEqual(names, ["thrust [N] · aaaaaaaa calibration 0.5", "thrust [N] · bbbbbbbb calibration 0.5"]);
});

test("a run without the x channel is left out and listed", () => {
  const a = shown("aaaaaaaa1", "calibration", [1, 2], [3, 4]);
  const b = shown("bbbbbbbb2", "tow", [1, 2], [5, 6]);
  delete b.samples.channels.rpm;
  const plot = runPlotSeries([a, b], ["thrust"], "rpm");
  assert.deepEqual(plot.missing, ["bbbbbbbb tow 0.5"]);
  assert.equal(plot.series.length, 1);
});

test("against time each run starts at its release, else at its first sample", () => {
  const a = shown("aaaaaaaa1", "tow", [1, 2, 3], [3, 4, 5], 100.1);
  const b = shown("bbbbbbbb2", "tow", [1, 2, 3], [3, 4, 5], 100.2);
  const released = runPlotSeries([a, b], ["thrust"], TIME_AXIS);
  assert.equal(released.xTitle, "time from release [s]");
  assert.equal(released.mode, "lines");
  assert.deepEqual(released.series[1].x.map((t) => Math.round(t * 10) / 10), [-0.2, -0.1, 0]);
  b.release = null;
  const first = runPlotSeries([a, b], ["thrust"]);
  assert.equal(first.xTitle, "time from first sample [s]");
  assert.deepEqual(first.series[0].x.map((t) => Math.round(t * 10) / 10), [0, 0.1, 0.2]);
});

test("a thruster's telemetry is named by what it measures, its unit not repeated", () => {
  assert.equal(channelLabel("thruster1_rpm"), "thruster 1 speed");
  assert.equal(channelLabel("thruster12_current"), "thruster 12 current");
  assert.equal(channelLabel("drive_force"), "drive force");
  assert.equal(channelLabel("thruster_rpm_note"), "thruster rpm note");
});
