// The rig's guard on the Rig page: an emergency stop waiting for an operator's
// acknowledgement, and who holds the rig (GET /api/rig → guard), in a technician's words
// with local times, drawn with each rig status (rig.js). A change made through the service
// (the stream's `guard` event) asks for the status at once, not at the next 2 s poll: a stop
// pressed on another page or by a lab tool shows on every open page within a round trip.
import { api } from "./api.js";
import { $ } from "./dom.js";
import { localTime } from "./format.js";
import { esc } from "./markup.js";
import { onRigStatus, refreshRig } from "./rig.js";
import { onGuard } from "./stream.js";

function renderGuard(guard) {
  const panel = $("#guard-panel");
  if (!panel) return;
  const stop = guard.estop;
  const hold = guard.hold;
  const who = (e) => esc(e.by || "someone without a sign-in");
  panel.innerHTML = `
    ${stop ? `<p class="error" id="estop-latched"><strong>Emergency stop</strong> pressed ${esc(localTime(stop.at))} by ${who(stop)}:
      the rig refuses motion until an operator has checked it and acknowledges the stop.</p>
      <button id="estop-ack-btn">Acknowledge emergency stop</button>` : ""}
    ${hold ? `<p id="hold-state"><strong>Held by ${who(hold)}</strong> since ${esc(localTime(hold.at))}: ${esc(hold.message)}</p>
      <button id="release-btn">Release hold</button>`
      : `<button id="hold-btn" title="Refuse starts by anyone else while you work at the tank">Hold the rig…</button>`}`;
  const act = (id, run) => {
    const b = $(id, panel);
    if (b) b.onclick = () => run().then(refreshRig).catch((e) => alert(e.message));
  };
  act("#estop-ack-btn", () => api("POST", "/api/estop/ack", { note: "" }));
  act("#hold-btn", async () => {
    const reason = prompt("Why do you hold the rig? (e.g. rigging the vehicle)");
    if (reason) await api("POST", "/api/rig/hold", { reason });
  });
  act("#release-btn", async () => {
    try {
      await api("POST", "/api/rig/release", { override: false });
    } catch (err) {
      if (err.status !== 423 || !confirm(`${err.message}\n\nOverride and release it?`)) throw err;
      await api("POST", "/api/rig/release", { override: true });
    }
  });
}

onRigStatus((s) => renderGuard(s.guard || {}));
onGuard(() => refreshRig());
