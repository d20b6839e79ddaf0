// Queue page and the Rig page's queue summary: the rig's queue (reorder, edit, remove, run
// now, stop after the current job, resume, with the reason it is paused), sequence files to
// start, and the history of past jobs with re-queue. Live from the stream's job events
// (onQueueJobEvent) and a poll of GET /api/queue.
import { api } from "./api.js";
import { $, $$, setHtml } from "./dom.js";
import { fmt, localTime } from "./format.js";
import { formBody, problemField } from "./forms.js";
import { showJob, shownState } from "./jobs.js";
import { esc } from "./markup.js";
import { onPage } from "./pages.js";
import { metadataBody } from "./run_metadata.js";
import { FINAL } from "./state.js";
import { onJob } from "./stream.js";

const HISTORY_LIMIT = 25;
const queueView = { data: null, seen: {}, editing: null, timer: null };

const paramsText = (job) =>
  (job.parameters_labelled || []).map((p) => `<span class="param"><span class="muted">${esc(p.label)}</span> ${esc(p.shown)}</span>`).join(" ");
const queuePageShown = () => !$("#page-queue").hidden;

async function refreshQueue() {
  let q;
  try {
    q = await api("GET", "/api/queue");
  } catch (err) {
    return;
  }
  queueView.data = q;
  showQueueSummary(q);
  if (queuePageShown()) showQueue(q);
}

// ---- the Rig page: queue state and next item in the Current job card ----------------------
function showQueueSummary(q) {
  const next = q.jobs[0];
  const waiting = q.jobs.length ? `${q.jobs.length} waiting · next: <strong>${esc(next.label)}</strong>` : "empty";
  const written = setHtml($("#queue-summary"), `
    <p class="muted"><a href="#queue">Queue</a>: <span id="queue-summary-text">${waiting}</span></p>
    ${q.paused ? `<p class="queue-paused" id="queue-summary-paused"><strong>Queue paused:</strong> ${esc(q.reason || "")}
      <button type="button" id="queue-summary-resume">Resume the queue</button></p>` : ""}`);
  if (!written) return; // the same summary: its elements and their handler stay
  const resume = $("#queue-summary-resume");
  if (resume) resume.onclick = () => queueAction("POST", "/api/queue/resume");
}

// ---- the Queue page -------------------------------------------------------------------------
function showQueue(q) {
  $("#queue-state").innerHTML = q.paused
    ? `<p class="queue-paused" id="queue-paused"><strong>Paused:</strong> <span id="queue-reason">${esc(q.reason || "")}</span></p>`
    : `<p class="muted" id="queue-running-state">${q.jobs.length ? "Running: queued jobs start in order as the rig frees." : "Not paused: a test started now runs at once."}</p>`;
  $("#queue-resume").disabled = !q.paused;
  $("#queue-stop").disabled = q.paused;
  const r = q.running;
  $("#queue-running").innerHTML = r
    ? `<p>On the rig: <strong>${esc(r.label)}</strong> <span class="state ${esc(shownState(r))}">${esc(shownState(r))}</span> <span class="muted">${esc(r.user || "—")} · ${esc(r.progress.message)}</span></p>`
    : `<p class="muted">The rig is free.</p>`;
  $("#queue-empty").hidden = q.jobs.length > 0;
  const list = $("#queue-list");
  const editing = queueView.editing && q.jobs.some((j) => j.id === queueView.editing) ? queueView.editing : null;
  queueView.editing = editing;
  // an item being edited keeps its form; the others are redrawn
  const keep = editing ? list.querySelector(`li[data-job="${editing}"]`) : null;
  list.innerHTML = "";
  for (const [i, job] of q.jobs.entries()) {
    if (keep && job.id === editing) {
      list.append(keep);
      continue;
    }
    const li = document.createElement("li");
    li.dataset.job = job.id;
    li.innerHTML = `<div><strong class="queue-label">${esc(job.label)}</strong> <span class="muted">#${esc(job.position)} · queued by <span class="queue-user">${esc(job.user || "—")}</span></span></div>
      <div class="params">${paramsText(job)}</div>
      <div class="row">
        <button type="button" data-act="up" ${i === 0 ? "disabled" : ""} title="Move up">↑</button>
        <button type="button" data-act="down" ${i === q.jobs.length - 1 ? "disabled" : ""} title="Move down">↓</button>
        ${job.kind === "queue_stop" ? "" : `<button type="button" data-act="edit">Edit</button>`}
        <button type="button" data-act="run-now" title="First in the queue, and the queue resumed">Run now</button>
        <button type="button" data-act="remove">Remove</button>
      </div>`;
    list.append(li);
  }
}

