// Entry point: the token field, the hash router (#/jobs, #/job/{id}, #/workers) and the banner.
// Each view exports start(root, ...) → stop(); the router stops the old view before starting
// the next, so no stream or timer outlives its page.
import { token } from "./api.js";
import * as jobs from "./jobs.js";
import * as job from "./job.js";
import * as workers from "./workers.js";

const $ = (id) => document.getElementById(id);
let stopView = () => {};

/** Shows a page-wide message (role=alert), or hides it when `text` is empty. */
export function banner(text) {
  const b = $("banner");
  b.textContent = text || "";
  b.hidden = !text;
}

function route() {
  stopView();
  banner("");
  const hash = location.hash || "#/jobs";
  const m = hash.match(/^#\/job\/(.+)$/);
  const name = m ? "job" : hash === "#/workers" ? "workers" : "jobs";
  for (const v of ["jobs", "job", "workers"]) $(`view-${v}`).hidden = v !== name;
  for (const v of ["jobs", "workers"]) {
    const link = $(`nav-${v}`);
    if (v === name || (v === "jobs" && name === "job")) link.setAttribute("aria-current", "page");
    else link.removeAttribute("aria-current");
  }
  const onError = (e) => banner(e.message);
  if (name === "job") stopView = job.start(decodeURIComponent(m[1]), onError);
  else if (name === "workers") stopView = workers.start(onError);
  else stopView = jobs.start(onError);
}

function initToken() {
  const input = $("token");
  input.value = token.get();
  $("token-form").addEventListener("submit", (e) => {
    e.preventDefault();
    token.set(input.value.trim());
    route(); // reload the view's data with the new token
  });
}

initToken();
window.addEventListener("hashchange", () => {
  route();
  $("main").focus({ preventScroll: true });
});
route();
