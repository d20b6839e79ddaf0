// The browser UI is ES modules with one entry (api/http/static/main.js): no script reaches
// another's names through the global scope, every import names an export, every module is
// reached from the entry, no two modules import each other (a cycle runs one module's code
// before the other's declarations exist), and index.html loads the entry alone.
import assert from "node:assert/strict";
import fs from "node:fs";
import path from "node:path";
import test from "node:test";
import { fileURLToPath } from "node:url";
import { exportedNames, globalUses, importsOf, topLevelNames, unusedImports } from "./scope_scan.js";

const STATIC = fileURLToPath(new URL("../../../api/http/static/", import.meta.url));
const ENTRY = "main.js";
// the UI's own scripts (plotly.js, third-party, is in vendor/: not listed here)
const scripts = fs.readdirSync(STATIC).filter((f) => f.endsWith(".js"));
const sources = Object.fromEntries(scripts.map((f) => [f, fs.readFileSync(path.join(STATIC, f), "utf8")]));

test("the scan finds another script's name used without an import", () => {
  const owner = new Map([["api", "api.js"], ["$", "dom.js"]]);
  const uses = (src) => globalUses(src, "page.js", owner).map((u) => u.name);
  assert.deepEqual(uses('const x = api("GET", "/api/rig");'), ["api"]);
  assert.deepEqual(uses('import { api } from "./api.js";\nconst x = api("GET", "/");'), []);
  assert.deepEqual(uses("const r = s.api; const o = { api: 1 }; // api\nconst t = `api ${1}`;"), []);
  assert.deepEqual(uses("const f = (api) => api(1);"), []); // a parameter of its own
  assert.deepEqual(uses("el.textContent = `${$(\"#x\")}`;"), ["$"]); // in an interpolation
  assert.deepEqual(unusedImports('import { api, $ } from "./api.js";\nconst x = api(1); // $'), [{ from: "api.js", name: "$" }]);
});

test("no script uses a name another declares without importing it", () => {
  const owner = new Map();
  for (const [file, src] of Object.entries(sources)) for (const n of topLevelNames(src)) owner.set(n, file);
  assert.ok(owner.size > 100, `${owner.size} top-level names`);
  const found = Object.entries(sources).flatMap(([file, src]) => globalUses(src, file, owner));
  assert.deepEqual(found.map((u) => `${u.where}: ${u.name} (declared in ${u.owner})`), []);
});

test("every import names a module of the UI and a name it exports, and is used", () => {
  const wrong = [];
  for (const [file, src] of Object.entries(sources)) {
    for (const { from, name } of unusedImports(src)) wrong.push(`${file}: ${name} from ${from} unused`);
    for (const { from, names } of importsOf(src)) {
      if (!(from in sources)) wrong.push(`${file}: no module ${from}`);
      else for (const n of names) if (!exportedNames(sources[from]).includes(n)) wrong.push(`${file}: ${from} exports no ${n}`);
    }
  }
  assert.deepEqual(wrong, []);
});

test("every module is reached from the entry, and no import leads back to its importer", () => {
  const reached = new Set();
  const cycles = [];
  const visit = (file, trail) => {
    if (trail.includes(file)) return cycles.push([...trail.slice(trail.indexOf(file)), file].join(" → "));
    if (reached.has(file)) return;
    reached.add(file);
    for (const { from } of importsOf(sources[file] || "")) visit(from, [...trail, file]);
  };
  visit(ENTRY, []);
  assert.deepEqual(cycles, []);
  assert.deepEqual(scripts.filter((f) => !reached.has(f)), []);
});

test("index.html loads the entry module and no other script of the UI, with no inline handler", () => {
  const html = fs.readFileSync(path.join(STATIC, "index.html"), "utf8");
  const tags = [...html.matchAll(/<script\b[^>]*>/g)].map((m) => m[0]);
  assert.deepEqual(tags, [`<script type="module" src="/static/${ENTRY}"></script>`.replace("</script>", "")]);
  assert.doesNotMatch(html, /\son[a-z]+\s*=/i);
  for (const [file, src] of Object.entries(sources)) assert.doesNotMatch(src, /\son[a-z]+=["'\\]/, file);
});