export async function queueAction(method, path, body) {
  $("#queue-error").textContent = "";
  try {
    const q = await api(method, path, body);
    if (q && "jobs" in q) {
      queueView.data = q;
      showQueueSummary(q);
      if (queuePageShown()) showQueue(q);
    } else refreshQueue();
    return q;
  } catch (err) {
    $("#queue-error").textContent = err.message;
    return null;
  }
}

$("#queue-list").addEventListener("click", (ev) => {
  const button = ev.target.closest("button[data-act]");
  const li = ev.target.closest("li[data-job]");
  if (!button || !li) return;
  const id = li.dataset.job;
  const position = queueView.data.jobs.findIndex((j) => j.id === id) + 1;
  const act = button.dataset.act;
  if (act === "up" || act === "down") queueAction("POST", `/api/queue/${id}/move`, { position: position + (act === "up" ? -1 : 1) });
  else if (act === "run-now") queueAction("POST", `/api/queue/${id}/run-now`);
  else if (act === "remove") queueAction("DELETE", `/api/queue/${id}`);
  else if (act === "edit") editQueued(li, queueView.data.jobs.find((j) => j.id === id));
  else if (act === "cancel") {
    queueView.editing = null;
    refreshQueue();
  }
});
$("#queue-resume").onclick = () => queueAction("POST", "/api/queue/resume");
$("#queue-stop").onclick = () => queueAction("POST", "/api/queue/pause");

// Edit a queued job: the Rig page's start form of its kind (same fields, labels and limits),
// filled with its request; a sequence edits its JSON. Saved with PUT /api/queue/{id}.
function editQueued(li, job) {
  if (!job || $(".queue-edit", li)) return;
  queueView.editing = job.id;
  const request = { ...(job.request || {}) };
  const metadata = request.metadata;
  delete request.metadata;
  const source = $(`.start-form[data-run-kind="${job.kind}"]`); // start_forms.js
  let form;
  if (source) {
    form = source.cloneNode(true);
    form.removeAttribute("id");
    form.removeAttribute("data-kind"); // not one of the Rig page's tabs
    form.removeAttribute("data-run-kind");
    form.hidden = false;
    form.noValidate = true; // the API checks it as a new submission and names the field
    $$(".capability-reason", form).forEach((n) => n.remove());
    for (const el of form.elements) {
      if (!el.name || !(el.name in request)) continue;
      const v = request[el.name];
      if (el.type === "checkbox") el.checked = !!v;
      else el.value = Array.isArray(v) ? v.join(", ") : v;
    }
  } else {
    form = document.createElement("form");
    form.className = "start-form";
    form.innerHTML = `<label>Sequence (JSON) <textarea name="json" rows="8"></textarea></label><button type="submit">Save</button><ul class="errors"></ul>`;
    form.elements.json.value = JSON.stringify(request, null, 1);
  }
  form.classList.add("queue-edit");
  const submit = form.querySelector("button[type=submit]");
  submit.disabled = false;
  submit.textContent = "Save parameters";
  submit.insertAdjacentHTML("afterend", ` <button type="button" data-act="cancel">Cancel</button>`);
  form.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const errors = $(".errors", form);
    errors.innerHTML = "";
    let body;
    try {
      body = source ? formBody(form) : JSON.parse(form.elements.json.value);
    } catch (err) {
      errors.innerHTML = `<li>${esc(err.message)}</li>`;
      return;
    }
    if (metadata) body.metadata = metadata;
    try {
      await api("PUT", `/api/queue/${job.id}`, body);
      queueView.editing = null;
      refreshQueue();
    } catch (err) {
      const problems = (err.body && err.body.errors) || [{ message: err.message }];
      errors.innerHTML = problems.map((p) => `<li>${esc(p.message)}</li>`).join("");
      for (const p of problems) {
        const input = form.querySelector(`[name="${problemField(p)}"]`);
        if (input) input.classList.add("invalid");
      }
    }
  });
  $(".params", li).replaceWith(form);
}

