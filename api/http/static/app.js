// towrig browser UI: plain JavaScript, talks to the same HTTP API as any lab tool.
"use strict";

const $ = (sel, root = document) => root.querySelector(sel);
const $$ = (sel, root = document) => [...root.querySelectorAll(sel)];
const FINAL = ["completed", "aborted", "failed", "interrupted"];
const state = { token: null, rig: null, job: null, runs: [], selectedRun: null, jobDocs: {}, stopping: new Set() };
// Pages defined in their own scripts register a loader here: pageLoaders.name = () => {...}
const pageLoaders = {};

// ---- token: from #token=... (the link `rig serve` prints), else localStorage, else ask ----
// The dialog opens when the API answers 401; it shows an error only for a token that was
// tried (none on a first visit; with `--open-read` reading works without one).
function initToken() {
  const m = location.hash.match(/token=([^&]+)/);
  if (m) {
    localStorage.setItem("rig-token", decodeURIComponent(m[1]));
    history.replaceState(null, "", location.pathname + location.search + "#rig");
  }
  state.token = localStorage.getItem("rig-token");
}

const authHeaders = () => (state.token ? { Authorization: `Bearer ${state.token}` } : {});

function askToken(message = "") {
  const dialog = $("#token-dialog");
  if (message) $("#token-error").textContent = message;
  if (!dialog.hidden) return; // already asking: leave what the user is typing alone
  dialog.hidden = false;
  $("#token-input").focus();
}

// A 401 to a request sent with `used`: ask for a token, saying it was refused only if there
// was one. An answer to a request sent before the token changed says nothing about the new one.
function tokenRefused(used, detail) {
  if (used !== state.token) return;
  askToken(used ? `The token was refused: ${detail || "HTTP 401"}` : "");
}

$("#token-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  state.token = $("#token-input").value.trim();
  $("#token-error").textContent = "";
  localStorage.setItem("rig-token", state.token);
  try {
    await api("GET", "/api/rig");
    $("#token-dialog").hidden = true;
    refreshAll();
  } catch (err) {
    askToken(err.message);
  }
});

// A refusal in a technician's words: an unacknowledged emergency stop names the button that
// acknowledges it, not the API route (the service's text is for API clients).
function refusalText(body) {
  if (body.holder !== "emergency stop") return body.detail;
  const stop = state.rig && state.rig.guard && state.rig.guard.estop;
  const when = stop ? ` (pressed ${localTime(stop.at)})` : "";
  return `The rig will not move: the emergency stop${when} is not acknowledged yet. An operator checks the rig, then presses "Acknowledge emergency stop" on the Rig page.`;
}

class ApiError extends Error {
  constructor(status, body) {
    super(refusalText(body) || `HTTP ${status}`);
    this.status = status;
    this.body = body;
  }
}

async function api(method, path, body, meta) {
  const used = state.token;
  const headers = authHeaders();
  const init = { method, headers };
  if (body !== undefined) {
    headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  const r = await fetch(path, init);
  const isJson = (r.headers.get("content-type") || "").includes("json");
  const data = isJson ? await r.json() : await r.text();
  if (r.status === 401) tokenRefused(used, data.detail);
  if (!r.ok) throw new ApiError(r.status, isJson ? data : { detail: data });
  if (meta) meta.headers = r.headers;
  return data;
}

async function download(path, filename) {
  const r = await fetch(path, { headers: { Authorization: `Bearer ${state.token}` } });
  if (!r.ok) return alert(`Export failed: HTTP ${r.status}`);
  const url = URL.createObjectURL(await r.blob());
  const a = Object.assign(document.createElement("a"), { href: url, download: filename });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 5000);
}

// fmt, localTime (format.js) and esc (markup.js) are shared by every page.
function kv(table, rows) {
  table.innerHTML = rows.map(([k, v]) => `<tr><td>${esc(k)}</td><td>${esc(v)}</td></tr>`).join("");
}
// What a run list shows of a run: the parameter its kind names (GET /api/kinds → shown, via
// start_forms.js's servedKinds: the drive, or the pendulum's start angle), with its unit.
function load(run) {
  const kind = servedKinds.find((k) => k.kind === run.kind);
  const shown = kind && kind.shown;
  const value = shown ? (run.parameters || {})[shown.field] : undefined;
  return value === undefined ? "" : `${fmt(value)} ${shown.unit}`;
}

