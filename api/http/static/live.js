// Rig page live plot: any channel the rig file defines (with its unit), the rates derived
// from the axes' positions, and the thruster commands; one row per unit, 1-2-5 ticks. The
// channels shown by default depend on the running job's kind (its registry entry's `live`
// and `rate`, GET /api/kinds via start_forms.js's `servedKinds`); the user's choice is kept
// per kind in localStorage. Fed by the stream's samples (stream.js); a started test calls
// resetLive(); it reads the page's `state` (rig status, current job).
import { $, $$, everyFrame } from "./dom.js";
import { esc } from "./markup.js";
import { onPage } from "./pages.js";
import { unitRowsPlot, withPlotly } from "./plots.js";
import { channelLabel } from "./run_plot.js";
import { servedKinds } from "./start_forms.js";
import { FINAL, state } from "./state.js";
import { onSample } from "./stream.js";

const LIVE_POINTS = 600; // one minute at 10 Hz
const LIVE_STORE = "rig-live-channels"; // {kind: [channel keys]}
const LIVE_KIND_STORE = "rig-live-kind"; // the kind whose choice was shown last
// What matters for each kind of test (keys that the rig lacks are dropped): its served
// `live`; a sequence's, those of every kind a weight or the thrusters drive; a kind not
// served, the first kind's. `null`: the kinds are not served yet.
export function liveDefaultsOf(kind) {
  if (!servedKinds.length) return null;
  const served = servedKinds.find((k) => k.kind === kind);
  if (served) return served.live;
  if (kind === "sequence") return servedKinds.filter((k) => k.drives.length).flatMap((k) => k.live);
  return servedKinds[0].live;
}
const liveKnows = (kind) => kind === "sequence" || servedKinds.some((k) => k.kind === kind);
// The rates derived from the axes' positions: [{key, label, unit, of}], each once.
const liveRates = () => servedKinds.map((k) => k.rate).filter((r, i, all) => r && all.findIndex((o) => o && o.key === r.key) === i);
const live = {
  channels: [], // [{key, label, unit}] in chooser order
  signature: "",
  kind: null, // the kind whose choice is shown
  jobId: null,
  selected: [],
  buffer: [], // [{t, v: {key: value}}], newest last
  t0: null,
  last: null, // previous sample (derivatives)
  count: 0,
};

// ---- channels ----------------------------------------------------------------------------
function liveChannelList() {
  const units = (state.rig && state.rig.units) || {};
  const names = Object.keys(units);
  if (!names.length) return [];
  const list = names.map((k) => ({ key: k, label: channelLabel(k), unit: units[k] }));
  for (const r of liveRates()) if (r.of in units) list.push({ key: r.key, label: r.label, unit: r.unit });
  const n = ((state.rig && state.rig.thrusters && state.rig.thrusters.output) || []).length;
  for (let i = 0; i < n; i += 1) list.push({ key: `thruster_${i + 1}`, label: `thruster ${i + 1} command`, unit: "fraction" });
  return list;
}

function liveDefaults(kind) {
  const keys = new Set(live.channels.map((c) => c.key));
  const wanted = (liveDefaultsOf(kind) || []).flatMap((k) =>
    k === "thrusters" ? live.channels.filter((c) => c.key.startsWith("thruster_")).map((c) => c.key) : [k],
  );
  return wanted.filter((k) => keys.has(k));
}

function liveSaved() {
  try {
    return JSON.parse(localStorage.getItem(LIVE_STORE) || "{}") || {};
  } catch (err) {
    return {};
  }
}

// Show the choice for `kind`: the user's saved one, else that kind's defaults.
function liveUseKind(kind) {
  live.kind = kind;
  localStorage.setItem(LIVE_KIND_STORE, kind);
  const keys = new Set(live.channels.map((c) => c.key));
  const saved = liveSaved()[kind];
  live.selected = Array.isArray(saved) ? saved.filter((k) => keys.has(k)) : liveDefaults(kind);
  liveRenderChooser();
  liveDrawSoon();
}

function liveRenderChooser() {
  const box = $("#live-channels");
  box.innerHTML = live.channels
    .map(
      (c) => `<label class="chip"><input type="checkbox" value="${esc(c.key)}" ${live.selected.includes(c.key) ? "checked" : ""}>
        ${esc(c.label)}${c.unit ? ` <span class="muted">${esc(c.unit)}</span>` : ""}</label>`,
    )
    .join("");
  $$("input", box).forEach((i) => (i.onchange = liveChosen));
  const name = (live.kind || "").replace(/_/g, " ");
  $("#live-kind").textContent = name;
}

function liveChosen() {
  live.selected = $$("#live-channels input:checked").map((i) => i.value);
  const saved = liveSaved();
  saved[live.kind] = live.selected;
  localStorage.setItem(LIVE_STORE, JSON.stringify(saved));
  liveDraw();
}

