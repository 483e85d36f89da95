#!/usr/bin/env bash
# Front-end libraries for the web apps (Leaflet, Leaflet-Geoman, Chart.js) and the API docs at /docs (Swagger UI),
# from npm by name, pinned in package-lock.json. Their dist files are copied into
# src/dronefleet/web/vendor/ (git-ignored), which the ground server serves under /web/vendor/, so
# neither the apps nor /docs load anything from elsewhere. Idempotent and quick when in place.
# Install scripts are not run: none of these needs one (swagger-ui-dist's @scarf/scarf would
# report the install to scarf.sh; package.json turns it off too).
# axe-core (a devDependency) stays in node_modules/: the browser tests put it into the page
# themselves (tests/e2e/a11y.py), so the app never serves it.
set -euo pipefail
cd "$(dirname "$0")/.."
vendor=src/dronefleet/web/vendor
stamp="$vendor/.stamp"
if [ -f "$stamp" ] && [ "$stamp" -nt package-lock.json ] && [ -f "$vendor/leaflet/leaflet.js" ] \
  && [ -f "$vendor/geoman/leaflet-geoman.js" ] && [ -f "$vendor/swagger-ui/swagger-ui-bundle.js" ] && [ -f node_modules/axe-core/axe.min.js ]; then
  exit 0
fi
if ! command -v npm >/dev/null 2>&1; then
  echo "npm is missing: install Node.js and npm (apt-get install npm) to get the web apps' libraries" >&2
  exit 1
fi
if [ -f package-lock.json ]; then
  npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >/dev/null
else
  npm install --ignore-scripts --no-audit --no-fund --loglevel=error >/dev/null
fi
rm -rf "$vendor"
mkdir -p "$vendor/leaflet" "$vendor/geoman" "$vendor/chartjs" "$vendor/swagger-ui"
cp node_modules/leaflet/dist/leaflet.js node_modules/leaflet/dist/leaflet.css "$vendor/leaflet/"
cp -r node_modules/leaflet/dist/images "$vendor/leaflet/"
# Leaflet-Geoman: the Planner's corners, fences and points edited on the map (web/js/map-edit.js).
# Its dist file is one bundle (its turf and lodash inside): nothing else of its tree is served.
geoman=node_modules/@geoman-io/leaflet-geoman-free
cp "$geoman/dist/leaflet-geoman.js" "$geoman/dist/leaflet-geoman.css" "$geoman/LICENSE" "$vendor/geoman/"
cp node_modules/chart.js/dist/chart.umd.min.js "$vendor/chartjs/chart.umd.js"
# Swagger UI for /docs (ground/manager/docs.py starts it from web/js/docs.js: no inline script).
swagger=node_modules/swagger-ui-dist
cp "$swagger/swagger-ui-bundle.js" "$swagger/swagger-ui.css" "$swagger/favicon-32x32.png" \
  "$swagger/LICENSE" "$swagger/NOTICE" "$vendor/swagger-ui/"
touch "$stamp"
