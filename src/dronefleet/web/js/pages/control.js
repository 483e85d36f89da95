// Control: the seed's commands for one drone as buttons; destructive ones ask first. Moves go
// any way (north, south, east, west, up, down) by a distance; the mode selector, Hold and Land
// are in the drone's panel. Every result is said in words with units and frames, and "done"
// only once the drone reports the move ended (web/js/flight-commands.js, issue 29).
import { dronePanel } from "../drone-panel.js";
import { describe, runCommand } from "../flight-commands.js";
import { droneIcon, latLngOf, makeMap } from "../map.js";
import { fleetColor, fleetOverlay } from "../map-fleet.js";
import { el, field, toast } from "../ui.js";

const L = window.L;

const COMMANDS = [
  { command: "arm", label: "Arm" },
  { command: "takeoff", label: "Take off", value: "altitude" },
  { command: "disarm", label: "Disarm", confirm: true },
  { command: "takepic", label: "Take picture" },
  { command: "resetfc", label: "Reset", confirm: true },
];
// The move pad: a command and the sign of the distance (south is a negative changeN).
const MOVES = [
  { command: "changeN", sign: 1, label: "North", key: "north" },
  { command: "changeE", sign: -1, label: "West", key: "west" },
  { command: "changeE", sign: 1, label: "East", key: "east" },
  { command: "changeN", sign: -1, label: "South", key: "south" },
  { command: "altitude", sign: 1, label: "Up", key: "up" },
  { command: "altitude", sign: -1, label: "Down", key: "down" },
];
const FORCEABLE = new Set(["takeoff", "navigate", "changeN", "changeE", "altitude"]);

export async function mount(root, ctx) {
  const can = ctx.me.can_command;
  const select = el("select", { id: "control-drone" });
  const altitude = el("input", { type: "number", id: "control-altitude", value: "10", min: "1", max: "120", step: "1" });
  const step = el("input", { type: "number", id: "control-step", value: "5", min: "1", max: "50", step: "1" });
  const result = el("p", { class: "command-result", id: "control-result", "aria-live": "polite" });
  const force = el("input", { type: "checkbox", id: "control-force", disabled: !can });
  const forceMoves = el("input", { type: "checkbox", id: "control-force-moves", disabled: !can });
  const buttons = COMMANDS.map((c) => el("button", {
    type: "button", class: `command${c.confirm ? " danger" : ""}`, "data-command": c.command,
    disabled: !can, onclick: () => send(c),
  }, c.label));
  const pad = MOVES.map((mv) => el("button", {
    type: "button", class: `command move move-${mv.key}`, "data-command": mv.command, "data-move": mv.key,
    disabled: !can, title: `${mv.label} by the distance above`, onclick: () => move(mv),
  }, mv.label));
  const goto = el("p", { class: "hint" }, can ? "Click the map to send the drone there (at the take-off height above home)." : "Viewer token: commands are disabled.");
  const mapBox = el("div", { class: "map", id: "control-map" });
  const panel = dronePanel(ctx, { idPrefix: "control-panel" });
  select.addEventListener("change", () => panel.show(select.value));
  root.append(el("h1", {}, "Control"), el("div", { class: "split" }, mapBox, el("div", { class: "side" },
    field("Drone", select), panel.element, field("Take-off height above home (m)", altitude),
    el("div", { class: "buttons" }, ...buttons),
    field("Move by (m)", step),
    el("div", { class: "buttons move-pad", role: "group", "aria-label": "Move" }, ...pad),
    el("label", { class: "check" }, forceMoves, " Force moves while a mission flies it (the mission is paused first)"),
    el("label", { class: "check" }, force, " Force the disarm, even in flight (the motors stop: it falls)"),
    goto, result)));

  function fillDrones() {
    const chosen = select.value;
    select.replaceChildren(...ctx.fleet.list().map((d) => el("option", { value: d.drone_id }, `${d.drone_id} — ${d.status === "lost" ? "lost" : d.state}`)));
    if (chosen) select.value = chosen;
    if (panel.selected !== select.value) panel.show(select.value);
  }

  async function post(command, body) {
    const id = select.value;
    if (!id) return toast("no drone selected", "error");
    const sent = FORCEABLE.has(command) && forceMoves.checked ? { ...(body || {}), force: true } : body;
    await runCommand(id, command, sent, ({ state, text }) => {
      result.textContent = text;
      Object.assign(result.dataset, { command, state });
      if (state === "done") toast(text);
      if (state === "failed" || state === "refused") toast(text, "error");
    });
  }

  function send(c) {
    const forced = c.command === "disarm" && force.checked;
    const question = forced
      ? `Force disarm ${select.value}? If it is flying, its motors stop and it falls.`
      : `${c.label} ${select.value}? This cannot be undone in flight.`;
    if (c.confirm && !window.confirm(question)) return;
    let body;
    if (forced) body = { force: true };
    if (c.value === "altitude") body = { value: Number(altitude.value) };
    post(c.command, body);
  }

  function move(mv) {
    const distance = Math.abs(Number(step.value));
    if (!Number.isFinite(distance) || distance <= 0) return toast("Move by: a distance in metres, above 0", "error");
    post(mv.command, { value: mv.sign * distance });
  }

  const map = await makeMap(mapBox, { search: true });
  const markers = new Map();
  const overlay = fleetOverlay(map, ctx.fleet); // homes, targets, tracks (issue 29)
  // A click on the map sends the drone there: asked first, with how far it is (issue 14).
  map.on("click", (e) => {
    if (!ctx.me.can_command || !select.value) return;
    const drone = ctx.fleet.list().find((d) => d.drone_id === select.value);
    const from = drone && latLngOf(drone.position);
    const away = from ? ` (${Math.round(map.distance(from, e.latlng))} m away)` : "";
    const body = { lat: e.latlng.lat, lon: e.latlng.lng, altitude_delta: Number(altitude.value) };
    if (!window.confirm(`${select.value}: ${describe("navigate", body)}${away}?`)) return;
    post("navigate", body);
  });
  let fitted = false;
  function render() {
    fillDrones();
    for (const d of ctx.fleet.list()) {
      const at = latLngOf(d.position);
      if (!at) continue;
      if (!markers.has(d.drone_id)) markers.set(d.drone_id, L.marker(at, { keyboard: false }).addTo(map));
      markers.get(d.drone_id).setLatLng(at).setIcon(droneIcon(d, fleetColor(ctx.fleet, d.drone_id)));
      if (!fitted) { map.setView(at, 19); fitted = true; }
    }
    overlay.update();
  }
  ctx.fleet.addEventListener("change", render);
  render();
  return () => { panel.destroy(); ctx.fleet.removeEventListener("change", render); map.remove(); };
}
