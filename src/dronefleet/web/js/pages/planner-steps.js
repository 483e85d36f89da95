// The Planner's step list: drag the seed's commands into a list, reorder by drag or with buttons.
import { el } from "../ui.js";

export const PALETTE = [
  { command: "arm" },
  { command: "takeoff", value: 10 },
  { command: "wait_for_flight" },
  { command: "navigate", lat: 0, lon: 0, altitude_delta: 10 },
  { command: "changeN", value: 10 },
  { command: "changeE", value: 10 },
  { command: "altitude", value: 5 },
  { command: "takepic" },
  { command: "read_sensors" },
  { command: "sleep", value: 2 },
  { command: "land" },
  { command: "disarm" },
];

/** A step-list editor; `steps()` gives the list as the API takes it. */
export function stepEditor(onChange) {
  const list = [];
  const palette = el("ul", { class: "palette", "aria-label": "Commands (drag into the list, or press Add)" });
  const box = el("ol", { class: "steps", id: "step-list", "aria-label": "Mission steps" });
  let dragFrom = null;

  for (const proto of PALETTE) {
    const item = el("li", { draggable: "true", "data-command": proto.command },
      el("span", {}, proto.command),
      el("button", { type: "button", class: "small", "aria-label": `Add ${proto.command}`, onclick: () => add(proto) }, "Add"));
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
      if (text) list.splice(at, 0, { ...JSON.parse(text) });
    }
    render();
  });

  function add(proto, at = list.length) {
    list.splice(at, 0, { ...proto });
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
      const params = Object.keys(step).filter((k) => k !== "command").map((k) => el("label", { class: "param" }, k,
        el("input", { type: "number", step: "any", value: step[k], "aria-label": `${step.command} ${k}`,
          onchange: (e) => { step[k] = Number(e.target.value); onChange(); } })));
      const item = el("li", { "data-index": i, draggable: "true" },
        el("strong", {}, step.command), ...params,
        el("span", { class: "row-buttons" },
          el("button", { type: "button", class: "small", "data-move": "up", "aria-label": `Move step ${i + 1} up`, onclick: () => move(i, -1) }, "↑"),
          el("button", { type: "button", class: "small", "data-move": "down", "aria-label": `Move step ${i + 1} down`, onclick: () => move(i, 1) }, "↓"),
          el("button", { type: "button", class: "small", "aria-label": `Remove step ${i + 1}`, onclick: () => { list.splice(i, 1); render(); } }, "✕")));
      item.addEventListener("dragstart", () => { dragFrom = i; });
      return item;
    }));
    onChange();
  }

  return {
    palette,
    box,
    add,
    steps: () => list.map((s) => ({ ...s })),
    clear: () => { list.length = 0; render(); },
  };
}
