// The Planner's rally points (issue 14): where a drone sent home early (abort, handover, lost)
// lands instead of home when one is nearer. Added by clicking the map in their own mode, or typed;
// dragged on the map to move one, right-clicked to delete it (issue 29): the field follows.
import { el, field } from "../ui.js";

const L = window.L;
const DEFAULT_ALT_M = 15;

/** `box` goes in the form, `attach(map)` once the map exists; `points()` as the API takes them. */
export function rallyEditor() {
  let on = false;
  let layer = null;
  const text = el("textarea", { id: "plan-rally", rows: 3, placeholder: "lat, lon[, height m] per line (none: home only)" });
  const toggle = el("button", { type: "button", id: "rally-mode", "aria-pressed": "false", onclick: () => setMode(!on) }, "Add rally points");
  const hint = el("p", { class: "hint", id: "rally-hint", hidden: true }, "Click the map to add rally points; press the button again to stop. Drag one to move it; right-click it to delete it.");
  const clear = el("button", { type: "button", id: "rally-clear", onclick: () => set([]) }, "Clear rally points");

  function setMode(value) {
    on = value;
    toggle.setAttribute("aria-pressed", String(on));
    hint.hidden = !on;
  }

  function points() {
    return text.value.split("\n").map((line) => line.split(",").map(Number))
      .filter((p) => (p.length === 2 || p.length === 3) && p.every(Number.isFinite))
      .map(([lat, lon, alt]) => ({ lat, lon, alt_m: alt === undefined ? DEFAULT_ALT_M : alt }));
  }

  function draw() {
    if (!layer) return;
    layer.clearLayers();
    const list = points();
    list.forEach((p, i) => {
      const icon = L.divIcon({ html: el("span", {}, `R${i + 1}`), className: "waypoint-pin rally rally-marker", iconSize: null, iconAnchor: [12, 12] });
      const marker = L.marker([p.lat, p.lon], { icon, draggable: true, keyboard: false, title: `rally point R${i + 1}, ${p.alt_m} m` })
        .bindTooltip(el("span", {}, `R${i + 1} (${p.alt_m} m)`), { permanent: true, direction: "top", offset: [0, -12], className: "rally-label" })
        // Redrawn after Leaflet is done with the marker's own event.
        .on("dragend", (e) => {
          const at = e.target.getLatLng();
          setTimeout(() => set(list.map((q, j) => (j === i ? { ...q, lat: at.lat, lon: at.lng } : q))), 0);
        })
        .on("contextmenu", () => setTimeout(() => set(list.filter((_, j) => j !== i)), 0))
        .addTo(layer);
      marker.getElement().dataset.rally = String(i);
    });
  }

  function set(list) {
    text.value = list.map((p) => `${p.lat.toFixed(7)}, ${p.lon.toFixed(7)}, ${p.alt_m}`).join("\n");
    draw();
  }

  text.addEventListener("change", draw);
  return {
    box: el("div", { id: "rally-box" }, field("Rally points (land here instead of home)", text),
      el("div", { class: "buttons" }, toggle, clear), hint),
    active: () => on,
    points,
    set,
    attach(map) {
      layer = L.layerGroup().addTo(map);
      map.on("click", (e) => {
        if (!on) return;
        set([...points(), { lat: e.latlng.lat, lon: e.latlng.lng, alt_m: DEFAULT_ALT_M }]);
      });
      draw();
    },
  };
}