// ---- pages ----------------------------------------------------------------------------
// Hash words shown on another page: #results/12 is a stored result on the Estimation page
// (results.js registers its loader as pageLoaders.results).
const pageAliases = { results: "estimation" };
function showPage() {
  const word = location.hash.replace("#", "").split(/[&/]/)[0] || "rig";
  const page = pageAliases[word] || word;
  $$(".page").forEach((s) => (s.hidden = s.id !== `page-${page}`));
  $$("nav a").forEach((a) => a.classList.toggle("active", a.dataset.page === page));
  if (word !== page && pageLoaders[word]) pageLoaders[word]();
  if (page === "runs") loadRuns();
  if (page === "estimation") loadEstimationRuns();
  if (page === "rig") Plotly.Plots.resize("live-plot");
  if (pageLoaders[page]) pageLoaders[page]();
}
window.addEventListener("hashchange", () => {
  if (/token=/.test(location.hash)) {
    // the link `rig serve` prints, opened in a tab that shows the page already
    initToken();
    $("#token-dialog").hidden = true;
    $("#token-error").textContent = "";
    return refreshAll();
  }
  showPage();
});

// ---- rig status -------------------------------------------------------------------------
async function refreshRig() {
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
    renderGuard(s.guard || {}); // guard.js: e-stop to acknowledge, who holds the rig
    if (typeof refreshUser === "function") refreshUser(); // people.js: who is signed in
    if (s.current_job) showJob(s.current_job);
    // The job shown left the rig but its ending never reached the page (an event lost
    // while the stream reconnected): ask for it, so it is never left showing "running".
    const shown = state.job;
    if (shown && !FINAL.includes(shown.state) && (!s.current_job || s.current_job.id !== shown.id)) {
      const job = await api("GET", `/api/jobs/${shown.id}`);
      if (state.job === shown) showJob(job);
    }
  } catch (err) {
    $("#conn-dot").className = "dot bad";
    $("#conn-text").textContent = err.status === 401 ? "waiting for the API token" : err.message;
  }
}

// The thrusters' state in words: armed or disarmed, and the controller's state only when it
// says more (a fault, a lost link), never "disarmed (DISARMED)".
function thrustersText(s) {
  const t = s.thrusters;
  if (!t || t.state === "absent") return "none on this rig";
  const armed = s.armed ? "armed" : "disarmed";
  const said = String(t.state || "").toLowerCase().replace(/_/g, " ");
  return !said || said === armed ? armed : `${armed} — controller ${said}`;
}

