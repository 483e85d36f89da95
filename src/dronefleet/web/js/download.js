// Files the API serves (mission logs) saved from the page. Fetched through api.js, with the
// session's credentials, then handed to the browser as a download: a plain link would carry none.
import { api } from "./api.js";
import { saveBlob } from "./files.js";

/** Save the JSON at /api/v1{path} as `filename`. */
export async function downloadJson(path, filename) {
  const data = await api(path);
  saveBlob(new Blob([JSON.stringify(data, null, 1)], { type: "application/json" }), filename);
}

/** A mission's log (the replay format) as mission-<id>.json. */
export function downloadMissionLog(missionId) {
  return downloadJson(`/missions/${encodeURIComponent(missionId)}/log`, `mission-${missionId}.json`);
}

/** The mission a drone's heartbeat names: legs are "<mission>.<n>" (ground/planner/service.py). */
export function missionOfLeg(legId) {
  if (!legId) return null;
  const dot = legId.lastIndexOf(".");
  return dot > 0 && /^\d+$/.test(legId.slice(dot + 1)) ? legId.slice(0, dot) : legId;
}
