// A form as a request body and the field a 422 names (api/http/static/forms.js), without a
// browser: a form is anything with `elements`.
import assert from "node:assert/strict";
import test from "node:test";
import { fieldHtml, formBody, problemField } from "../../../api/http/static/forms.js";

const input = (name, value, type = "text", extra = {}) => ({ name, value, type, dataset: {}, ...extra });

test("a form's filled inputs as the request body, typed", () => {
  const form = {
    elements: [
      input("force_n", "24.5", "number"),
      input("max_time_s", "", "number"), // empty: left out, the API's default applies
      input("drive", "weight", "select-one"),
      input("reverse", "on", "checkbox", { checked: false }),
      input("commands", "0.1, 0.5,1", "text", { dataset: { type: "array" } }),
      input("tags", "fins-v2, ,repeat ", "text", { dataset: { type: "texts" } }),
      input("", "x"), // no name
      input("go", "Start", "submit"),
    ],
  };
  assert.deepEqual(formBody(form), {
    force_n: 24.5,
    drive: "weight",
    reverse: false,
    commands: [0.1, 0.5, 1],
    tags: ["fins-v2", "repeat"],
  });
});

test("the field a 422 names: its field, else the start of its message", () => {
  assert.equal(problemField({ field: "force_n", message: "force_n: too large" }), "force_n");
  assert.equal(problemField({ message: "metadata.notes: at most 2000 characters" }), "metadata.notes");
  assert.equal(problemField({ message: "steps[2]: out of range" }), "steps[2]");
  assert.equal(problemField({ message: "the rig is held" }), "");
  assert.equal(problemField({}), "");
});

test("a schema property as an input: a text of its length, a list of texts, a range said in the tooltip", () => {
  const nullable = (t) => ({ anyOf: [t, { type: "null" }] });
  const text = fieldHtml("operator", { ...nullable({ type: "string", maxLength: 200 }), title: "Operator" });
  assert.match(text, /^<label>Operator <input name="operator" type="text" maxlength="200"><\/label>$/);
  const tags = fieldHtml("tags", { ...nullable({ type: "array", items: { type: "string" } }), title: "Tags" });
  assert.match(tags, /data-type="texts" placeholder="comma separated"/);
  const water = {
    ...nullable({ type: "number", minimum: -2, maximum: 50 }),
    title: "Water temperature (°C)",
    description: "Water temperature, °C.",
    unit: "°C",
  };
  assert.equal(
    fieldHtml("water_temperature_c", water),
    '<label title="Water temperature, °C. (-2 to 50 °C)">Water temperature (°C) <input name="water_temperature_c" type="number" step="any"></label>',
  );
});
