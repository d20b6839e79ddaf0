// The Thrusters page's manual control: one thruster at a command for a set time, started as
// the manual kind's job (POST /api/jobs/<its route>?queue=false), kept alive every second
// while this page is open (POST /api/jobs/{id}/alive: the service aborts it 3 s after the
// page falls silent), stopped with Stop (abort) or when the page closes. Off, with the reason,
// for a viewer, a rig that cannot, an unacknowledged emergency stop, a busy rig and disarmed
// thrusters (thrust_stand.js manualBlocked); the rig's limits on its fields shown and set on
// the inputs (GET /api/rig → field_limits).
import { api, authHeaders } from "./api.js";
import { $ } from "./dom.js";
import { withPlotly } from "./plots.js";
import { onRigStatus, refreshRig } from "./rig.js";
import { servedKinds } from "./start_forms.js";
import { FINAL, state } from "./state.js";
import { onJob } from "./stream.js";
import { manualBlocked, manualLimitsText } from "./thrust_stand.js";

/** The manual kind's route (its registry entry, served by GET /api/kinds). */
const ROUTE = "manual-thrust";
/** How often the page says it is still there, ms (the service waits 3 s). */
const ALIVE_MS = 1000;
const manual = { job: null, timer: null, role: null, token: undefined, count: 0 };

const served = () => servedKinds.find((k) => k.route === ROUTE);
const running = () => manual.job !== null && !FINAL.includes(manual.job.state);

/** The signed-in role (GET /api/whoami), asked once per token. */
async function role() {
  if (manual.token !== state.token) {
    manual.token = state.token;
    try {
      manual.role = (await api("GET", "/api/whoami")).role;
    } catch (err) {
      manual.role = null;
    }
  }
  return manual.role;
}

function setLimits(limits) {
  const thrusters = $("#manual-thruster");
  const count = (limits.thruster && limits.thruster.max) || 0;
  if (count !== manual.count) {
    manual.count = count;
    thrusters.replaceChildren(
      ...Array.from({ length: count }, (_, i) => Object.assign(document.createElement("option"), { value: String(i + 1), textContent: `thruster ${i + 1}` })),
    );
  }
  const c = limits.command || {};
  for (const el of [$("#manual-command"), $("#manual-slider")]) {
    if (c.max !== undefined) el.max = c.max;
    if (c.min !== undefined) el.min = c.min;
  }
  if (limits.duration_s && limits.duration_s.max !== undefined) $("#manual-duration").max = limits.duration_s.max;
  $("#manual-limits").textContent = manualLimitsText(limits);
}

onRigStatus(async (s) => {
  const kind = served();
  $("#manual-card").hidden = !kind;
  if (!kind) return;
  setLimits((s.field_limits || {})[kind.kind] || {});
  const reason = running() ? "" : manualBlocked(s, await role(), (s.capabilities || {})[kind.kind]);
  $("#manual-start").disabled = running() || !!reason;
  if (!$("#manual-start").dataset.roleLocked) $("#manual-start").title = reason; // people.js words a viewer's
  $("#manual-stop").disabled = !running();
  const absent = !s.thrusters || s.thrusters.state === "absent";
  $("#manual-arm").disabled = absent || s.armed || !!s.current_job;
  $("#manual-arm").textContent = s.armed ? "Thrusters armed" : "Arm thrusters";
  $("#manual-reason").textContent = reason;
});

function showJob(job) {
  const progress = (job.progress && job.progress.message) || job.state;
  $("#manual-status").textContent = FINAL.includes(job.state)
    ? `Manual run ${job.state}${job.error ? `: ${job.error}` : ""}. Thrusters at zero, brake on.`
    : `Running: ${progress}`;
}

function follow(job) {
  manual.job = job;
  clearInterval(manual.timer);
  const alive = () => api("POST", `/api/jobs/${job.id}/alive`).catch(() => {});
  alive();
  manual.timer = setInterval(alive, ALIVE_MS);
  showJob(job);
  $("#manual-stop").disabled = false;
  $("#manual-start").disabled = true;
}

onJob((job) => {
  if (!manual.job || job.id !== manual.job.id) return;
  manual.job = job;
  showJob(job);
  if (FINAL.includes(job.state)) {
    clearInterval(manual.timer);
    manual.timer = null;
    refreshRig();
  }
});

$("#manual-slider").addEventListener("input", () => ($("#manual-command").value = $("#manual-slider").value));
$("#manual-command").addEventListener("input", () => ($("#manual-slider").value = $("#manual-command").value));

$("#manual-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const kind = served();
  const body = {
    thruster: Number($("#manual-thruster").value),
    command: Number($("#manual-command").value),
    duration_s: Number($("#manual-duration").value),
  };
  try {
    // The run's live plot needs Plotly (plots.js loads it with the first plot): loaded before
    // the run starts, its compile (a second of a core, more on a loaded PC) cannot hold the
    // keep-alive back while the service counts its 3 s.
    await withPlotly(() => {}).catch(() => {});
    follow(await api("POST", `/api/jobs/${kind.route}?queue=false`, body));
  } catch (err) {
    $("#manual-status").textContent = err.message;
  }
});

$("#manual-stop").onclick = () => {
  if (running()) api("POST", `/api/jobs/${manual.job.id}/abort`).catch((err) => ($("#manual-status").textContent = err.message));
};

$("#manual-arm").onclick = () =>
  api("POST", "/api/rig/arm")
    .then(refreshRig)
    .catch((err) => ($("#manual-status").textContent = err.message));

// A page that closes stops its thrust now, not 3 s later (the dead-man is the fallback).
window.addEventListener("pagehide", () => {
  if (running()) fetch(`/api/jobs/${manual.job.id}/abort`, { method: "POST", headers: authHeaders(), keepalive: true });
});