// Channel list (from the rig status) and the running job's kind, checked on every sample.
function liveSync() {
  if (!servedKinds.length) return; // the kinds' defaults are not known yet
  const channels = liveChannelList();
  const signature = channels.map((c) => `${c.key}:${c.unit}`).join(",");
  let kind = live.kind;
  const job = state.job;
  if (job && job.id !== live.jobId && !FINAL.includes(job.state)) {
    live.jobId = job.id; // a job started: show what matters for its kind
    if (liveKnows(job.kind)) kind = job.kind;
  }
  if (!kind) kind = localStorage.getItem(LIVE_KIND_STORE) || servedKinds[0].kind;
  if (signature !== live.signature) {
    live.signature = signature;
    live.channels = channels;
    if (channels.length) return liveUseKind(kind);
  }
  if (kind !== live.kind && channels.length) liveUseKind(kind);
}

// ---- samples -------------------------------------------------------------------------------
function liveSample(s) {
  live.count += 1;
  if (live.t0 === null) live.t0 = s.t_mono;
  const v = { ...s.channels };
  (s.thrusters || []).forEach((u, i) => (v[`thruster_${i + 1}`] = u));
  const prev = live.last;
  const dt = prev ? s.t_mono - prev.t_mono : 0;
  const rate = (k) => (dt > 0 && v[k] != null && prev.channels[k] != null ? (v[k] - prev.channels[k]) / dt : null);
  for (const r of liveRates()) v[r.key] = rate(r.of);
  live.last = s;
  live.buffer.push({ t: s.t_mono - live.t0, v });
  if (live.buffer.length > LIVE_POINTS) live.buffer.splice(0, live.buffer.length - LIVE_POINTS);
  liveTick();
}

// The count, the channel list and the job's kind once a frame (at most at the stream's 10 Hz),
// however many samples arrived since.
const liveTick = everyFrame(() => {
  $("#live-count").textContent = String(live.count);
  liveSync();
  liveRequestDraw();
});

// Redraw at most every LIVE_REDRAW_MS while a job runs, every LIVE_IDLE_REDRAW_MS while the
// rig is idle (only its noise moves), and never more than half the time: a redraw costs
// Plotly tens of ms (hundreds on a loaded machine), samples arrive every 100 ms. An open Rig
// page kept a headless Chromium at 0.16-0.3 core redrawing an idle rig four times a second.
// Nothing is drawn while the Rig page is hidden, the first plot included: a page opened and
// left for another before the first redraw never loads Plotly (plots.js withPlotly).
const LIVE_REDRAW_MS = 250;
const LIVE_IDLE_REDRAW_MS = 1000;
let liveTimer = null;
let liveDrawMs = 0;
const liveRunning = () => Boolean(state.job && !FINAL.includes(state.job.state));
function liveRequestDraw() {
  if (liveTimer !== null) return;
  const every = liveRunning() ? LIVE_REDRAW_MS : LIVE_IDLE_REDRAW_MS;
  liveTimer = setTimeout(() => {
    liveTimer = null;
    if ($("#page-rig").hidden) return;
    const t = performance.now();
    liveDraw();
    liveDrawMs = performance.now() - t;
  }, Math.max(every, liveDrawMs));
}

// A change the user sees at once on a plot already drawn; else the next redraw draws it.
let liveDrawn = false;
function liveDrawSoon() {
  if (liveDrawn && !$("#page-rig").hidden) liveDraw();
  else liveRequestDraw();
}

export function resetLive() {
  live.last = null;
}

// ---- plot ------------------------------------------------------------------------------------
function liveDraw() {
  const chosen = live.channels.filter((c) => live.selected.includes(c.key));
  const t = live.buffer.map((p) => p.t);
  const series = chosen.map((c) => ({
    x: t,
    y: live.buffer.map((p) => (p.v[c.key] === undefined ? null : p.v[c.key])),
    name: c.unit ? `${c.label} [${c.unit}]` : c.label,
    label: c.label.replace(/ \(from .*\)$/, ""),
    unit: c.unit,
    key: c.key,
  }));
  const empty = live.channels.length ? "Choose channels above" : "Waiting for the rig's channels…";
  liveDrawn = true;
  unitRowsPlot("live-plot", series, { xTitle: "time [s]", empty, revision: "live" });
}

export function initLivePlot() {
  $("#live-defaults").onclick = () => {
    const saved = liveSaved();
    delete saved[live.kind];
    localStorage.setItem(LIVE_STORE, JSON.stringify(saved));
    if (live.kind) liveUseKind(live.kind);
  };
  liveRequestDraw();
}

onSample(liveSample);
onPage("rig", () => (liveDrawn ? withPlotly((Plotly) => Plotly.Plots.resize("live-plot")) : liveRequestDraw()));
