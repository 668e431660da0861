// Calls to the coordinator's API. Every call carries the client token from session storage;
// errors come back as ApiError built from the API's problem+json body.
const KEY = "tessera.token";

export const token = {
  get: () => sessionStorage.getItem(KEY) || "",
  set: (v) => (v ? sessionStorage.setItem(KEY, v) : sessionStorage.removeItem(KEY)),
};

export class ApiError extends Error {
  constructor(status, problem) {
    super(problem.detail || problem.title || `HTTP ${status}`);
    this.status = status;
    this.field = problem.field || null;
  }
}

/** fetch() with the token; throws ApiError on a non-2xx answer. */
export async function call(path, { method = "GET", json, body, type, signal, accept } = {}) {
  const headers = {};
  const t = token.get();
  if (t) headers.Authorization = `Bearer ${t}`;
  if (accept) headers.Accept = accept;
  if (json !== undefined) {
    headers["Content-Type"] = "application/json";
    body = JSON.stringify(json);
  } else if (type) {
    headers["Content-Type"] = type;
  }
  let resp;
  try {
    resp = await fetch(path, { method, headers, body, signal, cache: "no-store" });
  } catch (e) {
    if (e.name === "AbortError") throw e;
    throw new ApiError(0, { detail: `cannot reach the coordinator (${e.message})` });
  }
  if (!resp.ok) throw await problemOf(resp);
  return resp;
}

async function problemOf(resp) {
  let problem;
  try {
    problem = await resp.json();
  } catch {
    problem = { detail: `${resp.status} ${resp.statusText}` };
  }
  if (resp.status === 401) problem.detail = `${problem.detail} — enter the client token at the top of the page`;
  return new ApiError(resp.status, problem);
}

export const getJson = async (path, opts) => (await call(path, opts)).json();

/**
 * Follows a job: `onJob(job)` for each `progress` event of /v1/jobs/{id}/events, until the job
 * ends or `signal` aborts. EventSource cannot send an Authorization header, so the stream is read
 * with fetch() and a ReadableStream; where that fails, the job is polled once a second instead.
 */
export async function watchJob(id, onJob, signal) {
  const path = `/v1/jobs/${encodeURIComponent(id)}`;
  try {
    const resp = await call(`${path}/events`, { signal, accept: "text/event-stream" });
    if (resp.body && resp.body.getReader) {
      await readEvents(resp.body, (ev, data) => ev === "progress" && onJob(JSON.parse(data)));
      return;
    }
  } catch (e) {
    if (e.name === "AbortError" || (e instanceof ApiError && e.status !== 0)) throw e;
  }
  await poll(path, onJob, signal);
}

async function poll(path, onJob, signal) {
  while (!signal.aborted) {
    const job = await getJson(path, { signal });
    onJob(job);
    if (["done", "failed", "canceled"].includes(job.state)) return;
    await new Promise((r) => setTimeout(r, 1000));
  }
}

/** Parses a text/event-stream body: blocks separated by a blank line, `event:` and `data:` lines. */
async function readEvents(body, onEvent) {
  const reader = body.pipeThrough(new TextDecoderStream()).getReader();
  let buf = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return;
    buf += value.replace(/\r\n?/g, "\n");
    let end;
    while ((end = buf.indexOf("\n\n")) >= 0) {
      const block = buf.slice(0, end);
      buf = buf.slice(end + 2);
      let event = "message";
      const data = [];
      for (const line of block.split("\n")) {
        if (line.startsWith(":")) continue; // keep-alive comment
        const colon = line.indexOf(":");
        const name = colon < 0 ? line : line.slice(0, colon);
        const val = colon < 0 ? "" : line.slice(colon + 1).replace(/^ /, "");
        if (name === "event") event = val;
        else if (name === "data") data.push(val);
      }
      if (data.length) onEvent(event, data.join("\n"));
    }
  }
}

/** Fetches a job's file with the token and saves it under `name` (no token in any URL). */
export async function download(path, name) {
  const blob = await (await call(path)).blob();
  const url = URL.createObjectURL(blob);
  const a = document.createElement("a");
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
  return blob.size;
}
