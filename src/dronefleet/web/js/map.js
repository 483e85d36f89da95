// Leaflet maps that work offline: a plain grid with a scale bar under the (optional) tiles.
import { addSearch } from "./search.js";
import { addImagery } from "./tiles.js";

const L = window.L;
export const DEFAULT_CENTER = [40.63, -8.659];
const COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"];
const STATE_COLORS = { flying: "#2a7de1", armed: "#e1a12a", disarmed: "#6b7280", landing: "#8e44ad", lost: "#d62728" };

let configPromise = null;

/** The server's web config ({tiles}), fetched once. */
export function webConfig() {
  if (!configPromise) {
    configPromise = fetch("/api/v1/web/config").then((r) => r.json()).catch(() => ({ tiles: null }));
  }
  return configPromise;
}

/** A canvas grid: a line every 64 px, darker every 256 px; the scale bar gives the metres. */
const GridLayer = L.GridLayer.extend({
  createTile(coords) {
    const tile = document.createElement("canvas");
    const size = this.getTileSize();
    tile.width = size.x;
    tile.height = size.y;
    const g = tile.getContext("2d");
    g.fillStyle = "#f4f6f8";
    g.fillRect(0, 0, size.x, size.y);
    g.strokeStyle = "#dde2e7";
    g.lineWidth = 1;
    for (let p = 64; p < size.x; p += 64) {
      g.beginPath(); g.moveTo(p + 0.5, 0); g.lineTo(p + 0.5, size.y); g.stroke();
      g.beginPath(); g.moveTo(0, p + 0.5); g.lineTo(size.x, p + 0.5); g.stroke();
    }
    g.strokeStyle = "#b8c0c8";
    g.strokeRect(0.5, 0.5, size.x, size.y);
    return tile;
  },
});

/** A map in `element`; resolves once the tile/grid decision is made. `search`: a search box
 * (coordinates, drones, missions, addresses: web/js/search.js). */
export async function makeMap(element, { center, zoom = 18, search = false } = {}) {
  const map = L.map(element, { center: center || DEFAULT_CENTER, zoom, maxZoom: 22, attributionControl: false });
  new GridLayer({ maxZoom: 22, zIndex: 0 }).addTo(map);
  L.control.scale({ imperial: false, maxWidth: 150 }).addTo(map);
  // Leaflet measures its box once; a side panel that fills later narrows it, and "centre here"
  // would land off-centre (by half the change) until it is measured again.
  const resized = new ResizeObserver(() => map.invalidateSize({ pan: false }));
  resized.observe(element);
  map.on("unload", () => resized.disconnect());
  const view = await addImagery(map, await webConfig());
  if (view && !center) map.setView(view.center, view.zoom); // where the local imagery is
  if (search) addSearch(map);
  element.dataset.ready = "1";
  return map;
}

export function colorFor(index) {
  return COLORS[index % COLORS.length];
}

export function stateColor(drone) {
  if (drone.status === "lost") return STATE_COLORS.lost;
  return STATE_COLORS[drone.state] || "#374151";
}

const SVG = "http://www.w3.org/2000/svg";

/** An arrow pointing along `headingDeg`, coloured by state. Built from DOM nodes, never from an
 * HTML string: everything in `drone` came from the broker and is untrusted (issue 12). */
export function droneIcon(drone) {
  const lost = drone.status === "lost";
  const heading = Number.isFinite(drone.heading_deg) ? drone.heading_deg : 0;
  const root = document.createElement("div");
  const arrow = document.createElement("div");
  arrow.className = lost ? "drone-icon lost" : "drone-icon";
  arrow.style.transform = `rotate(${heading}deg)`;
  const svg = document.createElementNS(SVG, "svg");
  for (const [k, v] of Object.entries({ viewBox: "0 0 24 24", width: "24", height: "24", "aria-hidden": "true" })) svg.setAttribute(k, v);
  const path = document.createElementNS(SVG, "path");
  for (const [k, v] of Object.entries({ d: "M12 2 L20 21 L12 16 L4 21 Z", fill: stateColor(drone), stroke: "#fff", "stroke-width": "1.5" })) path.setAttribute(k, v);
  svg.appendChild(path);
  arrow.appendChild(svg);
  const label = document.createElement("span");
  label.className = "drone-label";
  label.textContent = `${drone.drone_id}${lost ? " (lost)" : ""}`;
  root.append(arrow, label);
  return L.divIcon({ html: root, className: "drone-marker", iconSize: [24, 24], iconAnchor: [12, 12] });
}

export function latLngOf(position) {
  return position ? [position.lat, position.lon] : null;
}
