// The pre-flight checklist before Send (issue 14): each chosen drone's battery, GPS, link,
// sensors, fence and wind as the server checked them (POST /missions/preflight), pass / FAIL /
// unknown in words and colour, with the reason. Failures block the Send unless the operator
// writes why to fly anyway (the server keeps that reason in its audit log).
import { el } from "../ui.js";

const NAMES = { battery: "Battery", gps: "GPS", link: "Link", sensors: "Sensors", fence: "Geofence", wind: "Wind" };
const RESULT = { pass: "✓ pass", fail: "✗ FAIL", unknown: "? unknown" };
const MIN_REASON = 3; // the server's minimum for an override reason

export function preflightDialog() {
  const title = el("h2", { id: "preflight-title" }, "Pre-flight checklist");
  const summary = el("p", { id: "preflight-summary", role: "status" });
  const tables = el("div", { id: "preflight-drones", class: "scroll" });
  const reason = el("textarea", { id: "preflight-reason", rows: 2, maxlength: 500 });
  const overrideBox = el("div", { class: "field", id: "preflight-override", hidden: true },
    el("label", { for: "preflight-reason" }, "Override: why fly anyway? (kept in the audit log)"), reason);
  const send = el("button", { type: "button", id: "preflight-send", class: "primary" }, "Send mission");
  const cancel = el("button", { type: "button", id: "preflight-cancel" }, "Cancel");
  const dialog = el("dialog", { id: "preflight", class: "checklist", "aria-labelledby": "preflight-title" },
    title, summary, tables, overrideBox, el("div", { class: "buttons" }, send, cancel));
  let settle = null;

  function close(answer) {
    if (dialog.open) dialog.close();
    if (settle) settle(answer);
    settle = null;
  }
  send.addEventListener("click", () => close({ override: overrideBox.hidden ? null : reason.value.trim() }));
  cancel.addEventListener("click", () => close(null));
  dialog.addEventListener("cancel", () => close(null)); // Escape

  function table(drone) {
    return el("table", { class: "grid", "data-drone": drone.drone_id },
      el("caption", {}, `${drone.drone_id}: ${drone.ok ? "ready" : "NOT READY"}`),
      el("thead", {}, el("tr", {}, ...["Check", "Result", "Why"].map((h) => el("th", { scope: "col" }, h)))),
      el("tbody", {}, ...drone.checks.map((c) => el("tr", { "data-check": c.check, "data-status": c.status },
        el("th", { scope: "row" }, NAMES[c.check] || c.check),
        el("td", { class: "status", "data-status": c.status }, RESULT[c.status] || c.status),
        el("td", {}, c.reason)))));
  }

  /** Show `report`; resolves with {override} to send (override null when all passed), or null. */
  function ask(report) {
    tables.replaceChildren(...report.drones.map(table));
    const failed = report.drones.flatMap((d) => d.checks.filter((c) => c.status === "fail").map((c) => `${d.drone_id} ${NAMES[c.check] || c.check}`));
    dialog.dataset.ok = String(report.ok);
    reason.value = "";
    overrideBox.hidden = report.ok || !report.overridable;
    if (report.ok) {
      summary.textContent = "Every check passed (an unknown is shown, never blocks).";
      send.textContent = "Send mission";
    } else if (report.overridable) {
      summary.textContent = `Failed: ${failed.join(", ")}. Fix it, or write why to fly anyway.`;
      send.textContent = "Override and send";
    } else {
      summary.textContent = `Failed: ${failed.join(", ")}. The planner refuses this mission as it is: it cannot be overridden.`;
      send.textContent = "Send mission";
    }
    const update = () => { send.disabled = !report.ok && (!report.overridable || reason.value.trim().length < MIN_REASON); };
    reason.oninput = update;
    update();
    dialog.showModal();
    (report.ok ? send : report.overridable ? reason : cancel).focus();
    return new Promise((resolve) => { settle = resolve; });
  }

  return { element: dialog, ask };
}
