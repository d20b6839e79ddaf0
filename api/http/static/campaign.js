// Queue page, Campaign card: start a campaign (target U in %, the expanded uncertainty of the
// GUM budget; axes, budget), watch its trail live — each test it chose, why, the operator's
// acts, U before → after and what the declared tolerances alone leave — and stop it.
// Live from the stream's campaign jobs (stream.js).
import { api } from "./api.js";
import { $, $$ } from "./dom.js";
import { shownState } from "./jobs.js";
import { esc } from "./markup.js";
import { onPage } from "./pages.js";
import { queueAction } from "./queue.js";
import { loadKinds } from "./start_forms.js";
import { FINAL, state } from "./state.js";
import { onJob } from "./stream.js";

// `streamed`: each campaign's newest document from the stream. An HTTP answer about a campaign
// (its start, its stop, the list) can be read after a newer stream event about it (the page
// showed the first test's instructions, then the start's answer, parsed later, wiped them
// for the whole run); the stream's document is drawn instead, and the stream always brings
// the last one.
const campaignView = { job: null, streamed: {} };
const newest = (job) => (job && campaignView.streamed[job.id]) || job;
// each coefficient by the name the result, the trail's "why" and the Estimation page give it
function sigmaText(status) {
  const pct = (status && status.expanded_percent) || {};
  const percent = (v) => (v == null ? "—" : `${Number(v).toPrecision(2)} %`);
  if (!Object.keys(pct).length) return `<span class="muted">no fit yet</span>`;
  const shown = Object.entries(pct).map(([k, v]) => `${esc(k)} ${percent(v)}`).join(" · ");
  const typeB = Object.entries(status.type_b_above_target || {});
  if (!typeB.length) return shown;
  const limited = typeB.map(([k, v]) => `${esc(k)} ${percent(v)}`).join(", ");
  return `${shown}<br><span class="muted">tolerances alone: ${limited}</span>`;
}

function showCampaign(job) {
  campaignView.job = job;
  const box = $("#campaign-view");
  if (!job) {
    box.innerHTML = `<p class="muted">No campaign yet.</p>`;
    return;
  }
  const c = job.outcome || {};
  const running = !FINAL.includes(job.state);
  const pending = c.pending
    ? `<p id="campaign-pending"><strong>Now:</strong> ${esc(c.pending.instructions)} <span class="muted">— ${esc(c.pending.why)}</span></p>`
    : "";
  const rows = (c.trail || [])
    .map((e) => `<tr><td>${esc(e.n)}</td><td>${esc(e.test)}<br><code>${esc(e.command)}</code></td><td class="muted">${esc(e.why)}</td>
      <td>${sigmaText(e.before)}</td><td>${sigmaText(e.after)}${e.after.unresolved.length ? `<br><span class="muted">${esc(e.after.unresolved.join("; "))}</span>` : ""}</td>
      <td>${e.tank_minutes.toFixed(1)}</td></tr>`)
    .join("");
  const shown = shownState(job); // jobs.js: "stopping" once asked, until it ends
  const stopping = shown === "stopping"
    ? ` <span class="muted" id="campaign-stopping">no further test; the run on the rig finishes first ·</span>` : "";
  box.innerHTML = `<p><strong>${esc(job.label)}</strong> <span class="state ${esc(shown)}" id="campaign-state">${esc(shown)}</span>${stopping}
      <span class="muted">started by ${esc(job.user || "—")}</span>
      ${running && shown !== "stopping" ? `<button type="button" id="campaign-stop">Stop the campaign</button>` : ""}</p>
    <p class="muted" id="campaign-summary">${esc(c.runs_used || 0)} of ${esc(c.max_runs)} runs · ${(c.tank_minutes || 0).toFixed(1)} of ${esc(c.max_minutes)} tank min${c.outcome ? ` · <strong>${esc(c.outcome)}</strong>` : ""}</p>
    ${pending}
    <table class="list" id="campaign-trail"><thead><tr><th>#</th><th>Test</th><th>Why</th><th>U before</th><th>U after</th><th>Tank min</th></tr></thead><tbody>${rows}</tbody></table>`;
  const stop = $("#campaign-stop");
  if (stop) {
    stop.onclick = async () => {
      state.stopping.add(job.id);
      showCampaign(job);
      if (await campaignCall("POST", `/api/campaigns/${job.id}/stop`)) return;
      state.stopping.delete(job.id); // refused: it is not stopping
      showCampaign(campaignView.job);
    };
  }
}

async function campaignCall(method, path, body) {
  $("#campaign-error").textContent = "";
  try {
    const job = await api(method, path, body);
    showCampaign(newest(job));
    return true;
  } catch (err) {
    $("#campaign-error").textContent = err.message;
    return false;
  }
}

$("#campaign-form").addEventListener("submit", (ev) => {
  ev.preventDefault();
  const f = ev.target;
  const axes = $$("#campaign-axes input:checked").map((i) => i.value);
  campaignCall("POST", "/api/campaigns", {
    target_percent: Number(f.elements.target_percent.value),
    axes,
    max_runs: Number(f.elements.max_runs.value),
    max_minutes: Number(f.elements.max_minutes.value),
  });
});

function onCampaignJobEvent(job) {
  campaignView.streamed[job.id] = job;
  if (!campaignView.job || campaignView.job.id === job.id || !FINAL.includes(job.state)) showCampaign(job);
}

// One box per axis the planner plans: those of the kinds it chooses (GET /api/kinds → planned).
function renderCampaignAxes(kinds) {
  const box = $("#campaign-axes");
  if (box.childElementCount) return; // rendered once: keep what the user ticked
  box.innerHTML = kinds
    .filter((k) => k.planned && k.axis)
    .map((k) => `<label><input name="axis-${esc(k.axis)}" value="${esc(k.axis)}" type="checkbox" checked> ${esc(k.axis)} (${esc(k.kind)}s)</label>`)
    .join("");
}

async function loadCampaign() {
  try {
    renderCampaignAxes(await loadKinds()); // start_forms.js
    const all = await api("GET", "/api/campaigns");
    if (!campaignView.job || !all.some((j) => j.id === campaignView.job.id)) showCampaign(newest(all[0] || null));
  } catch (err) {
    $("#campaign-error").textContent = err.message;
  }
}

$("#queue-marker").onclick = () => queueAction("POST", "/api/queue/stop-marker", {});
onJob((job) => {
  if (job.kind === "campaign") onCampaignJobEvent(job);
});
onPage("queue", loadCampaign);
