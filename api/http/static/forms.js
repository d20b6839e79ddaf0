// A request model's field as a form's input (from its JSON Schema), a form as the API's
// request body, and the field a 422 names; no DOM of its own (works on any object with
// `elements`), unit-tested with node --test.
import { esc } from "./markup.js";

/** A form's filled inputs as a request body: checkboxes as booleans, numbers as numbers, an
 * input with data-type="array" as numbers split at commas, one with data-type="texts" as
 * the texts between commas; empty inputs left out. */
export function formBody(form) {
  const body = {};
  for (const el of form.elements) {
    if (!el.name || el.value === "" || el.type === "submit") continue;
    if (el.type === "checkbox") body[el.name] = el.checked;
    else if (el.dataset.type === "array") body[el.name] = el.value.split(",").map((x) => Number(x.trim()));
    else if (el.dataset.type === "texts") body[el.name] = el.value.split(",").map((x) => x.trim()).filter(Boolean);
    else if (el.type === "number") body[el.name] = Number(el.value);
    else body[el.name] = el.value;
  }
  return body;
}

// The field a 422 names: `errors[].field`, else the start of the message (`metadata.notes: …`).
export function problemField(p) {
  return p.field || ((p.message || "").match(/^([\w.[\]]+):/) || [])[1] || "";
}

/** {type, enum, minimum, …} of a property, looking through `anyOf: [{…}, {type: "null"}]`. */
export function propertyType(prop) {
  const options = (prop.anyOf || [prop]).filter((p) => p.type !== "null");
  return options[0] || {};
}

/** One property of a request model's JSON Schema as a labelled input: its name is the
 * request's key, its title the label, its description (and its range, when it has one) the
 * tooltip, its default the placeholder; a text is a text input of its maximum length, a
 * list a comma-separated one (numbers: data-type="array", texts: data-type="texts"; its
 * placeholder says so when it has no default). */
export function fieldHtml(name, prop) {
  const t = propertyType(prop);
  const label = esc(prop.title || name);
  const range = t.minimum !== undefined && t.maximum !== undefined ? ` (${t.minimum} to ${t.maximum}${prop.unit ? ` ${prop.unit}` : ""})` : "";
  const said = (prop.description || "") + range;
  const tip = said ? ` title="${esc(said)}"` : "";
  const dflt = prop.default;
  if (t.type === "boolean") {
    return `<label${tip}><input name="${esc(name)}" type="checkbox"${dflt ? " checked" : ""}> ${label}</label>`;
  }
  if (t.enum) {
    const options = t.enum.map((v) => `<option${v === dflt ? " selected" : ""}>${esc(v)}</option>`).join("");
    return `<label${tip}>${label} <select name="${esc(name)}">${options}</select></label>`;
  }
  const shown = Array.isArray(dflt) ? dflt.join(", ") : dflt;
  const hint = shown === undefined || shown === null ? "" : ` placeholder="${esc(String(shown))}"`;
  if (t.type === "array") {
    const texts = (t.items || {}).type === "string";
    const listed = hint || ` placeholder="comma separated"`;
    return `<label${tip}>${label} <input name="${esc(name)}" type="text" data-type="${texts ? "texts" : "array"}"${listed}></label>`;
  }
  if (t.type === "string") {
    const length = t.maxLength ? ` maxlength="${esc(String(t.maxLength))}"` : "";
    return `<label${tip}>${label} <input name="${esc(name)}" type="text"${length}${hint}></label>`;
  }
  const step = t.type === "integer" ? "1" : "any";
  return `<label${tip}>${label} <input name="${esc(name)}" type="number" step="${esc(step)}"${hint}></label>`;
}
