// Telemetry: pick drones, fields and a time range (last N minutes or from/to); live mode follows.
import { api } from "../api.js";
import { colorFor } from "../map.js";
import { el, field, toast } from "../ui.js";

const Chart = window.Chart;
const DEFAULT_FIELDS = ["battery_pct", "relative_alt_m"];

function localInput(date) {
  const d = new Date(date.getTime() - date.getTimezoneOffset() * 60000);
  return d.toISOString().slice(0, 19);
}

export async function mount(root, ctx) {
  const drones = el("fieldset", { class: "drones", id: "tm-drones" }, el("legend", {}, "Drones"));
  const fields = el("fieldset", { class: "fields", id: "tm-fields" }, el("legend", {}, "Fields"));
  const rangeKind = el("select", { id: "tm-range" }, el("option", { value: "last" }, "Last minutes"), el("option", { value: "between" }, "From … to"));
  const minutes = el("input", { type: "number", id: "tm-minutes", value: "5", min: "1", step: "1" });
  const now = new Date();
  const from = el("input", { type: "datetime-local", id: "tm-from", step: "1", value: localInput(new Date(now - 600000)) });
  const to = el("input", { type: "datetime-local", id: "tm-to", step: "1", value: localInput(now) });
  const live = el("input", { type: "checkbox", id: "tm-live" });
  const charts = el("div", { class: "charts", id: "tm-charts" });
  const note = el("p", { class: "hint", id: "tm-note", role: "status" });
  root.append(el("h1", {}, "Telemetry"), el("div", { class: "controls" },
    drones, fields,
    el("div", { class: "range" }, field("Time range", rangeKind), field("Minutes", minutes), field("From", from), field("To", to),
      el("div", { class: "field check" }, live, el("label", { for: "tm-live" }, "Live"))),
    el("button", { type: "button", id: "tm-show", class: "primary", onclick: () => load() }, "Show")), note, charts);

  if (!ctx.fleet.drones.size) await ctx.fleet.refresh();
  const list = ctx.fleet.list();
  const first = (list.find((d) => d.status !== "lost") || list[0] || {}).drone_id;
  for (const d of list) {
    const id = `tm-d-${d.drone_id}`;
    drones.append(el("div", { class: "check" }, el("input", { type: "checkbox", id, value: d.drone_id, checked: d.drone_id === first }), el("label", { for: id }, d.drone_id)));
  }
  let known = DEFAULT_FIELDS;
  try {
    if (first) known = (await api("/telemetry", { query: { drone: first, every: "60s", from: Date.now() / 1000 - 3600 } })).fields;
  } catch { /* keep the defaults */ }
  for (const name of known) {
    const id = `tm-f-${name}`;
    fields.append(el("div", { class: "check" }, el("input", { type: "checkbox", id, value: name, checked: DEFAULT_FIELDS.includes(name) }), el("label", { for: id }, name)));
  }

  let made = [];
  async function load() {
    const chosen = [...drones.querySelectorAll("input:checked")].map((i) => i.value);
    const names = [...fields.querySelectorAll("input:checked")].map((i) => i.value);
    if (!chosen.length || !names.length) return toast("pick at least one drone and one field", "error");
    let t0;
    let t1;
    if (rangeKind.value === "last" || live.checked) {
      t1 = Date.now() / 1000;
      t0 = t1 - Number(minutes.value) * 60;
    } else {
      t0 = new Date(from.value).getTime() / 1000;
      t1 = new Date(to.value).getTime() / 1000;
    }
    const every = `${Math.max(1, Math.ceil((t1 - t0) / 600))}s`;
    const answers = await Promise.all(chosen.map((d) => api("/telemetry", { query: { drone: d, fields: names.join(","), from: t0, to: t1, every } })
      .catch((err) => { toast(`${d}: ${err.message}`, "error"); return null; })));
    for (const c of made) c.destroy();
    made = [];
    charts.replaceChildren();
    let points = 0;
    for (const name of names) {
      const canvas = el("canvas", { "aria-label": `${name} over time`, role: "img" });
      const box = el("figure", { class: "chart", "data-field": name }, el("figcaption", {}, name), el("div", { class: "chart-box" }, canvas));
      charts.append(box);
      const datasets = answers.map((a, i) => {
        const series = (a && a.series[name]) || [];
        points += series.length;
        return { label: chosen[i], data: series.map(([t, v]) => ({ x: t * 1000, y: v })), borderColor: colorFor(i), pointRadius: 0, borderWidth: 1.5 };
      });
      box.dataset.points = String(datasets.reduce((n, d) => n + d.data.length, 0));
      made.push(new Chart(canvas, {
        type: "line",
        data: { datasets },
        options: {
          animation: false, maintainAspectRatio: false, parsing: false,
          scales: { x: { type: "linear", ticks: { callback: (v) => new Date(v).toLocaleTimeString() } } },
        },
      }));
    }
    note.textContent = `${points} points from ${new Date(t0 * 1000).toLocaleString()} to ${new Date(t1 * 1000).toLocaleString()}`;
    charts.dataset.loaded = "1";
  }

  const timer = setInterval(() => { if (live.checked) load(); }, 3000);
  return () => { clearInterval(timer); for (const c of made) c.destroy(); };
}
