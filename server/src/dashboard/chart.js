// Noise against time, log-log, as hand-written SVG: the measured history, the noise target, and
// the extrapolation to it. Monte Carlo noise (relMSE) falls as 1/samples, i.e. as 1/time at a
// steady rate, so on log-log axes the price of each extra digit of accuracy is a straight line.
const SVG = "http://www.w3.org/2000/svg";
const W = 560, H = 300;
const M = { l: 64, r: 18, t: 14, b: 42 };
/** The axes reach at most this factor beyond the measured time, however far off the target is. */
const MAX_REACH = 1e4;

function svg(tag, attrs = {}, text = null) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== null) e.textContent = text;
  return e;
}

/** [t_s, noise] rows usable on log axes. */
function measured(history) {
  return (history || []).filter((r) => r[0] > 0 && r[2] > 0).map((r) => [r[0], r[2]]);
}

/** Fit noise·t = c over the newest third of the history (geometric mean), or null. */
function fitConstant(history) {
  const pts = measured(history);
  if (!pts.length) return null;
  const tail = pts.slice(-Math.max(1, Math.floor(pts.length / 3)));
  return Math.exp(tail.reduce((a, [t, n]) => a + Math.log(t * n), 0) / tail.length);
}

/** Seconds from the job's start until the noise reaches `target`, assuming noise ∝ 1/time. */
export function timeToTarget(history, target) {
  const c = fitConstant(history);
  return c !== null && target > 0 ? c / target : null;
}

/** log10 range [lo, hi] padded by 4%, never empty. */
function logRange(values) {
  let lo = Math.log10(Math.min(...values));
  let hi = Math.log10(Math.max(...values));
  if (hi - lo < 0.3) [lo, hi] = [lo - 0.3, hi + 0.3];
  const pad = (hi - lo) * 0.04;
  return [lo - pad, hi + pad];
}

/** Tick values: every decade, plus 2 and 5 when fewer than three decades show. */
function ticks([lo, hi]) {
  const out = [];
  const mult = hi - lo < 3 ? [1, 2, 5] : [1];
  for (let d = Math.floor(lo); d <= Math.ceil(hi); d++) {
    for (const m of mult) {
      const v = m * 10 ** d;
      if (Math.log10(v) >= lo && Math.log10(v) <= hi) out.push(v);
    }
  }
  return out;
}

const label = (v) => (v >= 0.01 && v < 1e4 ? String(+v.toPrecision(2)) : v.toExponential(0));

export function renderChart(root, history, target) {
  const pts = measured(history);
  const tTarget = timeToTarget(history, target);
  const chart = svg("svg", { viewBox: `0 0 ${W} ${H}`, role: "img", "aria-labelledby": "chart-title chart-desc", class: "chart" });
  chart.append(svg("title", { id: "chart-title" }, "Noise against time, log-log"));
  const desc = svg("desc", { id: "chart-desc" });
  chart.append(desc);
  if (!pts.length) {
    desc.textContent = "No noise estimate yet.";
    chart.append(svg("text", { x: W / 2, y: H / 2, "text-anchor": "middle", class: "axis-label" }, "Waiting for the first noise estimate…"));
    root.replaceChildren(chart);
    return;
  }
  const tLast = pts[pts.length - 1][0];
  const xs = pts.map((p) => p[0]);
  if (tTarget !== null) xs.push(Math.min(tTarget, tLast * MAX_REACH));
  const ys = pts.map((p) => p[1]);
  if (target > 0) ys.push(target);
  const xr = logRange(xs), yr = logRange(ys);
  const x = (t) => M.l + ((Math.log10(t) - xr[0]) / (xr[1] - xr[0])) * (W - M.l - M.r);
  const y = (n) => H - M.b - ((Math.log10(n) - yr[0]) / (yr[1] - yr[0])) * (H - M.t - M.b);
  axes(chart, xr, yr, x, y);
  const clip = svg("clipPath", { id: "plot-area" });
  clip.append(svg("rect", { x: M.l, y: M.t, width: W - M.l - M.r, height: H - M.t - M.b }));
  chart.append(clip);
  const plot = svg("g", { "clip-path": "url(#plot-area)" });
  chart.append(plot);
  const c = fitConstant(history);
  const [t0, t1] = [10 ** xr[0], 10 ** xr[1]];
  plot.append(svg("line", { x1: x(t0), y1: y(c / t0), x2: x(t1), y2: y(c / t1), class: "fit" }));
  plot.append(svg("polyline", { points: pts.map(([t, n]) => `${x(t).toFixed(1)},${y(n).toFixed(1)}`).join(" "), class: "measured" }));
  plot.append(svg("circle", { cx: x(tLast), cy: y(pts[pts.length - 1][1]), r: 4, class: "measured-dot" }));
  let summary = `${pts.length} measurements from ${label(xs[0])} s to ${label(tLast)} s; noise from ${label(ys[0])} to ${label(pts[pts.length - 1][1])}.`;
  if (target > 0) {
    plot.append(svg("line", { x1: M.l, x2: W - M.r, y1: y(target), y2: y(target), class: "target" }));
    chart.append(svg("text", { x: M.l + 6, y: y(target) - 6, class: "target-label" }, `target ${label(target)}`));
    if (tTarget !== null && tTarget <= tLast * MAX_REACH) {
      plot.append(svg("circle", { cx: x(tTarget), cy: y(target), r: 5, class: "eta-dot" }));
      // Beside the dot, on the side with room, above the target line (the x labels are below).
      const anchor = x(tTarget) > (M.l + W - M.r) / 2 ? "end" : "start";
      const dx = anchor === "end" ? -9 : 9;
      chart.append(svg("text", { x: x(tTarget) + dx, y: y(target) - 8, "text-anchor": anchor, class: "eta-label" }, `≈ ${label(tTarget)} s`));
    }
    summary += ` Target ${label(target)}, reached at about ${tTarget === null ? "?" : label(tTarget)} s.`;
  }
  desc.textContent = summary;
  root.replaceChildren(chart);
}

function axes(chart, xr, yr, x, y) {
  const g = svg("g", { class: "axes" });
  for (const t of ticks(xr)) {
    g.append(svg("line", { x1: x(t), x2: x(t), y1: M.t, y2: H - M.b, class: "grid" }));
    g.append(svg("text", { x: x(t), y: H - M.b + 16, "text-anchor": "middle" }, label(t)));
  }
  for (const n of ticks(yr)) {
    g.append(svg("line", { x1: M.l, x2: W - M.r, y1: y(n), y2: y(n), class: "grid" }));
    g.append(svg("text", { x: M.l - 6, y: y(n) + 4, "text-anchor": "end" }, label(n)));
  }
  g.append(svg("rect", { x: M.l, y: M.t, width: W - M.l - M.r, height: H - M.t - M.b, class: "frame" }));
  g.append(svg("text", { x: (M.l + W - M.r) / 2, y: H - 6, "text-anchor": "middle", class: "axis-label" }, "time since start (s)"));
  g.append(svg("text", { x: 14, y: (M.t + H - M.b) / 2, "text-anchor": "middle", transform: `rotate(-90 14 ${(M.t + H - M.b) / 2})`, class: "axis-label" }, "noise (relMSE)"));
  chart.append(g);
}
