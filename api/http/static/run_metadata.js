// The metadata a person gives a run (operator, the water, notes, tags …), with the inputs
// the start requests' `metadata` object declares (GET /api/kinds → a start request's JSON
// Schema, $defs.RunMetadataIn: the known keys of daq/store/run_metadata.py, each with its
// label, unit, range and help), so a key declared there appears here with nothing written
// twice: the Rig page's block, sent with every start (metadataBody), and the Runs page's
// form that edits a stored run's (runs.js). What a person sets once for many tests (all
// but the notes and tags) is remembered in localStorage.
import { $, $$ } from "./dom.js";
import { fieldHtml, formBody } from "./forms.js";

export const metaForm = $("#form-metadata");
/** What differs from run to run: not remembered for the next test. */
const PER_RUN = new Set(["notes", "tags"]);
/** The known keys' JSON Schema properties, in their declared order (set by renderMetadataForms). */
export let metadataKeys = {};

/** The `metadata` object's properties in a kind's start-request schema. */
function metadataProperties(kind) {
  const defs = kind.schema.$defs || {};
  const ref = ((kind.schema.properties.metadata || {}).anyOf || []).find((p) => p.$ref);
  return ref ? defs[ref.$ref.split("/").pop()].properties : {};
}

/** The inputs of both metadata forms, from the start kinds (GET /api/kinds): once. */
export function renderMetadataForms(kinds) {
  const kind = kinds.find((k) => k.schema && k.schema.properties.metadata);
  if (!kind) return;
  metadataKeys = metadataProperties(kind);
  const inputs = Object.entries(metadataKeys).map(([name, prop]) => fieldHtml(name, prop)).join("\n");
  for (const holder of $$(".metadata-fields")) holder.innerHTML = inputs;
  for (const name of Object.keys(metadataKeys)) {
    const saved = PER_RUN.has(name) ? null : localStorage.getItem(`rig-meta-${name}`);
    if (saved !== null) metaForm.elements[name].value = saved;
  }
  showMetadataSummary();
}

/** Each known key as a metadata form gives it: texts trimmed, numbers as numbers, a list of
 * texts split at commas; null where the form leaves it empty. */
export function metadataGiven(form) {
  const given = formBody(form);
  const out = {};
  for (const name of Object.keys(metadataKeys)) {
    const v = typeof given[name] === "string" ? given[name].trim() : given[name];
    out[name] = v === undefined || v === "" || (Array.isArray(v) && !v.length) ? null : v;
  }
  return out;
}

/** The Rig page's block as the `metadata` of a start request (undefined: nothing given). */
export function metadataBody() {
  const m = Object.fromEntries(Object.entries(metadataGiven(metaForm)).filter(([, v]) => v !== null));
  return Object.keys(m).length ? m : undefined;
}

/** A run's metadata in words: "Grace · 18.5 °C · 35.165 g/kg · fins-v2, repeat" (the known
 * keys in their order, each number with its unit; notes left out). */
export function metadataText(m) {
  return Object.entries(metadataKeys)
    .filter(([name]) => name !== "notes" && m[name] !== undefined && m[name] !== null)
    .map(([name, prop]) => (Array.isArray(m[name]) ? m[name].join(", ") : `${m[name]}${prop.unit ? ` ${prop.unit}` : ""}`))
    .filter(Boolean)
    .join(" · ");
}

function showMetadataSummary() {
  const text = metadataText(metadataBody() || {});
  $("#run-metadata-summary").textContent = text ? `(${text})` : "(none)";
}

metaForm.addEventListener("submit", (ev) => ev.preventDefault());
metaForm.addEventListener("input", () => {
  for (const name of Object.keys(metadataKeys)) {
    if (PER_RUN.has(name)) continue;
    const value = metaForm.elements[name].value.trim();
    if (value) localStorage.setItem(`rig-meta-${name}`, value);
    else localStorage.removeItem(`rig-meta-${name}`);
  }
  showMetadataSummary();
});
