// The rig's live stream (GET /api/stream, server-sent events read with fetch so the token
// travels in a header): samples, job updates and changes of the rig's guard, handed to the
// modules that subscribed (onSample, onJob, onGuard). Reconnects after a drop; asks for a
// token on a 401.
import { authHeaders, tokenRefused } from "./api.js";
import { FINAL, state } from "./state.js";

const sampleListeners = [];
const jobListeners = [];
const guardListeners = [];

/** Calls `listener(sample)` for every sample the stream sends ({seq, t_mono, channels, …}). */
export function onSample(listener) {
  sampleListeners.push(listener);
}

/** Calls `listener(job)` for every job update (a whole job document), in registration order;
 * each listener picks the jobs it shows (by kind, by state). */
export function onJob(listener) {
  jobListeners.push(listener);
}

/** Calls `listener(guard)` when the rig's guard changes through the service ({estop, hold}:
 * an emergency stop latched or acknowledged, a hold taken or released). */
export function onGuard(listener) {
  guardListeners.push(listener);
}

/** Hands a job document to every job listener, as the stream does. */
export function jobEvent(job) {
  for (const listener of jobListeners) listener(job);
}

// The stream's pause before it reconnects (after a 401 or a drop), cut short by a new token
// (reconnectStream): live data starts as soon as the user signs in, not up to 3 s later.
let wakeStream = null;
function streamPause(ms) {
  return new Promise((res) => {
    const timer = setTimeout(res, ms);
    wakeStream = () => {
      clearTimeout(timer);
      res();
    };
  }).finally(() => {
    wakeStream = null;
  });
}

/** A new token (typed, or from a #token= link): a stream waiting to reconnect connects now. */
export function reconnectStream() {
  if (wakeStream) wakeStream();
}

export async function stream() {
  for (;;) {
    try {
      const used = state.token;
      const r = await fetch("/api/stream?max_hz=10", { headers: authHeaders() });
      if (r.status === 401) {
        tokenRefused(used, (await r.json().catch(() => ({}))).detail);
        // refused with a token that was since replaced: try the new one at once
        if (used === state.token) await streamPause(3000);
        continue;
      }
      const reader = r.body.getReader();
      const decoder = new TextDecoder();
      let buf = "";
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        buf += decoder.decode(value, { stream: true });
        let i;
        while ((i = buf.indexOf("\n\n")) >= 0) {
          const block = buf.slice(0, i);
          buf = buf.slice(i + 2);
          let kind = "message";
          let data = "";
          for (const line of block.split("\n")) {
            if (line.startsWith("event: ")) kind = line.slice(7);
            else if (line.startsWith("data: ")) data += line.slice(6);
          }
          if (!data) continue;
          const obj = JSON.parse(data);
          if (kind === "sample") {
            for (const listener of sampleListeners) listener(obj);
          }
          else if (kind === "job") {
            if (FINAL.includes(obj.state)) delete state.jobDocs[obj.id];
            else state.jobDocs[obj.id] = obj;
            jobEvent(obj);
          } else if (kind === "guard") {
            for (const listener of guardListeners) listener(obj);
          } else if (kind === "job_progress" && state.jobDocs[obj.id]) {
            // only the progress changed: the stream sends it without the rest of the job
            const job = { ...state.jobDocs[obj.id], state: obj.state, progress: obj.progress };
            state.jobDocs[obj.id] = job;
            jobEvent(job);
          }
        }
      }
    } catch (err) {
      console.warn("stream", err);
    }
    await streamPause(2000);
  }
}
