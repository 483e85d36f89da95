// Direct flight commands as an operator reads them (issue 29): what was asked, in words with
// units and frames ("take-off to 10 m above home", never `alt_m: 20`), and where it stands:
// sending, accepted (moving), done only when the drone reports the move ended
// (drone/command_watch.py: the same request id again on the stream's "command" messages),
// refused (a mission flies it: the drone's own sentence), failed.
import { api } from "./api.js";

const MODE_WORDS = {
  GUIDED: "fly on to its goal (GUIDED)",
  HOLD: "stop and hold position (HOLD)",
  LAND: "land where it is (LAND)",
  RTL: "return home and land (RTL)",
};
/** The modes the selector offers, in the order shown. */
export const MODES = ["HOLD", "GUIDED", "LAND", "RTL"];
export const MODE_LABELS = { HOLD: "Hold position", GUIDED: "Guided (fly on)", LAND: "Land here", RTL: "Return home (RTL)" };
const ENDS = {
  reached: "reached", landed: "landed", holding: "holding still",
  superseded: "superseded by a later command or the mission", "timed out": "not done in time",
};

const m = (x) => `${Math.abs(x).toFixed(Math.abs(x) < 10 && x % 1 ? 1 : 0)} m`;
const above = (x) => `${m(x)} above home`;

/** What `command` with `body` asks, in words. */
export function describe(command, body = {}) {
  const v = body.value;
  switch (command) {
    case "arm": return "arm the motors";
    case "disarm": return body.force ? "disarm (forced: in the air it falls)" : "disarm";
    case "takeoff": return v ? `take-off to ${above(v)}` : "take-off to the drone's default height";
    case "land": return "land where it is";
    case "rtl": return "return home and land";
    case "changeN": return `move ${m(v)} ${v < 0 ? "south" : "north"}`;
    case "changeE": return `move ${m(v)} ${v < 0 ? "west" : "east"}`;
    case "altitude": return `${v < 0 ? "descend" : "climb"} ${m(v)}`;
    case "navigate": return `fly to ${Number(body.lat).toFixed(6)}, ${Number(body.lon).toFixed(6)}${Number.isFinite(body.altitude_delta) ? ` at ${above(body.altitude_delta)}` : ""}`;
    case "mode": return MODE_WORDS[v] || `switch to ${v}`;
    case "takepic": return "take a picture";
    case "resetfc": return "restart the flight controller";
    default: return command;
  }
}

/** What the drone's answer says, in words (where it is going, where it ended). */
export function answerWords(answer) {
  const r = (answer && answer.result) || {};
  const parts = [];
  const target = r.target || r.holding_at;
  if (target && Number.isFinite(target.above_home_m)) {
    parts.push(`${r.holding_at ? "holding at" : "target"} ${above(target.above_home_m)} (${target.alt_m.toFixed(1)} m above sea level)`);
  }
  if (r.lands_at) parts.push(`lands at ${r.lands_at.lat.toFixed(6)}, ${r.lands_at.lon.toFixed(6)}`);
  if (r.position && Number.isFinite(r.position.above_home_m)) parts.push(`now ${above(r.position.above_home_m)}`);
  if (r.capture) parts.push(`picture ${r.capture.name || r.capture.file || "taken"}`);
  return parts.join("; ");
}

// The stream's "command" messages by request id (the end of a move may come before the answer).
const ends = new Map();
const waiting = new Map();

/** Feed every stream message (app.js does, once). */
export function onStreamMessage(msg) {
  if (msg.kind !== "command" || !msg.data || !msg.data.done || !msg.data.request_id) return;
  const id = msg.data.request_id;
  const resolve = waiting.get(id);
  if (resolve) { waiting.delete(id); resolve(msg.data); return; }
  ends.set(id, msg.data);
  if (ends.size > 200) ends.delete(ends.keys().next().value);
}

function endOf(requestId) {
  if (ends.has(requestId)) {
    const end = ends.get(requestId);
    ends.delete(requestId);
    return Promise.resolve(end);
  }
  return new Promise((resolve) => waiting.set(requestId, resolve));
}

/**
 * Send `command` to drone `id` and report each stage to `update({state, text, answer})`:
 * "sending", then "accepted" (a move under way), then "done", "superseded", "refused" or "failed".
 */
export async function runCommand(id, command, body, update) {
  const what = describe(command, body);
  update({ state: "sending", text: `${id}: ${what}: sending…` });
  let answer;
  try {
    answer = await api(`/drones/${encodeURIComponent(id)}/commands/${command}`, { method: "POST", body });
  } catch (err) {
    const refused = err.status === 409;
    update({ state: refused ? "refused" : "failed", text: `${id}: ${what}: ${refused ? "refused" : "failed"}. ${err.message}`, error: err });
    return;
  }
  const words = answerWords(answer);
  if (answer.done !== false) {
    update({ state: "done", text: `${id}: ${what}: done${words ? `; ${words}` : ""}.`, answer });
    return;
  }
  update({ state: "accepted", text: `${id}: ${what}: accepted, under way${words ? `; ${words}` : ""}…`, answer });
  const end = await endOf(answer.request_id);
  const how = ENDS[end.outcome] || end.outcome;
  const after = answerWords(end);
  const state = end.ok ? "done" : end.outcome === "superseded" ? "superseded" : "failed";
  const verdict = end.ok ? `done, ${how}` : how;
  update({ state, text: `${id}: ${what}: ${verdict}${after ? `; ${after}` : ""}.`, answer, end });
}
