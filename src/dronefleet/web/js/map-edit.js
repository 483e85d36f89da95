// Editing the Planner's shapes on the map (issue 29): the area's and the fence's corners are
// dragged, inserted (click the midpoint between two corners) and deleted (right-click a corner);
// a step list's waypoints are dragged. The form fields follow the map: each edit rewrites the
// field (corners as text, a step's latitude and longitude) and fires its "change", so the page
// reads the map's edit exactly as it reads a typed one. The previewed route is drawn per drone,
// in the drone's colour, with a legend that names them.
//
// Corners are edited with Leaflet-Geoman (npm @geoman-io/leaflet-geoman-free, MIT, loaded by
// index.html from /web/vendor/geoman/): maintained, made for Leaflet 1.9, and it inserts and
// removes vertices as well as moving them. Leaflet.draw, the other candidate, has had no release
// since 2018 and breaks on Leaflet 1.8+ (its rectangles and its `_flat` use), and edits only in
// its own toolbar's mode. Waypoints and rally points need no library: Leaflet's own draggable
// markers.
import { el } from "./ui.js";

const L = window.L;
/** Geoman's edit mode: corners only (the shape itself does not drag with the map), no snapping
 * to the drones' markers, and never fewer corners than a polygon needs. */
const CORNERS = {
  draggable: false,
  snappable: false,
  allowSelfIntersection: true,
  removeLayerBelowMinVertexCount: false,
};
const ROUTE_DOTS_MAX = 300; // dots per drone's route; more would bury the map (the line stays)

function ring(layer) {
  const rings = layer.getLatLngs();
  return Array.isArray(rings[0]) ? rings[0] : rings;
}

function setField(input, value) {
  input.value = value;
  input.dispatchEvent(new Event("change", { bubbles: true }));
}

const asText = (latlngs) => latlngs.map((p) => `${p.lat.toFixed(7)}, ${p.lng.toFixed(7)}`).join("\n");

/** Corners of `layer` editable on the map, written to `text` ("lat, lon" a line) on each edit.
 * Returns refresh(): call it after the layer's corners were set from elsewhere; true when they
 * changed. The same corners set again (a field's "change" as it loses the focus) keep their
 * handles: one may be under the mouse, being dragged. */
function editableCorners(layer, text) {
  let handles = "";
  // While a corner is dragged, the layer already has it where the mouse is and the field does
  // not yet: a "change" then (the field losing the focus to the press that began the drag, seen
  // late on a busy host) made new handles and the drag was lost. Its end writes the field.
  let dragging = false;
  layer.on("pm:markerdragstart", () => { dragging = true; });
  layer.on("pm:markerdragend", () => { dragging = false; });
  layer.on("pm:edit", () => setField(text, asText(ring(layer))));
  return () => {
    if (dragging) return false;
    const now = ring(layer).length >= 3 ? asText(ring(layer)) : "";
    if (now === handles) return false;
    handles = now;
    if (layer.pm.enabled()) layer.pm.disable();
    if (now) layer.pm.enable(CORNERS);
    return true;
  };
}

/** A numbered pin that can be dragged; `moved(latlng)` when dropped. */
function pin(at, label, kind, moved) {
  const icon = L.divIcon({ html: el("span", {}, label), className: `waypoint-pin ${kind}`, iconSize: null, iconAnchor: [12, 12] });
  return L.marker(at, { icon, draggable: true, keyboard: false, autoPan: true })
    .on("dragend", (e) => moved(e.target.getLatLng()));
}

