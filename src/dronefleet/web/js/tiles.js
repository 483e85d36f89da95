// Map imagery under the grid (issue 14): a tile server's URL template (--tiles URL), or the
// ground's own tiles from an MBTiles file (--tiles FILE.mbtiles), fetched with the page's
// credentials and placed where the file's metadata says (bounds, zooms, centre).
import { api } from "./api.js";
import { apiBlob } from "./files.js";

const L = window.L;

/** A grid layer whose tiles come through apiBlob(): the ground's tiles need credentials. */
const GroundTiles = L.GridLayer.extend({
  createTile(coords, done) {
    const img = document.createElement("img");
    img.alt = "";
    img.setAttribute("role", "presentation");
    apiBlob(`/tiles/${coords.z}/${coords.x}/${coords.y}`)
      .then((blob) => {
        img.onload = () => { URL.revokeObjectURL(img.src); done(null, img); };
        img.onerror = () => done(new Error("the tile is not an image"), img);
        img.src = URL.createObjectURL(blob);
      })
      .catch((err) => done(err, img));
    return img;
  },
});

/** What the map says on itself when it has no imagery (issue 29): the grid alone looks like a
 * fault, and the operator needs the one option that fixes it. */
export const NO_TILES = "no map tiles: start the ground with --tiles FILE.mbtiles";

/** Add the ground's imagery to `map`; resolves to the view the imagery suggests ({center, zoom})
 * for a local MBTiles file, else null. Without imagery the grid alone stays, with a note. */
export async function addImagery(map, config) {
  if (config.local_tiles) return addGroundTiles(map);
  if (config.tiles) addRemoteTiles(map, config.tiles);
  else noTilesNote(map, NO_TILES);
  return null;
}

/** A note in the map's corner (a Leaflet control, so it stays put while the map pans). */
function noTilesNote(map, text) {
  const note = document.createElement("p");
  note.className = "map-note";
  note.id = `${map.getContainer().id || "map"}-no-tiles`;
  note.setAttribute("role", "note");
  note.textContent = text;
  const Note = L.Control.extend({ onAdd: () => note });
  new Note({ position: "bottomleft" }).addTo(map);
}

async function addGroundTiles(map) {
  let set;
  try {
    set = await api("/tiles");
  } catch (err) {
    console.warn("no map tiles:", err.message);
    noTilesNote(map, `no map tiles (${err.message}): start the ground with --tiles FILE.mbtiles`);
    return null;
  }
  const options = { minNativeZoom: set.min_zoom, maxNativeZoom: set.max_zoom, maxZoom: 22, zIndex: 1, className: "ground-tiles" };
  if (set.bounds) {
    const [west, south, east, north] = set.bounds;
    options.bounds = L.latLngBounds([south, west], [north, east]);
  }
  new GroundTiles(options).addTo(map);
  if (set.center) return { center: [set.center[1], set.center[0]], zoom: set.center[2] ?? set.max_zoom };
  if (options.bounds) return { center: options.bounds.getCenter(), zoom: set.max_zoom };
  return null;
}

function addRemoteTiles(map, template) {
  const layer = L.tileLayer(template, { maxZoom: 22, maxNativeZoom: 19, zIndex: 1 });
  let loaded = 0;
  let failed = 0;
  layer.on("tileload", () => { loaded += 1; });
  layer.on("tileerror", () => {
    failed += 1;
    if (failed >= 4 && loaded === 0 && map.hasLayer(layer)) { // offline: keep the grid only
      map.removeLayer(layer);
      noTilesNote(map, `the tile server does not answer: start the ground with --tiles FILE.mbtiles`);
    }
  });
  layer.addTo(map);
}
