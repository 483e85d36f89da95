// The planner's missions as options of a <select> (Replay picks a log, Planner watches one).
import { api } from "./api.js";
import { el } from "./ui.js";

/** Add to `select` the missions it does not list yet, newest first. */
export async function addMissionOptions(select) {
  const have = new Set([...select.options].map((o) => o.value));
  for (const m of await api("/missions")) {
    if (!have.has(m.mission_id)) select.append(el("option", { value: m.mission_id }, `${m.mission_id} — ${m.name || ""} (${m.state})`));
  }
}