/** A step list's places as dragged pins; the step editor's fields follow. */
function stepPins(map, box) {
  const layer = L.layerGroup().addTo(map);
  let queued = false;
  function draw() {
    queued = false;
    layer.clearLayers();
    if (box.closest("[hidden]")) return;
    const places = [...box.querySelectorAll("li[data-command='navigate']")].map((li) => ({
      n: Number(li.dataset.index) + 1,
      lat: li.querySelector("input[data-param='lat']"),
      lon: li.querySelector("input[data-param='lon']"),
    })).filter((p) => p.lat && p.lon && Number.isFinite(Number(p.lat.value)) && Number.isFinite(Number(p.lon.value)));
    const points = places.map((p) => [Number(p.lat.value), Number(p.lon.value)]);
    L.polyline(points, { color: "#0f766e", weight: 2, dashArray: "2 6", interactive: false }).addTo(layer);
    places.forEach((p, i) => {
      const marker = pin(points[i], String(p.n), "step", (at) => {
        setField(p.lat, Number(at.lat.toFixed(7)));
        setField(p.lon, Number(at.lng.toFixed(7)));
      }).addTo(layer);
      marker.getElement().dataset.step = String(p.n - 1);
    });
  }
  const soon = () => { if (!queued) { queued = true; requestAnimationFrame(draw); } };
  new MutationObserver(soon).observe(box, { childList: true });
  box.addEventListener("change", soon);
  const tab = box.closest("[id^='tab-']");
  if (tab) new MutationObserver(soon).observe(tab, { attributes: true, attributeFilter: ["hidden"] });
  soon();
}

/** The previewed route, one line per drone in its colour, and a legend naming the drones. */
function routeView(map) {
  const layer = L.layerGroup().addTo(map);
  const legend = el("ul", { class: "route-legend", id: "route-legend", "aria-label": "Route per drone", hidden: true });
  const Legend = L.Control.extend({ onAdd: () => legend });
  new Legend({ position: "bottomright" }).addTo(map);

  function clear() {
    layer.clearLayers();
    legend.replaceChildren();
    legend.hidden = true;
  }

  /** Draw `answer`'s shares (a preview); false when it gives no drone a place to fly. */
  function show(answer, colorOf) {
    clear();
    const shares = (answer.drones || []).filter((d) => (d.waypoints || []).length);
    if (!shares.length) return false;
    for (const d of shares) {
      const color = colorOf(d.drone_id);
      const points = d.waypoints.map((w) => [w.lat, w.lon]);
      const line = L.polyline(points, { color, weight: 3, opacity: 0.9, className: "route-share" }).addTo(layer);
      line.getElement().dataset.drone = d.drone_id;
      points.slice(0, ROUTE_DOTS_MAX).forEach((p, i) => L.circleMarker(p, { radius: 3, color, weight: 2 })
        .bindTooltip(el("span", {}, `${d.drone_id} #${i + 1}`)).addTo(layer));
      legend.append(el("li", { "data-drone": d.drone_id },
        el("span", { class: "swatch", style: `background:${color}`, "aria-hidden": "true" }),
        `${d.drone_id}: ${points.length} waypoint${points.length === 1 ? "" : "s"}`));
    }
    legend.hidden = false;
    return true;
  }

  return { show, clear };
}

/** The Planner's map editing: `shape` and `fence` (polygons whose corners are the `polygon` and
 * `fence` text fields), the step editor's `steps` list, and the per-drone route. */
export function planEditing(map, { shape, fence, polygon, fenceText, steps }) {
  const corners = [editableCorners(shape, polygon), editableCorners(fence, fenceText)];
  const hint = el("p", { class: "map-note edit-hint", id: "edit-hint", role: "note", hidden: true },
    "Drag a corner to move it; click a midpoint to add a corner; right-click a corner to delete it.");
  const Hint = L.Control.extend({ onAdd: () => hint });
  new Hint({ position: "bottomleft" }).addTo(map);
  const route = routeView(map);
  stepPins(map, steps);

  /** After the page set the corners (a click, a typed field, a file): edit the new ones. The
   * previewed route is for the old shape: it goes until the next preview. */
  function refresh() {
    // Not inside the edit's own event: Geoman is still handling it there.
    setTimeout(() => {
      if (corners.map((again) => again()).some(Boolean)) route.clear();
      hint.hidden = ring(shape).length < 3 && ring(fence).length < 3;
    }, 0);
  }

  return { refresh, route: route.show, clearRoute: route.clear };
}
