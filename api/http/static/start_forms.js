// The Rig page's start forms and the Estimation page's method menu, rendered from
// GET /api/kinds: one tab and one form per kind the rig runs, one field per property of the
// kind's JSON Schema (its request model: the field's name is the request's key, its title the
// label, its description the tooltip, its default the placeholder); one menu entry per method
// of the kinds' estimators. Rendered by refreshRig (rig.js) once the token is known; a start
// form is sent by start_requests.js. The other pages read the served kinds too (`servedKinds`,
// or await `loadKinds()`):
// the live plot what to show of a kind's runs, the cross-check page which kinds it compares,
// both result pages the units of an axis's estimates (`axisUnits()`).
import { api } from "./api.js";
import { $, $$ } from "./dom.js";
import { fieldHtml } from "./forms.js";
import { esc } from "./markup.js";
import { renderMetadataForms } from "./run_metadata.js";

let startKinds = null;
export let servedKinds = [];
let kindsRequest = null;

// GET /api/kinds once (again after a failure): every kind of the registry, in order.
export function loadKinds() {
  if (!kindsRequest) {
    kindsRequest = api("GET", "/api/kinds").then(
      (kinds) => (servedKinds = kinds),
      (err) => {
        kindsRequest = null;
        throw err;
      },
    );
  }
  return kindsRequest;
}

// Per axis (or a decay's dof), the unit of each quantity an estimate on it reports, from the
// kinds' estimators (GET /api/kinds → units): {surge: {inertia: "kg", position: "m", …}}.
export async function axisUnits() {
  const merged = {};
  for (const kind of await loadKinds()) {
    for (const [axis, units] of Object.entries(kind.units || {})) merged[axis] = { ...merged[axis], ...units };
  }
  return merged;
}

// The kinds whose runs the Estimation page offers (those with an estimator).
export function estimatedKinds() {
  return servedKinds.filter((k) => k.estimator).map((k) => k.kind);
}

export async function ensureStartForms() {
  if (startKinds) return;
  const kinds = await loadKinds();
  if (startKinds) return; // a concurrent refresh rendered them meanwhile
  startKinds = kinds.filter((k) => k.route && k.schema);
  renderStartForms(startKinds);
  renderMetadataForms(startKinds);
  renderMethodOptions(kinds);
  renderKindFilter(kinds);
}

// The Runs page's kind filter: "any", then every kind of the registry.
function renderKindFilter(kinds) {
  const select = document.querySelector("#runs-filter select[name=kind]");
  if (!select) return;
  const chosen = select.value;
  select.innerHTML = `<option value="">any</option>` + kinds.map((k) => `<option>${esc(k.kind)}</option>`).join("");
  select.value = chosen;
}

// The Estimation page's method menu: every method some kind's estimator takes, once, in the
// order served (each estimator's default first), worded by the estimator's method_labels.
function renderMethodOptions(kinds) {
  const select = document.getElementById("est-method");
  if (!select) return;
  const labels = new Map();
  for (const k of kinds) {
    for (const m of k.methods) if (!labels.has(m)) labels.set(m, (k.method_labels || {})[m] || m);
  }
  select.innerHTML = [...labels]
    .map(([m, label]) => `<option value="${esc(m)}">${esc(label)}</option>`)
    .join("");
}

function renderStartForms(kinds) {
  const title = (k) => k.label.charAt(0).toUpperCase() + k.label.slice(1);
  $("#start-tabs").innerHTML = kinds
    .map((k, i) => `<button data-form="${esc(k.route)}"${i ? "" : ' class="active"'}>${esc(title(k))}</button>`)
    .join("");
  $("#start-forms").innerHTML = kinds
    .map((k, i) => {
      const fields = Object.entries(k.schema.properties)
        .filter(([name]) => name !== "metadata") // the Run metadata block below sends it
        .map(([name, prop]) => fieldHtml(name, prop))
        .join("\n");
      return `<form id="form-${esc(k.route)}" class="start-form" data-kind="${esc(k.route)}" data-run-kind="${esc(k.kind)}"${i ? " hidden" : ""}>
        ${fields}
        <button type="submit" id="start-${esc(k.route)}">Start ${esc(k.label)}</button>
        <ul class="errors"></ul></form>`;
    })
    .join("");
  $$("#start-tabs button").forEach((b) => {
    b.onclick = () => {
      $$("#start-tabs button").forEach((x) => x.classList.toggle("active", x === b));
      $$(".start-form[data-kind]").forEach((f) => (f.hidden = f.dataset.kind !== b.dataset.form));
    };
  });
}
