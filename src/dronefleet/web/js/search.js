// The maps' search box (issue 14): coordinates (40.63, -8.66 or 40°37'48"N 8°39'36"W), a
// drone's id, a mission's name, or an address (through the ground's --geocoder). The ground
// reads what was typed (GET /api/v1/search); the map centres on the first place found, and
// lists the others to pick.
import { api } from "./api.js";
import { el } from "./ui.js";

const L = window.L;

export function addSearch(map) {
  const input = el("input", {
    type: "search", class: "map-search-input", autocomplete: "off",
    placeholder: "40.63, -8.66 · QUAD_1 · mission · address",
    "aria-label": "Search the map: coordinates, a drone, a mission or an address",
  });
  const status = el("p", { class: "map-search-status", role: "status", "aria-live": "polite" });
  const list = el("ul", { class: "map-search-results" });
  const form = el("form", { class: "map-search", role: "search" },
    el("div", { class: "map-search-row" }, input, el("button", { type: "submit", class: "small" }, "Find")),
    status, list);
  const marker = L.circleMarker([0, 0], { radius: 9, color: "#7c3aed", weight: 3, fill: false, className: "search-marker" });

  function go(place) {
    // A zoom animation under way (a page fitting its drones as it opens) ends where it was
    // going, over this move: the move waits for it.
    if (map._animatingZoom) {
      map.once("zoomend", () => go(place));
      return;
    }
    if (place.bounds) {
      const [south, west, north, east] = place.bounds;
      map.fitBounds([[south, west], [north, east]], { maxZoom: 19, padding: [24, 24] });
    } else {
      map.setView([place.lat, place.lon], Math.max(map.getZoom(), 17));
    }
    marker.setLatLng([place.lat, place.lon]).addTo(map);
    status.textContent = place.label; // text only: labels come from drones and geocoders
    form.dataset.kind = place.kind;
    form.dataset.state = "found";
  }

  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    const q = input.value.trim();
    if (!q) return;
    list.replaceChildren();
    status.textContent = "searching…";
    form.dataset.state = "searching";
    try {
      const answer = await api("/search", { query: { q } });
      if (!answer.places.length) {
        status.textContent = answer.note || "nothing found";
        form.dataset.state = "none";
        return;
      }
      go(answer.places[0]);
      if (answer.places.length > 1) {
        list.replaceChildren(...answer.places.map((p) => el("li", {},
          el("button", { type: "button", class: "link-button", onclick: () => go(p) }, p.label))));
      }
    } catch (err) {
      status.textContent = err.message;
      form.dataset.state = "error";
    }
  });
  // Clicks, wheel and keys in the box stay in the box (a planner click adds a corner).
  L.DomEvent.disableClickPropagation(form);
  L.DomEvent.disableScrollPropagation(form);
  L.DomEvent.on(form, "keydown", L.DomEvent.stopPropagation);
  const Control = L.Control.extend({ onAdd: () => form });
  new Control({ position: "topright" }).addTo(map);
  return form;
}
