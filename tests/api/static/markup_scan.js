// A static scan of the browser UI's scripts for values that reach markup unescaped
// (escaping.test.js). Markup is every template literal whose text holds a tag ("<li>",
// "</td>") and every right-hand side of `innerHTML =`, `innerHTML +=` and the markup argument
// of `insertAdjacentHTML`. In markup each interpolation `${…}` must be one of:
//   esc(…), emptyRow(…)          markup.js's helpers, which escape what they take
//   a string or number literal   "—", 0
//   a template literal           itself scanned as markup
//   c ? a : b, a || b, c && a    with a and b (not c) again one of these
//   xs.map((x) => a).join(…)     with a (or every template of a block body) one of these
//   a name in MARKUP_NAMES       (of that script) a value holding markup built by scanned templates
// Anything else — a field of a run, a job label, an error text — is a finding.

/**
 * Per script, the names whose values hold markup already escaped where they were built (from
 * templates this scan checks, or from esc): helpers by their callee, variables by their name.
 */
const MARKUP_NAMES = {
  "campaign.js": ["stopping", "pending", "rows", "sigmaText", "shown", "limited"], // badge, next test, trail, U cells
  "crosscheck.js": ["option", "abortButton", "none"], // a stored result as an <option>, jobs.js's Abort, the empty picker
  "dom.js": ["html"], // setHtml's markup, scanned where each caller builds it
  "estimation.js": ["tags", "source", "wellDeterminedRows", "abortButton"], // run_text.js's cells, rows, jobs.js's Abort
  "forms.js": ["label", "tip", "options", "hint", "length", "listed"], // a field's escaped pieces
  "guard.js": ["who"], // esc(who pressed or holds)
  "jobs.js": ["runs"], // the job's run links
  "queue.js": ["paramsText", "waiting", "steps", "problems"], // parameter chips, summary, lists
  "results.js": ["resultLink", "heads", "body", "cell"], // links, the comparison's cells
  "run_metadata.js": ["inputs"], // the metadata object's fields (forms.js's fieldHtml)
  "runs.js": ["tags", "source"], // run_text.js's cells
  "start_forms.js": ["fields"], // a form's fields (forms.js's fieldHtml)
  "thrusters.js": ["cells"], // a live row's cells
  // the budget's parts; the repeats table, its runs (esc'd ids) and its note
  "uncertainty.js": ["notes", "summary", "tables", "details", "rep", "rows", "repeatsMarkup", "shortId", "each", "note"],
};

/** markup.js's helpers: each escapes every value it puts into markup. */
const ESCAPING = new Set(["esc", "emptyRow"]);

// ---- a small lexer: template literals with their interpolations, strings, comments, regexes

/** Skips a quoted string starting at i (s[i] is the quote); returns the index after it. */
function skipString(s, i) {
  const q = s[i];
  for (i += 1; i < s.length; i++) {
    if (s[i] === "\\") i++;
    else if (s[i] === q) return i + 1;
  }
  return i;
}

/** Skips a regex literal starting at i (s[i] is "/"); returns the index after its flags. */
function skipRegex(s, i) {
  let inClass = false;
  for (i += 1; i < s.length; i++) {
    const c = s[i];
    if (c === "\\") i++;
    else if (c === "[") inClass = true;
    else if (c === "]") inClass = false;
    else if (c === "/" && !inClass) break;
  }
  i += 1;
  while (i < s.length && /[a-z]/.test(s[i])) i++;
  return i;
}

/** Whether a "/" at i starts a regex (not a division): by the code before it. */
function regexAt(s, i) {
  let j = i - 1;
  while (j >= 0 && /\s/.test(s[j])) j--;
  if (j < 0) return true;
  if ("(,=:[!&|?{};+-*%<>~^".includes(s[j])) return true;
  return /\b(return|typeof|case|in|of)$/.test(s.slice(Math.max(0, j - 6), j + 1));
}

/**
 * Reads a template literal starting at i (s[i] is "`"): {end, quasis, parts} where parts are
 * the interpolations' source texts.
 */
