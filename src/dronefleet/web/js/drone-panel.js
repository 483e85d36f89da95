// The per-drone panel (issue 14): everything an operator reads about one drone, and the four
// buttons that act on it alone (Pause, Resume, Abort, RTL), on every page that shows drones.
// Flight control (issue 29): a flight-mode selector and Hold and Land buttons, with the result in
// words (web/js/flight-commands.js): "done" only once the drone reports the move ended.
//
// Figures come from the drone's heartbeats (via ctx.fleet): mode, height above home, ground
// speed, battery, GPS, link, and what follows from them (distance home, flight time left).
import { levelWord } from "./alarms.js";
import { api } from "./api.js";
import { missionOfLeg, downloadMissionLog } from "./download.js";
import { describe, MODE_LABELS, MODES, runCommand } from "./flight-commands.js";
import { distanceM, el, fmtAgo, fmtDuration, toast } from "./ui.js";

/** Battery levels: a colour and a word (never colour alone). */
export const BATTERY_LEVELS = [
  { min: 40, level: "ok", word: "OK" },
  { min: 20, level: "warn", word: "LOW" },
  { min: -Infinity, level: "critical", word: "CRITICAL" },
];
/** What the flight time left counts down to: the CRITICAL alarm's level (drone/battery_guard.py). */
export const RESERVE_PCT = 20;

export function batteryLevel(pct) {
  return BATTERY_LEVELS.find((b) => pct >= b.min);
}

/** Seconds of flight until the reserve, from the charge left and the current it draws (flying)
 * or would draw hovering (on the ground); null when the drone does not say enough. */
export function flightTimeLeftS(drone) {
  const battery = drone.battery || {};
  const flight = drone.flight || {};
  const capacity = flight.capacity_mah;
  const flying = ["flying", "taking_off", "landing"].includes(drone.state);
  const current = flying && battery.current_a > 1 ? battery.current_a : flight.hover_current_a || flight.flight_current_a;
  if (!Number.isFinite(battery.remaining_pct) || !capacity || !current) return null;
  const usableMah = Math.max(0, battery.remaining_pct - RESERVE_PCT) / 100 * capacity;
  return (usableMah / 1000 / current) * 3600;
}

function linkText(d) {
  const ago = d.last_seen ? Math.max(0, Date.now() / 1000 - d.last_seen) : d.seen_ago_s;
  const state = d.status === "lost" ? "LOST" : d.status === "autopilot link lost" ? "autopilot link lost" : "online";
  return `${state}, heard ${fmtAgo(ago)}`;
}

function gpsText(gps) {
  if (!gps) return "unknown";
  const fix = { "3d": "3-D fix", "2d": "2-D fix", no_fix: "no fix", no_gps: "no GPS" }[gps.fix] || gps.fix;
  return `${fix}, ${gps.satellites} satellites`;
}

/**
 * A panel for one drone at a time. `panel.show(id)` picks the drone (null: none); the panel
 * follows ctx.fleet until `panel.destroy()`. `onAction(name, answer)` hears each done action.
 */
