// 6-DOF page: pick a vehicle, give per-thruster commands and/or a body force, simulate,
// plot u v w / p q r and the x–y track; the allocation matrix of the vehicle.
import { api } from "./api.js";
import { $, $$, kv } from "./dom.js";
import { fmt, localTime } from "./format.js";
import { esc } from "./markup.js";
import { onPage } from "./pages.js";
import { newPlot } from "./plots.js";

const sixdof = { vehicles: null, detail: null, estimates: [] };
const SIXDOF_FORCE = ["X (N)", "Y (N)", "Z (N)", "K (N·m)", "M (N·m)", "N (N·m)"];
const SIXDOF_PLOT = { responsive: true, displaylogo: false };

async function sixdofLoad() {
  if (sixdof.vehicles === null) {
    try {
      sixdof.vehicles = await api("GET", "/api/vehicles");
    } catch (err) {
      $("#sixdof-status").textContent = err.message;
      return;
    }
    const select = $("#sixdof-vehicle");
    select.innerHTML = sixdof.vehicles
      .map((v) => `<option value="${esc(v.name)}"${v.error ? " disabled" : ""}>${esc(v.name)}${v.error ? " (invalid file)" : ` — ${esc(v.vehicle)}`}</option>`)
      .join("");
    select.addEventListener("change", () => sixdofVehicle(select.value));
    $("#sixdof-form").addEventListener("submit", sixdofRun);
    const broken = sixdof.vehicles.filter((v) => v.error);
    $("#sixdof-file-errors").innerHTML = broken.map((v) => `<li>${esc(v.error)}</li>`).join("");
    if (sixdof.vehicles.length) await sixdofVehicle(select.value);
  }
  sixdofLoadEstimates();
}

async function sixdofLoadEstimates() {
  try {
    const results = await api("GET", "/api/results?kind=estimation");
    $("#sixdof-estimates").innerHTML = results
      .filter((r) => ["surge", "sway", "heave", "roll", "pitch", "yaw"].includes((r.data || {}).dof || (r.data || {}).axis))
      .slice(0, 20)
      .map((r) => `<label><input type="checkbox" value="${esc(r.id)}"> #${esc(r.id)} ${esc(r.subject || r.data.axis)} (${esc(localTime(r.created_at))})</label>`)
      .join("") || '<span class="muted">no stored estimation results</span>';
  } catch (err) {
    $("#sixdof-estimates").textContent = err.message;
  }
}

async function sixdofVehicle(name) {
  let detail;
  try {
    detail = await api("GET", `/api/vehicles/${encodeURIComponent(name)}`);
  } catch (err) {
    $("#sixdof-status").textContent = err.message;
    return;
  }
  if (name !== $("#sixdof-vehicle").value) return; // another vehicle was picked meanwhile
  sixdof.detail = detail;
  const v = sixdof.detail.vehicle;
  $("#sixdof-commands").innerHTML = v.thrusters
    .map((t, i) => `<label>${esc(t.name)} <input name="u${esc(i)}" type="number" step="any" value="0"
       min="${esc(-t.max_command)}" max="${esc(t.max_command)}" title="|u| ≤ ${esc(t.max_command)}"></label>`)
    .join("");
  $("#sixdof-force").innerHTML = SIXDOF_FORCE
    .map((label, i) => `<label>${esc(label)} <input name="f${esc(i)}" type="number" step="any" value="0"></label>`)
    .join("");
  kv($("#sixdof-params"), [
    ["Vehicle", v.name],
    ["Mass", `${fmt(v.mass_kg)} kg (W ${fmt(v.weight_n)} N, B ${fmt(v.buoyancy_n)} N)`],
    ["Body inertia Ixx, Iyy, Izz", `${v.inertia_kg_m2.map((x) => fmt(x)).join(", ")} kg·m²`],
    ["CG / CB", `${v.cg_m.map((x) => fmt(x)).join(", ")} / ${v.cb_m.map((x) => fmt(x)).join(", ")} m`],
    ["Notes", v.notes || ""],
  ]);
  const dofs = sixdof.detail.dofs;
  const c = v.coefficients;
  $("#sixdof-coefs tbody").innerHTML = dofs
    .map((d) => `<tr><td>${esc(d)}</td><td>${esc(fmt(c[`added_mass.${d}`]))}</td><td>${esc(fmt(v.total_inertia[d]))}</td>
      <td>${esc(fmt(c[`linear_damping.${d}`]))}</td><td>${esc(fmt(c[`quadratic_damping.${d}`]))}</td></tr>`)
    .join("");
  const rows = ["X", "Y", "Z", "K", "M", "N"];
  $("#sixdof-alloc thead").innerHTML = `<tr><th></th>${v.thrusters.map((t) => `<th>${esc(t.name)}</th>`).join("")}</tr>`;
  $("#sixdof-alloc tbody").innerHTML = sixdof.detail.allocation_matrix
    .map((row, i) => `<tr><td>${esc(rows[i])}</td>${row.map((x) => `<td>${esc(fmt(x, 4))}</td>`).join("")}</tr>`)
    .join("");
}

