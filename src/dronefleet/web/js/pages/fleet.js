// Fleet: every drone live on the map (position, heading, trail, colour by state) and in a table.
import { droneIcon, latLngOf, makeMap, stateColor } from "../map.js";
import { el, fmtAgo } from "../ui.js";

const L = window.L;

export async function mount(root, ctx) {
  const mapBox = el("div", { class: "map", id: "fleet-map", role: "region", "aria-label": "Fleet map" });
  const body = el("tbody");
  const table = el("table", { class: "grid", id: "fleet-table" },
    el("caption", {}, "Drones"),
    el("thead", {}, el("tr", {}, ...["Drone", "State", "Battery", "Mode", "Mission", "Last alarm", "Last seen"].map((h) => el("th", { scope: "col" }, h)))),
    body);
  root.append(el("h1", {}, "Fleet"), el("div", { class: "split" }, mapBox, el("div", { class: "side" }, table)));
  const map = await makeMap(mapBox);
  const markers = new Map();
  let fitted = false;

  function render() {
    const drones = ctx.fleet.list();
    body.replaceChildren(...drones.map((d) => el("tr", { "data-drone": d.drone_id, "data-status": d.status || "", "data-alarm": d.alarm ? d.alarm.level : "", class: d.status === "lost" ? "lost" : "" },
      el("th", { scope: "row" }, el("span", { class: "dot", style: `background:${stateColor(d)}` }), d.drone_id),
      el("td", { class: "state" }, d.status === "lost" ? "LOST" : d.status === "autopilot link lost" ? "AUTOPILOT LINK LOST" : d.state || "—"),
      el("td", {}, d.battery ? `${d.battery.remaining_pct.toFixed(0)} %` : "—"),
      el("td", {}, d.mode || "—"),
      el("td", {}, d.mission_id || "—"),
      el("td", { class: d.alarm ? "alarm" : "" }, d.alarm ? `${d.alarm.level} ${d.alarm.message} (${fmtAgo(Date.now() / 1000 - d.alarm.at)})` : "—"),
      el("td", {}, fmtAgo(d.last_seen ? Math.max(0, Date.now() / 1000 - d.last_seen) : d.seen_ago_s)))));
    const points = [];
    for (const d of drones) {
      const at = latLngOf(d.position);
      if (!at) continue;
      points.push(at);
      let m = markers.get(d.drone_id);
      if (!m) {
        m = {
          marker: L.marker(at, { icon: droneIcon(d), keyboard: false }).addTo(map),
          trail: L.polyline([], { weight: 2, opacity: 0.6 }).addTo(map),
        };
        markers.set(d.drone_id, m);
      }
      m.marker.setLatLng(at).setIcon(droneIcon(d));
      m.trail.setLatLngs(d.trail).setStyle({ color: stateColor(d) });
    }
    if (!fitted && points.length) {
      map.fitBounds(L.latLngBounds(points).pad(0.5), { maxZoom: 19 });
      fitted = true;
    }
  }

  let pending = false;
  const onChange = () => {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => { pending = false; render(); });
  };
  ctx.fleet.addEventListener("change", onChange);
  const ticker = setInterval(render, 2000);
  render();
  return () => {
    ctx.fleet.removeEventListener("change", onChange);
    clearInterval(ticker);
    map.remove();
  };
}
