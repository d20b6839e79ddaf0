// The one escaping path (api/http/static/markup.js) and the scan that keeps every script on
// it: a value from the user, the database or an error reaches innerHTML only through esc.
import test from "node:test";
import assert from "node:assert/strict";
import fs from "node:fs";
import path from "node:path";
import { fileURLToPath } from "node:url";
import { emptyRow, esc } from "../../../api/http/static/markup.js";
import { scanScript } from "./markup_scan.js";

const STATIC = fileURLToPath(new URL("../../../api/http/static/", import.meta.url));
// the UI's own scripts (plotly.js, third-party, is in vendor/: not listed here)
const scripts = fs.readdirSync(STATIC).filter((f) => f.endsWith(".js"));

test("esc escapes what could open a tag, an entity or leave a quoted attribute", () => {
  assert.equal(esc(`<img src=x onerror="a('b')">&`), "&lt;img src=x onerror=&quot;a(&#39;b&#39;)&quot;&gt;&amp;");
  assert.equal(esc("fins-long-name v2 · 30 N"), "fins-long-name v2 · 30 N");
  assert.equal(esc(0), "0");
  assert.equal(esc(null), "null");
});

test("an empty table's row escapes its text and spans the table", () => {
  assert.equal(emptyRow("3", "no <run> yet"), '<tr class="empty"><td colspan="3" class="muted">no &lt;run&gt; yet</td></tr>');
  assert.equal(emptyRow("3 onclick=x", "-"), '<tr class="empty"><td colspan="NaN" class="muted">-</td></tr>');
});

test("the scan finds a value interpolated into markup without esc", () => {
  const found = (src) => scanScript(src, "page.js").map((f) => f.expression);
  assert.deepEqual(found("el.innerHTML = `<li>${run.name}</li>`;"), ["run.name"]);
  assert.deepEqual(found("el.innerHTML = `<li>${esc(run.name)}</li>`;"), []);
  assert.deepEqual(found("el.innerHTML = run.notes;"), ["run.notes"]);
  assert.deepEqual(found('el.innerHTML = "<b>" + job.error;'), ["job.error"]);
  assert.deepEqual(found('el.insertAdjacentHTML("beforeend", `<li>${p.message}</li>`);'), ["p.message"]);
  assert.deepEqual(found('setHtml($("#t tbody"), run.notes);'), ["run.notes"]);
  assert.deepEqual(found('setHtml(table, rows.map((r) => esc(r)).join(""));'), []);
  assert.deepEqual(found("x = `<td>${ok ? esc(a) : b}</td>`;"), ["b"]); // any template with a tag
  assert.deepEqual(found("x = `<td>${ok ? `(${n})` : esc(b)}</td>`;"), ["n"]); // nested, no tag
  assert.deepEqual(found('x = tags.map((t) => `<i>${t}</i>`).join("");'), ["t"]);
  assert.deepEqual(found('x = tags.map((t) => { const y = 1; return `<i>${t}</i>`; }).join("");'), ["t"]);
  assert.deepEqual(found('el.innerHTML = xs.map(row).join("");'), ['xs.map(row).join("")']);
  assert.deepEqual(found("x = `<td>${n.length} ${Number(id)} ${v.toFixed(1)} ${\"—\"}</td>`;"), []);
  // a regex with quotes and a backtick in a comment do not derail the lexer
  assert.deepEqual(found('const r = /["`]/g; // `\nel.innerHTML = `<p>${who}</p>`;'), ["who"]);
  assert.deepEqual(found('text = `plain ${name}`; el.textContent = name;'), []); // no markup
});

test("markup built elsewhere passes only under the name its script declares", () => {
  const src = "el.innerHTML = `<ul>${paramsText(job)}</ul>`;";
  assert.deepEqual(scanScript(src, "queue.js"), []);
  assert.equal(scanScript(src, "app.js").length, 1);
});

test("no script lets a value reach markup unescaped", () => {
  let sinks = 0;
  const findings = [];
  for (const file of scripts) {
    const source = fs.readFileSync(path.join(STATIC, file), "utf8");
    sinks += (source.match(/\.innerHTML\s*\+?=|\.insertAdjacentHTML\(|\bsetHtml\(/g) || []).length;
    findings.push(...scanScript(source, file));
  }
  assert.ok(scripts.length >= 15 && sinks >= 60, `scanned ${scripts.length} scripts, ${sinks} sinks`);
  assert.deepEqual(findings.map((f) => `${f.where}: \${${f.expression}}`), []);
});
