// Stored results on the Estimation page: a list filtered by kind, run, vehicle and day (paged by
// the API), each reopened in the page's result card as a fresh one is drawn (renderEstimation,
// one renderer for every kind), its report downloaded as a zip or its JSON, and two or
// more compared side by side (GET /api/results/compare). The URL hash names the open result
// (#results/12), so a reload shows it again. The run page lists a run's results (showRunResults).
import { api, download } from "./api.js";
import { $, $$ } from "./dom.js";
import { onFreshResult, renderEstimation } from "./estimation.js";
import { fmt, TIME_ZONE } from "./format.js";
import { emptyRow, esc } from "./markup.js";
import { onPage } from "./pages.js";

const RESULTS_PAGE = 20;
const resultsState = { offset: 0, open: null };

const resultLink = (id) => `<a href="#results/${Number(id)}" class="result-link">#${Number(id)}</a>`;

async function loadResults() {
  const params = new URLSearchParams({ limit: RESULTS_PAGE, offset: resultsState.offset, tz: TIME_ZONE });
  for (const el of $("#results-filter").elements) {
    if (el.name && el.value.trim()) params.set(el.name, el.value.trim());
  }
  const meta = {};
  let found;
  try {
    found = await api("GET", `/api/results?${params}`, undefined, meta);
  } catch (err) {
    $("#results-error").textContent = err.message;
    return;
  }
  $("#results-error").textContent = "";
  const total = Number(meta.headers.get("X-Total-Count") || 0);
  const first = found.length ? resultsState.offset + 1 : 0;
  $("#results-count").textContent = `${first}–${resultsState.offset + found.length} of ${total}`;
  $("#results-prev").disabled = resultsState.offset === 0;
  $("#results-next").disabled = !meta.headers.get("X-Next-Offset");
  $("#results-table tbody").innerHTML = found
    .map(
      (r) => `<tr data-result="${Number(r.id)}"${r.id === resultsState.open ? ' class="selected"' : ""}>
      <td><input type="checkbox" value="${Number(r.id)}" aria-label="compare result ${Number(r.id)}"></td>
      <td>${resultLink(r.id)}</td><td>${esc(r.kind)}</td><td>${esc(new Date(r.created_at).toLocaleString())}</td>
      <td>${esc(r.subject)}</td><td>${r.run_ids.map((id) => `<code>${esc(id.slice(0, 8))}</code>`).join(" ")}</td>
      <td><button type="button" class="result-zip">report.zip</button> <button type="button" class="result-json">JSON</button></td></tr>`,
    )
    .join("") ||
    emptyRow(7, [...params.keys()].some((k) => !["limit", "offset", "tz"].includes(k)) ? "no stored result matches these filters" : "no stored result yet: an estimation stores one");
  $$("#results-table tbody tr[data-result]").forEach((tr) => {
    const id = Number(tr.dataset.result);
    tr.querySelector(".result-zip").onclick = () => download(`/api/results/${id}/report.zip`, `result-${id}-report.zip`);
    tr.querySelector(".result-json").onclick = () => download(`/api/results/${id}`, `result-${id}.json`);
  });
}

// Draw stored result `id` in the result card as the job's own result is drawn: the stored
// document is what the job returned (with the id it got as result_id).
async function openStoredResult(id) {
  let stored;
  try {
    stored = await api("GET", `/api/results/${id}`);
  } catch (err) {
    $("#results-error").textContent = err.message;
    return;
  }
  resultsState.open = stored.id;
  $$("#results-table tbody tr").forEach((tr) => tr.classList.toggle("selected", Number(tr.dataset.result) === stored.id));
  $("#est-status").textContent = `Stored result #${stored.id} (${stored.kind}, made ${new Date(stored.created_at).toLocaleString()})`;
  if (stored.kind !== "estimation") {
    $("#est-result").hidden = true;
    $("#est-status").textContent += ": a thrust calibration, shown on the Thrusters page.";
    return;
  }
  await renderEstimation({ ...stored.data, result_id: stored.id }); // estimation.js
}

// Ticked results side by side: per coefficient value ± U (budget U, else 2σ) and each
// result's distance from the first in σ units (|a−b|/√(σa²+σb²), from the API).
async function compareResults() {
  const ids = $$("#results-table tbody input:checked").map((i) => i.value);
  const box = $("#results-comparison");
  if (ids.length < 2) return (box.innerHTML = `<p class="error">Tick two or more results to compare.</p>`);
  let cmp;
  try {
    cmp = await api("GET", `/api/results/compare?ids=${ids.join(",")}`);
  } catch (err) {
    return (box.innerHTML = `<p class="error">${esc(err.message)}</p>`);
  }
  const ref = cmp.reference;
  const heads = cmp.results
    .map((r, i) => `<th>#${Number(r.id)} value ± U</th>${i ? `<th title="|a−b|/√(σa²+σb²)">#${Number(r.id)} − #${Number(ref)} (σ)</th>` : ""}`)
    .join("");
  const cell = (c) => (c ? `${esc(fmt(c.value, 5))} ± ${esc(fmt(c.U, 3))} <span class="muted">(${esc(c.U_from)})</span>` : "—");
  const body = cmp.coefficients
    .map((row) => `<tr data-coefficient="${esc(row.coefficient)}"><td>${esc(row.coefficient)}${row.unit ? ` (${esc(row.unit)})` : ""}</td>${row.cells
      .map((c, i) => `<td>${cell(c)}</td>${i ? `<td class="difference${row.difference_sigma[i] >= 2 ? " error" : ""}">${esc(fmt(row.difference_sigma[i], 3))}</td>` : ""}`)
      .join("")}</tr>`)
    .join("");
  box.innerHTML = `<h3>Comparison</h3><table class="list" id="results-compare-table"><thead><tr><th>Coefficient</th>${heads}</tr></thead><tbody>${body}</tbody></table>
    <p class="muted">U: the budget's expanded uncertainty (95 %) where the result has one, else 2σ. A difference of 2σ or more (red) is beyond the two results' uncertainties.</p>`;
}

// The run page's list of the results made from a run, each opening in the list above.
export async function showRunResults(runId) {
  const list = $("#run-results");
  list.innerHTML = "";
  let found;
  try {
    found = await api("GET", `/api/runs/${encodeURIComponent(runId)}/results`);
  } catch (err) {
    list.innerHTML = `<li class="error">${esc(err.message)}</li>`;
    return;
  }
  list.innerHTML = found.length
    ? found.map((r) => `<li>${resultLink(r.id)} ${esc(r.kind)} — ${esc(r.subject)}, made ${esc(new Date(r.created_at).toLocaleString())}</li>`).join("")
    : `<li class="muted">none yet</li>`;
}

$("#results-filter").addEventListener("submit", (ev) => {
  ev.preventDefault();
  resultsState.offset = 0;
  loadResults();
});
$("#results-prev").onclick = () => {
  resultsState.offset = Math.max(0, resultsState.offset - RESULTS_PAGE);
  loadResults();
};
$("#results-next").onclick = () => {
  resultsState.offset += RESULTS_PAGE;
  loadResults();
};
$("#results-compare").onclick = compareResults;

onFreshResult(() => loadResults()); // a fresh estimation is listed
onPage("estimation", loadResults); // #results/… shows the Estimation page: this runs too
onPage("results", () => {
  const id = Number(location.hash.split("/")[1]);
  if (Number.isInteger(id) && id > 0) openStoredResult(id);
});
