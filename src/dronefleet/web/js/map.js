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
  keepLabelsApart(map);
  element.dataset.ready = "1";
  return map;
}

/** Drones' name labels never cover each other (issue 29): three drones ten metres apart at the
 * default zoom had their names on top of each other. Each label keeps its place beside its
 * arrow when it is free (of other labels and of the arrows), else moves up or down by whole
 * label heights to the nearest free row.
 * The plug-ins found (Leaflet.LayerGroup.Collision, LabelTextCollision, labelgun) hide the
 * labels that collide, and an operator must see every drone's name; leaflet-tooltip-layout
 * expects markers that do not move. */
function keepLabelsApart(map) {
  const pane = map.getPane("markerPane");
  const place = () => placeLabels(pane);
  // A marker moves by its style; a new icon's label is new content (Leaflet reuses the icon's
  // box). The labels' own shifts are style changes too, and are not a reason to run again. An
  // observer runs before the browser paints: a label is never drawn in its colliding place.
  const watch = new MutationObserver((changes) => {
    if (changes.some((c) => c.type === "childList" || !c.target.classList.contains("drone-label"))) place();
  });
  watch.observe(pane, { childList: true, attributes: true, subtree: true, attributeFilter: ["style"] });
  // Only what is on screen is laid out, so a pan (the map centring on the fleet once it is
  // known) lays out again: an arrow that was off screen had been left out, and a name moved
  // onto it (seen on the Control page: QUAD_3's name over QUAD_2's arrow).
  map.on("zoomend moveend", place);
  map.on("unload", () => watch.disconnect());
}

const MAX_SHIFT_ROWS = 6;

/** Only what is on screen is laid out: pairs are compared, and a big fleet is mostly off it. */
function placeLabels(pane) {
  const container = pane.closest(".leaflet-container");
  if (!container) return; // the map has left the page (a pan's last event after it)
  const view = container.getBoundingClientRect();
  const seen = (r) => r.width > 0 && r.right > view.left && r.left < view.right && r.bottom > view.top && r.top < view.bottom;
  const labels = [...pane.querySelectorAll(".drone-label")];
  for (const label of labels) label.style.transform = "";
  // The arrows are in the way too: a name over another drone's arrow hides that drone.
  const placed = [...pane.querySelectorAll(".drone-icon")].map((icon) => icon.getBoundingClientRect()).filter(seen);
  const boxes = labels.map((label) => ({ label, r: label.getBoundingClientRect() }))
    .filter(({ r }) => seen(r))
    .sort((a, b) => a.r.top - b.r.top || a.r.left - b.r.left);
  for (const { label, r } of boxes) {
    const row = r.height + 2;
    let shift = 0;
    for (let k = 0; k <= 2 * MAX_SHIFT_ROWS; k += 1) {
      // 0, +1, -1, +2, -2, ... rows
      const dy = (k % 2 ? 1 : -1) * Math.ceil(k / 2) * row;
      const box = { left: r.left, right: r.right, top: r.top + dy, bottom: r.bottom + dy };
      // A pixel clear of everything: a name placed edge to edge with an arrow was drawn over
      // it by a hundred-thousandth of a pixel (the shift rounded as the style's number).
      const near = (p) => p.left < box.right + 1 && box.left < p.right + 1 && p.top < box.bottom + 1 && box.top < p.bottom + 1;
      if (!placed.some(near)) {
        shift = dy;
        placed.push(box);
        break;
      }
    }
    if (shift) label.style.transform = `translateY(${shift}px)`;
    label.dataset.shift = String(shift);
  }
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
export function droneIcon(drone, color = null) {
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
  // The drone's own colour (its home, target, track and planned route): which label is whose.
  if (color) label.style.borderLeft = `4px solid ${color}`;
  root.append(arrow, label);
  return L.divIcon({ html: root, className: "drone-marker", iconSize: [24, 24], iconAnchor: [12, 12] });
}

export function latLngOf(position) {
  return position ? [position.lat, position.lon] : null;
}