function readTemplate(s, i) {
  const quasis = [];
  const parts = [];
  let text = "";
  for (i += 1; i < s.length; i++) {
    const c = s[i];
    if (c === "\\") {
      text += s.slice(i, i + 2);
      i++;
    } else if (c === "`") {
      quasis.push(text);
      return { end: i + 1, quasis, parts };
    } else if (c === "$" && s[i + 1] === "{") {
      quasis.push(text);
      text = "";
      const end = skipCode(s, i + 2, "}");
      parts.push(s.slice(i + 2, end));
      i = end;
    } else text += c;
  }
  throw new Error("unterminated template literal");
}

/** Skips code from i up to the unmatched closing `close`; returns its index. */
function skipCode(s, i, close) {
  let depth = 0;
  while (i < s.length) {
    const c = s[i];
    if (c === "`") i = readTemplate(s, i).end;
    else if (c === '"' || c === "'") i = skipString(s, i);
    else if (c === "/" && s[i + 1] === "/") i = s.indexOf("\n", i) < 0 ? s.length : s.indexOf("\n", i);
    else if (c === "/" && s[i + 1] === "*") i = s.indexOf("*/", i) + 2;
    else if (c === "/" && regexAt(s, i)) i = skipRegex(s, i);
    else {
      if (depth === 0 && close.includes(c)) return i;
      if ("([{".includes(c)) depth++;
      else if (")]}".includes(c)) depth--;
      i++;
    }
  }
  return i;
}

/** Every top-level template literal of a script: [{start, quasis, parts}]. */
function templatesOf(s) {
  const found = [];
  let i = 0;
  while (i < s.length) {
    const c = s[i];
    if (c === "`") {
      const t = readTemplate(s, i);
      found.push({ start: i, ...t });
      i = t.end;
    } else if (c === '"' || c === "'") i = skipString(s, i);
    else if (c === "/" && s[i + 1] === "/") i = s.indexOf("\n", i) < 0 ? s.length : s.indexOf("\n", i);
    else if (c === "/" && s[i + 1] === "*") i = s.indexOf("*/", i) + 2;
    else if (c === "/" && regexAt(s, i)) i = skipRegex(s, i);
    else i++;
  }
  return found;
}

// ---- expressions: split at top level -----------------------------------------------------

/** Splits `e` at the top-level occurrences of the operator `op` ("||", "&&", "+"). */
function splitTop(e, op) {
  const pieces = [];
  let last = 0;
  let i = 0;
  let depth = 0;
  while (i < e.length) {
    const c = e[i];
    if (c === "`") i = readTemplate(e, i).end;
    else if (c === '"' || c === "'") i = skipString(e, i);
    else if ("([{".includes(c)) (depth++, i++);
    else if (")]}".includes(c)) (depth--, i++);
    else if (depth === 0 && e.startsWith(op, i) && (op !== "+" || (e[i + 1] !== "+" && e[i + 1] !== "="))) {
      pieces.push(e.slice(last, i));
      i += op.length;
      last = i;
    } else i++;
  }
  pieces.push(e.slice(last));
  return pieces.map((p) => p.trim());
}

/** A top-level ternary `c ? a : b` as [c, a, b], or null. */
function ternary(e) {
  const q = splitTop(e, "?");
  if (q.length < 2) return null;
  const rest = q.slice(1).join(" ? ");
  const branches = splitTop(rest, ":");
  if (branches.length < 2) return null;
  return [q[0], branches[0], branches.slice(1).join(" : ")];
}

