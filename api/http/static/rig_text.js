// The rig's status (GET /api/rig) in a technician's words, no DOM: the Rig page's status
// table prints these (unit-tested with node --test).
import { localTime } from "./format.js";

// The thrusters' state in words: armed or disarmed, and the controller's state only when it
// says more (a fault, a lost link), never "disarmed (DISARMED)".
export function thrustersText(s) {
  const t = s.thrusters;
  if (!t || t.state === "absent") return "none on this rig";
  const armed = s.armed ? "armed" : "disarmed";
  const said = String(t.state || "").toLowerCase().replace(/_/g, " ");
  return !said || said === armed ? armed : `${armed} — controller ${said}`;
}

// Who may move the rig now, the same words the start form uses when it refuses: an
// unacknowledged emergency stop, a hold, the job on the rig, or free.
export function whoHoldsTheRig(s) {
  const guard = s.guard || {};
  if (guard.estop) return `stopped: emergency stop at ${localTime(guard.estop.at)}, not acknowledged`;
  if (guard.hold) return `held by ${guard.hold.by || "no token"} since ${localTime(guard.hold.at)}: ${guard.hold.message}`;
  if (s.current_job) return `busy: ${s.current_job.label}`;
  return s.lock_holder ? `busy: ${s.lock_holder}` : "free";
}
