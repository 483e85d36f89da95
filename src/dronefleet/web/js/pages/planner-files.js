// The Planner's mission files (issue 14): import a QGroundControl .plan or a Google Earth KML into
// the form, export what the form would fly as a .plan. The server reads and writes the formats
// (ground/planner/files/); this only moves the file and fills the form.
import { ApiError, api, authHeaders } from "../api.js";
import { el, field, toast } from "../ui.js";

const L = window.L;

/** POST the file itself (not JSON-wrapped) to /missions/import; the server's answer. */
async function importFile(file) {
  const url = new URL("/api/v1/missions/import", location.origin);
  url.searchParams.set("name", file.name.replace(/\.[^.]*$/, "").slice(0, 200));
  const response = await fetch(url, { method: "POST", headers: authHeaders(), credentials: "same-origin", body: await file.arrayBuffer() });
  const data = await response.json().catch(() => null);
  if (!response.ok) throw new ApiError(response.status, (data && data.detail) || response.statusText);
  return data;
}

/** Save `document` (a .plan) as a download named `name`. */
function download(document_, name) {
  const blob = new Blob([JSON.stringify(document_, null, 2)], { type: "application/json" });
  const link = el("a", { href: URL.createObjectURL(blob), download: name, hidden: true });
  document.body.append(link);
  link.click();
  setTimeout(() => { URL.revokeObjectURL(link.href); link.remove(); }, 1000);
}

/**
 * Import and Export buttons. `load(answer)` fills the form from an import's answer; `spec()` is
 * the form's mission request. The fence's exclusion zones, which the form has no field for, are
 * kept here (`exclusions()`) and drawn once `attach(map)` has been called.
 */
export function planFiles({ load, spec }) {
  let zones = [];
  let layer = null;
  const input = el("input", { type: "file", id: "plan-import", accept: ".plan,.kml,application/json,application/vnd.google-earth.kml+xml" });
  const notes = el("ul", { id: "plan-import-notes", class: "hint", hidden: true });

  input.addEventListener("change", async () => {
    const file = input.files && input.files[0];
    if (!file) return;
    try {
      const answer = await importFile(file);
      zones = (answer.spec.options && answer.spec.options.geofence && answer.spec.options.geofence.exclusions) || [];
      drawZones();
      load(answer);
      const zonesNote = zones.length ? [el("li", {}, `${zones.length} exclusion zone(s) kept in the fence (drawn in red)`)] : [];
      notes.replaceChildren(el("li", {}, `${file.name}: imported`), ...zonesNote, ...answer.warnings.map((w) => el("li", {}, w)));
      notes.hidden = false;
      notes.dataset.loaded = file.name;
      toast(`${file.name} imported (${answer.kind})`);
    } catch (err) {
      toast(`import failed: ${err.message}`, "error");
      notes.replaceChildren(el("li", {}, `Import failed: ${err.message}`));
      notes.hidden = false;
    } finally {
      input.value = "";  // the same file may be imported again
    }
  });

  async function exportPlan() {
    try {
      download(await api("/missions/preview/plan", { method: "POST", body: spec() }), "mission.plan");
    } catch (err) {
      toast(`export failed: ${err.message}`, "error");
    }
  }

  function drawZones() {
    if (!layer) return;
    layer.clearLayers();
    for (const zone of zones) L.polygon(zone, { color: "#dc2626", weight: 2, fillOpacity: 0.25, className: "exclusion-zone" }).addTo(layer);
  }

  return {
    box: el("div", { id: "plan-files" },
      field("Import a .plan (QGroundControl) or KML (Google Earth)", input), notes,
      el("div", { class: "buttons" },
        el("button", { type: "button", id: "plan-export", onclick: exportPlan }, "Export .plan"))),
    exclusions: () => zones,
    attach(map) { layer = L.layerGroup().addTo(map); drawZones(); },
  };
}