// Who may move the rig now, the same words the start form uses when it refuses: an
// unacknowledged emergency stop, a hold, the job on the rig, or free.
function whoHoldsTheRig(s) {
  const guard = s.guard || {};
  if (guard.estop) return `stopped: emergency stop at ${localTime(guard.estop.at)}, not acknowledged`;
  if (guard.hold) return `held by ${guard.hold.by || "no token"} since ${localTime(guard.hold.at)}: ${guard.hold.message}`;
  if (s.current_job) return `busy: ${s.current_job.label}`;
  return s.lock_holder ? `busy: ${s.lock_holder}` : "free";
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

// ---- jobs ---------------------------------------------------------------------------------
// A job or campaign asked to stop shows "stopping" at once, until its ending arrives (a
// campaign lets the run on the rig finish, which can take a minute).
function shownState(job) {
  if (FINAL.includes(job.state)) {
    state.stopping.delete(job.id);
    return job.state;
  }
  return state.stopping.has(job.id) ? "stopping" : job.state;
}

function showJob(job) {
  if (!job) return;
  if (job.kind === "estimation") return showEstimationJob(job);
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
  $$("#job-runs a").forEach((a) => (a.onclick = () => openRunSoon(a.dataset.run)));
  if (FINAL.includes(job.state)) setTimeout(refreshRig, 200);
}

function openRunSoon(runId) {
  setTimeout(() => openRun(runId), 100);
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

function formBody(form) {
  const body = {};
  for (const el of form.elements) {
    if (!el.name || el.value === "" || el.type === "submit") continue;
    if (el.type === "checkbox") body[el.name] = el.checked;
    else if (el.dataset.type === "array") body[el.name] = el.value.split(",").map((x) => Number(x.trim()));
    else if (el.type === "number") body[el.name] = Number(el.value);
    else body[el.name] = el.value;
  }
  return body;
}

// ---- run metadata: one block sent as `metadata` with every start --------------------------
// Operator and water temperature are remembered in localStorage (many tests in a row).
const metaForm = $("#form-metadata");
const META_REMEMBERED = ["operator", "water_temperature_c"];
for (const name of META_REMEMBERED) {
  const saved = localStorage.getItem(`rig-meta-${name}`);
  if (saved !== null) metaForm.elements[name].value = saved;
}

function metadataBody() {
  const f = metaForm.elements;
  const m = {};
  if (f.operator.value.trim()) m.operator = f.operator.value.trim();
  if (f.water_temperature_c.value !== "") m.water_temperature_c = Number(f.water_temperature_c.value);
  if (f.notes.value.trim()) m.notes = f.notes.value.trim();
  const tags = f.tags.value.split(",").map((t) => t.trim()).filter(Boolean);
  if (tags.length) m.tags = tags;
  return Object.keys(m).length ? m : undefined;
}

function showMetadataSummary() {
  const m = metadataBody() || {};
  const parts = [m.operator, m.water_temperature_c === undefined ? "" : `${m.water_temperature_c} °C`,
    (m.tags || []).join(", ")].filter(Boolean);
  $("#run-metadata-summary").textContent = parts.length ? `(${parts.join(" · ")})` : "(none)";
}

metaForm.addEventListener("submit", (ev) => ev.preventDefault());
metaForm.addEventListener("input", () => {
  for (const name of META_REMEMBERED) {
    const value = metaForm.elements[name].value.trim();
    if (value) localStorage.setItem(`rig-meta-${name}`, value);
    else localStorage.removeItem(`rig-meta-${name}`);
  }
  showMetadataSummary();
});
showMetadataSummary();

// The field a 422 names: `errors[].field`, else the start of the message (`metadata.notes: …`).
function problemField(p) {
  return p.field || ((p.message || "").match(/^([\w.[\]]+):/) || [])[1] || "";
}

// A start form (start_forms.js renders them): POST /api/jobs/<route>; a 422 marks the fields.
function attachStart(form) {
  form.addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const errors = $(".errors", form);
    const metaErrors = $(".errors", metaForm);
    errors.innerHTML = "";
    metaErrors.innerHTML = "";
    $$("input", form).forEach((i) => i.classList.remove("invalid"));
    $$("input", metaForm).forEach((i) => i.classList.remove("invalid"));
    if (!form.checkValidity()) {
      form.reportValidity();
      return;
    }
    const body = formBody(form);
    const metadata = metadataBody();
    if (metadata) body.metadata = metadata;
    try {
      const job = await api("POST", `/api/jobs/${form.dataset.kind}`, body);
      showJob(job);
      resetLive();
    } catch (err) {
      const problems = (err.body && err.body.errors) || [{ message: err.message, field: "" }];
      for (const p of problems) {
        const field = problemField(p);
        const key = (field.match(/^metadata\.([a-z0-9_]+)/) || [])[1];
        const target = key ? metaForm : form;
        $(".errors", target).insertAdjacentHTML("beforeend", `<li>${esc(p.message)}</li>`);
        const input = $(`[name="${key || field}"]`, target);
        if (input) input.classList.add("invalid");
        if (key) $("#run-metadata").open = true;
      }
      if (err.body && err.body.holder && err.body.holder !== "emergency stop") errors.insertAdjacentHTML("beforeend", `<li>Rig held by ${esc(err.body.holder)}</li>`);
    }
  });
}

// ---- live stream (SSE read with fetch so the token travels in a header) -----------------
// The live plot itself is api/http/static/live.js (onSample, resetLive, initLivePlot).
async function stream() {
  for (;;) {
    try {
      const used = state.token;
      const r = await fetch("/api/stream?max_hz=10", { headers: authHeaders() });
      if (r.status === 401) {
        tokenRefused(used, (await r.json().catch(() => ({}))).detail);
        await new Promise((res) => setTimeout(res, 3000));
        continue;
      }
      const reader = r.body.getReader();
      const decoder = new TextDecoder();
      let buf = "";
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buf += decoder.decode(value, { stream: true });
        let i;
        while ((i = buf.indexOf("\n\n")) >= 0) {
          const block = buf.slice(0, i);
          buf = buf.slice(i + 2);
          let kind = "message";
          let data = "";
          for (const line of block.split("\n")) {
            if (line.startsWith("event: ")) kind = line.slice(7);
            else if (line.startsWith("data: ")) data += line.slice(6);
          }
          if (!data) continue;
          const obj = JSON.parse(data);
          if (kind === "sample") {
            onSample(obj);
            if (typeof onStandSample === "function") onStandSample(obj); // thrusters.js
          }
          else if (kind === "job") {
            if (FINAL.includes(obj.state)) delete state.jobDocs[obj.id];
            else state.jobDocs[obj.id] = obj;
            onJobEvent(obj);
          } else if (kind === "job_progress" && state.jobDocs[obj.id]) {
            // only the progress changed: the stream sends it without the rest of the job
            const job = { ...state.jobDocs[obj.id], state: obj.state, progress: obj.progress };
            state.jobDocs[obj.id] = job;
            onJobEvent(job);
          }
        }
      }
    } catch (err) {
      console.warn("stream", err);
    }
    await new Promise((res) => setTimeout(res, 2000));
  }
}

