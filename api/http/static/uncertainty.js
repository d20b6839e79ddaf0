// Estimation page: the uncertainty budget of each coefficient (ITTC 7.5-02-01-01 / GUM, 95 %)
// and the repeat-run analysis of every kind's result (docs/uncertainty.md), under the
// coefficients: a summary row per quantity (value ± U, k, ν_eff, u_c, dominant source), then each
// quantity's sources (folded when there are more than three). From the result's `budget` and `repeats`.
import { $ } from "./dom.js";
import { fmt } from "./format.js";
import { esc } from "./markup.js";

export function renderUncertainty(res) {
  const box = $("#est-uncertainty");
  if (!box) return;
  const budget = res.budget;
  if (!budget) {
    // every method's result has one (a seed method's too); a document stored before it had none
    box.innerHTML = repeatsMarkup(res.repeats); // what was compared and left out, with or without a budget
    return;
  }
  const notes = (budget.notes || []).map((n) => `<p class="${n.startsWith("Type B not declared") ? "error" : "muted"}">${esc(n)}</p>`).join("");
  // the coefficients, then the combinations the record determines well (a decay's T₀, ζ)
  const budgeted = { ...(budget.coefficients || {}), ...(budget.combinations || {}) };
  // ν_eff ≥ 10⁴ is ∞ to k's four digits (estimation/uncertainty/text.py says the same)
  // without U (a quantity not identified) there is no k or ν_eff either: "—", as the CLI prints
  const dofOf = (c) =>
    c.expanded_uncertainty == null ? "—" : c.effective_dof === null || c.effective_dof >= 1e4 ? "∞" : fmt(c.effective_dof, 3);
  const kOf = (c) => (c.expanded_uncertainty == null ? "—" : fmt(c.coverage_factor, 4));
  const entries = Object.entries(budgeted);
  // a quantity as the result names it (a decay given the body's own inertia: its added inertia)
  const label = (name) => (res.labels || {})[name] || name;
  // one summary row per quantity, read first; each quantity's sources in its own table below
  // (folded when there are many: a decay's T₀ and ζ at every amplitude)
  const summary = `<table class="list est-budget-summary"><thead><tr><th>Quantity</th><th>Value ± U (95 %)</th><th>k</th><th>ν_eff</th><th>u_c</th><th>Dominant source</th></tr></thead><tbody>${entries
    .map(([name, c]) => `<tr data-quantity="${esc(name)}"><td>${esc(label(name))}</td><td><strong>${esc(c.reported)}</strong></td><td>${esc(kOf(c))}</td><td>${esc(dofOf(c))}</td><td>${esc(fmt(c.combined_standard_uncertainty, 3))}</td><td>${esc(c.dominant_source)}</td></tr>`)
    .join("")}</tbody></table>`;
  const tables = entries.map(([name, c]) => {
    const rows = (c.rows || []).map((r) => `<tr${r.combined ? "" : ' class="muted"'}>
        <td>${esc(r.source)}</td><td>${esc(r.type)}</td>
        <td>${esc(fmt(r.standard_uncertainty, 3))} ${esc(r.unit)}</td><td>${esc(fmt(r.sensitivity, 3))}</td>
        <td>${esc(fmt(r.contribution, 3))}</td>
        <td>${r.combined ? `${(100 * (r.share || 0)).toFixed(1)} %` : "not combined"}</td>
        <td class="muted">${esc(r.note || "")}</td></tr>`).join("");
    return `<h4 class="est-budget-head"><strong>${esc(label(name))} = ${esc(c.reported)}</strong>
        <span class="muted">(95 %, k = ${esc(kOf(c))}, ν_eff = ${esc(dofOf(c))}, u_c = ${esc(fmt(c.combined_standard_uncertainty, 3))}; dominant: ${esc(c.dominant_source)})</span></h4>
      <table class="list est-budget" data-coefficient="${esc(name)}"><thead><tr><th>Source</th><th>Type</th><th>u</th><th>Sensitivity c</th><th>Contribution c·u</th><th>Share</th><th>Note</th></tr></thead>
      <tbody>${rows}</tbody></table>`;
  }).join("");
  const folded = entries.length > 3;
  const details = `<details class="est-budget-details"${folded ? "" : " open"}><summary>Sources of each quantity's uncertainty (${entries.length} budgets)</summary>${tables}</details>`;
  const rep = repeatsMarkup(res.repeats);
  box.innerHTML = `<h3>Uncertainty (ITTC / GUM, 95 %)</h3>${notes}${summary}${details}${rep}`;
}

// A run as the page names it elsewhere (the Runs row): its id's first 8 characters.
const shortId = (id) => `<code title="${esc(id)}">${esc(String(id).slice(0, 8))}</code>`;
// A value with its unit; none for a dimensionless "1" (a decay's logarithmic decrement).
const withUnit = (text, unit) => (unit && unit !== "1" && text !== "—" ? `${text} ${unit}` : text);

/** The repeats document (every kind's shape, docs/uncertainty.md) as the page draws it: per
 * condition N, each repeat's value (an outlier in bold, marked left out of the fit or kept),
 * their mean ± t·s/√N with the unit, then which were left out; "" without a repeated
 * condition. */
export function repeatsMarkup(repeats) {
  if (!repeats || !(repeats.conditions || []).some((c) => c.n > 1)) return "";
  const excluded = new Set(repeats.excluded || []);
  const fate = (r) => (excluded.has(r) ? "left out of the fit" : "kept in the fit");
  const each = (c) =>
    c.runs
      .map((r, i) =>
        (c.outliers || []).includes(r)
          ? `<strong class="${excluded.has(r) ? "est-left-out" : "est-kept-outlier"}">${shortId(r)} ${esc(fmt(c.values[i], 4))} (outlier, ${esc(fate(r))})</strong>`
          : `${shortId(r)} ${esc(fmt(c.values[i], 4))}`,
      )
      .join(", ");
  const rows = repeats.conditions
    .map(
      (c) => `<tr${(c.outliers || []).length ? ' class="est-outlier"' : ""}><td>${esc(c.condition)}</td><td>${esc(c.n)}</td>
        <td>${each(c)}</td><td>${esc(withUnit(fmt(c.mean, 5), c.unit))}</td><td>${esc(withUnit(fmt(c.repeatability_95, 3), c.unit))}</td></tr>`,
    )
    .join("");
  const quantity = repeats.quantity || "terminal speed"; // documents before it was named
  const left = [...excluded];
  const outliers = repeats.outliers || [];
  const note = left.length
    ? `<p id="est-left-out">Left out of the fit at the user's request: ${left.map((r) => shortId(r)).join(", ")} (the mean and t·s/√N are of all N repeats).</p>`
    : outliers.length
      ? `<p class="muted" id="est-left-out">Flagged but kept in the fit: ${outliers.map((r) => shortId(r)).join(", ")}; tick “leave out flagged repeats” to fit without them.</p>`
      : "";
  return `<h4>Repeat runs <span class="muted">(${esc(repeats.outlier_test)})</span></h4>
    <table class="list" id="est-repeats"><thead><tr><th>Condition</th><th>N</th><th>${esc(quantity)}, each repeat</th><th>Mean</th><th>± t·s/√N</th></tr></thead><tbody>${rows}</tbody></table>${note}`;
}
