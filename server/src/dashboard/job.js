// One job: live progress, preview, noise chart, settings, effects, contributions, frames, actions.
import { call, download, watchJob } from "./api.js";
import { renderChart, timeToTarget } from "./chart.js";
import * as fmt from "./format.js";

const $ = (id) => document.getElementById(id);
/** Fewest milliseconds between two preview downloads (each is a PNG encode on the coordinator). */
const PREVIEW_EVERY_MS = 300;

export function start(id, onError) {
  const view = new JobView(id, onError);
  view.run();
  return () => view.stop();
}

class JobView {
  constructor(id, onError) {
    this.id = id;
    this.path = `/v1/jobs/${encodeURIComponent(id)}`;
    this.onError = onError;
    this.ctl = new AbortController();
    this.job = null;
    this.preview = { key: null, busy: false, url: null, last: 0, timer: null };
    this.spoken = null;
    /** The animation frame the preview shows (null: the job's first frame). */
    this.previewFrame = null;
    this.reset();
  }

  reset() {
    $("j-id").textContent = this.id;
    $("j-state").replaceChildren();
    $("j-progress").value = 0;
    for (const id of ["j-progress-text", "j-live", "j-message", "j-chart-text"]) $(id).textContent = "";
    for (const id of ["j-facts", "j-effects", "j-chart"]) $(id).replaceChildren();
    $("j-contrib").tBodies[0].replaceChildren();
    $("j-frames").tBodies[0].replaceChildren();
    $("j-frames-card").hidden = true;
    $("j-zip").onclick = () => this.act(() => download(`${this.path}/frames.zip`, `${this.id}-frames.zip`));
    $("j-target").value = "";
    const img = $("j-preview");
    img.removeAttribute("src");
    delete img.dataset.samples;
    $("j-cancel").onclick = () => this.act(() => this.cancel());
    $("j-pause").onclick = () => this.act(() => this.togglePause());
    $("j-delete").onclick = () => this.act(() => this.delete());
    $("j-exr").onclick = () => this.act(() => download(`${this.path}/image.exr`, `${this.id}.exr`));
    $("j-png").onclick = () => this.act(() => download(`${this.path}/preview.png`, `${this.id}.png`));
    $("j-target").oninput = () => this.job && this.chart(this.job);
  }

  run() {
    watchJob(this.id, (job) => this.update(job), this.ctl.signal).catch((e) => e.name !== "AbortError" && this.onError(e));
  }

  stop() {
    this.ctl.abort();
    clearTimeout(this.preview.timer);
  }

  async act(f) {
    try {
      await f();
    } catch (e) {
      this.onError(e);
    }
  }

  async cancel() {
    const job = await (await call(this.path, { method: "DELETE" })).json();
    this.update(job);
  }

  /** Deletes the job for good (its images and checkpoints too), after asking; back to the list. */
  async delete() {
    if (!confirm(`Delete job ${this.id} and its images for good?`)) return;
    await call(`${this.path}?purge=true`, { method: "DELETE" });
    location.hash = "#/jobs";
  }

  /** Pauses a queued or running job, resumes a paused one. */
  async togglePause() {
    const action = this.job?.state === "paused" ? "resume" : "pause";
    this.update(await (await call(`${this.path}/${action}`, { method: "POST" })).json());
  }

  update(job) {
    this.job = job;
    const pct = Math.floor(job.progress.fraction * 100);
    $("j-state").replaceChildren(fmt.stateBadge(job.state));
    $("j-cancel").disabled = fmt.isFinal(job);
    $("j-pause").disabled = fmt.isFinal(job);
    $("j-pause").textContent = job.state === "paused" ? "Resume" : "Pause";
    $("j-progress").value = pct;
    const spp = `${job.progress.samples_done.toFixed(1)} of ${job.progress.samples_target} spp`;
    const eta = fmt.isFinal(job) ? "" : ` · ETA ${fmt.duration(job.eta_s)}`;
    $("j-progress-text").textContent = `${pct}% · ${spp} · noise ${fmt.noise(job.noise)}${eta}`;
    this.speak(job, pct);
    $("j-message").textContent = job.message || "";
    this.facts(job);
    $("j-effects").replaceChildren(...job.effects.map((e) => fmt.el("li", { text: e.replaceAll("_", " ") })));
    this.contributions(job);
    this.frames(job);
    this.chart(job);
    this.refreshPreview();
  }