function onJobEvent(job) {
  if (job.kind === "estimation") return showEstimationJob(job);
  if (job.kind === "campaign") return typeof onCampaignJobEvent === "function" && onCampaignJobEvent(job); // campaign.js
  if (typeof onQueueJobEvent === "function") onQueueJobEvent(job); // queue.js
  // a job queued behind the one on the rig does not take its panel (see /api/queue)
  const onRig = state.job && state.job.id !== job.id && !FINAL.includes(state.job.state);
  if (job.state === "queued" && onRig) return;
  showJob(job);
  if (FINAL.includes(job.state) && !$("#page-runs").hidden) loadRuns();
}

// ---- runs -----------------------------------------------------------------------------------
const RUNS_PAGE = 50;
const TZ = Intl.DateTimeFormat().resolvedOptions().timeZone;
const tags = (r) => (r.metadata && r.metadata.tags ? r.metadata.tags.map((t) => `<span class="tag">${esc(t)}</span>`).join(" ") : "");
const source = (r) => (r.source === "imported" ? `imported <span class="muted">${esc(r.source_file || "")}</span>` : "recorded");
state.runsOffset = 0;

async function loadRuns() {
  const params = new URLSearchParams({ limit: RUNS_PAGE, offset: state.runsOffset, tz: TZ });
  for (const el of $("#runs-filter").elements) {
    if (el.name && el.value) params.set(el.name, el.value);  // days: the API takes them in tz
  }
  const meta = {};
  try {
    [state.runs] = await Promise.all([api("GET", `/api/runs?${params}`, undefined, meta), loadKinds()]);
  } catch (err) {
    $("#runs-count").textContent = err.message;
    return;
  }
  const total = Number(meta.headers.get("X-Total-Count") || 0);
  const first = state.runs.length ? state.runsOffset + 1 : 0;
  $("#runs-count").textContent = `${first}–${state.runsOffset + state.runs.length} of ${total}`;
  $("#runs-prev").disabled = state.runsOffset === 0;
  $("#runs-next").disabled = !meta.headers.get("X-Next-Offset");
  $("#runs-table tbody").innerHTML = state.runs
    .map(
      (r) => `<tr data-run="${esc(r.id)}"><td><code>${esc(r.id.slice(0, 8))}</code></td><td>${esc(r.kind)}</td><td>${esc(r.drive || "—")}</td><td>${esc(load(r))}</td>
      <td><span class="state ${esc(r.status)}">${esc(r.status)}</span>${r.reason ? ` <span class="muted">${esc(r.reason)}</span>` : ""}</td>
      <td>${esc(new Date(r.started_at).toLocaleString())}</td><td>${esc(fmt(r.duration_s, 3))} s</td><td>${esc(r.sample_count)}</td><td>${esc(r.vehicle)}</td>
      <td>${source(r)}</td><td>${tags(r)}</td></tr>`,
    )
    .join("");
  $$("#runs-table tbody tr").forEach((tr) => (tr.onclick = () => openRun(tr.dataset.run)));
}
$("#runs-filter").addEventListener("submit", (ev) => {
  ev.preventDefault();
  state.runsOffset = 0;
  loadRuns();
});
$("#runs-prev").onclick = () => {
  state.runsOffset = Math.max(0, state.runsOffset - RUNS_PAGE);
  loadRuns();
};
$("#runs-next").onclick = () => {
  state.runsOffset += RUNS_PAGE;
  loadRuns();
};

function showRunMeta(run) {
  const m = run.metadata || {};
  const known = ["operator", "water_temperature_c", "notes", "tags"];
  kv($("#run-meta"), [
    ["Kind", run.kind],
    ["Status", run.summary || run.status + (run.reason ? ` (${run.reason})` : "")],
    ["Drive", run.drive || "—"],
    ["Load", load(run)],
    ["Source", run.source === "imported" ? `imported ${new Date(run.imported_at).toLocaleString()} from ${run.source_file}` : "recorded"],
    ...(run.parameters_labelled || []).map((p) => [p.label[0].toUpperCase() + p.label.slice(1), p.shown]),
    ["Recorded at", new Date(run.started_at).toLocaleString()],
    ["Duration", `${fmt(run.duration_s, 4)} s`],
    ["Samples", run.sample_count],
    ["Rig / vehicle", `${run.rig_name} / ${run.vehicle}`],
    ["Operator", m.operator || "—"],
    ["Water", m.water_temperature_c === undefined ? "—" : `${m.water_temperature_c} °C`],
    ["Notes", m.notes || "—"],
    ["Tags", (m.tags || []).join(", ") || "—"],
    ...Object.entries(m).filter(([k]) => !known.includes(k)).map(([k, v]) => [k, String(v)]),
  ]);
  const form = $("#run-annotate");
  for (const name of known) form.elements[name].value = name === "tags" ? (m.tags || []).join(", ") : (m[name] ?? "");
}

