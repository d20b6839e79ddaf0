// The Rig page's job panel: the job on the rig (or the last one) with its progress, the
// operator's act to confirm, pause and resume, its runs (a link opens the run: runs.js) and
// its ending; the abort button (and the one an estimation or cross-check shows beside its
// progress: abortButton). A job asked to stop shows "stopping" until its ending arrives.
import { api } from "./api.js";
import { $ } from "./dom.js";
import { localTime } from "./format.js";
import { esc } from "./markup.js";
import { onRigStatus, refreshRig } from "./rig.js";
import { FINAL, state } from "./state.js";
import { jobEvent, onJob } from "./stream.js";

// A job or campaign asked to stop shows "stopping" at once, until its ending arrives (a
// campaign lets the run on the rig finish, which can take a minute).
export function shownState(job) {
  if (FINAL.includes(job.state)) {
    state.stopping.delete(job.id);
    return job.state;
  }
  return state.stopping.has(job.id) ? "stopping" : job.state;
}

export function showJob(job) {
  if (!job) return;
  if (job.kind === "estimation") return jobEvent(job); // the Estimation page shows it
  // a job never leaves a final state: a report of it still running that arrives after its
  // end (a status poll answered before the end, read after the stream's final event) is stale
  const ended = state.job && state.job.id === job.id && FINAL.includes(state.job.state);
  if (ended && !FINAL.includes(job.state)) return;
  state.job = job;
  const pct = Math.round(100 * (job.progress.fraction || 0));
  const act = job.operator_act;
  const runs = job.run_ids.map((r) => `<a href="#runs" data-run="${esc(r)}">${esc(r.slice(0, 8))}</a>`).join(", ");
  $("#job-panel").innerHTML = `
    <p><strong>${esc(job.label)}</strong> <span class="state ${esc(shownState(job))}" id="job-state">${esc(shownState(job))}</span>
      <span class="muted" id="job-user">started by ${esc(job.user || "—")}${job.started_at ? ` at ${esc(localTime(job.started_at))}` : ""}</span></p>
    <div class="progress"><div style="width:${esc(pct)}%"></div></div>
    <p id="job-message">${esc(job.progress.message)}</p>
    ${act ? `<div class="operator" id="operator-act"><strong>Operator:</strong> ${act.reverse ? `<span class="tag">reverse rigging</span>` : ""}${esc(act.instruction)}
        <button id="confirm-btn">Done — continue</button></div>` : ""}
    ${job.kind === "sequence" && !FINAL.includes(job.state)
      ? `<button id="pause-btn">Pause</button> <button id="resume-btn">Resume</button>` : ""}
    <p class="muted">Runs: <span id="job-runs">${runs || "—"}</span></p>
    ${job.error ? `<p class="error">${esc(job.error)}</p>` : ""}`;
  const bind = (id, action) => {
    const b = $(id);
    if (b) b.onclick = () => api("POST", `/api/jobs/${job.id}/${action}`).then(showJob).catch((e) => alert(e.message));
  };
  bind("#confirm-btn", "confirm");
  bind("#pause-btn", "pause");
  bind("#resume-btn", "resume");
  if (FINAL.includes(job.state)) setTimeout(refreshRig, 200);
}

$("#abort-btn").onclick = async () => {
  const job = (state.rig && state.rig.current_job) || state.job;
  if (!job || FINAL.includes(job.state)) return alert("No test is running.");
  state.stopping.add(job.id);
  if (state.job && state.job.id === job.id) showJob(state.job);
  try {
    showJob(await api("POST", `/api/jobs/${job.id}/abort`));
  } catch (err) {
    state.stopping.delete(job.id);
    alert(err.message);
  }
};

// The Abort control of an estimation or cross-check job shown on its page (the header's, same
// look), while it is queued or running and not yet asked to stop.
export function abortButton(job) {
  if (FINAL.includes(job.state) || state.stopping.has(job.id)) return "";
  return ` <button class="danger" data-abort-job="${esc(job.id)}" title="Abort this ${esc(job.kind)}: a queued one never runs, a running fit is stopped and nothing of it is stored">Abort</button>`;
}

document.addEventListener("click", async (event) => {
  const button = event.target.closest("button[data-abort-job]");
  if (!button) return;
  const id = button.dataset.abortJob;
  state.stopping.add(id); // shownState: "stopping" until the poll reads its ending
  button.disabled = true;
  try {
    await api("POST", `/api/jobs/${id}/abort`);
  } catch (err) {
    state.stopping.delete(id);
    button.disabled = false;
    alert(err.message);
  }
});

// A job update from the stream takes the panel, unless it is queued behind the one on the rig
// (see /api/queue); estimations and campaigns have their own pages.
onJob((job) => {
  if (job.kind === "estimation" || job.kind === "campaign") return;
  const onRig = state.job && state.job.id !== job.id && !FINAL.includes(state.job.state);
  if (job.state === "queued" && onRig) return;
  showJob(job);
});

// Each rig status: the job on the rig takes the panel; the job shown left the rig but its
// ending never reached the page (an event lost while the stream reconnected): ask for it, so
// it is never left showing "running".
onRigStatus(async (s) => {
  if (s.current_job) showJob(s.current_job);
  const shown = state.job;
  if (shown && !FINAL.includes(shown.state) && (!s.current_job || s.current_job.id !== shown.id)) {
    const job = await api("GET", `/api/jobs/${shown.id}`);
    if (state.job === shown) showJob(job);
  }
});