  /** Tells screen readers about state changes and each further tenth of progress, not every event. */
  speak(job, pct) {
    const said = `${job.state} ${Math.floor(pct / 10)}`;
    if (said === this.spoken) return;
    this.spoken = said;
    $("j-live").textContent = `Job ${job.state}, ${pct}% done.`;
  }

  facts(job) {
    const r = job.request;
    const frames = job.frames || [];
    const rows = [
      ["Scene", fmt.sceneLabel(r.scene)],
      ["Size", fmt.size(r)],
      ["Frames", r.frames ? `${r.frames.start}–${r.frames.end}${(r.frames.step || 1) > 1 ? ` every ${r.frames.step}` : ""} at ${r.frames.fps ?? 24} fps` : "still"],
      ["Estimator", r.estimator || "mis"],
      ["Sampler", r.sampler || "sobol"],
      ["Seed", String(r.seed ?? 0)],
      ["Samples per pixel", `${job.progress.samples_done.toFixed(2)} / ${job.progress.samples_target}`],
      ["Noise (relMSE)", fmt.noise(job.noise)],
      ["Noise target", r.noise_target ? fmt.noise(r.noise_target) : "—"],
      ["Time limit", r.time_limit_s ? fmt.duration(r.time_limit_s) : "—"],
      ["Elapsed", fmt.duration(job.elapsed_s)],
      ["Samples/s", fmt.count(job.samples_per_s)],
      ["Workers now", String(job.workers)],
      // One renderer id per job unless it outlived every worker of its first (see the API docs).
      ["Renderer", (job.renderers || []).join(" + ") || "—"],
      ["Dropped samples", String(job.dropped_samples)],
      ["Largest sample weight", job.max_sample_weight.toPrecision(3)],
      // What workers reported with their results: scene load + BVH build (or refit) time summed
      // over units, and the largest peak resident memory of a worker process.
      ["Scene load + build", fmt.duration(frames.reduce((s, f) => s + f.prepare_ms, 0) / 1000)],
      ["Worker peak memory", fmt.bytes(Math.max(...frames.map((f) => f.worker_peak_rss_bytes ?? -Infinity)))],
      ["Submitted", new Date(job.created_unix_ms).toLocaleString()],
      ["Ended", job.ended_unix_ms ? new Date(job.ended_unix_ms).toLocaleString() : "—"],
    ];
    $("j-facts").replaceChildren(...rows.flatMap(([k, v]) => [fmt.el("dt", { text: k }), fmt.el("dd", { text: v })]));
  }

  contributions(job) {
    const list = job.contributions || [];
    const total = list.reduce((a, c) => a + c.samples, 0);
    const rows = list.map((c) => {
      const share = total > 0 ? c.samples / total : 0;
      const fill = fmt.el("span");
      fill.style.width = `${(share * 100).toFixed(1)}%`; // CSSOM: the CSP forbids inline style attributes
      const bar = fmt.el("span", { class: "share", "aria-hidden": "true" }, fill);
      return fmt.el(
        "tr", {},
        fmt.el("th", { scope: "row" }, `${c.name} `, fmt.el("span", { class: "muted mono", text: c.worker_id })),
        fmt.el("td", { class: "num", text: fmt.count(c.samples) }),
        fmt.el("td", {}, bar, ` ${Math.round(share * 100)}%`),
      );
    });
    if (!rows.length) rows.push(fmt.el("tr", {}, fmt.el("td", { colspan: 3, class: "muted", text: "No unit merged yet." })));
    $("j-contrib").tBodies[0].replaceChildren(...rows);
  }

