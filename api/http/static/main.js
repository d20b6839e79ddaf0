// towrig browser UI, the one entry module index.html loads: plain ES modules talking to the
// same HTTP API as any lab tool. Importing the page modules wires their pages (api.js reads
// the token first); then the live plot is drawn, the rig polled and the stream opened.
import { api, askToken, initToken } from "./api.js";
import { $ } from "./dom.js";
import { initLivePlot } from "./live.js";
import { showPage } from "./pages.js";
import { refreshRig } from "./rig.js";
import { state } from "./state.js";
import { reconnectStream, stream } from "./stream.js";
// the pages: each registers its loaders, listeners and controls when imported
import "./analysis.js";
import "./campaign.js";
import "./crosscheck.js";
import "./estimation.js";
import "./guard.js";
import "./jobs.js";
import "./people.js";
import "./queue.js";
import "./results.js";
import "./runs.js";
import "./sixdof.js";
import "./start_requests.js";
import "./thrusters.js";

function refreshAll() {
  refreshRig();
  showPage();
}

$("#token-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  state.token = $("#token-input").value.trim();
  $("#token-error").textContent = "";
  localStorage.setItem("rig-token", state.token);
  try {
    await api("GET", "/api/rig");
    $("#token-dialog").hidden = true;
    reconnectStream();
    refreshAll();
  } catch (err) {
    // a 401 has been said already (api.js tokenRefused: "The token was refused: …"); its bare
    // detail here replaced that until the next poll refused the token again, 2-3 s later
    askToken(err.status === 401 && state.token ? "" : err.message);
  }
});

window.addEventListener("hashchange", () => {
  if (/token=/.test(location.hash)) {
    // the link `rig serve` prints, opened in a tab that shows the page already
    initToken();
    $("#token-dialog").hidden = true;
    $("#token-error").textContent = "";
    reconnectStream();
    return refreshAll();
  }
  showPage();
});

initLivePlot();
window.addEventListener("load", showPage);
refreshRig();
setInterval(refreshRig, 2000);
stream();
