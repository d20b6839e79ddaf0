// What the page knows and several modules read: the API token, the rig's last status
// (GET /api/rig), the job shown on the Rig page, the runs listed, the run opened, the jobs the
// stream has told of and the jobs asked to stop. One object, shared by import.

/** The states a job never leaves. */
export const FINAL = ["completed", "aborted", "failed", "interrupted"];

export const state = { token: null, rig: null, job: null, runs: [], selectedRun: null, jobDocs: {}, stopping: new Set() };
