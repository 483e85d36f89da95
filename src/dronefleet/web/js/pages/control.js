// Control: the seed's commands for one drone as buttons; destructive ones ask first.
import { api } from "../api.js";
import { dronePanel } from "../drone-panel.js";
import { droneIcon, latLngOf, makeMap } from "../map.js";
import { el, field, toast } from "../ui.js";

const L = window.L;

const COMMANDS = [
  { command: "arm", label: "Arm" },
  { command: "disarm", label: "Disarm", confirm: true },
  { command: "takeoff", label: "Take off", value: "altitude" },
  { command: "land", label: "Land", confirm: true },
  { command: "changeN", label: "Move north", value: "step" },
  { command: "changeE", label: "Move east", value: "step" },
  { command: "altitude", label: "Move up", value: "step" },
  { command: "takepic", label: "Take picture" },
  { command: "resetfc", label: "Reset", confirm: true },
];

export async function mount(root, ctx) {
  const select = el("select", { id: "control-drone" });
  const altitude = el("input", { type: "number", id: "control-altitude", value: "10", min: "1", max: "120", step: "1" });
  const step = el("input", { type: "number", id: "control-step", value: "5", min: "-50", max: "50", step: "1" });
  const result = el("pre", { class: "result", id: "control-result", "aria-live": "polite" });
  const force = el("input", { type: "checkbox", id: "control-force", disabled: !ctx.me.can_command });
  const buttons = COMMANDS.map((c) => el("button", {
    type: "button", class: `command${c.confirm ? " danger" : ""}`, "data-command": c.command,
    disabled: !ctx.me.can_command, onclick: () => send(c),
  }, c.label));
  const goto = el("p", { class: "hint" }, ctx.me.can_command ? "Click the map to send the drone there (at the altitude above)." : "Viewer token: commands are disabled.");
  const mapBox = el("div", { class: "map", id: "control-map" });
  const panel = dronePanel(ctx, { idPrefix: "control-panel" });
  select.addEventListener("change", () => panel.show(select.value));
  root.append(el("h1", {}, "Control"), el("div", { class: "split" }, mapBox, el("div", { class: "side" },
    field("Drone", select), panel.element, field("Take-off altitude (m)", altitude), field("Move by (m)", step),
    el("div", { class: "buttons" }, ...buttons),
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
    result.textContent = `${command} → ${id}…`;
    Object.assign(result.dataset, { command, state: "sending" });
    try {
      const answer = await api(`/drones/${encodeURIComponent(id)}/commands/${command}`, { method: "POST", body });
      result.textContent = JSON.stringify(answer, null, 1);
      result.dataset.state = "done";
      toast(`${id}: ${command} done`);
    } catch (err) {
      result.textContent = `${command} failed: ${err.message}`;
      result.dataset.state = "failed";
      toast(`${id}: ${command} failed: ${err.message}`, "error");
    }
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
    if (c.value === "step") body = { value: Number(step.value) };
    post(c.command, body);
  }

  const map = await makeMap(mapBox, { search: true });
  const markers = new Map();
  // A click on the map sends the drone there: asked first, with how far it is (issue 14).
  map.on("click", (e) => {
    if (!ctx.me.can_command || !select.value) return;
    const drone = ctx.fleet.list().find((d) => d.drone_id === select.value);
    const from = drone && latLngOf(drone.position);
    const away = from ? ` (${Math.round(map.distance(from, e.latlng))} m away)` : "";
    const where = `${e.latlng.lat.toFixed(6)}, ${e.latlng.lng.toFixed(6)}`;
    if (!window.confirm(`Fly ${select.value} to ${where} at ${Number(altitude.value)} m${away}?`)) return;
    post("navigate", { lat: e.latlng.lat, lon: e.latlng.lng, altitude_delta: Number(altitude.value) });
  });
  let fitted = false;
  function render() {
    fillDrones();
    for (const d of ctx.fleet.list()) {
      const at = latLngOf(d.position);
      if (!at) continue;
      if (!markers.has(d.drone_id)) markers.set(d.drone_id, L.marker(at, { keyboard: false }).addTo(map));
      markers.get(d.drone_id).setLatLng(at).setIcon(droneIcon(d));
      if (!fitted) { map.setView(at, 19); fitted = true; }
    }
  }
  ctx.fleet.addEventListener("change", render);
  render();
  return () => { panel.destroy(); ctx.fleet.removeEventListener("change", render); map.remove(); };
}
