// The Planner's step list: drag the seed's commands into a list, reorder by drag or with buttons.
// Each command has a person's name (the raw one beside it) and each number its unit (issue 14).
import { DEFAULT_CENTER } from "../map.js";
import { el } from "../ui.js";

export const PALETTE = [
  { command: "arm" },
  { command: "takeoff", value: 10 },
  { command: "wait_for_flight" },
  { command: "navigate", lat: null, lon: null, altitude_delta: 10 }, // lat/lon: where the map is
  { command: "changeN", value: 10 },
  { command: "changeE", value: 10 },
  { command: "altitude", value: 5 },
  { command: "takepic" },
  { command: "read_sensors" },
  { command: "sleep", value: 2 },
  { command: "land" },
  { command: "rtl" },
  { command: "disarm" },
];

/** What a person calls each command (Table 4.3's names stay visible beside them). */
export const NAMES = {
  arm: "Arm the motors",
  takeoff: "Take off",
  wait_for_flight: "Wait until there",
  navigate: "Fly to a point",
  changeN: "Move north",
  changeE: "Move east",
  altitude: "Climb or descend",
  takepic: "Take a picture",
  read_sensors: "Read the sensors",
  sleep: "Hover and wait",
  land: "Land here",
  rtl: "Return home and land",
  disarm: "Disarm the motors",
  virtualalarm: "Raise an alarm",
  camera_trigger: "Photograph every …",
};

/** Each parameter's label and unit: [label, unit]. */
const PARAMS = {
  takeoff: { value: ["height", "m"] },
  navigate: { lat: ["latitude", "°"], lon: ["longitude", "°"], altitude_delta: ["height", "m"] },
  changeN: { value: ["north", "m"] },
  changeE: { value: ["east", "m"] },
  altitude: { value: ["up", "m"] },
  sleep: { value: ["for", "s"] },
  read_sensors: { value: ["hold", "s"] },
  camera_trigger: { value: ["every", "m"] },
};

export function paramLabel(command, key) {
  const [label, unit] = (PARAMS[command] || {})[key] || [key, ""];
  return { label, unit };
}

/** A step-list editor; `steps()` gives the list as the API takes it. */
export function stepEditor(onChange, where = () => null) {
  const list = [];
  const palette = el("ul", { class: "palette", "aria-label": "Commands (drag into the list, or press Add)" });
  const box = el("ol", { class: "steps", id: "step-list", "aria-label": "Mission steps" });
  let dragFrom = null;

  for (const proto of PALETTE) {
    // The palette is narrow: the raw name is its tooltip here, and shown beside each step.
    const item = el("li", { draggable: "true", "data-command": proto.command, title: `${proto.command} (Table 4.3)` },
      el("span", {}, NAMES[proto.command] || proto.command),
      el("button", { type: "button", class: "small", "aria-label": `Add ${NAMES[proto.command] || proto.command}`, onclick: () => add(proto) }, "Add"));
    item.addEventListener("dragstart", (e) => {
      dragFrom = null;
      e.dataTransfer.setData("text/plain", JSON.stringify(proto));
    });
    palette.append(item);
  }
  box.addEventListener("dragover", (e) => e.preventDefault());
  box.addEventListener("drop", (e) => {
    e.preventDefault();
    // On a step's upper half: before it; on its lower half: after it; elsewhere: at the end.
    const target = e.target.closest("li[data-index]");
    let at = list.length;
    if (target) {
      const r = target.getBoundingClientRect();
      at = Number(target.dataset.index) + (e.clientY > r.top + r.height / 2 ? 1 : 0);
    }
    if (dragFrom !== null) {
      const [moved] = list.splice(dragFrom, 1);
      list.splice(at > dragFrom ? at - 1 : at, 0, moved);
      dragFrom = null;
    } else {
      const text = e.dataTransfer.getData("text/plain");
      if (text) list.splice(at, 0, placed(JSON.parse(text)));
    }
    render();
  });

  /** A new step from the palette; a navigate without a place of its own goes where the planner
   * is looking (the chosen drone's home, or the map's centre), never to 0°, 0°. An imported
   * step keeps its coordinates. */
  function placed(proto) {
    const step = { ...proto };
    if (step.command === "navigate" && (step.lat == null || step.lon == null)) {
      const at = where() || { lat: DEFAULT_CENTER[0], lon: DEFAULT_CENTER[1] };
      step.lat = Number(at.lat.toFixed(7));
      step.lon = Number(at.lon.toFixed(7));
    }
    return step;
  }

  function add(proto, at = list.length) {
    list.splice(at, 0, placed(proto));
    render();
  }

  function move(i, by) {
    const j = i + by;
    if (j < 0 || j >= list.length) return;
    [list[i], list[j]] = [list[j], list[i]];
    render();
    // Keep the keyboard on the moved step: pressing again moves it further.
    box.querySelector(`li[data-index="${j}"] button[data-move="${by < 0 ? "up" : "down"}"]`).focus();
  }

  function render() {
    box.replaceChildren(...list.map((step, i) => {
      const params = Object.keys(step).filter((k) => k !== "command").map((k) => {
        const { label, unit } = paramLabel(step.command, k);
        return el("label", { class: "param" }, label,
          el("input", { type: "number", step: "any", value: step[k], "aria-label": `step ${i + 1} ${label}${unit ? ` (${unit})` : ""}`,
            "data-param": k, onchange: (e) => { step[k] = Number(e.target.value); onChange(); } }),
          unit);
      });
      const item = el("li", { "data-index": i, "data-command": step.command, draggable: "true" },
        el("strong", {}, NAMES[step.command] || step.command), el("code", { class: "raw" }, step.command), ...params,
        el("span", { class: "row-buttons" },
          el("button", { type: "button", class: "small", "data-move": "up", "aria-label": `Move step ${i + 1} up`, onclick: () => move(i, -1) }, "↑"),
          el("button", { type: "button", class: "small", "data-move": "down", "aria-label": `Move step ${i + 1} down`, onclick: () => move(i, 1) }, "↓"),
          el("button", { type: "button", class: "small", "aria-label": `Remove step ${i + 1}`, onclick: () => { list.splice(i, 1); render(); } }, "✕")));
      item.addEventListener("dragstart", () => { dragFrom = i; });
      return item;
    }));
    onChange();
  }

  /** Say what the server found wrong with step `index` (0-based), beside it; null clears. */
  function markError(index, text) {
    for (const li of box.querySelectorAll("li.step-error")) {
      li.classList.remove("step-error");
      li.querySelector(".step-problem")?.remove();
    }
    if (index === null || index === undefined) return;
    const li = box.querySelector(`li[data-index="${index}"]`);
    if (!li) return;
    li.classList.add("step-error");
    li.append(el("p", { class: "step-problem", role: "alert", id: `step-problem-${index}` }, text));
    li.scrollIntoView({ block: "nearest" });
  }

  return {
    palette,
    box,
    add,
    markError,
    steps: () => list.map((s) => ({ ...s })),
    clear: () => { list.length = 0; render(); },
  };
}
