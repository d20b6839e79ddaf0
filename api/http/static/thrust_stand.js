// A thrust stand's arithmetic, no DOM (unit-tested with node --test): thrust units, efficiency
// in g/W, the fitted thrust law and its inverse, the figures the Thrusters page prints.
import { fmt, reading, voltageText } from "./format.js";

/** Standard gravity [m/s²]: kgf → N, g/W → N/W. */
const STANDARD_GRAVITY = 9.80665;
/** The thrust units offered: newtons per unit, by label. */
export const THRUST_UNITS = { N: 1, kgf: STANDARD_GRAVITY, lbf: 4.4482216152605 };
/** A thrust [N] in `unit` (a key of THRUST_UNITS); null for none. */
export const inThrustUnit = (newtons, unit) => (newtons === null || newtons === undefined ? null : newtons / THRUST_UNITS[unit]);
/** Efficiency as a thrust stand prints it: grams-force per watt [g/W], from N/W; null for none. */
export const gramsPerWatt = (nPerW) => (nPerW === null || nPerW === undefined ? null : (nPerW / STANDARD_GRAVITY) * 1000);

/** The fitted thrust law: thrust [N] of one thruster at command `u` (dead bands, gains and
 * exponents per direction, `p` as GET /api/calibration/latest gives them). */
export function thrust(p, u) {
  const fwd = Math.max(u - p.forward_dead_band, 0);
  const rev = Math.max(-u - p.reverse_dead_band, 0);
  return p.forward_gain * fwd ** p.forward_exponent - p.reverse_gain * rev ** p.reverse_exponent;
}
/** The inverse map: the command giving thrust `f` [N] under the law `p`. */
export function commandFor(p, f) {
  if (f > 0) return p.forward_dead_band + (f / p.forward_gain) ** (1 / p.forward_exponent);
  if (f < 0) return -(p.reverse_dead_band + (-f / p.reverse_gain) ** (1 / p.reverse_exponent));
  return 0;
}

/** The figures a thrust stand prints, as [label, text] rows, from the calibration's rows and
 * response, thrusts in `unit`. */
export function standFigures(data, unit) {
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
  if (fwd) out.push(["Largest forward thrust", `${fmt(inThrustUnit(fwd.thrust_per_thruster_n, unit), 4)} ${unit} at command ${fmt(fwd.command, 3)}`]);
  if (rev && rev.thrust_per_thruster_n < 0) out.push(["Largest reverse thrust", `${fmt(inThrustUnit(rev.thrust_per_thruster_n, unit), 4)} ${unit} at command ${fmt(rev.command, 3)}`]);
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

const finite = (v) => (typeof v === "number" && Number.isFinite(v) ? v : null);

/** The live thrust-stand readings of one stream sample, one row per thruster (`count`):
 * its command (fraction), RPM, motor current [A], the supply voltage [V] and the electrical
 * power P = V·I [W]; null where the sample lacks it. The controller's telemetry travels as
 * the channels thruster<i>_rpm and thruster<i>_current (1-based, daq/vocabulary.py) while a
 * run logs it (a calibration, a thruster-driven test, a manual run); the supply is the rig's
 * channel in V (`units`: GET /api/rig → units). */
export function liveStand(sample, units, count) {
  const ch = (sample && sample.channels) || {};
  const supply = Object.keys(units || {}).find((k) => units[k] === "V" && finite(ch[k]) !== null);
  const volts = supply ? ch[supply] : null;
  return Array.from({ length: count }, (_, j) => {
    const current = finite(ch[`thruster${j + 1}_current`]);
    return {
      thruster: j + 1,
      command: finite(((sample && sample.thrusters) || [])[j]),
      rpm: finite(ch[`thruster${j + 1}_rpm`]),
      current_a: current,
      voltage_v: volts,
      power_w: volts !== null && current !== null ? volts * current : null,
    };
  });
}

/** A live row as the page's readout prints it, one text per column: thruster, command,
 * RPM, current, supply, power ("—" where the sample lacks it). */
export const liveStandCells = (row) => [
  `thruster ${row.thruster}`,
  row.command === null ? "—" : fmt(row.command, 3),
  reading(row.rpm, "rpm", 4),
  reading(row.current_a, "A", 3),
  row.voltage_v === null ? "—" : voltageText([row.voltage_v]),
  reading(row.power_w, "W", 3),
];

/** Why the manual thrust control is off now, or "" when it may start: the signed-in role
 * (`role`: "viewer" cannot), what the rig can do (`capability`: GET /api/rig →
 * capabilities of the manual kind), an emergency stop not yet acknowledged, a job holding the
 * rig, the thrusters disarmed (a remote start of thrust is two acts: arm, then start). */
export function manualBlocked(status, role, capability) {
  if (!status) return "Waiting for the rig's status…";
  if (role && role !== "operator") return `You are signed in with role ${role}: driving a thruster needs role operator.`;
  if (capability && !capability.available) return `This rig cannot: ${capability.reason}.`;
  if (status.guard && status.guard.estop) return "The emergency stop is not acknowledged yet: an operator checks the rig, then acknowledges it on the Rig page.";
  if (status.current_job) return `The rig is busy: ${status.current_job.label}.`;
  if (!status.armed) return "The thrusters are disarmed: arm them first (Arm thrusters).";
  return "";
}

/** The manual control's limits as the page states them, from the rig's limits on the
 * request's fields (GET /api/rig → field_limits of the manual kind). */
export function manualLimitsText(limits) {
  const c = (limits && limits.command) || {};
  const d = (limits && limits.duration_s) || {};
  const parts = [];
  if (c.max !== undefined) parts.push(`command ${fmt(c.min ?? -c.max, 3)} … ${fmt(c.max, 3)} (fraction of full thrust, the rig's max_thruster_command)`);
  if (d.max !== undefined) parts.push(`duration up to ${fmt(d.max, 3)} s`);
  return parts.length ? `Limits: ${parts.join("; ")}.` : "";
}

/** What the live stand plot draws (plots.js unitRowsPlot: one row per unit): each
 * thruster's RPM and electrical power over `buffer` ([{t [s], rows: liveStand(…)}], oldest
 * first); none for a rig without thrusters. */
export function standSeries(buffer, count) {
  const t = buffer.map((p) => p.t);
  const out = [];
  for (const [key, label, unit] of [["rpm", "RPM", "rpm"], ["power_w", "power", "W"]]) {
    for (let i = 0; i < count; i += 1) {
      const y = buffer.map((p) => (p.rows[i] ? p.rows[i][key] : null));
      out.push({ x: t, y, name: `thruster ${i + 1} ${label} [${unit}]`, label, unit, key: `thruster${i + 1}_${key}` });
    }
  }
  return out;
}
