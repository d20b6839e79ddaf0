// Who is signed in (GET /api/whoami) in the header, with a sign-out; for a viewer, every
// control that starts, stops or changes something is disabled with the reason as its
// tooltip, however and whenever the page draws it.
import { api } from "./api.js";
import { $, $$ } from "./dom.js";
import { onRigStatus } from "./rig.js";
import { state } from "./state.js";

// The controls that need role operator (the API answers 403 to a viewer). The emergency
// stop is not among them: anyone may press it.
const OPERATOR_ONLY = [
  ".start-form button[type=submit]",
  "#arm-btn", "#disarm-btn", "#abort-btn",
  "#confirm-btn", "#pause-btn", "#resume-btn",
  "#guard-panel button",
  "#queue-resume", "#queue-stop", "#queue-marker", "#queue-list button", "#queue-summary-resume",
  "#sequence-list button[data-start]",
  "#history-table button[data-requeue]",
  "#campaign-form button[type=submit]", "#campaign-stop",
  "#est-run", "#est-reverse-btn", "#cc-compare", "#cc-estimate", "button[data-abort-job]",
  "#an-form button[type=submit]", "#sixdof-form button[type=submit]",
  "#manual-form button",
].join(", ");

const people = { user: null, token: undefined };

// The reason a viewer reads on a disabled control.
const viewerReason = (user) =>
  `You are signed in as ${user.name} (role ${user.role}): starting, stopping or changing anything needs role operator`;

function lockForRole() {
  const user = people.user;
  if (!user || user.role === "operator") return;
  for (const el of $$(OPERATOR_ONLY)) {
    if (el.dataset.roleLocked && el.disabled) continue;
    el.disabled = true;
    el.title = viewerReason(user);
    el.dataset.roleLocked = "1";
  }
}

// Controls are drawn and re-enabled by many scripts (capabilities, queue redraws, job panels):
// lock them again each time the page changes.
new MutationObserver(lockForRole).observe(document.body, {
  subtree: true,
  childList: true,
  attributes: true,
  attributeFilter: ["disabled"],
});

function showUser(user) {
  people.user = user;
  $("#who").hidden = !user;
  $("#sign-out").hidden = !user;
  // a viewer reads why the controls are greyed without hovering each one
  $("#role-note").hidden = !user || user.role === "operator";
  if (!user) return;
  $("#role-note").textContent = `${viewerReason(user)}. You can watch the rig, read runs and results, and press the emergency stop.`;
  $("#who-name").textContent = user.name;
  $("#who-role").textContent = user.role;
  $("#who").title = user.role === "operator" ? "operator: may start, stop and change tests" : viewerReason(user);
  lockForRole();
}

// Called after each status poll (rig.js): ask who we are once per token.
async function refreshUser() {
  if (people.token === state.token) return;
  const asked = state.token;
  try {
    const user = await api("GET", "/api/whoami");
    if (asked !== state.token) return;
    people.token = asked;
    showUser(user);
  } catch (err) {
    if (asked === state.token) showUser(null);
  }
}

$("#sign-out").onclick = () => {
  localStorage.removeItem("rig-token");
  state.token = null;
  people.token = undefined;
  showUser(null);
  // a page drawn for one role is not left to another: reload it unlocked, asking a token
  location.reload();
};

// Each rig status: who is signed in (asked once per token; not awaited by the status poll).
onRigStatus(() => {
  refreshUser();
});
