// A form as the API's request body, and the field a 422 names; no DOM of its own (works on
// any object with `elements`), unit-tested with node --test.

/** A form's filled inputs as a request body: checkboxes as booleans, numbers as numbers, an
 * input with data-type="array" as numbers split at commas; empty inputs left out. */
export function formBody(form) {
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

// The field a 422 names: `errors[].field`, else the start of the message (`metadata.notes: …`).
export function problemField(p) {
  return p.field || ((p.message || "").match(/^([\w.[\]]+):/) || [])[1] || "";
}