function sixdofBody() {
  const form = $("#sixdof-form");
  const v = sixdof.detail.vehicle;
  const commands = v.thrusters.map((_, i) => Number(form.elements[`u${i}`].value || 0));
  const force = SIXDOF_FORCE.map((_, i) => Number(form.elements[`f${i}`].value || 0));
  const body = {
    vehicle: $("#sixdof-vehicle").value,
    duration_s: Number(form.elements.duration_s.value || 30),
    dt: Number(form.elements.dt.value || 0.01),
    estimates: $$("#sixdof-estimates input:checked").map((x) => Number(x.value)),
  };
  if (commands.length) body.commands = commands;
  if (force.some((x) => x !== 0) || !commands.length) body.force = force;
  return body;
}

async function sixdofRun(ev) {
  ev.preventDefault();
  const status = $("#sixdof-status");
  status.textContent = "simulating…";
  let out;
  try {
    out = await api("POST", "/api/sixdof/simulate", sixdofBody());
  } catch (err) {
    status.innerHTML = `<span class="error">${esc(err.message)}</span>`;
    return;
  }
  const s = out.steady;
  status.textContent = `${fmt(out.duration_s)} s simulated (${out.samples} samples)` +
    (out.applied_estimates.length ? `; estimates plugged in: ${out.applied_estimates.map((a) => `#${a.result_id} ${a.axis}`).join(", ")}` : "");
  kv($("#sixdof-steady"), [
    ["Settled", s.settled ? "yes" : `no (largest |dν/dt| ${fmt(s.max_acceleration, 2)})`],
    ["u, v, w (m/s)", ["u", "v", "w"].map((k) => fmt(s.nu[k], 5)).join(", ")],
    ["p, q, r (rad/s)", ["p", "q", "r"].map((k) => fmt(s.nu[k], 5)).join(", ")],
    ["Speed over ground", `${fmt(s.speed_m_s, 5)} m/s`],
    ["Turn radius", s.turn_radius_m === null ? "—" : `${fmt(s.turn_radius_m, 4)} m`],
    ["τ applied", Object.entries(out.tau).filter(([, x]) => Math.abs(x) > 1e-9).map(([k, x]) => `${k} ${fmt(x)}`).join(", ") || "none"],
  ]);
  $("#sixdof-empty").hidden = true;
  const tr = out.trajectory;
  const line = (obj, k) => ({ x: tr.t, y: obj[k], name: k, mode: "lines" });
  const layout = (y) => ({ margin: { t: 20, r: 20, b: 45, l: 60 }, xaxis: { title: { text: "t (s)" } }, yaxis: { title: { text: y } } });
  newPlot("sixdof-linear", ["u", "v", "w"].map((k) => line(tr.nu, k)), layout("u, v, w (m/s)"), SIXDOF_PLOT);
  newPlot("sixdof-angular", ["p", "q", "r"].map((k) => line(tr.nu, k)), layout("p, q, r (rad/s)"), SIXDOF_PLOT);
  newPlot(
    "sixdof-track",
    [{ x: tr.eta.y, y: tr.eta.x, mode: "lines", name: "track" }],
    {
      margin: { t: 20, r: 20, b: 45, l: 60 },
      xaxis: { title: { text: "y east (m)" }, scaleanchor: "y" },
      yaxis: { title: { text: "x north (m)" } },
    },
    SIXDOF_PLOT,
  );
}

onPage("sixdof", sixdofLoad);
