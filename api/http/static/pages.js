// The pages of the one-page UI, chosen by the URL hash (#rig, #runs, #results/12 …): each
// module registers what to do when its page is shown (onPage), and showPage shows the page the
// hash names and runs those loaders.
import { $$ } from "./dom.js";

/** Hash words shown on another page: #results/12 is a stored result on the Estimation page. */
const PAGE_ALIASES = { results: "estimation" };

/** Per hash word, the loaders registered for it, in registration order. */
const loaders = {};

/** Runs `loader` each time the page (or hash word) `word` is shown. */
export function onPage(word, loader) {
  (loaders[word] ||= []).push(loader);
}

/** Shows the page the hash names (default: the Rig page) and runs its loaders; a hash word
 * shown on another page (#results/12) runs its own loaders first. */
export function showPage() {
  const word = location.hash.replace("#", "").split(/[&/]/)[0] || "rig";
  const page = PAGE_ALIASES[word] || word;
  $$(".page").forEach((s) => (s.hidden = s.id !== `page-${page}`));
  $$("nav a").forEach((a) => a.classList.toggle("active", a.dataset.page === page));
  if (word !== page) for (const load of loaders[word] || []) load();
  for (const load of loaders[page] || []) load();
}
