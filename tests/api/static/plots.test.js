// The plots' axes (api/http/static/plots.js) without a browser: ticks on 1-2-5 steps.
import test from "node:test";
import assert from "node:assert/strict";
import { niceAxis } from "../../../api/http/static/plots.js";

test("about five ticks on a 1-2-5 step, the range just past the outer ticks", () => {
  const a = niceAxis(0.13, 3.17);
  assert.equal(a.dtick, 1);
  assert.equal(a.tickformat, ".0f");
  assert.ok(a.range[0] < 0 && a.range[0] > -0.2 && a.range[1] > 4 && a.range[1] < 4.2, a.range);
  assert.equal(niceAxis(0, 0.9).dtick, 0.2);
  assert.equal(niceAxis(0, 0.9).tickformat, ".1f");
  assert.equal(niceAxis(-20, 230).dtick, 50);
});

test("a flat series still gets an axis; no numbers give none", () => {
  const flat = niceAxis(5, 5);
  assert.ok(flat.range[0] < 5 && flat.range[1] > 5, flat.range);
  assert.equal(niceAxis(NaN, 1), null);
});

test("every plot title is an object: the bundled Plotly draws no title given as a string", async () => {
  // Plotly ≥ 3 (the vendored plotly-basic.min.js) ignores `title: "…"` on the
  // layout and on axes; the cross-check and analysis plots once lost theirs that way.
  const { readdir, readFile } = await import("node:fs/promises");
  const dir = new URL("../../../api/http/static/", import.meta.url);
  const found = [];
  for (const name of (await readdir(dir)).filter((n) => n.endsWith(".js") && !n.includes(".min."))) {
    const text = await readFile(new URL(name, dir), "utf8");
    text.split("\n").forEach((line, i) => {
      if (/\btitle:\s*["'`]/.test(line)) found.push(`${name}:${i + 1}: ${line.trim()}`);
    });
  }
  assert.deepEqual(found, []);
});
