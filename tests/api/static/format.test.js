// Values as the pages print them (api/http/static/format.js), without a browser.
process.env.TZ = "Europe/Berlin"; // local times are the reader's: UTC+1 in January
import test from "node:test";
import assert from "node:assert/strict";
import { fmt, localTime, reading, voltageText } from "../../../api/http/static/format.js";

test("numbers to a few significant digits without float noise", () => {
  assert.equal(fmt(0.28500000000000003), "0.285");
  assert.equal(fmt(15.711000000000002, 3), "15.7");
  assert.equal(fmt(123456, 3), "123000");
  assert.equal(fmt(-0.000123456), "-0.0001235");
  assert.equal(fmt(null), "—");
  assert.equal(fmt(undefined), "—");
  assert.equal(fmt("n/a"), "n/a");
});

test("an API time in the reader's local time, not the raw ISO text", () => {
  const shown = localTime("2026-01-01T23:30:00Z");
  assert.doesNotMatch(shown, /T23:30/);
  assert.match(shown, /2026/);
  assert.match(shown, /\b0?2\b/); // 00:30 on the 2nd in Berlin
  assert.match(shown, /12:30|00:30/);
  assert.equal(localTime(null), "—");
  assert.equal(localTime(""), "—");
});

test("a calibration's supply voltages once: one value or a range, to 0.1 V", () => {
  assert.equal(voltageText([15.711000000000002, 15.69, 15.72]), "15.7 V");
  assert.equal(voltageText([15.7, 16.0]), "15.7–16.0 V");
  assert.equal(voltageText([15.7, null, "x", NaN]), "15.7 V");
  assert.equal(voltageText([]), "");
  assert.equal(voltageText(undefined), "");
});

test("a live reading with its unit, never NaN or float noise", () => {
  assert.equal(reading(15.711000000000002, "V"), "15.7 V");
  assert.equal(reading(2480.4, "rpm", 4), "2480 rpm");
  assert.equal(reading(-3.2149, "A"), "-3.21 A");
  assert.equal(reading(NaN, "A"), "—");
  assert.equal(reading(null, "W"), "—");
  assert.equal(reading(undefined, "W"), "—");
});