  /** Per-frame progress for jobs with a frame range; a row's button puts that frame in the preview. */
  frames(job) {
    const animated = Boolean(job.request.frames);
    $("j-frames-card").hidden = !animated;
    if (!animated) return;
    const rows = (job.frames || []).map((f) => {
      const show = fmt.el("button", { type: "button", text: f.frame === this.previewFrame ? "shown" : "preview" });
      show.onclick = () => {
        this.previewFrame = f.frame;
        this.preview.key = null;
        this.frames(this.job);
        this.refreshPreview();
      };
      const exr = fmt.el("button", { type: "button", text: "EXR" });
      exr.onclick = () => this.act(() => download(`${this.path}/frames/${f.frame}/image.exr`, `${this.id}_${String(f.frame).padStart(4, "0")}.exr`));
      return fmt.el(
        "tr", {},
        fmt.el("th", { scope: "row", text: `${f.frame}${f.done ? " ✓" : ""}` }),
        fmt.el("td", { class: "num", text: `${f.time_s.toFixed(3)} s` }),
        fmt.el("td", { class: "num", text: f.samples_done.toFixed(1) }),
        fmt.el("td", { class: "num", text: fmt.noise(f.noise) }),
        fmt.el("td", { class: "num", text: `${f.builds} / ${f.refits} (${fmt.duration(f.prepare_ms / 1000)})` }),
        fmt.el("td", {}, show, " ", exr),
      );
    });
    $("j-frames").tBodies[0].replaceChildren(...rows);
  }

  chart(job) {
    const typed = Number($("j-target").value);
    const target = typed > 0 ? typed : job.request.noise_target || null;
    $("j-target").placeholder = job.request.noise_target ? String(job.request.noise_target) : "what if…";
    renderChart($("j-chart"), job.history, target);
    const t = timeToTarget(job.history, target);
    const last = job.history[job.history.length - 1];
    let text = last ? `Noise ${fmt.noise(last[2])} after ${fmt.duration(last[0])}.` : "No noise estimate yet (needs two samples per pixel).";
    if (t !== null) text += ` Reaching ${fmt.noise(target)} takes ≈ ${fmt.duration(t)} in all (noise ∝ 1/time).`;
    $("j-chart-text").textContent = text;
  }

  /** Downloads the preview again when the merge changed, at most every PREVIEW_EVERY_MS. */
  refreshPreview() {
    const p = this.preview;
    const job = this.job;
    const key = `${job.progress.samples_done}|${job.state}|${this.previewFrame}`;
    if (key === p.key || p.busy || p.timer) return;
    const wait = p.last + PREVIEW_EVERY_MS - Date.now();
    if (wait > 0) {
      p.timer = setTimeout(() => {
        p.timer = null;
        this.refreshPreview();
      }, wait);
      return;
    }
    p.key = key;
    p.busy = true;
    p.last = Date.now();
    this.loadPreview(job.progress.samples_done)
      .catch((e) => e.name !== "AbortError" && this.onError(e))
      .finally(() => {
        p.busy = false;
        if (!this.ctl.signal.aborted) this.refreshPreview();
      });
  }

  async loadPreview(samples) {
    const frame = this.previewFrame;
    const path = frame === null ? `${this.path}/preview.png` : `${this.path}/frames/${frame}/preview.png`;
    const blob = await (await call(path, { signal: this.ctl.signal })).blob();
    const url = URL.createObjectURL(blob);
    const img = $("j-preview");
    const old = this.preview.url;
    img.src = url;
    img.dataset.samples = String(samples);
    const which = frame === null ? "" : `Frame ${frame}: `;
    $("j-preview-cap").textContent = `${which}Preview at ${samples.toFixed(1)} samples per pixel (sRGB)`;
    this.preview.url = url;
    if (old) setTimeout(() => URL.revokeObjectURL(old), 1000);
  }
}