$("#run-annotate").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const run = state.selectedRun;
  if (!run) return;
  const f = ev.target.elements;
  const body = {
    operator: f.operator.value.trim() || null,
    water_temperature_c: f.water_temperature_c.value === "" ? null : Number(f.water_temperature_c.value),
    notes: f.notes.value.trim() || null,
    tags: f.tags.value.split(",").map((t) => t.trim()).filter(Boolean),
  };
  if (!body.tags.length) body.tags = null;
  try {
    state.selectedRun = await api("PATCH", `/api/runs/${run.id}/metadata`, body);
    showRunMeta(state.selectedRun);
    $("#run-annotate-status").textContent = "saved";
    loadRuns();
  } catch (err) {
    $("#run-annotate-status").textContent = err.message;
  }
});

// The run detail plots any of the run's channels, with units, one row per unit, against time
// from each run's release or against another channel, with other runs overlaid and named in
// the legend (run_plot.js builds the series). It opens on the first channel its kind's live
// plot shows (GET /api/kinds), against time.
state.runPlot = { runs: [], channels: [], x: TIME_AXIS }; // [{run, samples, release, name}], y channels, x

async function runSeries(runId) {
  const [run, samples, events] = await Promise.all([
    api("GET", `/api/runs/${runId}`),
    api("GET", `/api/runs/${runId}/samples?limit=100000`),
    api("GET", `/api/runs/${runId}/events`),
  ]);
  const released = events.find((e) => e.data && e.data.action === "release" && e.data.t_mono !== undefined);
  return { run, samples, events, release: released ? released.data.t_mono : null, name: runName(run, load(run)) };
}

async function openRun(runId) {
  location.hash = "#runs";
  const [shown, kinds] = await Promise.all([runSeries(runId), loadKinds()]); // start_forms.js
  const { run, events } = shown;
  state.selectedRun = run;
  $("#run-detail").hidden = false;
  loadExportFormats();
  $("#run-detail-id").textContent = run.id;
  $$("#runs-table tbody tr").forEach((tr) => tr.classList.toggle("selected", tr.dataset.run === run.id));
  showRunMeta(run);
  $("#run-annotate-status").textContent = "";
  const names = Object.keys(shown.samples.channels);
  const first = (kinds.find((k) => k.kind === run.kind) || kinds[0]).live[0];
  state.runPlot = { runs: [shown], channels: [names.includes(first) ? first : names[0]].filter(Boolean), x: TIME_AXIS };
  const unitOf = (k) => shownUnit(shown.samples.units[k]);
  $("#run-channels").innerHTML = names
    .map((k) => {
      const on = state.runPlot.channels.includes(k) ? "checked" : "";
      return `<label class="chip"><input type="checkbox" value="${esc(k)}" ${esc(on)}>${esc(channelLabel(k))} <span class="muted">${esc(unitOf(k))}</span></label>`;
    })
    .join("");
  $("#run-x").innerHTML = `<option value="${esc(TIME_AXIS)}">time [s]</option>` + names
    .map((k) => `<option value="${esc(k)}">${esc(withUnit(channelLabel(k), unitOf(k)))}</option>`)
    .join("");
  $("#run-overlay-pick").innerHTML = `<option value="">—</option>` + state.runs
    .filter((r) => r.id !== run.id)
    .map((r) => `<option value="${esc(r.id)}">${esc(runName(r, load(r)))}</option>`)
    .join("");
  drawRunPlot();
  $("#run-events").innerHTML = events
    .map((e) => `<li><span class="tag">${esc(e.kind)}</span>${esc(new Date(e.time).toLocaleTimeString())} — ${esc(e.message)}</li>`)
    .join("");
  if (typeof showRunResults === "function") showRunResults(run.id); // results.js
}

function drawRunPlot() {
  const { runs, channels, x } = state.runPlot;
  const { series, xTitle, mode, missing } = runPlotSeries(runs, channels, x);
  $("#run-overlays").innerHTML = runs
    .slice(1)
    .map((r) => `<span class="tag">${esc(r.name)} <button type="button" data-drop="${esc(r.run.id)}" title="Remove the overlay">×</button></span>`)
    .join("");
  for (const box of $$("#run-channels input")) {
    box.disabled = box.value === x; // the x axis is not also a y
    box.closest("label").title = box.disabled ? "on the X axis" : "";
  }
  $("#run-plot-note").textContent = missing.length ? `Not plotted (no ${channelLabel(x)} channel): ${missing.join(", ")}` : "";
  unitRowsPlot("run-plot", series, { xTitle, mode, empty: "Choose channels above", revision: `${runs[0] && runs[0].run.id}:${x}` });
}

