// The page's elements: find them ($, $$), fill a two-column table (kv), write markup only
// when it changed (setHtml) and redraw a readout once a frame, not once a sample (everyFrame).
// Every module that draws imports these; nothing here knows a page.
import { esc } from "./markup.js";

/** The first element under `root` matching a CSS selector, or null. */
export const $ = (sel, root = document) => root.querySelector(sel);
/** Every element under `root` matching a CSS selector, as an array. */
export const $$ = (sel, root = document) => [...root.querySelectorAll(sel)];

// The markup each element was last given by setHtml.
const written = new WeakMap();

/** Writes `html` as the element's markup, unless it is what setHtml last wrote there: a poll or sample
 * that brings the same values rebuilds no elements (no style, layout or paint). For
 * elements only setHtml writes. True when it wrote. */
export function setHtml(el, html) {
  if (written.get(el) === html) return false;
  written.set(el, html);
  el.innerHTML = html;
  return true;
}

/** A table's rows as [label, value] pairs, both escaped (rewritten only when they changed). */
export function kv(table, rows) {
  setHtml(table, rows.map(([k, v]) => `<tr><td>${esc(k)}</td><td>${esc(v)}</td></tr>`).join(""));
}

/** `draw` as a function to call on every sample: it runs at most once per animation frame and
 * per `ms` (the readout's rate; the stream's 10 Hz), with whatever arrived meanwhile, and not
 * while the tab is hidden (no frames). A simulated rig on a fast clock sends samples many
 * times faster than the stream's max_hz (77 a second in the browser tests): each redrew a
 * readout, restyled and repainted the page. */
export function everyFrame(draw, ms = 100) {
  let queued = false;
  let last = -Infinity;
  const frame = () =>
    requestAnimationFrame((now) => {
      queued = false;
      last = now;
      draw();
    });
  return () => {
    if (queued) return;
    queued = true;
    const wait = last + ms - performance.now();
    if (wait > 0) setTimeout(frame, wait);
    else frame();
  };
}