export function dronePanel(ctx, { idPrefix = "drone-panel", onAction = () => {} } = {}) {
  const can = ctx.me.can_command;
  const title = el("h2", { id: `${idPrefix}-title` }, "No drone selected");
  const figures = el("dl", { class: "figures" });
  const note = el("p", { class: "hint", id: `${idPrefix}-note` }, can ? "" : "Viewer token: the buttons are disabled.");
  const button = (action, label, extra = {}) => el("button", {
    type: "button", class: "command", "data-action": action, id: `${idPrefix}-${action}`, disabled: true,
    onclick: () => act(action), ...extra,
  }, label);
  const buttons = {
    pause: button("pause", "Pause (hold)", { title: "Hold where it is; Resume flies on" }),
    resume: button("resume", "Resume"),
    abort: button("abort", "Abort: home", { class: "command danger", title: "End its part of the mission; it returns home and lands" }),
    rtl: button("rtl", "RTL", { class: "command danger", title: "Return to launch and land" }),
  };
  const log = el("button", { type: "button", id: `${idPrefix}-log`, class: "small", hidden: true, onclick: () => saveLog() }, "Mission log");
  // Flight control: the mode selector, Hold and Land, and what came of the last one.
  const modeSelect = el("select", { id: `${idPrefix}-mode-select`, "aria-label": "Flight mode to set", disabled: true },
    el("option", { value: "" }, "Set a flight mode…"), ...MODES.map((mode) => el("option", { value: mode }, MODE_LABELS[mode])));
  const flight = {
    mode: el("button", { type: "button", class: "command", id: `${idPrefix}-set-mode`, disabled: true, onclick: () => fly("mode", { value: modeSelect.value }) }, "Set mode"),
    hold: el("button", { type: "button", class: "command", id: `${idPrefix}-hold`, disabled: true, title: "Stop and hold position (pauses a mission)", onclick: () => fly("mode", { value: "HOLD" }) }, "Hold"),
    land: el("button", { type: "button", class: "command danger", id: `${idPrefix}-land`, disabled: true, title: "Land where it is (pauses a mission)", onclick: () => fly("land") }, "Land"),
  };
  const result = el("p", { class: "command-result", id: `${idPrefix}-result`, "aria-live": "polite" });
  const element = el("section", { class: "drone-panel", id: idPrefix, "aria-labelledby": `${idPrefix}-title` },
    title, figures, el("div", { class: "buttons" }, ...Object.values(buttons), log),
    el("div", { class: "buttons flight" }, modeSelect, flight.mode, flight.hold, flight.land), result, note);
  let chosen = null;

  function row(key, label, value, attrs = {}) {
    return [el("dt", {}, label), el("dd", { "data-figure": key, ...attrs }, value)];
  }

  function render() {
    const d = chosen && ctx.fleet.drones.get(chosen);
    element.dataset.drone = chosen || "";
    if (!d) {
      title.textContent = chosen ? `${chosen}: not heard yet` : "No drone selected";
      if (can) note.textContent = "Pick a drone: its name in the list, or its arrow on the map.";
      figures.replaceChildren();
      for (const b of [...Object.values(buttons), ...Object.values(flight), modeSelect]) b.disabled = true;
      log.hidden = true;
      return;
    }
    if (can) note.textContent = "Abort and RTL ask first.";
    const pct = d.battery ? d.battery.remaining_pct : null;
    const level = pct === null ? null : batteryLevel(pct);
    const home = d.home && d.position ? distanceM(d.position, d.home) : null;
    const left = flightTimeLeftS(d);
    const mission = missionOfLeg(d.mission_id);
    title.textContent = `${d.drone_id}${d.status === "lost" ? " (lost)" : ""}`;
    figures.replaceChildren(
      ...row("state", "State", d.state || "—"),
      ...row("mode", "Mode", d.mode || "—"),
      ...row("altitude", "Altitude", d.position && Number.isFinite(d.position.relative_alt_m) ? `${d.position.relative_alt_m.toFixed(1)} m` : "—"),
      ...row("speed", "Speed", Number.isFinite(d.ground_speed_mps) ? `${d.ground_speed_mps.toFixed(1)} m/s` : "—"),
      ...row("battery", "Battery", level ? `${pct.toFixed(0)} % ${level.word}` : "—", level ? { class: `battery ${level.level}`, "data-level": level.level } : {}),
      ...row("gps", "GPS", gpsText(d.gps)),
      ...row("link", "Link", linkText(d), { class: d.status === "online" ? "" : "alarm" }),
      ...row("home", "Distance to home", home === null ? "—" : `${home.toFixed(0)} m`),
      ...row("time-left", `Flight time left (to ${RESERVE_PCT} %)`, left === null ? "—" : fmtDuration(left)),
      ...row("wind", "Wind", d.wind ? `${d.wind.speed_mps.toFixed(1)} m/s from ${d.wind.from_deg.toFixed(0)}°` : "unknown"),
      ...row("mission", "Mission", mission || "none"),
      ...row("alarm", "Last alarm", d.alarm ? `${levelWord(d.alarm.level)}: ${d.alarm.message || "(no message)"} (${fmtAgo(Math.max(0, Date.now() / 1000 - d.alarm.at))})` : "none",
        d.alarm ? { class: d.alarm.level === "CRITICAL" ? "alarm" : "", "data-level": d.alarm.level } : {}),
    );
    const flying = ["flying", "taking_off", "landing"].includes(d.state);
    buttons.pause.disabled = !can || !mission;
    buttons.resume.disabled = !can || !mission;
    buttons.abort.disabled = !can || !mission;
    buttons.rtl.disabled = !can || (!flying && !mission);
    modeSelect.disabled = !can;
    flight.mode.disabled = !can || !modeSelect.value;
    flight.hold.disabled = !can || !flying;
    flight.land.disabled = !can || !flying;
    log.hidden = !mission;
  }

  async function act(action) {
    const id = chosen;
    if (!id) return;
    const questions = {
      abort: `Abort ${id}'s part of its mission? It stops, returns home and lands; its steps left are not flown.`,
      rtl: `Send ${id} home now (RTL)? It returns to its launch point and lands.`,
    };
    if (questions[action] && !window.confirm(questions[action])) return;
    const path = action === "rtl" ? `/drones/${encodeURIComponent(id)}/commands/rtl` : `/drones/${encodeURIComponent(id)}/${action}`;
    element.dataset.state = "sending";
    try {
      const answer = await api(path, { method: "POST" });
      element.dataset.state = "done";
      element.dataset.action = action;
      toast(`${id}: ${action} sent`);
      onAction(action, answer);
    } catch (err) {
      element.dataset.state = "failed";
      element.dataset.action = action;
      toast(`${id}: ${action} failed: ${err.message}`, "error");
    }
  }

  modeSelect.addEventListener("change", () => { flight.mode.disabled = !can || !modeSelect.value; });

  /** A flight command from the panel: Land, RTL and LAND ask first; the result in words. */
  async function fly(command, body) {
    const id = chosen;
    if (!id || (command === "mode" && !body.value)) return;
    const what = describe(command, body);
    const asks = command === "land" || (command === "mode" && ["LAND", "RTL"].includes(body.value));
    if (asks && !window.confirm(`${id}: ${what}? It comes down${body && body.value === "RTL" ? " at home" : " where it is"}.`)) return;
    await runCommand(id, command, body, ({ state, text, answer }) => {
      if (chosen !== id) return; // another drone is shown now
      result.textContent = text;
      Object.assign(result.dataset, { command, state });
      if (state === "done") onAction(command, answer);
    });
  }

  async function saveLog() {
    const d = chosen && ctx.fleet.drones.get(chosen);
    const mission = d && missionOfLeg(d.mission_id);
    if (!mission) return;
    try { await downloadMissionLog(mission); } catch (err) { toast(`mission log: ${err.message}`, "error"); }
  }

  const onChange = () => render();
  ctx.fleet.addEventListener("change", onChange);
  const ticker = setInterval(render, 2000); // "heard N s ago" ages between heartbeats
  render();
  return {
    element,
    show(id) {
      if ((id || null) !== chosen) { result.textContent = ""; delete result.dataset.state; }
      chosen = id || null;
      render();
    },
    get selected() { return chosen; },
    destroy() { ctx.fleet.removeEventListener("change", onChange); clearInterval(ticker); },
  };
}
