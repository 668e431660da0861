// The jobs page: the submit form and the live job list.
import { ApiError, call, getJson, watchJob } from "./api.js";
import * as fmt from "./format.js";

const $ = (id) => document.getElementById(id);
const FIELDS = ["scene", "file", "width", "height", "spp", "noise_target", "time_limit_s", "estimator", "seed"];
/** Live streams at once: browsers allow ~6 connections per origin over HTTP/1.1. */
const MAX_STREAMS = 3;
const LIST_EVERY_MS = 2000;

let formReady = false;

export function start(onError) {
  if (!formReady) {
    $("submit-form").addEventListener("submit", submit);
    formReady = true;
  }
  loadScenes().catch(onError);
  const list = new JobList($("jobs").tBodies[0], onError);
  list.refresh();
  const timer = setInterval(() => list.refresh(), LIST_EVERY_MS);
  return () => {
    clearInterval(timer);
    list.stop();
  };
}

async function loadScenes(select = null) {
  const scenes = await getJson("/v1/scenes");
  const sel = $("f-scene");
  const keep = select || sel.value || "cornell-box";
  sel.replaceChildren(
    ...scenes.map((s) => {
      const value = s.name || s.id;
      const label = `${s.name || fmt.sceneLabel(s.id)} — ${s.triangles} triangles`;
      return fmt.el("option", { value, selected: value === keep, text: label });
    }),
  );
}

/** The value of a form field: undefined when empty, a number when it parses, else the text. */
function value(name) {
  const input = $(`f-${name}`);
  if (input.validity && input.validity.badInput) throw new ApiError(400, { field: name, detail: "enter a number" });
  const v = input.value.trim();
  if (v === "") return undefined;
  if (input.type !== "number") return v;
  const n = Number(v);
  return Number.isFinite(n) ? n : v;
}

async function submit(e) {
  e.preventDefault();
  clearErrors();
  const button = $("f-submit");
  button.disabled = true;
  try {
    const req = { scene: await sceneToUse() };
    for (const f of ["width", "height", "spp", "noise_target", "time_limit_s", "seed", "estimator"]) {
      const v = value(f);
      if (v !== undefined) req[f] = v;
    }
    const job = await (await call("/v1/jobs", { method: "POST", json: req })).json();
    location.hash = `#/job/${encodeURIComponent(job.id)}`;
  } catch (err) {
    showError(err);
  } finally {
    button.disabled = false;
  }
}

/** The chosen scene; an attached file is uploaded first and its id used. */
async function sceneToUse() {
  const file = $("f-file").files[0];
  if (!file) return $("f-scene").value;
  const type = file.name.toLowerCase().endsWith(".glb") ? "model/gltf-binary" : "model/gltf+json";
  try {
    const up = await (await call("/v1/scenes", { method: "POST", body: file, type })).json();
    $("f-file").value = "";
    await loadScenes(up.id);
    return up.id;
  } catch (err) {
    if (err instanceof ApiError && !err.field) err.field = "file";
    throw err;
  }
}

function clearErrors() {
  $("submit-err").textContent = "";
  for (const f of FIELDS) {
    $(`f-${f}-err`).textContent = "";
    $(`f-${f}`).removeAttribute("aria-invalid");
  }
}

/** A problem naming a field goes next to it (and takes the focus); anything else under the form. */
function showError(err) {
  const field = err.field && FIELDS.includes(err.field) ? err.field : null;
  if (!field) {
    $("submit-err").textContent = err.message;
    return;
  }
  $(`f-${field}-err`).textContent = err.message;
  const input = $(`f-${field}`);
  input.setAttribute("aria-invalid", "true");
  input.focus();
  $("submit-err").textContent = "Please correct the marked field.";
}

/** The job table: rows updated in place (focus stays put), live streams for running jobs. */
class JobList {
  constructor(tbody, onError) {
    this.tbody = tbody;
    this.onError = onError;
    this.rows = new Map();
    this.streams = new Map();
  }

  async refresh() {
    try {
      const page = await getJson("/v1/jobs?limit=50");
      page.jobs.forEach((job, i) => this.show(job, i));
      $("jobs-empty").hidden = page.jobs.length > 0;
      for (const job of page.jobs) if (!fmt.isFinal(job)) this.watch(job.id);
    } catch (e) {
      this.onError(e);
    }
  }

  watch(id) {
    if (this.streams.has(id) || this.streams.size >= MAX_STREAMS) return;
    const ctl = new AbortController();
    this.streams.set(id, ctl);
    watchJob(id, (job) => this.show(job), ctl.signal)
      .catch((e) => e.name !== "AbortError" && this.onError(e))
      .finally(() => this.streams.delete(id));
  }

  stop() {
    for (const ctl of this.streams.values()) ctl.abort();
  }

  /** Updates the job's row, creating it at `index` (newest first) if new. */
  show(job, index = null) {
    let row = this.rows.get(job.id);
    if (!row) {
      const link = fmt.el("a", { href: `#/job/${encodeURIComponent(job.id)}`, text: job.id, class: "mono" });
      const cells = Array.from({ length: 8 }, () => fmt.el("td"));
      const tr = fmt.el("tr", { "data-job": job.id }, fmt.el("th", { scope: "row" }, link), ...cells);
      row = { tr, cells };
      this.rows.set(job.id, row);
      const before = index === null ? this.tbody.firstChild : this.tbody.children[index];
      this.tbody.insertBefore(tr, before || null);
    }
    const values = [
      fmt.stateBadge(job.state),
      fmt.sceneLabel(job.request.scene),
      fmt.size(job.request),
      fmt.progressCell(job),
      fmt.noise(job.noise),
      fmt.count(job.samples_per_s),
      fmt.isFinal(job) ? "—" : fmt.duration(job.eta_s),
      String(job.workers),
    ];
    values.forEach((v, i) => row.cells[i].replaceChildren(v));
    row.tr.dataset.state = job.state;
  }
}
