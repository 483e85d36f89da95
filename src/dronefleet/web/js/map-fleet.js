// Where each drone came from, where it is going and where it has been (issue 29), on the Fleet
// and Control maps: its home (an "H"), its target (a ring, and a dashed line from the drone) and
// its track, all in the drone's own colour (the one its label, trail and planned route use).
// The target is the next place of the drone's mission leg from the step it reports flying
// (heartbeat step_index; the leg's steps from GET /missions/{id}), or home once it returns.
import { api } from "./api.js";
import { colorFor, latLngOf } from "./map.js";
import { el } from "./ui.js";

const L = window.L;

/** The drone's colour: its place in the fleet's sorted list, as the Planner colours its routes. */
export function fleetColor(fleet, droneId) {
  return colorFor(Math.max(0, fleet.list().findIndex((d) => d.drone_id === droneId)));
}

function badge(kind, color, text) {
  const node = el("div", { class: `map-badge ${kind}`, style: `border-color:${color};color:${color}` }, text);
  return L.divIcon({ html: node, className: "map-badge-icon", iconSize: [18, 18], iconAnchor: [9, 9] });
}

/** Legs of missions, read once per leg (a leg's steps never change; a handover is a new leg). */
class Legs {
  constructor() {
    this.steps = new Map(); // leg id -> steps as flown (prefix, work, suffix), or null: unknown
    this.asked = new Set();
  }

  /** The steps of leg `legId` if read already; else asks for them and calls `then` when in. */
  get(legId, then) {
    if (this.steps.has(legId)) return this.steps.get(legId);
    // A planner leg is "<mission>.<n>"; an id without the dot is a mission sent straight to the
    // drone (POST /drones/{id}/mission), which the planner does not keep: nothing to ask.
    const dot = legId.lastIndexOf(".");
    if (dot <= 0) { this.steps.set(legId, null); return null; }
    if (!this.asked.has(legId)) {
      this.asked.add(legId);
      const mission = legId.slice(0, dot);
      api(`/missions/${encodeURIComponent(mission)}`)
        .then((record) => {
          for (const leg of record.legs || []) {
            this.steps.set(leg.leg_id, [...leg.prefix, ...leg.indices.map((i) => record.work[i]), ...leg.suffix]);
          }
          if (!this.steps.has(legId)) this.steps.set(legId, null);
          then();
        })
        .catch((err) => {
          if (err.status === 404) this.steps.set(legId, null); // not the planner's: never again
          else this.asked.delete(legId); // asked again at the next update
        });
    }
    return null;
  }
}

/** Where drone `d` is going: its leg's next place from the step it flies, home on a return. */
function targetOf(d, legs, redraw) {
  if (!d.mission_id || d.step_index === null || d.step_index === undefined) return null;
  const steps = legs.get(d.mission_id, redraw);
  if (!steps) return null;
  for (const step of steps.slice(d.step_index)) {
    if (step && Number.isFinite(step.lat) && Number.isFinite(step.lon)) return [step.lat, step.lon];
    if (step && step.command === "rtl") return latLngOf(d.home);
  }
  return null;
}

/** Homes, targets and tracks of every drone of `fleet` on `map`; `update()` after a change. */
export function fleetOverlay(map, fleet) {
  const layer = L.layerGroup().addTo(map);
  const shown = new Map(); // drone id -> {home, target, line, track}
  const legs = new Legs();

  function parts(d, color) {
    let p = shown.get(d.drone_id);
    if (!p) {
      const options = { keyboard: false };
      p = {
        track: L.polyline([], { color, weight: 2, opacity: 0.7, className: "drone-track" }).addTo(layer),
        line: L.polyline([], { color, weight: 2, dashArray: "5 5", interactive: false, className: "drone-target-line" }).addTo(layer),
        home: L.marker([0, 0], { ...options, icon: badge("home", color, "H"), title: `${d.drone_id} home` })
          .bindTooltip(el("span", {}, `${d.drone_id}: home (lands here on return)`)),
        target: L.marker([0, 0], { ...options, icon: badge("target", color, ""), title: `${d.drone_id} target` })
          .bindTooltip(el("span", {}, `${d.drone_id}: going here`)),
      };
      shown.set(d.drone_id, p);
    }
    return p;
  }

  function place(marker, at, droneId, kind) {
    if (!at) { layer.removeLayer(marker); return; }
    marker.setLatLng(at);
    if (!layer.hasLayer(marker)) {
      layer.addLayer(marker);
      const node = marker.getElement();
      node.dataset.drone = droneId;
      node.dataset.kind = kind;
    }
  }

  function update() {
    for (const d of fleet.list()) {
      const color = fleetColor(fleet, d.drone_id);
      const p = parts(d, color);
      p.track.setLatLngs(d.trail || []);
      const home = latLngOf(d.home);
      place(p.home, home, d.drone_id, "home");
      const target = targetOf(d, legs, update);
      const at = latLngOf(d.position);
      place(p.target, target, d.drone_id, "target");
      // A late answer (the legs asked for by targetOf) may come after the page left: no marker.
      const pin = p.target.getElement();
      if (target && pin) pin.title = `${d.drone_id} going to ${target[0].toFixed(7)}, ${target[1].toFixed(7)}`;
      p.line.setLatLngs(target && at ? [at, target] : []);
    }
  }

  update();
  return { update, destroy: () => map.removeLayer(layer) };
}
