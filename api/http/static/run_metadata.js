// The Rig page's run metadata block (operator, water temperature and salinity, notes, tags),
// sent as `metadata` with every start (metadataBody); operator and the water are remembered
// in localStorage (many tests in a row).
import { $ } from "./dom.js";

export const metaForm = $("#form-metadata");
const META_REMEMBERED = ["operator", "water_temperature_c", "salinity_g_kg"];
for (const name of META_REMEMBERED) {
  const saved = localStorage.getItem(`rig-meta-${name}`);
  if (saved !== null) metaForm.elements[name].value = saved;
}

export function metadataBody() {
  const f = metaForm.elements;
  const m = {};
  if (f.operator.value.trim()) m.operator = f.operator.value.trim();
  if (f.water_temperature_c.value !== "") m.water_temperature_c = Number(f.water_temperature_c.value);
  if (f.salinity_g_kg.value !== "") m.salinity_g_kg = Number(f.salinity_g_kg.value);
  if (f.notes.value.trim()) m.notes = f.notes.value.trim();
  const tags = f.tags.value.split(",").map((t) => t.trim()).filter(Boolean);
  if (tags.length) m.tags = tags;
  return Object.keys(m).length ? m : undefined;
}

function showMetadataSummary() {
  const m = metadataBody() || {};
  const parts = [m.operator, m.water_temperature_c === undefined ? "" : `${m.water_temperature_c} °C`,
    m.salinity_g_kg === undefined ? "" : `${m.salinity_g_kg} g/kg`, (m.tags || []).join(", ")].filter(Boolean);
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
