#!/usr/bin/env bash
# Front-end libraries for the web apps (Leaflet, Chart.js), from npm by name, pinned in
# package-lock.json. Their dist files are copied into src/dronefleet/web/vendor/ (git-ignored),
# which the ground server serves under /vendor/. Idempotent and quick when already in place.
# axe-core (a devDependency) stays in node_modules/: the browser tests put it into the page
# themselves (tests/e2e/a11y.py), so the app never serves it.
set -euo pipefail
cd "$(dirname "$0")/.."
vendor=src/dronefleet/web/vendor
stamp="$vendor/.stamp"
if [ -f "$stamp" ] && [ "$stamp" -nt package-lock.json ] && [ -f "$vendor/leaflet/leaflet.js" ] \
  && [ -f node_modules/axe-core/axe.min.js ]; then
  exit 0
fi
if ! command -v npm >/dev/null 2>&1; then
  echo "npm is missing: install Node.js and npm (apt-get install npm) to get the web apps' libraries" >&2
  exit 1
fi
if [ -f package-lock.json ]; then
  npm ci --no-audit --no-fund --loglevel=error >/dev/null
else
  npm install --no-audit --no-fund --loglevel=error >/dev/null
fi
rm -rf "$vendor"
mkdir -p "$vendor/leaflet" "$vendor/chartjs"
cp node_modules/leaflet/dist/leaflet.js node_modules/leaflet/dist/leaflet.css "$vendor/leaflet/"
cp -r node_modules/leaflet/dist/images "$vendor/leaflet/"
cp node_modules/chart.js/dist/chart.umd.min.js "$vendor/chartjs/chart.umd.js"
touch "$stamp"
