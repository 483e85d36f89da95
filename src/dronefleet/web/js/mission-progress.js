// A mission's progress as GET /missions/{id}/progress answers it (issue 29): a bar for the whole
// mission and one per drone (its share), the step each flies now, the time each has left (the
// ground's estimate, vehicle seconds) and the mission's timeline. The Planner and Fleet pages use it.
import { NAMES } from "./pages/planner-steps.js";
import { el, fmtDuration } from "./ui.js";

const DOING = {
  flying: "flying", sent: "starting", paused: "paused", leaving: "leaving (replaced)",
  "handed over": "handed over", done: "done", failed: "failed", stopped: "stopped",
};

function clock(at) {
  return Number.isFinite(at) ? new Date(at * 1000).toLocaleTimeString([], { hour12: false }) : "";
}

function timeLeft(d) {
  if (!d.current) return d.doing === "done" ? "done" : "—";
  if (d.eta_s === null || d.eta_s === undefined) return d.eta_pending ? "estimating…" : "—";
  return `${fmtDuration(d.eta_s)} left`;
}

function stepText(d) {
  const c = d.current;
  if (!c) return "—";
  return `step ${c.drone_step + 1}/${c.drone_steps}: ${NAMES[c.command] || c.command}`;
}

/** The latest thing that happened, for a one-line status (null when nothing has). */
export function latestEvent(view) {
  const events = (view && view.events) || [];
  return events.length ? events[events.length - 1] : null;
}

/**
 * A progress panel; `show(view)` fills it from a progress answer. `colorOf(droneId)` gives the
 * drone's colour on the map (optional). Every id starts with `idPrefix`.
 */
export function missionProgress({ idPrefix, colorOf = () => null }) {
  const overall = el("progress", { id: `${idPrefix}-overall`, max: 1, value: 0, "aria-label": "Mission done" });
  const overallText = el("span", { class: "progress-text", id: `${idPrefix}-overall-text` });
  const rows = el("tbody");
  const table = el("table", { class: "grid progress-table", id: `${idPrefix}-drones` },
    el("caption", {}, "Drones in this mission"),
    el("thead", {}, el("tr", {}, ...["Drone", "Share done", "Now", "Time left"].map((h) => el("th", { scope: "col" }, h)))),
    rows);
  const events = el("ol", { class: "timeline", id: `${idPrefix}-events`, reversed: true, "aria-label": "What happened" });
  const element = el("div", { class: "mission-progress", id: idPrefix, hidden: true },
    el("div", { class: "progress-line" }, overall, overallText), table,
    el("p", { class: "timeline-title" }, el("strong", {}, "Events")), events);

  function show(view) {
    if (!view) { element.hidden = true; return; }
    element.hidden = false;
    element.dataset.mission = view.mission_id;
    element.dataset.state = view.state;
    overall.value = view.fraction_done;
    const left = Number.isFinite(view.eta_s) ? `, about ${fmtDuration(view.eta_s)} left` : "";
    overallText.textContent = `${Math.round(100 * view.fraction_done)} % done (${view.waypoints_reached}/${view.waypoints} waypoints)${left}`;
    rows.replaceChildren(...view.progress.map((d) => {
      const color = colorOf(d.drone_id);
      return el("tr", { "data-drone": d.drone_id, "data-doing": d.doing, "data-share": String(d.share) },
        el("th", { scope: "row" }, color ? el("span", { class: "swatch", style: `background:${color}`, "aria-hidden": "true" }) : null,
          d.drone_id, el("span", { class: "hint" }, ` ${DOING[d.doing] || d.doing}${d.role !== "primary" ? ` · ${d.role}` : ""}`)),
        el("td", { class: "share" },
          el("progress", { max: 1, value: d.share, "aria-label": `${d.drone_id}: share done` }),
          el("span", { class: "progress-text" }, ` ${d.waypoints_reached}/${d.waypoints} waypoints`)),
        el("td", { class: "step", title: d.paused || "" }, stepText(d)),
        el("td", { class: "eta", "data-eta": d.eta_s ?? "" }, timeLeft(d)));
    }));
    // Newest first: what just happened is what an operator looks for.
    events.replaceChildren(...[...view.events].reverse().map((e) => el("li", { "data-kind": e.kind },
      el("time", {}, clock(e.at)), " ", e.text)));
    if (!view.events.length) events.append(el("li", { class: "hint" }, "nothing yet"));
  }

  return { element, show };
}