/** Whether the whole of `e` is one call `name(…)`; gives the name. */
function wholeCall(e) {
  const m = /^([A-Za-z_$][\w$]*)\s*\(/.exec(e);
  if (!m) return null;
  const close = skipCode(e, m[0].length, ")");
  return close === e.length - 1 ? m[1] : null;
}

/** The findings (unescaped interpolations) of markup expression `e`, at `where`. */
function checkExpression(e, where, findings, names = new Set()) {
  e = e.trim();
  while (e.startsWith("(") && skipCode(e, 1, ")") === e.length - 1) e = e.slice(1, -1).trim();
  if (e === "") return;
  if (/^("([^"\\]|\\.)*"|'([^'\\]|\\.)*'|-?\d+(\.\d+)?)$/.test(e)) return;
  if (e.startsWith("`")) {
    const t = readTemplate(e, 0);
    if (t.end === e.length) return checkTemplate(t, where, findings, names);
  }
  const call = wholeCall(e);
  if (ESCAPING.has(call) || (call && names.has(call))) return;
  if (/^[A-Za-z_$][\w$]*$/.test(e) && names.has(e)) return;
  const t3 = ternary(e);
  if (t3) return [t3[1], t3[2]].forEach((b) => checkExpression(b, where, findings, names));
  for (const op of ["||", "&&", "+"]) {
    const pieces = splitTop(e, op);
    if (pieces.length > 1) {
      // c && a: the condition is not shown, the value is
      (op === "&&" ? pieces.slice(-1) : pieces).forEach((p) => checkExpression(p, where, findings, names));
      return;
    }
  }
  if (/^(Number\(|[\w$.]+\.length$)/.test(e) && (wholeCall(e) || !e.includes("("))) return; // a number
  if (/\.toFixed\(\d\)$/.test(e)) return; // a number's digits
  for (const map of e.matchAll(/\.map\(\s*(?:\([^)]*\)\s*=>|[\w$]+\s*=>|(?=[\w$]+\s*\)))\s*/g)) {
    const start = map.index + map[0].length;
    const close = skipCode(e, start, ")");
    const after = e.slice(close + 1).trim();
    if (/^\.join\(\s*("[^"]*"|'[^']*')\s*\)$/.test(after)) {
      const fn = e.slice(start, close).trim().replace(/,$/, "");
      if (!map[0].includes("=>")) {
        if (!names.has(fn)) findings.push({ where, expression: e });
        return;
      }
      if (fn.startsWith("{")) {
        const inner = templatesOf(fn);
        const returns = [...fn.matchAll(/return\s+([^;]+);/g)].map((m) => m[1]);
        inner.forEach((t) => checkTemplate(t, where, findings, names));
        returns.filter((r) => !r.trim().startsWith("`")).forEach((r) => checkExpression(r, where, findings, names));
      } else checkExpression(fn, where, findings, names);
      return;
    }
  }
  findings.push({ where, expression: e });
}

/** The findings of a template literal taken as markup. */
function checkTemplate(t, where, findings, names) {
  for (const part of t.parts) checkExpression(part, where, findings, names);
}

/** Whether a template literal's text holds a tag. */
function isMarkup(t) {
  return /<\/?[a-zA-Z]/.test(t.quasis.join(""));
}

/** The right-hand sides written into markup: innerHTML (+)= … ; insertAdjacentHTML(_, …);
 * setHtml(_, …). */
function markupSinks(s) {
  const sinks = [];
  for (const m of s.matchAll(/\.innerHTML\s*\+?=\s*/g)) {
    const start = m.index + m[0].length;
    sinks.push({ start, text: s.slice(start, skipCode(s, start, ";)")) });
  }
  // dom.js setHtml(element, markup): innerHTML unless unchanged
  for (const m of s.matchAll(/\bsetHtml\(\s*(?:[^,()]|\([^()]*\))+,\s*/g)) {
    const start = m.index + m[0].length;
    sinks.push({ start, text: s.slice(start, skipCode(s, start, ")")) });
  }
  for (const m of s.matchAll(/\.insertAdjacentHTML\(\s*("[^"]*"|'[^']*')\s*,\s*/g)) {
    const start = m.index + m[0].length;
    sinks.push({ start, text: s.slice(start, skipCode(s, start, ")")) });
  }
  return sinks;
}

/** Every finding in script `source` (named `file`): [{where: "file:line", expression}]. */
function scanScript(source, file) {
  const findings = [];
  const names = new Set(MARKUP_NAMES[file] || []);
  const line = (at) => `${file}:${source.slice(0, at).split("\n").length}`;
  for (const t of templatesOf(source)) if (isMarkup(t)) checkTemplate(t, line(t.start), findings, names);
  for (const sink of markupSinks(source)) {
    // a sink's templates are scanned above when they hold a tag; here what surrounds them
    const subFindings = [];
    checkExpression(sink.text, line(sink.start), subFindings, names);
    findings.push(...subFindings.filter((f) => !findings.some((g) => g.expression === f.expression)));
  }
  return findings;
}

export { scanScript, checkExpression, templatesOf, isMarkup, MARKUP_NAMES, readTemplate, regexAt, skipRegex, skipString };
