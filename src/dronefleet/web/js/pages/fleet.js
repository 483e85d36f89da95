// Fleet: every drone live on the map (position, heading, trail, colour by state) and in a table.
import { batteryLevel, dronePanel } from "../drone-panel.js";
import { api } from "../api.js";
import { droneIcon, latLngOf, makeMap, stateColor } from "../map.js";
import { fleetColor, fleetOverlay } from "../map-fleet.js";
import { missionProgress } from "../mission-progress.js";
import { el, fmtAgo } from "../ui.js";

const L = window.L;

const ENDED = new Set(["completed", "failed", "stopped", "planned"]);
/** Running missions shown at most (the newest). */
const MAX_SHOWN = 5;

/** Every running mission's progress (issue 29), read every 3 s: bars, steps, time left, events. */
function runningMissions() {
  const list = el("div", { class: "missions-list" });
  const none = el("p", { class: "hint", id: "fleet-no-mission" }, "No mission is running.");
  const shown = new Map();  // mission id -> its progress panel
  const element = el("section", { id: "fleet-missions", "aria-label": "Running missions" }, el("h2", {}, "Running missions"), none, list);

  async function refresh() {
    let running;
    try {
      running = (await api("/missions")).filter((m) => !ENDED.has(m.state)).slice(0, MAX_SHOWN);
    } catch { return; }  // the link state says why; the panels stay as they were
    const views = await Promise.all(running.map((m) => api(`/missions/${m.mission_id}/progress`).catch(() => null)));
    const keep = new Set();
    running.forEach((m, i) => {
      if (!views[i]) return;
      keep.add(m.mission_id);
      if (!shown.has(m.mission_id)) {
        const safe = m.mission_id.replace(/[^A-Za-z0-9_-]/g, "_");
        const panel = missionProgress({ idPrefix: `fleet-progress-${safe}` });
        panel.box = el("article", { class: "fleet-mission", "data-mission": m.mission_id }, el("h3", {}, `${m.name || "mission"} (${m.mission_id})`), panel.element);
        shown.set(m.mission_id, panel);
      }
      shown.get(m.mission_id).show(views[i]);
    });
    for (const id of [...shown.keys()]) if (!keep.has(id)) shown.delete(id);
    list.replaceChildren(...[...shown.values()].map((p) => p.box));
    none.hidden = shown.size > 0;
  }
  return { element, refresh };
}

/** The battery with its level in words as well as colour (issue 14). */
function batteryCell(d) {
  if (!d.battery) return el("td", {}, "—");
  const pct = d.battery.remaining_pct;
  const level = batteryLevel(pct);
  return el("td", { class: `battery ${level.level}`, "data-level": level.level }, `${pct.toFixed(0)} % ${level.word}`);
}

export async function mount(root, ctx) {
  const mapBox = el("div", { class: "map", id: "fleet-map", role: "region", "aria-label": "Fleet map" });
  const body = el("tbody");
  const table = el("table", { class: "grid", id: "fleet-table" },
    el("caption", {}, "Drones"),
    el("thead", {}, el("tr", {}, ...["Drone", "State", "Battery", "Mode", "Mission", "Last alarm", "Last seen"].map((h) => el("th", { scope: "col" }, h)))),
    body);
  // The side scrolls on a phone: focusable so a keyboard can scroll it too (axe: scrollable-region).
  const panel = dronePanel(ctx, { idPrefix: "fleet-panel" });
  const select = (id) => {
    panel.show(id);
    for (const b of body.querySelectorAll("button.select")) b.setAttribute("aria-pressed", String(b.dataset.drone === id));
  };
  const missions = runningMissions();
  root.append(el("h1", {}, "Fleet"), el("div", { class: "split" }, mapBox,
    el("div", { class: "side", tabindex: "0", role: "region", "aria-label": "Drones and the selected drone" }, table, missions.element, panel.element)));
  const map = await makeMap(mapBox, { search: true });
  const markers = new Map();
  const overlay = fleetOverlay(map, ctx.fleet); // homes, targets, tracks (issue 29)
  let fitted = false;

  function render() {
    const drones = ctx.fleet.list();
    // Rows are rebuilt every update: a keyboard on a drone's button stays on it.
    const focused = body.contains(document.activeElement) ? document.activeElement.dataset.drone : null;
    body.replaceChildren(...drones.map((d) => el("tr", { "data-drone": d.drone_id, "data-status": d.status || "", "data-alarm": d.alarm ? d.alarm.level : "", class: d.status === "lost" ? "lost" : "" },
      el("th", { scope: "row" }, el("span", { class: "dot", style: `background:${stateColor(d)}` }),
        el("button", { type: "button", class: "select link-button", "data-drone": d.drone_id, "aria-pressed": String(panel.selected === d.drone_id),
          title: `Show ${d.drone_id} below`, onclick: () => select(d.drone_id) }, d.drone_id)),
      el("td", { class: "state" }, d.status === "lost" ? "LOST" : d.status === "autopilot link lost" ? "AUTOPILOT LINK LOST" : d.state || "—"),
      batteryCell(d),
      el("td", {}, d.mode || "—"),
      el("td", {}, d.mission_id || "—"),
      el("td", { class: d.alarm ? "alarm" : "" }, d.alarm ? `${d.alarm.level} ${d.alarm.message} (${fmtAgo(Date.now() / 1000 - d.alarm.at)})` : "—"),
      el("td", {}, fmtAgo(d.last_seen ? Math.max(0, Date.now() / 1000 - d.last_seen) : d.seen_ago_s)))));
    if (focused) body.querySelector(`button.select[data-drone="${CSS.escape(focused)}"]`)?.focus();
    const points = [];
    for (const d of drones) {
      const at = latLngOf(d.position);
      if (!at) continue;
      points.push(at);
      let m = markers.get(d.drone_id);
      if (!m) {
        m = { marker: L.marker(at, { icon: droneIcon(d), keyboard: false }).on("click", () => select(d.drone_id)).addTo(map) };
        markers.set(d.drone_id, m);
      }
      m.marker.setLatLng(at).setIcon(droneIcon(d, fleetColor(ctx.fleet, d.drone_id)));
    }
    overlay.update();
    if (!fitted && points.length) {
      // At once, not animated: a page left during Leaflet's zoom animation had its map removed
      // under it ("Cannot read properties of undefined (reading '_leaflet_pos')", CI).
      map.fitBounds(L.latLngBounds(points).pad(0.5), { maxZoom: 19, animate: false });
      fitted = true;
    }
  }

  let pending = false;
  let gone = false; // the page was left: a frame asked for before must not touch the removed map
  const onChange = () => {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => { pending = false; if (!gone) render(); });
  };
  ctx.fleet.addEventListener("change", onChange);
  const ticker = setInterval(render, 2000);
  const missionTicker = setInterval(missions.refresh, 3000);
  missions.refresh();
  render();
  return () => {
    gone = true;
    panel.destroy();
    ctx.fleet.removeEventListener("change", onChange);
    clearInterval(ticker);
    clearInterval(missionTicker);
    map.remove();
  };
}
