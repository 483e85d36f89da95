// The REST API and the live stream, with the token kept in localStorage.
const TOKEN_KEY = "dronefleet.token";
// Raw telemetry is left out of the shared stream (it is the bulk of it); charts query it.
const KINDS = "heartbeat,progress,alarm,fleet,mission";
// A request that hangs becomes an error the page shows; longer than a command's own 30 s limit.
const REQUEST_TIMEOUT_MS = 40000;

export function getToken() {
  return localStorage.getItem(TOKEN_KEY);
}

export function setToken(token) {
  if (token) localStorage.setItem(TOKEN_KEY, token);
  else localStorage.removeItem(TOKEN_KEY);
}

export class ApiError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

/** fetch() on /api/v1 with the token; JSON in, JSON out; errors carry the server's reason. */
export async function api(path, { method = "GET", body, query } = {}) {
  const url = new URL(`/api/v1${path}`, location.origin);
  for (const [k, v] of Object.entries(query || {})) {
    if (v !== undefined && v !== null && v !== "") url.searchParams.set(k, v);
  }
  const headers = { Authorization: `Bearer ${getToken() || ""}` };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  let response;
  try {
    response = await fetch(url, {
      method, headers, body: body === undefined ? undefined : JSON.stringify(body), signal: AbortSignal.timeout(REQUEST_TIMEOUT_MS),
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
    const url = `${scheme}://${location.host}/api/v1/stream?token=${encodeURIComponent(getToken() || "")}&kinds=${KINDS}`;
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