$("#run-channels").addEventListener("change", () => {
  state.runPlot.channels = $$("#run-channels input:checked").map((i) => i.value);
  drawRunPlot();
});
$("#run-x").addEventListener("change", (ev) => {
  state.runPlot.x = ev.target.value;
  drawRunPlot();
});
$("#run-overlay-pick").addEventListener("change", async (ev) => {
  const id = ev.target.value;
  ev.target.value = "";
  if (!id || state.runPlot.runs.some((r) => r.run.id === id)) return;
  state.runPlot.runs.push(await runSeries(id));
  drawRunPlot();
});
$("#run-overlays").addEventListener("click", (ev) => {
  const id = ev.target.dataset && ev.target.dataset.drop;
  if (!id) return;
  state.runPlot.runs = state.runPlot.runs.filter((r) => r.run.id !== id);
  drawRunPlot();
});
// The export menu: the formats of GET /api/export-formats (daq/export_formats.py), once.
let exportFormats = null;
async function loadExportFormats() {
  if (exportFormats) return;
  exportFormats = await api("GET", "/api/export-formats");
  $("#export-format").innerHTML = exportFormats
    .map((f) => `<option value="${esc(f.name)}" title="${esc(f.help)}">${esc(f.label)}</option>`)
    .join("");
}
$("#export-run").onclick = () => {
  const run = state.selectedRun, format = $("#export-format").value;
  const spec = (exportFormats || []).find((f) => f.name === format);
  if (run && spec) download(`/api/runs/${run.id}/export?format=${format}`, `run-${run.id.slice(0, 8)}${spec.suffix}`);
};

// ---- estimation -----------------------------------------------------------------------------
async function loadEstimationRuns() {
  let runs = [];
  const search = $("#est-search").value.trim();
  const query = new URLSearchParams({ status: "completed", limit: 1000 });
  if (search) query.set("search", search);
  try {
    await ensureStartForms(); // the kinds (start_forms.js): those with an estimator are listed
    runs = (await api("GET", `/api/runs?${query}`)).filter((r) => estimatedKinds().includes(r.kind));
  } catch (err) {
    return;
  }
  const checked = new Set($$("#est-runs input:checked").map((i) => i.value));
  $("#est-runs tbody").innerHTML = runs
    .map(
      (r) => `<tr><td><input type="checkbox" value="${esc(r.id)}" data-kind="${esc(r.kind)}" ${checked.has(r.id) ? "checked" : ""}></td>
      <td><code>${esc(r.id.slice(0, 8))}</code></td><td>${esc(r.kind)}</td><td>${esc(r.drive || "—")}</td><td>${esc(load(r))}</td>
      <td>${esc(new Date(r.started_at).toLocaleString())}</td><td>${esc(r.vehicle)}</td><td>${source(r)}</td><td>${tags(r)}</td></tr>`,
    )
    .join("");
}
$("#est-search").addEventListener("change", loadEstimationRuns);

let estimationJobId = null;
$("#est-run").onclick = async () => {
  const runIds = $$("#est-runs input:checked").map((i) => i.value);
  if (!runIds.length) return ($("#est-status").textContent = "Pick at least one run.");
  $("#est-status").textContent = "Starting…";
  try {
    const job = await api("POST", "/api/jobs/estimation", {
      run_ids: runIds,
      method: $("#est-method").value,
      search_effects: $("#est-effects").checked,
    });
    estimationJobId = job.id;
    showEstimationJob(job);
    pollEstimation(job.id);
  } catch (err) {
    $("#est-status").textContent = err.message;
  }
};

async function pollEstimation(jobId) {
  for (;;) {
    const job = await api("GET", `/api/jobs/${jobId}`);
    showEstimationJob(job);
    if (FINAL.includes(job.state)) return;
    await new Promise((res) => setTimeout(res, 500));
  }
}

// The job whose result is drawn: the poll and the event stream both report its completion,
// and a late second report must not redraw it (that would clear what the user started from it,
// e.g. the reverse button's status).
let estimationDrawn = null;

