// The page's elements: find them ($, $$) and fill a two-column table (kv). Every module
// that draws imports these; nothing here knows a page.
import { esc } from "./markup.js";

/** The first element under `root` matching a CSS selector, or null. */
export const $ = (sel, root = document) => root.querySelector(sel);
/** Every element under `root` matching a CSS selector, as an array. */
export const $$ = (sel, root = document) => [...root.querySelectorAll(sel)];

/** A table's rows as [label, value] pairs, both escaped. */
export function kv(table, rows) {
  table.innerHTML = rows.map(([k, v]) => `<tr><td>${esc(k)}</td><td>${esc(v)}</td></tr>`).join("");
}