// ---- sequences ------------------------------------------------------------------------------
async function loadSequences() {
  let files;
  try {
    files = await api("GET", "/api/sequences");
  } catch (err) {
    $("#sequence-status").textContent = err.message;
    return;
  }
  $("#sequence-list").innerHTML = files.length
    ? files
        .map((s) => {
          const steps = s.steps.map((st) => `<li>${esc(st.kind)}: ${st.parameters_labelled.map((p) => esc(`${p.label} ${p.shown}`)).join("; ")}</li>`).join("");
          const problems = s.problems.map((p) => `<li>${esc(p)}</li>`).join("");
          return `<li data-file="${esc(s.file)}"><strong>${esc(s.name)}</strong> <span class="muted">${esc(s.runs)} run(s), ${esc(fmt(s.rest_s))} s rest</span>
            <button type="button" data-start="${esc(s.file)}" ${s.problems.length ? "disabled" : ""}>Start sequence</button>
            <details><summary class="muted">${s.steps.length} step(s)</summary><ol>${steps}</ol></details>
            ${problems ? `<ul class="errors">${problems}</ul>` : ""}</li>`;
        })
        .join("")
    : `<li class="muted">No sequence files.</li>`;
  queueView.sequences = Object.fromEntries(files.map((s) => [s.file, s]));
}

$("#sequence-list").addEventListener("click", async (ev) => {
  const file = ev.target.dataset && ev.target.dataset.start;
  if (!file) return;
  const body = { ...queueView.sequences[file].content };
  const metadata = metadataBody();
  if (metadata) body.metadata = metadata;
  try {
    const job = await api("POST", "/api/jobs/sequence", body);
    $("#sequence-status").textContent = `${job.label}: ${job.state}${job.position ? ` (position ${job.position})` : ""}`;
    showJob(job);
    refreshQueue();
  } catch (err) {
    $("#sequence-status").textContent = err.message;
  }
});

// ---- history ----------------------------------------------------------------------------------
async function loadHistory() {
  let jobs;
  try {
    jobs = await api("GET", `/api/jobs?limit=${HISTORY_LIMIT}`);
  } catch (err) {
    $("#history-status").textContent = err.message;
    return;
  }
  const past = jobs.filter((j) => FINAL.includes(j.state) && j.request);
  $("#history-status").textContent = past.length ? "" : "No finished tests yet.";
  $("#history-table tbody").innerHTML = past
    .map((j) => `<tr data-job="${esc(j.id)}"><td><strong>${esc(j.label)}</strong></td><td>${paramsText(j)}</td>
      <td>${esc(j.user || "—")}</td>
      <td><span class="state ${esc(j.state)}">${esc(j.state)}</span>${j.error ? ` <span class="muted">${esc(j.error)}</span>` : ""}</td>
      <td>${esc(localTime(j.finished_at))}</td>
      <td>${j.run_ids.map((r) => `<code>${esc(r.slice(0, 8))}</code>`).join(" ") || "—"}</td>
      <td><button type="button" data-requeue="${esc(j.id)}" title="Submit the same request again">Re-queue</button></td></tr>`)
    .join("");
}

$("#history-table").addEventListener("click", async (ev) => {
  const id = ev.target.dataset && ev.target.dataset.requeue;
  if (!id) return;
  try {
    const job = await api("POST", `/api/jobs/${id}/requeue`);
    $("#history-status").textContent = `re-queued: ${job.label} — ${job.state}${job.position ? ` (position ${job.position})` : ""}`;
    refreshQueue();
  } catch (err) {
    $("#history-status").textContent = err.message;
  }
});

// ---- live: a job that changes state redraws the queue (and, ended, the history) --------------
function onQueueJobEvent(job) {
  if (queueView.seen[job.id] === job.state) return; // progress only
  queueView.seen[job.id] = job.state;
  clearTimeout(queueView.timer);
  queueView.timer = setTimeout(() => {
    refreshQueue();
    if (queuePageShown() && FINAL.includes(job.state)) loadHistory();
  }, 150);
}

onJob((job) => {
  if (job.kind !== "estimation" && job.kind !== "campaign") onQueueJobEvent(job);
});
onPage("queue", () => {
  refreshQueue();
  loadSequences();
  loadHistory();
});
refreshQueue();
setInterval(refreshQueue, 2000); // pauses and edits by other clients send no job event
