// Small DOM and number-formatting helpers shared by the views.

/** el("td", {class: "x"}, child, "text", …): an element with attributes and children. */
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === null || v === undefined || v === false) continue;
    if (k === "text") e.textContent = v;
    else e.setAttribute(k, v === true ? "" : v);
  }
  e.append(...children.filter((c) => c !== null && c !== undefined));
  return e;
}

export const FINAL = ["done", "failed", "canceled"];
export const isFinal = (job) => FINAL.includes(job.state);

export function duration(s) {
  if (s === null || s === undefined || !isFinite(s)) return "—";
  if (s < 1) return `${(s * 1000).toFixed(0)} ms`;
  if (s < 60) return `${s.toFixed(s < 10 ? 1 : 0)} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${Math.round(s % 60)} s`;
  return `${Math.floor(s / 3600)} h ${Math.round((s % 3600) / 60)} min`;
}

export function noise(n) {
  return n === null || n === undefined || !isFinite(n) || n <= 0 ? "—" : n.toExponential(2);
}

/** 1234567 → "1.23 M". */
export function count(n) {
  if (!isFinite(n)) return "—";
  const units = [[1e9, "G"], [1e6, "M"], [1e3, "k"]];
  for (const [f, u] of units) if (Math.abs(n) >= f) return `${(n / f).toPrecision(3)} ${u}`;
  return `${Math.round(n)}`;
}

/** 1536 → "1.5 KiB"; null or absent → "—". */
export function bytes(n) {
  if (n === null || n === undefined || !isFinite(n)) return "—";
  const units = [[2 ** 30, "GiB"], [2 ** 20, "MiB"], [2 ** 10, "KiB"]];
  for (const [f, u] of units) if (n >= f) return `${(n / f).toPrecision(3)} ${u}`;
  return `${n} B`;
}

export const percent = (f) => `${Math.floor(Math.min(1, Math.max(0, f)) * 100)}%`;

/** A bundled name as is; a sha256 id shortened. */
export const sceneLabel = (s) => (/^[0-9a-f]{64}$/.test(s) ? `upload ${s.slice(0, 10)}…` : s);

export const size = (req) => `${req.width}×${req.height}`;

export function stateBadge(state) {
  return el("span", { class: `state s-${state}`, text: state });
}

export function progressCell(job) {
  const pct = Math.floor(job.progress.fraction * 100);
  const bar = el("progress", { max: 100, value: pct, "aria-label": `Progress of job ${job.id}` });
  return el("span", { class: "cell-progress" }, bar, el("span", { class: "mono", text: `${pct}%` }));
}
