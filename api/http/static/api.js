// The HTTP API as the page calls it: the token (from #token=… in the link `rig serve`
// prints, else localStorage, else asked for), requests with it, refusals in a technician's
// words, downloads.
import { $ } from "./dom.js";
import { localTime } from "./format.js";
import { state } from "./state.js";

// ---- token: from #token=... (the link `rig serve` prints), else localStorage, else ask ----
// The dialog opens when the API answers 401; it shows an error only for a token that was
// tried (none on a first visit; with `--open-read` reading works without one).
export function initToken() {
  const m = location.hash.match(/token=([^&]+)/);
  if (m) {
    localStorage.setItem("rig-token", decodeURIComponent(m[1]));
    history.replaceState(null, "", location.pathname + location.search + "#rig");
  }
  state.token = localStorage.getItem("rig-token");
}

export const authHeaders = () => (state.token ? { Authorization: `Bearer ${state.token}` } : {});

export function askToken(message = "") {
  const dialog = $("#token-dialog");
  if (message) $("#token-error").textContent = message;
  if (!dialog.hidden) return; // already asking: leave what the user is typing alone
  dialog.hidden = false;
  $("#token-input").focus();
}

// A 401 to a request sent with `used`: ask for a token, saying it was refused only if there
// was one. An answer to a request sent before the token changed says nothing about the new one.
export function tokenRefused(used, detail) {
  if (used !== state.token) return;
  askToken(used ? `The token was refused: ${detail || "HTTP 401"}` : "");
}

// A refusal in a technician's words: an unacknowledged emergency stop names the button that
// acknowledges it, not the API route (the service's text is for API clients).
export function refusalText(body) {
  if (body.holder !== "emergency stop") return body.detail;
  const stop = state.rig && state.rig.guard && state.rig.guard.estop;
  const when = stop ? ` (pressed ${localTime(stop.at)})` : "";
  return `The rig will not move: the emergency stop${when} is not acknowledged yet. An operator checks the rig, then presses "Acknowledge emergency stop" on the Rig page.`;
}

export class ApiError extends Error {
  constructor(status, body) {
    super(refusalText(body) || `HTTP ${status}`);
    this.status = status;
    this.body = body;
  }
}

export async function api(method, path, body, meta) {
  const used = state.token;
  const headers = authHeaders();
  const init = { method, headers };
  if (body !== undefined) {
    headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  const r = await fetch(path, init);
  const isJson = (r.headers.get("content-type") || "").includes("json");
  const data = isJson ? await r.json() : await r.text();
  if (r.status === 401) tokenRefused(used, data.detail);
  if (!r.ok) throw new ApiError(r.status, isJson ? data : { detail: data });
  if (meta) meta.headers = r.headers;
  return data;
}

export async function download(path, filename) {
  const r = await fetch(path, { headers: { Authorization: `Bearer ${state.token}` } });
  if (!r.ok) return alert(`Export failed: HTTP ${r.status}`);
  const url = URL.createObjectURL(await r.blob());
  const a = Object.assign(document.createElement("a"), { href: url, download: filename });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 5000);
}

// The token is known before any module asks the API anything.
initToken();
