// The rig's status in a technician's words (api/http/static/rig_text.js), without a browser.
import assert from "node:assert/strict";
import test from "node:test";
import { localTime } from "../../../api/http/static/format.js";
import { thrustersText, whoHoldsTheRig } from "../../../api/http/static/rig_text.js";

test("thrusters: armed or disarmed, the controller's state only when it says more", () => {
  assert.equal(thrustersText({ armed: false, thrusters: { state: "DISARMED" } }), "disarmed");
  assert.equal(thrustersText({ armed: true, thrusters: { state: "ARMED" } }), "armed");
  assert.equal(thrustersText({ armed: false, thrusters: { state: "LINK_LOST" } }), "disarmed — controller link lost");
  assert.equal(thrustersText({ thrusters: { state: "absent" } }), "none on this rig");
  assert.equal(thrustersText({}), "none on this rig");
});

test("who may move the rig: an unacknowledged stop first, then a hold, the job on it, free", () => {
  const at = "2026-01-01T23:30:00Z";
  const estop = { estop: { at, by: "ana" }, hold: { at, by: "bo", message: "rigging" } };
  assert.equal(whoHoldsTheRig({ guard: estop }), `stopped: emergency stop at ${localTime(at)}, not acknowledged`);
  assert.doesNotMatch(whoHoldsTheRig({ guard: estop }), /T23:30/); // local time, not ISO
  assert.equal(whoHoldsTheRig({ guard: { hold: { at, by: "bo", message: "rigging" } } }), `held by bo since ${localTime(at)}: rigging`);
  assert.equal(whoHoldsTheRig({ guard: { hold: { at, message: "m" } } }), `held by no token since ${localTime(at)}: m`);
  assert.equal(whoHoldsTheRig({ current_job: { label: "tow 24.5 N" }, lock_holder: "x" }), "busy: tow 24.5 N");
  assert.equal(whoHoldsTheRig({ lock_holder: "calibration" }), "busy: calibration");
  assert.equal(whoHoldsTheRig({}), "free");
});
