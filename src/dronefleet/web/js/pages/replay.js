// Replay: a mission log (dropped file or a finished mission), each drone's path on a timeline.
import { api } from "../api.js";
import { downloadMissionLog } from "../download.js";
import { colorFor, makeMap } from "../map.js";
import { addMissionOptions } from "../missions.js";
import { el, field, fmtDuration, toast } from "../ui.js";

const L = window.L;

export async function mount(root, ctx) {
  const pick = el("select", { id: "replay-mission" }, el("option", { value: "" }, "— pick a mission —"));
  const file = el("input", { type: "file", id: "replay-file", accept: ".json,application/json" });
  const drop = el("div", { class: "drop", id: "replay-drop" },
    el("label", { for: "replay-file" }, "Drop a mission log (.json) here, or choose a file: "), file);
  const download = el("button", { type: "button", id: "replay-download", class: "small", disabled: true, onclick: () => saveLog() }, "Download its log");
  const slider = el("input", { type: "range", id: "replay-time", min: "0", max: "1000", value: "1000", disabled: true });
  const clock = el("output", { id: "replay-clock", for: "replay-time" }, "—");
  // Play at 1×, 2×, 5× or 10× vehicle time (issue 14); the timeline follows.
  const play = el("button", { type: "button", id: "replay-play", disabled: true, "aria-pressed": "false", onclick: () => toggle() }, "▶ Play");
  const speed = el("select", { id: "replay-speed" }, ...[1, 2, 5, 10].map((x) => el("option", { value: String(x) }, `${x}×`)));
  const title = el("p", { id: "replay-title", role: "status" }, "No log loaded.");
  const steps = el("div", { id: "replay-steps", class: "scroll", tabindex: "0", role: "region", "aria-label": "Steps flown" });
  const mapBox = el("div", { class: "map", id: "replay-map" });
  root.append(el("h1", {}, "Replay"), el("div", { class: "split" }, mapBox, el("div", { class: "side" },
    field("Finished mission", pick), el("div", { class: "buttons" }, download), drop, title, field("Timeline", slider), clock,
    el("div", { class: "controls" }, play, field("Speed", speed)), steps)));
  const map = await makeMap(mapBox);
  const layers = L.layerGroup().addTo(map);
  let tracks = [];
  let span = [0, 0];

  try {
    await addMissionOptions(pick);
  } catch (err) {
    toast(`missions: ${err.message}`, "error");
  }
  pick.addEventListener("change", async () => {
    download.disabled = !pick.value;
    if (!pick.value) return;
    try { show(await api(`/missions/${encodeURIComponent(pick.value)}/log`)); } catch (err) { toast(err.message, "error"); }
  });
  async function readFile(f) {
    try { show(JSON.parse(await f.text())); } catch (err) { toast(`not a mission log: ${err.message}`, "error"); }
  }
  file.addEventListener("change", () => file.files[0] && readFile(file.files[0]));
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    if (e.dataTransfer.files[0]) readFile(e.dataTransfer.files[0]);
  });
  slider.addEventListener("input", () => { stop(); seek(Number(slider.value) / 1000); });

  let timer = null;
  let last = 0;
  /** Play from where the timeline is (from the start when at the end), `speed` × vehicle time. */
  function toggle() {
    if (timer) return stop();
    if (Number(slider.value) >= 1000) slider.value = "0";
    last = performance.now();
    timer = setInterval(() => {
      const now = performance.now();
      const length = span[1] - span[0];
      const step = length > 0 ? ((now - last) / 1000) * Number(speed.value) / length : 1;
      last = now;
      const at = Math.min(1, Number(slider.value) / 1000 + step);
      slider.value = String(Math.round(at * 1000));
      seek(at);
      if (at >= 1) stop();
    }, 100);
    play.textContent = "⏸ Pause";
    play.setAttribute("aria-pressed", "true");
  }
  function stop() {
    clearInterval(timer);
    timer = null;
    play.textContent = "▶ Play";
    play.setAttribute("aria-pressed", "false");
  }
  async function saveLog() {
    try { await downloadMissionLog(pick.value); } catch (err) { toast(`mission log: ${err.message}`, "error"); }
  }

  function show(log) {
    if (!log || !Array.isArray(log.drones)) throw new Error("no drones in this file");
    layers.clearLayers();
    if (log.area && log.area.polygon) L.polygon(log.area.polygon, { color: "#9ca3af", weight: 1, fillOpacity: 0.05 }).addTo(layers);
    // A dropped file is untrusted input (issue 25): every name in it goes on the page as text —
    // a Leaflet tooltip given a string would insert it as HTML, so it gets a text node.
    tracks = log.drones.map((d, i) => {
      const color = colorFor(i);
      const all = d.path.map((p) => [p.lat, p.lon]);
      L.polyline(all, { color, weight: 1, opacity: 0.35 }).addTo(layers);
      return {
        d, path: d.path,
        line: L.polyline([], { color, weight: 3, className: "replay-path" }).addTo(layers),
        dot: L.circleMarker(all[0] || [0, 0], { radius: 6, color, fillOpacity: 0.9 }).bindTooltip(el("span", {}, d.drone_id), { permanent: true }).addTo(layers),
      };
    });
    const times = tracks.flatMap((t) => t.path.map((p) => p.t));
    span = times.length ? [Math.min(...times), Math.max(...times)] : [0, 0];
    const all = tracks.flatMap((t) => t.path.map((p) => [p.lat, p.lon]));
    if (all.length) map.fitBounds(L.latLngBounds(all).pad(0.2));
    stop();
    slider.disabled = false;
    play.disabled = false;
    slider.value = "1000";
    seek(1);
    // The log lists its handovers (the mission summary counts them): "[object Object]" was shown.
    const handovers = Array.isArray(log.handovers) ? log.handovers.length : Number(log.handovers) || 0;
    title.textContent = `${log.mission_id} “${log.name || ""}”: ${log.state}, ${log.drones.length} drone(s), ${log.steps_done}/${log.steps_planned} steps, ${handovers} handover(s)`;
    title.dataset.handovers = String(handovers);
    title.dataset.mission = log.mission_id;
    renderSteps();
  }

  function seek(fraction) {
    const t = span[0] + (span[1] - span[0]) * fraction;
    for (const track of tracks) {
      const upto = track.path.filter((p) => p.t <= t);
      const pts = upto.map((p) => [p.lat, p.lon]);
      track.line.setLatLngs(pts);
      if (pts.length) track.dot.setLatLng(pts[pts.length - 1]);
    }
    clock.textContent = `t = ${(t - span[0]).toFixed(1)} s of ${(span[1] - span[0]).toFixed(1)} s (vehicle time)`;
  }

  function renderSteps() {
    steps.replaceChildren(el("table", { class: "grid", id: "replay-step-table" },
      el("caption", {}, "Steps"),
      el("thead", {}, el("tr", {}, ...["Drone", "#", "Command", "Start (s)", "Took"].map((h) => el("th", { scope: "col" }, h)))),
      el("tbody", {}, ...tracks.flatMap((t) => (t.d.steps || []).map((s) => el("tr", {},
        el("td", {}, t.d.drone_id), el("td", {}, s.index ?? "—"), el("td", {}, s.command),
        el("td", {}, Number.isFinite(s.started_s) ? (s.started_s - span[0]).toFixed(1) : "—"),
        el("td", {}, fmtDuration(s.duration_s))))))));
  }

  return () => { stop(); map.remove(); };
}
