// The web app's shell: sign-in, the page router (#/fleet, #/control, ...), the live stream.
import { api, signIn as openSession, signOut, Stream, takeLegacyToken } from "./api.js";
import { installAlarmCentre } from "./alarms.js";
import { announce, installAlerts } from "./alerts.js";
import { Fleet } from "./fleet.js";
import { onStreamMessage as onCommandMessage } from "./flight-commands.js";
import { watchHealth } from "./health.js";
import { toast } from "./ui.js";

const PAGES = {
  fleet: () => import("./pages/fleet.js"),
  control: () => import("./pages/control.js"),
  planner: () => import("./pages/planner.js"),
  telemetry: () => import("./pages/telemetry.js"),
  replay: () => import("./pages/replay.js"),
  photos: () => import("./pages/gallery.js"),
  call: () => import("./pages/call.js"),
};

const ctx = { fleet: new Fleet(), me: null, listeners: new Set() };
let current = null;
let stream = null;
let alarmCentre = null;

/** Pages subscribe to raw stream messages with ctx.onStream(fn) → unsubscribe(). */
ctx.onStream = (fn) => {
  ctx.listeners.add(fn);
  return () => ctx.listeners.delete(fn);
};

function onMessage(msg) {
  ctx.fleet.onStream(msg);
  announce(msg); // alarms: a toast, and a beep for CRITICAL ones and lost drones (alerts.js)
  if (alarmCentre) alarmCentre.onStream(msg); // the bell's count and the alarm list (alarms.js)
  onCommandMessage(msg); // a move's end, reported by the drone (flight-commands.js)
  for (const fn of ctx.listeners) fn(msg);
}

// Abort all, from any page (issue 14): Shift+Escape, asked first; every unfinished mission is
// stopped and its drones come home.
document.addEventListener("keydown", async (e) => {
  if (e.key !== "Escape" || !e.shiftKey || !ctx.me || !ctx.me.can_command) return;
  e.preventDefault();
  if (!window.confirm("Abort every mission? All their drones stop and return home.")) return;
  try {
    const aborted = await api("/missions/abort", { method: "POST" });
    toast(`aborted ${aborted.length} mission(s): their drones are going home`);
  } catch (err) {
    toast(`abort all failed: ${err.message}`, "error");
  }
});

function setLink(state) {
  const node = document.getElementById("link-state");
  node.textContent = state === "live" ? "live" : state;
  node.dataset.state = state;
  if (state === "live") ctx.fleet.refresh();
  if (state === "unauthorized") askToken("Signed out: sign in again.");
}

async function route() {
  const name = (location.hash.replace(/^#\/?/, "").split("?")[0] || "fleet").toLowerCase();
  const page = PAGES[name] ? name : "fleet";
  document.body.dataset.page = page;
  for (const a of document.querySelectorAll("nav a")) {
    if (a.dataset.page === page) a.setAttribute("aria-current", "page");
    else a.removeAttribute("aria-current");
  }
  if (current) current();
  current = null;
  const root = document.getElementById("page");
  root.replaceChildren();
  const module = await PAGES[page]();
  delete root.dataset.mounted;
  current = (await module.mount(root, ctx)) || null;
  root.dataset.mounted = page; // the page is built and listening (tests wait for this)
}

function askToken(message) {
  const dialog = document.getElementById("login");
  document.getElementById("login-error").textContent = message || "";
  if (!dialog.open) dialog.showModal();
}

/** Who the session cookie belongs to, or null when there is no (live) session. */
async function whoAmI() {
  try {
    return await api("/web/me");
  } catch (err) {
    if (err.status === 401) return null;
    throw err;
  }
}

function signedIn(me) {
  ctx.me = me;
  document.body.classList.toggle("viewer", !me.can_command);
  return true;
}

async function signIn(token) {
  try {
    return signedIn(await openSession(token));
  } catch (err) {
    askToken(err.status === 401 ? "Unknown token." : err.message);
    return false;
  }
}

async function start() {
  document.getElementById("login-form").addEventListener("submit", async (event) => {
    event.preventDefault();
    const field = document.getElementById("login-token");
    const token = field.value.trim();
    field.value = ""; // the token is not kept, not even in the form
    if (await signIn(token)) {
      document.getElementById("login").close();
      boot();
    }
  });
  document.getElementById("logout").addEventListener("click", async () => {
    try { await signOut(); } catch { /* already signed out */ }
    location.reload();
  });
  // The sign-in link (/?token=...): read once, out of the address bar and history at once.
  const fromUrl = new URLSearchParams(location.search).get("token") || takeLegacyToken();
  if (location.search) history.replaceState(null, "", location.pathname + location.hash);
  if (fromUrl && (await signIn(fromUrl))) return boot();
  let me = null;
  try {
    me = await whoAmI();
  } catch (err) {
    askToken(err.message);
    return;
  }
  if (me) {
    signedIn(me);
    return boot();
  }
  askToken();
}

function boot() {
  if (stream) return;
  ctx.fleet.addEventListener("unauthorized", () => askToken("Signed out: sign in again."));
  ctx.fleet.start();
  alarmCentre = installAlarmCentre(ctx, {
    bell: document.getElementById("alarms-bell"),
    count: document.getElementById("alarm-count"),
    panel: document.getElementById("alarm-centre"),
  });
  stream = new Stream(onMessage, setLink);
  watchHealth(document.getElementById("health")); // a banner while the ground is degraded
  window.addEventListener("hashchange", route);
  route();
}

installAlerts(document.getElementById("mute"));
start();
