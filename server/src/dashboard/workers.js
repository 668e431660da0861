// The workers page: GET /v1/workers, refreshed every two seconds while shown.
import { getJson } from "./api.js";
import * as fmt from "./format.js";

const $ = (id) => document.getElementById(id);
const EVERY_MS = 2000;

export function start(onError) {
  let stopped = false;
  const refresh = async () => {
    try {
      const workers = await getJson("/v1/workers");
      if (!stopped) show(workers);
    } catch (e) {
      onError(e);
    }
  };
  refresh();
  const timer = setInterval(refresh, EVERY_MS);
  return () => {
    stopped = true;
    clearInterval(timer);
  };
}

/** "job/tile/batch" → a link to the job plus the unit; idle, and why when jobs refuse it. */
function unit(current, idleReason) {
  if (!current) return fmt.el("span", { class: "muted", text: idleReason ? `idle: ${idleReason}` : "idle" });
  const [job, tile, batch] = current.split("/");
  const link = fmt.el("a", { href: `#/job/${encodeURIComponent(job)}`, class: "mono", text: job });
  return fmt.el("span", {}, link, ` tile ${tile}, batch ${batch}`);
}

function show(workers) {
  $("workers-empty").hidden = workers.length > 0;
  const rows = workers.map((w) =>
    fmt.el(
      "tr", { "data-worker": w.id },
      fmt.el("th", { scope: "row", text: w.name }),
      fmt.el("td", { class: "mono", text: w.id }),
      fmt.el("td", { class: "num", text: String(w.threads) }),
      fmt.el("td", {}, unit(w.current, w.idle_reason)),
      fmt.el("td", { class: "num", text: String(w.units_done) }),
      fmt.el("td", { class: `num${w.failures ? " warn" : ""}`, text: String(w.failures) }),
      fmt.el("td", { text: `${fmt.duration(w.last_seen_ms_ago / 1000)} ago` }),
      fmt.el("td", { class: "num", text: w.rss_bytes === undefined ? "—" : `${fmt.bytes(w.rss_bytes)} (peak ${fmt.bytes(w.peak_rss_bytes)})` }),
      fmt.el("td", { class: "mono", text: w.renderer || "—" }),
    ),
  );
  $("workers").tBodies[0].replaceChildren(...rows);
}
