// The Rig page's status: GET /api/rig every 2 s into the connection dot and the status and
// channel tables, the start forms' limits and what the rig can do; arm, disarm and the
// emergency stop. Other modules read each status as it arrives (onRigStatus).
import { api } from "./api.js";
import { $, $$, kv } from "./dom.js";
import { fmt } from "./format.js";
import { thrustersText, whoHoldsTheRig } from "./rig_text.js";
import { ensureStartForms } from "./start_forms.js";
import { state } from "./state.js";

const statusListeners = [];

/** Calls `listener(status)` (awaited, in registration order) with each status the page polls,
 * once state.rig holds it: who holds the rig, who is signed in, the job on the rig. */
export function onRigStatus(listener) {
  statusListeners.push(listener);
}

export async function refreshRig() {
  try {
    const s = await api("GET", "/api/rig");
    await ensureStartForms(); // start_forms.js: once, from GET /api/kinds
    state.rig = s;
    const ok = s.running && s.connected && !s.device_lost;
    $("#conn-dot").className = "dot " + (ok ? "ok" : "bad");
    $("#conn-text").textContent = ok ? `${s.rig_name}${s.simulated ? " (simulated)" : ""}` : s.error || "device lost";
    $("#conn-text").title = $("#conn-text").textContent; // in full where the header cuts it
    const clock = s.clock || {};
    kv($("#status-table"), [
      ["Rig", `${s.rig_name} — ${s.vehicle || ""}`],
      ["Mode", s.simulated ? "simulated" : "hardware"],
      ["PLC connected", s.connected ? "yes" : "NO"],
      ["Device lost", s.device_lost ? "YES" : "no"],
      ["Thrusters", thrustersText(s)],
      ["Rig access", whoHoldsTheRig(s)],
      ["Stale channels", (s.stale_channels || []).join(", ") || "none"],
      ["Clock", `${fmt(clock.rate_hz)} Hz, p99 lateness ${fmt((clock.lateness_p99_s || 0) * 1000, 3)} ms`],
    ]);
    const ch = (s.sample && s.sample.channels) || {};
    const units = s.units || {};
    kv($("#channels-table"), Object.entries(ch).map(([k, v]) => [k, units[k] && v !== null ? `${fmt(v, 6)} ${units[k]}` : fmt(v, 6)]));
    setLimits();
    setCapabilities(s.capabilities || {});
    for (const listener of statusListeners) await listener(s);
  } catch (err) {
    $("#conn-dot").className = "dot bad";
    $("#conn-text").textContent = err.status === 401 ? "waiting for the API token" : err.message;
  }
}

// Each start form's inputs take the rig's limits on their fields (GET /api/rig →
// field_limits: {kind: {field: {max, min?}}}, declared by the request models' RigLimit; a
// signed field's min is −max, a negative drive being a reverse test).
function setLimits() {
  const limits = (state.rig && state.rig.field_limits) || {};
  for (const form of $$(".start-form[data-run-kind]")) {
    for (const [name, range] of Object.entries(limits[form.dataset.runKind] || {})) {
      const el = form.querySelector(`[name="${name}"]`);
      if (!el) continue;
      if (range.max !== undefined) el.max = range.max;
      if (range.min !== undefined) el.min = range.min;
    }
  }
}

// Offer only what the rig can do (GET /api/rig → capabilities); say why the rest is missing.
function setCapabilities(caps) {
  for (const el of $$(".start-form[data-run-kind]")) {
    const form = el.dataset.kind;
    const cap = caps[el.dataset.runKind];
    if (!cap) continue;
    const tab = $(`.tabs button[data-form=${form}]`);
    if (tab) {
      tab.classList.toggle("unavailable", !cap.available);
      tab.title = cap.available ? "" : cap.reason;
    }
    el.querySelector("button[type=submit]").disabled = !cap.available;
    let note = el.querySelector(".capability-reason");
    if (!note) {
      note = document.createElement("p");
      note.className = "capability-reason muted";
      el.prepend(note);
    }
    const reasons = cap.available ? [] : [cap.reason];
    const drive = el.querySelector("select[name=drive]");
    for (const [name, d] of Object.entries(cap.drives || {})) {
      const option = drive && [...drive.options].find((o) => o.value === name);
      if (!option) continue;
      option.disabled = !d.available;
      option.title = d.available ? "" : d.reason;
      if (!d.available && cap.available) reasons.push(d.reason);
      if (!d.available && drive.value === name) {
        const other = [...drive.options].find((o) => !o.disabled);
        if (other) drive.value = other.value;
      }
    }
    note.textContent = reasons.length ? `This rig cannot: ${reasons.join("; ")}` : "";
    note.hidden = !reasons.length;
  }
  const noThrusters = state.rig && state.rig.thrusters && state.rig.thrusters.state === "absent";
  for (const id of ["#arm-btn", "#disarm-btn"]) {
    $(id).disabled = !!noThrusters;
    $(id).title = noThrusters ? "this rig has no thrusters (no [thrusters] section in its rig file)" : "";
  }
}

$("#estop-btn").onclick = async () => {
  try {
    const r = await api("POST", "/api/rig/emergency-stop");
    $("#job-panel").insertAdjacentHTML("afterbegin", `<p class="error">Emergency stop: aborted ${r.aborted_jobs.length} job(s); rig safe.</p>`);
  } catch (err) {
    alert(err.message);
  }
};
$("#arm-btn").onclick = () => api("POST", "/api/rig/arm").then(refreshRig).catch((e) => alert(e.message));
$("#disarm-btn").onclick = () => api("POST", "/api/rig/disarm").then(refreshRig).catch((e) => alert(e.message));
