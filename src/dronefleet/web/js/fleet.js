// The fleet as the pages see it: /drones at start and every 5 s, the stream in between.
import { api } from "./api.js";

export class Fleet extends EventTarget {
  constructor() {
    super();
    this.drones = new Map();
    this.timer = null;
  }

  start() {
    this.refresh();
    this.timer = setInterval(() => this.refresh(), 5000);
  }

  async refresh() {
    try {
      const list = await api("/drones");
      for (const d of list) this.merge(d.drone_id, d);
      this.changed();
    } catch (err) {
      if (err.status === 401) this.dispatchEvent(new Event("unauthorized"));
    }
  }

  merge(id, data) {
    const drone = this.drones.get(id) || { drone_id: id, trail: [] };
    Object.assign(drone, data);
    if (data.position) {
      const last = drone.trail[drone.trail.length - 1];
      const p = [data.position.lat, data.position.lon];
      if (!last || last[0] !== p[0] || last[1] !== p[1]) {
        // Heading from the direction of travel (heartbeats carry no yaw).
        if (last) drone.heading_deg = (Math.atan2((p[1] - last[1]) * Math.cos((p[0] * Math.PI) / 180), p[0] - last[0]) * 180) / Math.PI;
        drone.trail.push(p);
      }
      if (drone.trail.length > 500) drone.trail.shift();
    }
    this.drones.set(id, drone);
    return drone;
  }

  changed() {
    this.dispatchEvent(new Event("change"));
  }

  /** Feed one stream message. */
  onStream(msg) {
    const id = msg.drone_id;
    const data = msg.data || {};
    if (msg.kind === "heartbeat" && id) {
      const status = data.autopilot_link === false ? "autopilot link lost" : "online";
      this.merge(id, { ...data, status, seen_ago_s: 0, last_seen: data.timestamp });
      this.changed();
    } else if (msg.kind === "telemetry" && id && this.drones.has(id)) {
      const f = data.fields || {};
      if (Number.isFinite(f.yaw_deg)) this.drones.get(id).heading_deg = f.yaw_deg;
    } else if (msg.kind === "alarm" && id) {
      this.merge(id, { alarm: { level: data.level || "ALARM", message: data.message || "", at: Date.now() / 1000 } });
      this.changed();
    } else if (msg.kind === "fleet" && id) {
      const status = data.event === "lost" ? "lost" : data.event === "autopilot_link_lost" ? "autopilot link lost" : "online";
      this.merge(id, { ...(data.drone || {}), status });
      this.changed();
    }
  }

  list() {
    return [...this.drones.values()].sort((a, b) => a.drone_id.localeCompare(b.drone_id));
  }

  stop() {
    clearInterval(this.timer);
  }
}
