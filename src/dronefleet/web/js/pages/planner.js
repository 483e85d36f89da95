// Planner: draw an area (polygon or the seed's three clicks), preview it, send it, watch it fly.
import { api } from "../api.js";
import { downloadMissionLog } from "../download.js";
import { dronePanel } from "../drone-panel.js";
import { colorFor, droneIcon, latLngOf, makeMap } from "../map.js";
import { planEditing } from "../map-edit.js";
import { latestEvent, missionProgress } from "../mission-progress.js";
import { addMissionOptions } from "../missions.js";
import { el, field, fmtDuration, toast } from "../ui.js";
import { planFiles } from "./planner-files.js";
import { rallyEditor } from "./planner-rally.js";
import { preflightDialog } from "./planner-preflight.js";
import { stepEditor } from "./planner-steps.js";

const L = window.L;
// GoPro Hero3 (the seed's camera), for the camera+overlap spacing.
const CAMERA = { sensor_width_mm: 6.17, sensor_height_mm: 4.55, focal_length_mm: 2.77, image_width_px: 4000, image_height_px: 3000 };
const END_NAMES = { rtl: "return home and land", land: "land where the work ends", hold: "hold there" };
/** A refusal that names a step ("step 3 (navigate): ...", ground/planner/step_order.py). */
const STEP_REFUSAL = /^step (\d+) \(/;

export async function mount(root, ctx) {
  const s = { mode: "polygon", vertices: [], clicks: [], missionId: null };
  const num = (id, value, attrs = {}) => el("input", { type: "number", id, value, step: "any", ...attrs });
  const inputs = {
    spacingKind: el("select", { id: "plan-spacing-kind" }, el("option", { value: "spacing" }, "Line spacing"), el("option", { value: "camera" }, "Camera + overlap")),
    spacing: num("plan-spacing", 10, { min: 1 }),
    front: num("plan-front-overlap", 0.7, { min: 0, max: 0.95 }),
    side: num("plan-side-overlap", 0.6, { min: 0, max: 0.95 }),
    altitude: num("plan-altitude", 15, { min: 1, max: 120 }),
    angle: el("input", { type: "number", id: "plan-angle", placeholder: "auto", step: "any" }),
    action: el("select", { id: "plan-action" }, ...["none", "takepic", "read_sensors"].map((a) => el("option", { value: a }, a))),
    hold: num("plan-hold", 2, { min: 0 }),
    flyThrough: el("input", { type: "checkbox", id: "plan-fly-through" }),
    polygon: el("textarea", { id: "plan-polygon", rows: 4, placeholder: "lat, lon (°) per line" }),
    fence: el("textarea", { id: "plan-fence", rows: 3, placeholder: "lat, lon (°) per line (none: no fence)" }),
    ceiling: el("input", { type: "number", id: "plan-fence-ceiling", placeholder: "none", min: 1, step: "any" }),
  };
  const colorOf = (id) => colorFor(Math.max(0, ctx.fleet.list().findIndex((d) => d.drone_id === id)));
  const cornersOf = (text) => text.split("\n").map((line) => line.split(",").map(Number)).filter((p) => p.length === 2 && p.every(Number.isFinite));
  // Every mission ends with a safe action (ground/planner/ends.py): home by default.
  const endAction = el("select", { id: "plan-end" },
    el("option", { value: "rtl" }, "Return to launch and land (default)"),
    el("option", { value: "land" }, "Land where the work ends"),
    el("option", { value: "hold" }, "Hold there (an operator takes over)"));
  const drones = el("fieldset", { class: "drones", id: "plan-drones" }, el("legend", {}, "Drones"));
  // What the planner may do while the mission flies (issue 29: on by default, as the API's).
  const replacement = el("input", { type: "checkbox", id: "plan-replacement", checked: true });
  const collaboration = el("input", { type: "checkbox", id: "plan-collaboration", checked: true });
  const behaviour = el("fieldset", { class: "options-box", id: "plan-behaviour" }, el("legend", {}, "While it flies"),
    el("div", { class: "field check" }, replacement, el("label", { for: "plan-replacement" },
      "Replacement: an idle drone takes over from one with a CRITICAL alarm or a low battery")),
    el("div", { class: "field check" }, collaboration, el("label", { for: "plan-collaboration" },
      "Collaboration: a reading out of bounds grows the area and calls idle drones")));
  const status = el("div", { id: "mission-status", class: "status", role: "status", "aria-live": "polite" }, "No mission sent yet.");
  const watch = el("select", { id: "plan-watch" }, el("option", { value: "" }, "— the one sent from here —"));
  const estimate = el("div", { id: "plan-estimate" });
  const readingsKey = el("p", { id: "readings-key", class: "hint", hidden: true });
  // A new "fly to a point" starts at the chosen drone's home, or where the map is looking.
  const editor = stepEditor(() => editor.markError(null), () => {
    const first = drones.querySelector("input:checked");
    const drone = first && ctx.fleet.drones.get(first.value);
    if (drone && drone.home) return { lat: drone.home.lat, lon: drone.home.lon };
    const c = map.getCenter();
    return { lat: c.lat, lon: c.lng };
  });
  const checklist = preflightDialog();
  const panel = dronePanel(ctx, { idPrefix: "plan-panel" });
  const rally = rallyEditor();
  const files = planFiles({ spec: () => spec(), load: (answer) => load(answer) });
  const mapBox = el("div", { class: "map", id: "planner-map" });
  const progress = missionProgress({ idPrefix: "plan-progress", colorOf: (id) => colorOf(id) });
  const can = ctx.me.can_command;
  const btn = (id, label, onclick, extra = {}) => el("button", { type: "button", id, onclick, ...extra }, label);

  const areaTab = el("div", { id: "tab-area" },
    el("div", { class: "buttons" },
      btn("draw-polygon", "Draw polygon", () => setMode("polygon"), { "aria-pressed": "true" }),
      btn("draw-three", "Three clicks", () => setMode("three"), { "aria-pressed": "false" }),
      btn("draw-finish", "Finish shape", finish),
      btn("draw-clear", "Clear", clearShape)),
    el("p", { class: "hint", id: "draw-hint" }, "Click the map to add corners, then Finish shape."),
    field("Corners (lat, lon in °)", inputs.polygon),
    field("Spacing from", inputs.spacingKind), field("Line spacing (m)", inputs.spacing),
    field("Front overlap (fraction, 0–0.95)", inputs.front), field("Side overlap (fraction, 0–0.95)", inputs.side),
    field("Altitude above home (m)", inputs.altitude), field("Angle (° from north; empty: best)", inputs.angle),
    field("Action at each waypoint", inputs.action), field("Hold at each waypoint (s)", inputs.hold),
    // Checked before a mission is accepted: a share leaving it is refused with the reason.
    field("Geofence corners (lat, lon in °; fly inside)", inputs.fence), field("Fence ceiling (m above home)", inputs.ceiling),
    el("div", { class: "buttons" }, btn("fence-from-shape", "Fence = this shape", () => { inputs.fence.value = inputs.polygon.value; drawFence(); })),
    el("div", { class: "field check" }, inputs.flyThrough, el("label", { for: "plan-fly-through" }, "Fly through (photograph without stopping)")));
  const stepsTab = el("div", { id: "tab-steps", hidden: true },
    el("p", { class: "hint" }, "Drag commands into the list (or press Add); drag or use ↑ ↓ to reorder."),
    el("div", { class: "steps-editor" }, editor.palette, editor.box));
  const kind = el("select", { id: "plan-kind" }, el("option", { value: "area" }, "Cover an area"), el("option", { value: "steps" }, "Step list"));
  kind.addEventListener("change", () => { areaTab.hidden = kind.value !== "area"; stepsTab.hidden = kind.value !== "steps"; });

  root.append(el("h1", {}, "Planner"), el("div", { class: "split" }, mapBox, el("div", { class: "side" },
    files.box, field("Mission", kind), areaTab, stepsTab, drones, behaviour, field("When done", endAction), rally.box,
    el("div", { class: "buttons" },
      btn("plan-preview", "Preview", preview, { disabled: !can }),
      btn("plan-send", "Send", send, { class: "primary", disabled: !can })),
    estimate, field("Watch a mission", watch), status, progress.element, readingsKey,
    el("div", { class: "buttons" },
      btn("plan-pause", "Pause", () => pauseOrResume("pause"), { disabled: !can, title: "Its drones hold; Resume flies on" }),
      btn("plan-resume", "Resume", () => pauseOrResume("resume"), { disabled: !can, title: "Fly on with a paused mission (paused here, or a drone taken over by someone else)" }),
      btn("plan-abort", "Abort: all home", abort, { class: "danger", disabled: !can }),
      btn("plan-log", "Mission log", saveLog, { class: "small", title: "Download the watched mission's log (the Replay page reads it)" })),
    el("p", { class: "hint" }, "Click a drone on the map for its figures and buttons."), panel.element)),
    checklist.element);

  // Read when opened; on an error the list stays as it was and the stream keeps the status.
  const fillWatch = () => addMissionOptions(watch).catch(() => {});
  watch.addEventListener("focus", fillWatch);
  watch.addEventListener("change", () => {
    if (!watch.value) return;
    s.missionId = watch.value;
    s.lastEvent = null;
    for (const t of trails.values()) t.setLatLngs([]);
    poll();
  });
  fillWatch();

  const map = await makeMap(mapBox, { search: true });
  const shape = L.polygon([], { color: "#2563eb", weight: 2, fillOpacity: 0.1 }).addTo(map);
  const corners = L.layerGroup().addTo(map);
  const route = L.polyline([], { color: "#f97316", weight: 2, dashArray: "4 4" }).addTo(map);
  const waypoints = L.layerGroup().addTo(map);
  const markers = new Map();
  const trails = new Map();
  const handoverLayer = L.layerGroup().addTo(map);
  const readingLayer = L.layerGroup().addTo(map);
  rally.attach(map);
  files.attach(map);

  function setMode(mode) {
    s.mode = mode;
    s.clicks = [];
    document.getElementById("draw-polygon").setAttribute("aria-pressed", String(mode === "polygon"));
    document.getElementById("draw-three").setAttribute("aria-pressed", String(mode === "three"));
    document.getElementById("draw-hint").textContent = mode === "three"
      ? "Click three corners: the fourth makes a parallelogram (the seed's planner)."
      : "Click the map to add corners, then Finish shape.";
  }

  function drawShape() {
    shape.setLatLngs(s.vertices);
    corners.clearLayers();
    for (const v of s.vertices) L.circleMarker(v, { radius: 4, color: "#2563eb" }).addTo(corners);
    inputs.polygon.value = s.vertices.map(([a, b]) => `${a.toFixed(7)}, ${b.toFixed(7)}`).join("\n");
    edits.refresh();
  }

  map.on("click", (e) => {
    if (kind.value !== "area" || rally.active()) return;
    const p = [e.latlng.lat, e.latlng.lng];
    if (s.mode === "three") {
      s.clicks.push(p);
      s.vertices = [...s.clicks];
      if (s.clicks.length === 3) {
        const [a, b, c] = s.clicks;
        s.vertices = [a, b, c, [a[0] + c[0] - b[0], a[1] + c[1] - b[1]]];
        s.clicks = [];
      }
    } else {
      s.vertices.push(p);
    }
    drawShape();
  });
  const fenceLine = L.polygon([], { color: "#dc2626", weight: 2, dashArray: "6 4", fill: false }).addTo(map);
  function drawFence() { fenceLine.setLatLngs(cornersOf(inputs.fence.value)); edits.refresh(); }
  // Corners, fence and a step list's waypoints dragged on the map; the fields follow (issue 29).
  const edits = planEditing(map, { shape, fence: fenceLine, polygon: inputs.polygon, fenceText: inputs.fence, steps: editor.box });
  inputs.fence.addEventListener("change", drawFence);
  inputs.polygon.addEventListener("change", () => {
    s.vertices = inputs.polygon.value.split("\n").map((line) => line.split(",").map(Number)).filter((p) => p.length === 2 && p.every(Number.isFinite));
    drawShape();
  });

  /** Fill the form from an imported file (planner-files.js): its steps or area, fence, rally. */
  function load({ spec: imported }) {
    const fence = imported.options.geofence || {};
    inputs.fence.value = (fence.inclusion || []).map(([a, b]) => `${a}, ${b}`).join("\n");
    inputs.ceiling.value = fence.ceiling_m ?? "";
    drawFence();
    rally.set(imported.options.rally_points || []);
    kind.value = imported.steps ? "steps" : "area";
    kind.dispatchEvent(new Event("change"));
    const a = imported.area;
    if (imported.steps) {
      editor.clear();
      imported.steps.forEach((step) => editor.add(step));
      route.setLatLngs(imported.steps.filter((x) => x.command === "navigate").map((x) => [x.lat, x.lon]));
    } else {
      s.vertices = a.polygon;
      drawShape();
      inputs.spacingKind.value = "spacing";
      inputs.spacing.value = a.spacing_m;
      inputs.altitude.value = a.altitude_m;
      inputs.angle.value = a.angle_deg ?? "";
      inputs.action.value = a.action;
      inputs.flyThrough.checked = a.fly_through;
    }
    const seen = [...(a ? a.polygon : []), ...route.getLatLngs(), ...(fence.inclusion || []), ...rally.points().map((p) => [p.lat, p.lon])];
    if (seen.length) map.fitBounds(L.latLngBounds(seen), { padding: [40, 40], maxZoom: 19 });
  }

  function finish() {
    if (s.vertices.length < 3) return toast("an area needs at least three corners", "error");
    drawShape();
    toast(`area with ${s.vertices.length} corners ready`);
  }

  function clearShape() {
    s.vertices = [];
    s.clicks = [];
    drawShape();
    route.setLatLngs([]);
    waypoints.clearLayers();
  }

  function spec() {
    const chosen = [...drones.querySelectorAll("input:checked")].map((i) => i.value);
    const options = {
      end_action: endAction.value,
      // Off means no replacement of any kind: neither on an alarm nor before the battery runs low.
      replacement: replacement.checked, early_replacement: replacement.checked,
      collaboration: collaboration.checked,
    };
    const body = { name: `web ${new Date().toISOString().slice(0, 19)}`, drones: chosen, options };
    const fence = cornersOf(inputs.fence.value);
    if (fence.length || inputs.ceiling.value !== "" || files.exclusions().length) {
      body.options.geofence = { exclusions: files.exclusions() };
      if (fence.length) body.options.geofence.inclusion = fence;
      if (inputs.ceiling.value !== "") body.options.geofence.ceiling_m = Number(inputs.ceiling.value);
    }
    if (rally.points().length) body.options.rally_points = rally.points();
    if (kind.value === "steps") {
      body.steps = editor.steps();
      return body;
    }
    const area = {
      polygon: s.vertices,
      altitude_m: Number(inputs.altitude.value),
      action: inputs.action.value,
      hold_s: Number(inputs.hold.value),
      fly_through: inputs.flyThrough.checked,
    };
    if (inputs.angle.value !== "") area.angle_deg = Number(inputs.angle.value);
    if (inputs.spacingKind.value === "camera") {
      area.camera = { ...CAMERA, front_overlap: Number(inputs.front.value), side_overlap: Number(inputs.side.value) };
    } else {
      area.spacing_m = Number(inputs.spacing.value);
    }
    body.area = area;
    return body;
  }

  /** A refusal on the page: beside its step when it names one (a step list's order). */
  function refused(what, err) {
    const match = kind.value === "steps" && STEP_REFUSAL.exec(err.message);
    editor.markError(match ? Number(match[1]) : null, err.message);
    estimate.textContent = `${what} failed: ${err.message}`;
  }

  function batteryLeft(d) {
    // A share below the reserve is accepted only with a handover planned (the notes say so).
    const handover = d.notes.some((n) => n.includes("handed over"));
    return `${d.battery_end_pct} %${d.battery_end_pct < 20 ? (handover ? " (handover planned)" : " (below reserve!)") : ""}`;
  }

  async function preview() {
    editor.markError(null);
    try {
      const answer = await api("/missions/preview", { method: "POST", body: spec() });
      const points = answer.waypoints.map((w) => [w.lat, w.lon]);
      const perDrone = edits.route(answer, colorOf); // each drone's share in its colour (issue 29)
      route.setLatLngs(perDrone ? [] : points);
      waypoints.clearLayers();
      if (!perDrone) points.forEach((p, i) => L.circleMarker(p, { radius: 3, color: "#f97316" }).bindTooltip(el("span", {}, `#${i + 1}`)).addTo(waypoints));
      estimate.replaceChildren(el("table", { class: "grid", id: "estimate-table" },
        el("caption", {}, `${points.length} waypoints${answer.area_m2 ? `, ${answer.area_m2} m²` : ""}; when done: ${END_NAMES[answer.end_action] || answer.end_action}`),
        el("thead", {}, el("tr", {}, ...["Drone", "Steps", "Time", "Battery used", "Battery left", "Ends with", "Notes"].map((h) => el("th", { scope: "col" }, h)))),
        el("tbody", {}, ...answer.drones.map((d) => el("tr", { "data-drone": d.drone_id },
          // The drone's colour on the map (its trail), and what the plan decided for it.
          el("th", { scope: "row" }, el("span", { class: "swatch", style: `background:${colorOf(d.drone_id)}`, "aria-hidden": "true" }), d.drone_id),
          el("td", {}, d.steps), el("td", {}, fmtDuration(d.duration_s)),
          el("td", {}, `${d.battery_used_pct} %`), el("td", { class: "battery-left" }, batteryLeft(d)),
          el("td", { class: "ends" }, d.end.length ? d.end.join(", ") : answer.end_action === "hold" ? "hold" : "its own landing"),
          el("td", { class: "notes" }, d.notes.length ? d.notes.join("; ") : "—"))))));
    } catch (err) {
      refused("Preview", err);
    }
  }

  /** Send: the pre-flight checklist first (its failures need an override with a reason). */
  async function send() {
    editor.markError(null);
    const body = spec();
    let decision;
    try {
      decision = await checklist.ask(await api("/missions/preflight", { method: "POST", body }));
    } catch (err) {
      refused("Pre-flight check", err);
      status.textContent = `Send failed: ${err.message}`;
      return;
    }
    if (!decision) return;
    try {
      const query = { start: "true", override: decision.override || undefined };
      const record = await api("/missions", { method: "POST", body, query });
      s.missionId = record.mission_id;
      s.lastEvent = null;
      showMission(record);
      poll();
      toast(`mission ${record.mission_id} sent${decision.override ? " (checks overridden)" : ""}`);
    } catch (err) {
      refused("Send", err);
      status.textContent = `Send failed: ${err.message}`;
      toast(`send failed: ${err.message}`, "error");
    }
  }

  async function saveLog() {
    if (!s.missionId) { toast("no mission is watched", "error"); return; }
    try { await downloadMissionLog(s.missionId); } catch (err) { toast(`mission log: ${err.message}`, "error"); }
  }

  /** Stop the watched mission and send its drones home (RTL); never waits for a confirmation. */
  async function abort() {
    if (!s.missionId) { toast("no mission is watched", "error"); return; }
    try {
      showMission(await api(`/missions/${s.missionId}/abort`, { method: "POST" }));
      toast(`mission ${s.missionId} aborted: its drones are going home`);
    } catch (err) {
      toast(`abort failed: ${err.message}`, "error");
    }
  }

  /** Pause the watched mission (its drones hold) or fly on with it; each drone answers. */
  async function pauseOrResume(action) {
    if (!s.missionId) { toast("no mission is watched", "error"); return; }
    try {
      showMission(await api(`/missions/${s.missionId}/${action}`, { method: "POST" }));
      toast(`mission ${s.missionId}: ${action} sent`);
    } catch (err) {
      toast(`${action} failed: ${err.message}`, "error");
    }
  }

  function showMission(m) {
    // The stream's summary counts the handovers; the mission itself (GET) lists them.
    const handovers = Array.isArray(m.handovers) ? m.handovers.length : m.handovers;
    status.dataset.state = m.state;
    status.dataset.mission = m.mission_id;
    status.dataset.handovers = String(handovers ?? 0);
    // What happened last (an expansion, a handover, a pause) says what the planner did.
    const last = s.lastEvent && s.lastEvent.mission === m.mission_id ? ` — last: ${s.lastEvent.text}` : "";
    status.textContent = `Mission ${m.mission_id}: ${m.state} — ${m.steps_done}/${m.steps} steps, ${m.waypoints_reached}/${m.waypoints} waypoints, ${handovers} handover(s)${m.error ? ` — ${m.error}` : ""}${last}`;
    if (Array.isArray(m.handovers)) showHandovers(m.handovers);
  }

  /** Where each handover happened: a marker saying which drone took over from which. */
  function showHandovers(list) {
    handoverLayer.clearLayers();
    for (const h of list) {
      const at = h.resume_position;
      if (!at) continue;
      const text = `handover: ${h.from_drone} → ${h.to_drone || "nobody"} (${h.kind || ""})`;
      L.circleMarker([at.lat, at.lon], { radius: 9, color: "#dc2626", weight: 3, fill: false, className: "handover-marker" })
        .bindTooltip(el("span", {}, text), { permanent: true, direction: "right", className: "handover-label" }).addTo(handoverLayer);
    }
  }

  /** What the drones measured: one dot per reading, green (lowest) to red (highest). */
  function showReadings(geo) {
    readingLayer.clearLayers();
    const features = (geo && geo.features) || [];
    const values = features.map((f) => f.properties.value);
    readingsKey.hidden = !values.length;
    if (!values.length) return;
    const lo = Math.min(...values), hi = Math.max(...values);
    const unit = features[0].properties.unit || "";
    readingsKey.textContent = `Readings (${features.length}): green ${lo.toFixed(0)} → red ${hi.toFixed(0)} ${unit}`;
    for (const f of features) {
      const [lon, lat] = f.geometry.coordinates;
      const p = f.properties;
      const t = hi > lo ? (p.value - lo) / (hi - lo) : 0;
      // Text nodes only: the sensor's and drone's names come from the drones (issue 12).
      const label = el("span", {}, `${p.sensor} ${p.value.toFixed(1)} ${p.unit || ""} (${p.drone_id})`);
      L.circleMarker([lat, lon], { radius: 6, weight: 1, color: "#1e293b", fillColor: `hsl(${Math.round(120 - 120 * t)}, 85%, 42%)`, fillOpacity: 0.9, className: "reading-marker" })
        .bindTooltip(label).addTo(readingLayer);
    }
    if (s.readingsShown !== s.missionId) {  // once per mission: the operator's view stays put
      s.readingsShown = s.missionId;
      map.fitBounds(L.featureGroup(readingLayer.getLayers()).getBounds(), { padding: [40, 40], maxZoom: 19 });
    }
  }

  function fillDrones() {
    const have = new Set([...drones.querySelectorAll("input")].map((i) => i.value));
    for (const d of ctx.fleet.list()) {
      if (have.has(d.drone_id)) continue;
      const id = `plan-drone-${d.drone_id}`;
      drones.append(el("div", { class: "check" }, el("input", { type: "checkbox", id, value: d.drone_id }), el("label", { for: id }, d.drone_id)));
    }
  }

  let fitted = false;
  function render() {
    fillDrones();
    ctx.fleet.list().forEach((d, i) => {
      const at = latLngOf(d.position);
      if (!at) return;
      if (!markers.has(d.drone_id)) {
        markers.set(d.drone_id, L.marker(at, { keyboard: false }).on("click", () => panel.show(d.drone_id)).addTo(map));
        trails.set(d.drone_id, L.polyline([], { color: colorFor(i), weight: 2 }).addTo(map));
      }
      markers.get(d.drone_id).setLatLng(at).setIcon(droneIcon(d));
      if (s.missionId && d.mission_id && d.mission_id.startsWith(s.missionId)) trails.get(d.drone_id).addLatLng(at);
      if (!fitted) {
        // Not animated: a zoom animation ran on after "fitted" was set, and a test's drag on a
        // handle still moving with it missed (a busy host makes it longer).
        map.setView(at, 19, { animate: false });
        fitted = true;
        map.getContainer().dataset.fitted = "1"; // the view moves no more by itself (tests wait)
      }
    });
  }

  const off = ctx.onStream((msg) => {
    if (msg.kind === "mission" && msg.data && msg.data.mission_id === s.missionId) {
      if (msg.data.state && msg.data.steps !== undefined) showMission(msg.data);
      else poll();
      if (msg.data.event === "handover") toast(`mission ${s.missionId}: handover`);
    }
  });
  async function poll() {
    if (!s.missionId) return;
    const id = s.missionId;
    try {
      const view = await api(`/missions/${id}/progress`);
      if (id !== s.missionId) return;  // another mission was chosen meanwhile
      const last = latestEvent(view);
      s.lastEvent = last ? { mission: id, text: last.text } : null;
      progress.show(view);
    } catch { /* the stream will tell */ }
    try { showMission(await api(`/missions/${id}`)); } catch { /* the stream will tell */ }
    try { showReadings(await api(`/missions/${s.missionId}/readings`)); } catch { showReadings(null); }
  }
  const poller = setInterval(poll, 3000);
  ctx.fleet.addEventListener("change", render);
  render();
  return () => { off(); panel.destroy(); clearInterval(poller); ctx.fleet.removeEventListener("change", render); map.remove(); };
}
