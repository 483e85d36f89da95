// The REST API and the live stream. The page never keeps the API token (issue 12): it is
// exchanged once for an HttpOnly session cookie (POST /api/v1/session) that script cannot read.
// Raw telemetry is left out of the shared stream (it is the bulk of it); charts query it.
const KINDS = "heartbeat,progress,alarm,fleet,mission,command";
// A request that hangs becomes an error the page shows; longer than a command's own 30 s limit.
const REQUEST_TIMEOUT_MS = 40000;
// What earlier versions kept in localStorage; removed on sight.
const LEGACY_TOKEN_KEY = "dronefleet.token";
// Sent with every call: the server refuses a signed-in change without it (a forged cross-site
// form or image cannot set a header).
const CSRF = { "X-Requested-With": "dronefleet" };

/** The token an earlier version left in localStorage (then forgotten), or null. */
export function takeLegacyToken() {
  let token = null;
  try {
    token = localStorage.getItem(LEGACY_TOKEN_KEY);
    localStorage.removeItem(LEGACY_TOKEN_KEY);
  } catch { /* storage disabled: nothing was kept */ }
  return token;
}

/** Exchange `token` for a session cookie; resolves to who signed in. */
export function signIn(token) {
  return api("/session", { method: "POST", headers: { Authorization: `Bearer ${token}` } });
}

export function signOut() {
  return api("/session", { method: "DELETE" });
}

export class ApiError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

/** The headers every request to the ground carries (also the maps' tiles and the pictures,
 * fetched as files: web/js/tiles.js, web/js/pages/gallery.js); the session cookie goes with
 * them by itself. */
export function authHeaders() {
  return { ...CSRF };
}

/** fetch() on /api/v1 with the session cookie; JSON in, JSON out; errors carry the reason. */
export async function api(path, { method = "GET", body, query, headers: extra } = {}) {
  const url = new URL(`/api/v1${path}`, location.origin);
  for (const [k, v] of Object.entries(query || {})) {
    if (v !== undefined && v !== null && v !== "") url.searchParams.set(k, v);
  }
  const headers = { ...authHeaders(), ...(extra || {}) };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  let response;
  try {
    response = await fetch(url, {
      method, headers, credentials: "same-origin", body: body === undefined ? undefined : JSON.stringify(body), signal: AbortSignal.timeout(REQUEST_TIMEOUT_MS),
    });
  } catch (err) {
    throw new ApiError(0, `the server does not answer (${err.message})`);
  }
  const text = await response.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch { data = text; }
  if (!response.ok) {
    const reason = (data && (data.detail || data.error || data.message)) || response.statusText;
    throw new ApiError(response.status, typeof reason === "string" ? reason : JSON.stringify(reason));
  }
  return data;
}

/** The /api/v1/stream WebSocket; reconnects by itself (1 s, growing to 10 s) until close(). */
export class Stream {
  constructor(onMessage, onState) {
    this.onMessage = onMessage;
    this.onState = onState || (() => {});
    this.delay = 1000;
    this.closed = false;
    this.connect();
  }

  connect() {
    if (this.closed) return;
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    // The browser sends the session cookie with the handshake; the server checks the Origin.
    const url = `${scheme}://${location.host}/api/v1/stream?kinds=${KINDS}`;
    const ws = new WebSocket(url);
    this.ws = ws;
    ws.onopen = () => { this.delay = 1000; this.onState("live"); };
    ws.onmessage = (event) => {
      try { this.onMessage(JSON.parse(event.data)); } catch (err) { console.warn("bad stream message", err); }
    };
    ws.onclose = (event) => {
      if (this.closed) return;
      this.onState(event.code === 4401 ? "unauthorized" : "reconnecting");
      if (event.code === 4401) return;
      setTimeout(() => this.connect(), this.delay);
      this.delay = Math.min(this.delay * 2, 10000);
    };
  }

  close() {
    this.closed = true;
    if (this.ws) this.ws.close();
  }
}
