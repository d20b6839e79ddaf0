// The one escaping path of the browser UI: every value from the user, the database or an
// error that goes into markup (innerHTML, insertAdjacentHTML) passes through esc; plain text
// goes in with textContent. tests/api/static/escaping.test.js scans the scripts for markup
// that interpolates anything else. No DOM: unit-tested with node --test.

const ENTITIES = { "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" };

/** A value as text safe inside markup and in a quoted attribute (either quote): & < > " ' escaped. */
export function esc(value) {
  return String(value).replace(/[&<>"']/g, (c) => ENTITIES[c]);
}

/** A table's one row when it has nothing to list: `text` (what the emptiness means) across
 * its `columns`, so an empty table never looks like a page still loading. */
export function emptyRow(columns, text) {
  return `<tr class="empty"><td colspan="${Number(columns)}" class="muted">${esc(text)}</td></tr>`;
}
