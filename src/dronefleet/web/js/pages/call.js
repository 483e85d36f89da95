// Call: the seed's panic button (5.1). One big button; the nearest drone comes to you.
import { api } from "../api.js";
import { dronePanel } from "../drone-panel.js";
import { droneIcon, latLngOf, makeMap } from "../map.js";
import { distanceM, el, fmtDuration } from "../ui.js";

const L = window.L;
const SPEED_MPS = 5; // what the ETA assumes until the drone's approach has been seen
const WINDOW_MS = 3000; // the approach speed is measured over this much of the recent past

export async function mount(root, ctx) {
  const button = el("button", { type: "button", id: "call-button", class: "call", disabled: !ctx.me.can_command }, "Call drone");
  const info = el("p", { id: "call-status", class: "call-status", role: "status", "aria-live": "polite" },
    ctx.me.can_command ? "Press the button: the nearest drone comes and hovers above you." : "Viewer token: calling is disabled.");
  const mapBox = el("div", { class: "map small", id: "call-map" });
  // The drone that comes, with its figures and buttons (send it home when you are done).
  const panel = dronePanel(ctx, { idPrefix: "call-panel" });
  panel.element.hidden = true;
  root.append(el("section", { class: "phone" }, el("h1", {}, "Call a drone"), button, info, mapBox, panel.element));
  const map = await makeMap(mapBox);
  const s = { me: null, mission: null, drone: null, marker: null, arrived: false, seen: [] };

  /** Metres a second the drone has been closing in, over the last few seconds (or null). */
  function approachSpeed(dist) {
    const now = performance.now();
    s.seen.push([now, dist]);
    while (s.seen.length > 2 && now - s.seen[0][0] > WINDOW_MS) s.seen.shift();
    const [t0, d0] = s.seen[0];
    const speed = (d0 - dist) / ((now - t0) / 1000);
    return now - t0 > 500 && speed > 0.5 ? speed : null;
  }

  function where() {
    return new Promise((resolve, reject) => {
      if (!navigator.geolocation) return reject(new Error("this browser cannot tell where you are"));
      navigator.geolocation.getCurrentPosition(
        (p) => resolve({ lat: p.coords.latitude, lon: p.coords.longitude }),
        (err) => reject(new Error(`no location: ${err.message}`)),
        { enableHighAccuracy: true, timeout: 15000 });
    });
  }

  button.addEventListener("click", async () => {
    button.disabled = true;
    info.textContent = "Finding you…";
    try {
      s.me = await where();
      L.circleMarker([s.me.lat, s.me.lon], { radius: 8, color: "#dc2626" }).bindTooltip("you").addTo(map);
      map.setView([s.me.lat, s.me.lon], 18);
      info.textContent = "Asking for the nearest drone…";
      const record = await api("/call", { method: "POST", body: { lat: s.me.lat, lon: s.me.lon, altitude_m: 10 } });
      s.mission = record.mission_id;
      s.drone = record.drones[0];
      panel.show(s.drone);
      panel.element.hidden = false;
      info.dataset.state = "coming";
      update();
    } catch (err) {
      info.textContent = `Could not call a drone: ${err.message}`;
      button.disabled = false;
    }
  });

  function update() {
    if (!s.drone) return;
    const d = ctx.fleet.drones.get(s.drone);
    if (!d || !d.position) return;
    const at = latLngOf(d.position);
    if (!s.marker) s.marker = L.marker(at, { keyboard: false }).addTo(map);
    s.marker.setLatLng(at).setIcon(droneIcon(d));
    const dist = distanceM(s.me, d.position);
    const close = dist < 3 && (d.position.relative_alt_m || 0) > 2;
    if (close) s.arrived = true;
    const eta = dist / (approachSpeed(dist) || SPEED_MPS);
    info.dataset.state = s.arrived ? "arrived" : "coming";
    info.dataset.etaS = s.arrived ? "0" : eta.toFixed(1);
    info.textContent = s.arrived
      ? `${s.drone} is here, hovering above you.`
      : `${s.drone} is coming: ${dist.toFixed(0)} m away, about ${fmtDuration(eta)}.`;
  }

  ctx.fleet.addEventListener("change", update);
  return () => { panel.destroy(); ctx.fleet.removeEventListener("change", update); map.remove(); };
}
