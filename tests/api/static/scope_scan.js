// A static scan of the browser UI's ES modules for names shared through the global scope
// (modules.test.js): a name declared at the top level of one script and used in another must
// be exported by the first and imported by the second. Code is read with markup_scan.js's
// lexer, so strings, comments, regexes and template text are not mistaken for code.
import { readTemplate, regexAt, skipRegex, skipString } from "./markup_scan.js";

/** The source with every string, comment, regex and template text blanked to spaces (lines
 * kept), and template interpolations kept as code. */
export function codeOnly(s) {
  let out = "";
  const blank = (text) => text.replace(/[^\n]/g, " ");
  let i = 0;
  while (i < s.length) {
    const c = s[i];
    let end = i + 1;
    if (c === "`") {
      const t = readTemplate(s, i);
      out += " " + t.quasis.map((q, k) => blank(q) + (k < t.parts.length ? `  ${codeOnly(t.parts[k])} ` : "")).join("") + " ";
      i = t.end;
      continue;
    }
    if (c === '"' || c === "'") end = skipString(s, i);
    else if (c === "/" && s[i + 1] === "/") end = s.indexOf("\n", i) < 0 ? s.length : s.indexOf("\n", i);
    else if (c === "/" && s[i + 1] === "*") end = s.indexOf("*/", i) + 2;
    else if (c === "/" && regexAt(s, i)) end = skipRegex(s, i);
    else {
      out += c;
      i = end;
      continue;
    }
    out += blank(s.slice(i, end));
    i = end;
  }
  return out;
}

const DECLARED = /^(?:export\s+)?(?:async\s+)?(?:function\*?|class|const|let|var)\s+([A-Za-z_$][\w$]*)/gm;

/** The names a script declares at its top level (column 0: the UI's scripts are formatted). */
export function topLevelNames(source) {
  return [...codeOnly(source).matchAll(DECLARED)].map((m) => m[1]);
}

/** The names a script imports: `import { a, b as c } from "./x.js"` gives ["a", "c"]. */
export function importedNames(source) {
  const names = [];
  for (const m of codeOnly(source).matchAll(/^import\s*\{([^}]*)\}\s*from/gm)) {
    for (const part of m[1].split(",")) {
      const name = part.trim().split(/\s+as\s+/).pop();
      if (name) names.push(name);
    }
  }
  return names;
}

/** Every name declared anywhere in a script (top level or inner: a local that shadows another
 * script's name is the script's own), with its parameters' simple names. */
function ownNames(code) {
  const names = new Set(topLevelNames(code));
  for (const m of code.matchAll(/\b(?:function\*?|class|const|let|var)\s+([A-Za-z_$][\w$]*)/g)) names.add(m[1]);
  for (const m of code.matchAll(/\b(?:const|let|var)\s*[{[]([^=]*)[}\]]\s*=/g)) {
    for (const n of m[1].matchAll(/([A-Za-z_$][\w$]*)\s*(?=[,}\]]|$|=)/g)) names.add(n[1]);
  }
  for (const m of code.matchAll(/\(([^()]*)\)\s*(?:=>|\{)/g)) {
    for (const n of m[1].matchAll(/([A-Za-z_$][\w$]*)\s*(?=[,)=]|$)/g)) names.add(n[1]);
  }
  for (const m of code.matchAll(/\b([A-Za-z_$][\w$]*)\s*=>/g)) names.add(m[1]);
  return names;
}

/**
 * The uses, in script `file`, of a name that another script declares at its top level
 * (`declaredBy`: name → file) and this one neither declares nor imports: [{where, name}].
 * A property (`x.name`) or an object key (`{name: …}`) is not a use.
 */
export function globalUses(source, file, declaredBy) {
  const code = codeOnly(source);
  const own = ownNames(code);
  for (const n of importedNames(source)) own.add(n);
  const found = [];
  const lines = code.split("\n");
  lines.forEach((line, k) => {
    for (const m of line.matchAll(/[A-Za-z_$][\w$]*/g)) {
      const name = m[0];
      const owner = declaredBy.get(name);
      if (!owner || owner === file || own.has(name)) continue;
      const before = line.slice(0, m.index).trimEnd();
      const after = line.slice(m.index + name.length);
      if (before.endsWith(".") && !before.endsWith("...")) continue; // a property
      if (/^\s*:(?!:)/.test(after) && /[{,]$/.test(before)) continue; // an object key
      found.push({ where: `${file}:${k + 1}`, name, owner });
    }
  });
  return found;
}

/** The modules a script imports (relative specifiers, "./x.js" → "x.js"), with the names
 * it imports from each: [{from, names}]. A bare `import "./x.js"` imports no names. */
export function importsOf(source) {
  const found = [];
  for (const m of source.matchAll(/^import\s*(?:\{([^}]*)\}\s*from\s*)?"\.\/([\w.]+)";/gm)) {
    const names = (m[1] || "").split(",").map((p) => p.trim().split(/\s+as\s+/)[0]).filter(Boolean);
    found.push({ from: m[2], names });
  }
  return found;
}

/** The names a module exports (`export function f`, `export const x`, …). */
export function exportedNames(source) {
  return [...codeOnly(source).matchAll(/^export\s+(?:async\s+)?(?:function\*?|class|const|let|var)\s+([A-Za-z_$][\w$]*)/gm)].map((m) => m[1]);
}

/** The names a script imports but never uses: [{from, name}]. */
export function unusedImports(source) {
  const body = codeOnly(source)
    .split("\n")
    .filter((l) => !l.startsWith("import "))
    .join("\n");
  const unused = [];
  for (const { from, names } of importsOf(source)) {
    for (const name of names) {
      const use = new RegExp(`(^|[^\\w$.])${name.replace(/\$/g, "\\$")}(?![\\w$])`);
      if (!use.test(body)) unused.push({ from, name });
    }
  }
  return unused;
}