function showEstimationJob(job) {
  if (job.id !== estimationJobId) return;
  $("#est-status").innerHTML = `<span class="state ${esc(job.state)}" id="est-state">${esc(job.state)}</span> ${esc(job.progress.message)}`;
  if (job.state !== "completed" || !job.outcome || estimationDrawn === job.id) return;
  estimationDrawn = job.id;
  renderEstimation(job.outcome);
  if (typeof loadResults === "function") loadResults(); // results.js: the new one is listed
}

// What the record determines well beside the raw coefficients (terminal speed, period,
// damping ratio: docs/estimation.md), as rows under the coefficients, every kind alike.
function wellDeterminedRows(res) {
  return (res.well_determined || [])
    .map((c) => `<tr class="est-known"><td><em>${esc(c.name)}</em>${c.unit ? ` (${esc(c.unit)})` : ""}</td><td>${esc(fmt(c.value, 5))}</td><td>± ${esc(fmt(c.std, 3))}</td></tr>`)
    .join("");
}

// Views of their own for result documents, by the document's `analysis` ({render, clear};
// pendulum.js registers the pendulum swing's); any other result is drawn by renderEstimation.
const resultViews = {};

async function renderEstimation(res) {
  if (typeof renderUncertainty === "function") renderUncertainty(res); // uncertainty.js
  for (const view of Object.values(resultViews)) view.clear();
  const view = resultViews[res.analysis];
  if (view) return view.render(res);
  // the position's unit on the result's axis (a decay's dof), from its estimator's units
  const unit = ((await axisUnits())[res.axis || res.dof] || {}).position || ""; // start_forms.js
  $("#est-result").hidden = false;
  const units = res.units || {}; // an axis result's units; a decay's coefficients carry theirs
  $("#est-coefs tbody").innerHTML = Object.entries(res.coefficients || {})
    .map(([k, c]) => {
      const before = (res.coefficients_before || {})[k];
      return `<tr><td>${esc(k)} (${esc(units[k] || c.unit || "")})</td><td>${esc(fmt(c.value, 5))}</td><td>± ${esc(fmt(c.std, 3))}</td>
        ${before ? `<td class="muted">before effects: ${esc(fmt(before.value, 5))}</td>` : ""}</tr>`;
    })
    .join("") + wellDeterminedRows(res);
  // a decay's equivalent linear damping over the swings it covers (docs/estimation.md)
  const equivalent = res.equivalent_linear_damping || [];
  $("#est-equivalent").hidden = !equivalent.length;
  $("#est-equivalent tbody").innerHTML = equivalent
    .map((e) => `<tr><td>${esc(fmt(e.amplitude, 3))} ${esc(unit)}</td><td>${esc(fmt(e.value, 4))} ${esc(e.unit)}</td><td>± ${esc(fmt(e.std, 2))}</td></tr>`)
    .join("");
  // a tow imported as heave names its dof; a decay names its dof instead of an axis
  const axis = res.axis ? res.dof || res.axis : `${res.dof} ${res.kind}`;
  kv($("#est-rmse"), [
    ["Axis / method", `${axis} / ${res.method || "output-error"}`],
    ["RMSE before", `${fmt(res.rmse_before, 3)} ${unit}`],
    ["RMSE after", `${fmt(res.rmse_after, 3)} ${unit}`],
    ["Runs", (res.runs || []).map((r) => r.slice(0, 8)).join(", ")],
  ]);
  $("#est-effects-list").innerHTML = (res.effects || []).length
    ? res.effects.map((e) => `<li><strong>${esc(e.name)}</strong>: ${esc(fmt(e.value, 4))} ± ${esc(fmt(e.std, 3))} ${esc(e.unit)}</li>`).join("")
    : "<li>none (the base model explains the data)</li>";
  const amb = (res.ambiguous || []).map((g) => g.join(" ≈ "));
  $("#est-ambiguous").innerHTML =
    (amb.length ? `<p class="error">Ambiguous: ${esc(amb.join("; "))}</p>` : "") +
    [...(res.warnings || []), ...(res.advice || [])].map((w) => `<p class="muted">${esc(w)}</p>`).join("");
  showReverseButton(res.reverse_test);
  const perRun = Object.keys(res.rmse_per_run_before || {});
  // the report figures' labels: "run 1 (a1b2c3d4)" in the result's run order
  const runLabels = perRun.map((r) => `run ${(res.runs || []).indexOf(r) + 1} (${r.slice(0, 8)})`);
  Plotly.newPlot(
    "est-fit-plot",
    [
      { x: runLabels, y: perRun.map((r) => res.rmse_per_run_before[r]), type: "bar", name: "RMSE before" },
      { x: runLabels, y: perRun.map((r) => (res.rmse_per_run_after || {})[r]), type: "bar", name: "RMSE after" },
    ],
    { title: { text: "Residual RMSE per run (the fits themselves are in the report figures below)" }, margin: { t: 40, r: 20, b: 60, l: 60 }, yaxis: { title: { text: `residual RMSE (${unit})` } }, barmode: "group" },
    { responsive: true, displaylogo: false },
  );
  await showReportPlots(res.result_id);
}

