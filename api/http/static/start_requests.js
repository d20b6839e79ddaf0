// A start form (start_forms.js renders them in #start-forms) sent: POST /api/jobs/<route> with
// the run metadata block; the job takes the panel and the live plot starts afresh; a 422 marks
// the fields it names, in the start form or the metadata block.
import { api } from "./api.js";
import { $, $$ } from "./dom.js";
import { formBody, problemField } from "./forms.js";
import { showJob } from "./jobs.js";
import { resetLive } from "./live.js";
import { esc } from "./markup.js";
import { metaForm, metadataBody } from "./run_metadata.js";

// A start form (start_forms.js renders them): POST /api/jobs/<route>; a 422 marks the fields.
$("#start-forms").addEventListener("submit", async (ev) => {
  const form = ev.target.closest(".start-form[data-kind]");
  if (!form) return;
  ev.preventDefault();
  const errors = $(".errors", form);
  const metaErrors = $(".errors", metaForm);
  errors.innerHTML = "";
  metaErrors.innerHTML = "";
  $$("input", form).forEach((i) => i.classList.remove("invalid"));
  $$("input", metaForm).forEach((i) => i.classList.remove("invalid"));
  if (!form.checkValidity()) {
    form.reportValidity();
    return;
  }
  const body = formBody(form);
  const metadata = metadataBody();
  if (metadata) body.metadata = metadata;
  try {
    const job = await api("POST", `/api/jobs/${form.dataset.kind}`, body);
    showJob(job);
    resetLive();
  } catch (err) {
    const problems = (err.body && err.body.errors) || [{ message: err.message, field: "" }];
    for (const p of problems) {
      const field = problemField(p);
      const key = (field.match(/^metadata\.([a-z0-9_]+)/) || [])[1];
      const target = key ? metaForm : form;
      $(".errors", target).insertAdjacentHTML("beforeend", `<li>${esc(p.message)}</li>`);
      const input = $(`[name="${key || field}"]`, target);
      if (input) input.classList.add("invalid");
      if (key) $("#run-metadata").open = true;
    }
    if (err.body && err.body.holder && err.body.holder !== "emergency stop") errors.insertAdjacentHTML("beforeend", `<li>Rig held by ${esc(err.body.holder)}</li>`);
  }
});
