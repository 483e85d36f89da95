// Photos: what the drones photographed, per mission (issue 14). Thumbnails with the drone, the
// step and where each was taken; a click shows the picture as the drone took it; "Download
// all" saves the zip of geotagged JPEGs that photogrammetry tools (OpenDroneMap) read.
import { api } from "../api.js";
import { apiBlob, saveBlob } from "../files.js";
import { addMissionOptions } from "../missions.js";
import { el, field, toast } from "../ui.js";

const POLL_MS = 3000; // a mission in flight: its new pictures appear as they reach the ground

export async function mount(root) {
  const pick = el("select", { id: "gallery-mission" }, el("option", { value: "" }, "— pick a mission —"));
  const download = el("button", { type: "button", id: "gallery-zip", disabled: true }, "Download all (.zip)");
  const summary = el("p", { id: "gallery-summary", role: "status", "aria-live": "polite" }, "No mission picked.");
  const grid = el("ul", { id: "gallery-grid", class: "gallery" });
  const big = el("img", { id: "gallery-picture", alt: "" });
  const caption = el("p", { id: "gallery-caption" });
  const viewer = el("dialog", { id: "gallery-viewer", class: "picture-viewer", "aria-label": "Picture" },
    big, caption, el("form", { method: "dialog" }, el("button", { type: "submit" }, "Close")));
  root.append(el("h1", {}, "Photos"),
    el("div", { class: "controls" }, field("Mission", pick), download), summary, grid, viewer);

  const urls = new Set(); // blob: URLs, let go when the page is left
  const cards = new Map(); // picture number -> its <li>
  let mission = null;

  const keep = (blob) => { const url = URL.createObjectURL(blob); urls.add(url); return url; };
  const describe = (p) => `#${p.n} ${p.drone_id} · step ${p.step ?? p.drone_step} · ${p.lat.toFixed(6)}, ${p.lon.toFixed(6)}`
    + (Number.isFinite(p.relative_alt_m) ? ` · ${p.relative_alt_m.toFixed(1)} m up` : "");

  async function show(p) {
    try {
      big.src = keep(await apiBlob(`/missions/${encodeURIComponent(mission)}/photos/${p.n}`));
      big.alt = `picture ${p.n} by ${p.drone_id}`;
      caption.textContent = describe(p);
      viewer.dataset.n = String(p.n);
      if (!viewer.open) viewer.showModal();
    } catch (err) {
      toast(`picture ${p.n}: ${err.message}`, "error");
    }
  }

  function card(p) {
    const thumb = el("img", { class: "thumb", alt: `thumbnail of picture ${p.n}` });
    const open = el("button", { type: "button", class: "thumb-button", "aria-label": `open picture ${p.n}`, onclick: () => show(p) }, thumb);
    const note = el("span", { class: "hint" });
    const li = el("li", { class: "photo", "data-n": String(p.n) }, el("figure", {}, open, el("figcaption", {}, describe(p), note)));
    li.thumb = thumb;
    li.note = note;
    return li;
  }

  async function refresh() {
    if (!mission) return;
    const id = mission;
    let list;
    try {
      list = await api(`/missions/${encodeURIComponent(id)}/photos`);
    } catch (err) {
      summary.textContent = `Pictures: ${err.message}`;
      return;
    }
    if (id !== mission) return; // another mission was picked meanwhile
    for (const p of list) {
      if (!cards.has(p.n)) { cards.set(p.n, card(p)); grid.append(cards.get(p.n)); }
      const li = cards.get(p.n);
      li.note.textContent = p.stored ? "" : ` — ${p.error || "on its way from the drone"}`;
      if (p.stored && !li.dataset.stored) {
        li.dataset.stored = "1";
        apiBlob(`/missions/${encodeURIComponent(id)}/photos/${p.n}/thumb`)
          .then((blob) => { li.thumb.src = keep(blob); li.dataset.thumb = "1"; })
          .catch((err) => { li.note.textContent = ` — ${err.message}`; delete li.dataset.stored; });
      }
    }
    const stored = list.filter((p) => p.stored).length;
    summary.textContent = list.length
      ? `${list.length} picture(s), ${stored} on the ground.`
      : "No pictures in this mission (yet).";
    summary.dataset.count = String(list.length);
    summary.dataset.stored = String(stored);
    download.disabled = stored === 0;
  }

  function choose(id) {
    mission = id || null;
    cards.clear();
    grid.replaceChildren();
    for (const url of urls) URL.revokeObjectURL(url);
    urls.clear();
    download.disabled = true;
    summary.textContent = mission ? "Loading…" : "No mission picked.";
    refresh();
  }

  download.addEventListener("click", async () => {
    try {
      saveBlob(await apiBlob(`/missions/${encodeURIComponent(mission)}/photos.zip`), `mission-${mission}-photos.zip`);
    } catch (err) {
      toast(`download failed: ${err.message}`, "error");
    }
  });
  pick.addEventListener("focus", () => addMissionOptions(pick).catch(() => {}));
  pick.addEventListener("change", () => choose(pick.value));
  try {
    await addMissionOptions(pick);
  } catch (err) {
    toast(`missions: ${err.message}`, "error");
  }
  const wanted = new URLSearchParams(location.hash.split("?")[1] || "").get("mission");
  if (wanted && [...pick.options].some((o) => o.value === wanted)) { pick.value = wanted; choose(wanted); }
  const poller = setInterval(refresh, POLL_MS);
  return () => {
    clearInterval(poller);
    for (const url of urls) URL.revokeObjectURL(url);
  };
}