// The reverse tow/spin the estimator asks for (friction ≈ bias), as a button that starts it
// when the rig can run it: the service runs a rig whose PLC answers, and the rig's
// capabilities (GET /api/rig) offer that kind with that drive. Otherwise: why not.
function reverseBlocker(test) {
  const r = state.rig;
  if (!r || !r.running || !r.connected || r.device_lost) return "the rig is not connected";
  const cap = (r.capabilities || {})[test.kind];
  if (!cap) return `this rig cannot run a ${test.kind}`;
  if (!cap.available) return cap.reason;
  const drive = (cap.drives || {})[test.request.drive];
  if (drive && !drive.available) return drive.reason;
  return null;
}

function showReverseButton(test) {
  const box = $("#est-reverse");
  box.innerHTML = "";
  if (!test) return;
  const blocker = reverseBlocker(test);
  if (blocker) {
    box.innerHTML = `<p class="muted">Reverse ${esc(test.kind)} to record: <code>${esc(test.command)}</code> (not offered here: ${esc(blocker)}).</p>`;
    return;
  }
  box.innerHTML = `<button id="est-reverse-btn" title="POST ${esc(test.route)}">Run the reverse ${esc(test.kind)}</button>
    <code>${esc(test.command)}</code> <span id="est-reverse-status" class="muted"></span>`;
  $("#est-reverse-btn").onclick = async () => {
    const body = { ...test.request };
    const metadata = metadataBody();
    if (metadata) body.metadata = metadata;
    try {
      const job = await api("POST", test.route, body);
      $("#est-reverse-status").textContent = `started: ${job.label}`;
      showJob(job);
    } catch (err) {
      $("#est-reverse-status").textContent = err.message;
    }
  };
}

// The stored result's report figures into #est-plots, full width (fetched with the token):
// click a figure to see it at its natural size; links open the PNG and the SVG on their own.
// Each call draws its result's figures in report order; a later call (the job's update and
// its final result arrive close together) supersedes an earlier one still fetching.
let reportPlotsCall = 0;
async function showReportPlots(resultId) {
  const call = ++reportPlotsCall;
  const box = $("#est-plots");
  box.innerHTML = "";
  if (resultId === undefined || resultId === null) return;
  try {
    const stored = await api("GET", `/api/results/${resultId}`);
    for (const name of stored.report_plots) {
      const png = await reportBlob(resultId, `${name}.png`);
      const svg = png && (await reportBlob(resultId, `${name}.svg`));
      if (call !== reportPlotsCall) return;
      if (!png) continue;
      const fig = document.createElement("figure");
      fig.className = "report-figure";
      fig.innerHTML = `<img alt="report figure ${esc(name)}" title="click to view at full size">
        <figcaption>${esc(name)} — <a class="report-png" target="_blank" rel="noopener">PNG</a>${svg ? ` · <a class="report-svg" target="_blank" rel="noopener">SVG</a>` : ""}</figcaption>`;
      fig.querySelector("img").src = png;
      fig.querySelector("img").addEventListener("click", () => openLightbox(png, name));
      fig.querySelector(".report-png").href = png;
      if (svg) fig.querySelector(".report-svg").href = svg;
      box.append(fig);
    }
  } catch (err) {
    console.warn(err);
  }
}

async function reportBlob(resultId, file) {
  const r = await fetch(`/api/results/${resultId}/report/${file}`, { headers: { Authorization: `Bearer ${state.token}` } });
  return r.ok ? URL.createObjectURL(await r.blob()) : null;
}

// A report figure at its natural size over the page; click or Escape closes it.
function openLightbox(src, name) {
  const box = $("#lightbox");
  box.querySelector("img").src = src;
  box.querySelector("img").alt = `report figure ${name}`;
  box.hidden = false;
}
function closeLightbox() {
  $("#lightbox").hidden = true;
}
$("#lightbox").addEventListener("click", closeLightbox);
document.addEventListener("keydown", (e) => {
  if (e.key === "Escape") closeLightbox();
});

// ---- start ------------------------------------------------------------------------------------
function refreshAll() {
  refreshRig();
  showPage();
}

initToken();
initLivePlot();
// Page scripts load after this one: show the page once they have registered.
window.addEventListener("load", showPage);
refreshRig();
setInterval(refreshRig, 2000);
stream();
