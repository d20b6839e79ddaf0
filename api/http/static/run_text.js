// How the run lists (Runs, Estimation, Cross-check) print a run: its load, where it came
// from, its tags; the markup is escaped here.
import { fmt } from "./format.js";
import { esc } from "./markup.js";
import { servedKinds } from "./start_forms.js";

// What a run list shows of a run: the parameter its kind names (GET /api/kinds → shown, via
// start_forms.js's servedKinds: the drive, or the pendulum's start angle), with its unit.
export function load(run) {
  const kind = servedKinds.find((k) => k.kind === run.kind);
  const shown = kind && kind.shown;
  const value = shown ? (run.parameters || {})[shown.field] : undefined;
  return value === undefined ? "" : `${fmt(value)} ${shown.unit}`;
}

/** A run's tags as escaped chips. */
export const tags = (r) => (r.metadata && r.metadata.tags ? r.metadata.tags.map((t) => `<span class="tag">${esc(t)}</span>`).join(" ") : "");
/** Recorded, or imported with its file's name (escaped markup). */
export const source = (r) => (r.source === "imported" ? `imported <span class="muted">${esc(r.source_file || "")}</span>` : "recorded");
