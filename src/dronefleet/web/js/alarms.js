// The alarm centre (issue 29): every alarm the ground kept (GET /api/v1/alarms), reachable from
// every page by the bell in the header, which counts the alarms nobody has acknowledged yet.
// The panel lists those first, each with an Acknowledge button (operators; the ground records
// who and when, and audits it), then the acknowledged ones with who did it. The list is read
// again when the stream brings an alarm, after an acknowledgement, and every 15 s (another
// console may have acknowledged). Each drone's newest alarm is handed to the fleet model too, so
// "Last alarm" is filled after a reload (GET /api/v1/alarms/latest).
import { api } from "./api.js";
import { el, fmtAgo, toast } from "./ui.js";

const LIMIT = 100;
const REFRESH_MS = 15000;
const LEVEL_WORDS = { CRITICAL: "Critical", WARNING: "Warning", OUT_MEASURE: "Reading out of bounds" };

/** An alarm's level in words (never colour alone). */
export function levelWord(level) {
  return LEVEL_WORDS[level] || level;
}

function when(seconds) {
  const date = new Date(seconds * 1000);
  return `${date.toLocaleTimeString()} (${fmtAgo(Math.max(0, Date.now() / 1000 - seconds))})`;
}

/** Wire the bell (a button with a count) and the panel (an element the list goes into). */
export function installAlarmCentre(ctx, { bell, count, panel }) {
  const list = el("ol", { class: "alarm-list", id: "alarm-list" });
  const status = el("p", { class: "hint", id: "alarm-status", "aria-live": "polite" }, "Loading…");
  const close = el("button", { type: "button", class: "small", id: "alarm-close", onclick: () => toggle(false) }, "Close");
  panel.replaceChildren(el("div", { class: "alarm-head" }, el("h2", { id: "alarm-title" }, "Alarms"), close), status, list);
  panel.setAttribute("aria-labelledby", "alarm-title");
  let timer = null;
  let pending = null;

  function toggle(open = panel.hidden) {
    panel.hidden = !open;
    bell.setAttribute("aria-expanded", String(open));
    if (open) { refresh(); list.querySelector("button")?.focus(); }
  }
  bell.addEventListener("click", () => toggle());
  document.addEventListener("keydown", (e) => { if (e.key === "Escape" && !e.shiftKey && !panel.hidden) toggle(false); });

  function item(a) {
    const canAck = ctx.me.can_command && !a.acknowledged;
    const who = a.source === "separation" ? "separation monitor" : a.drone_id;
    return el("li", { class: `alarm-item level-${a.level.toLowerCase()}${a.acknowledged ? " acked" : ""}`, "data-alarm": a.id, "data-drone": a.drone_id, "data-level": a.level, "data-acked": String(a.acknowledged) },
      el("div", { class: "alarm-line" },
        el("strong", { class: "alarm-level" }, levelWord(a.level)), " · ", el("span", { class: "alarm-drone" }, a.drone_id),
        a.source === "separation" ? el("span", { class: "hint" }, ` (${who})`) : null,
        a.mission_id ? el("span", { class: "hint" }, ` · mission ${a.mission_id}`) : null),
      el("div", { class: "alarm-message" }, a.message || "(no message)"),
      el("div", { class: "hint alarm-when" }, `received ${when(a.received_at)}`),
      a.acknowledged
        ? el("div", { class: "alarm-ack" }, `Acknowledged by ${a.acked_by} at ${new Date(a.acked_at * 1000).toLocaleTimeString()}`)
        : canAck ? el("button", { type: "button", class: "small ack", "data-ack": a.id, onclick: () => acknowledge(a) }, "Acknowledge")
          : el("div", { class: "hint" }, "Not acknowledged"));
  }

  function show(page) {
    const open = page.unacknowledged;
    count.textContent = String(open);
    bell.dataset.open = String(open);
    bell.classList.toggle("alarming", open > 0);
    bell.setAttribute("aria-label", `Alarms: ${open} not acknowledged`);
    status.textContent = page.alarms.length
      ? `${open} not acknowledged${page.alarms.length >= LIMIT ? `; the newest ${LIMIT} shown` : ""}.`
      : "No alarms.";
    list.replaceChildren(...page.alarms.map(item));
    panel.dataset.loaded = "true";
  }

  async function refresh() {
    try {
      show(await api("/alarms", { query: { unacknowledged_first: true, limit: LIMIT } }));
    } catch (err) {
      status.textContent = `Alarms could not be read: ${err.message}`;
    }
  }

  async function acknowledge(a) {
    try {
      await api(`/alarms/${a.id}/ack`, { method: "POST" });
      toast(`alarm from ${a.drone_id} acknowledged`);
    } catch (err) {
      toast(`acknowledge failed: ${err.message}`, "error");
    }
    await refresh();
  }

  // Each drone's newest alarm, handed to the fleet model once the drone is in it.
  const latest = new Map();
  async function lastAlarms() {
    try {
      for (const a of await api("/alarms/latest")) latest.set(a.drone_id, a);
      applyLatest();
    } catch { /* the table keeps what the stream brings */ }
  }
  function applyLatest() {
    let changed = false;
    for (const [id, a] of latest) {
      const d = ctx.fleet.drones.get(id);
      if (!d) continue;
      latest.delete(id);
      if (d.alarm && d.alarm.at >= a.received_at) continue; // the stream's is newer
      d.alarm = { level: a.level, message: a.message, at: a.received_at };
      changed = true;
    }
    if (changed) ctx.fleet.changed();
  }
  ctx.fleet.addEventListener("change", applyLatest);

  /** A stream message: an alarm makes the list be read again (once for a burst). */
  function onStream(msg) {
    if (msg.kind !== "alarm" || pending) return;
    pending = setTimeout(() => { pending = null; refresh(); }, 300);
  }

  refresh();
  lastAlarms();
  timer = setInterval(refresh, REFRESH_MS);
  return { onStream, refresh, toggle, stop() { clearInterval(timer); } };
}
