#!/usr/bin/env bash
# Install the front-end dependency of the studio and serve pages (three.js, pinned in
# src/mimika/web/npm/package-lock.json) and copy the ES modules the pages import into
# src/mimika/web/vendor/three/ (served at /vendor/three through an import map; no bundler).
# Needs npm and the npm registry on the first run; later runs are no-ops.
set -euo pipefail
cd "$(dirname "$0")/.."
web=src/mimika/web/npm
vendor=src/mimika/web/vendor/three
stamp="$vendor/.installed"
if [ -f "$stamp" ] && [ "$stamp" -nt "$web/package-lock.json" ]; then
  exit 0
fi
if ! command -v npm >/dev/null 2>&1; then
  echo "setup-studio: npm not found; 'mimika studio' needs three.js from npm." >&2
  echo "  install it with: sudo apt-get install -y nodejs npm   then rerun scripts/setup-studio.sh" >&2
  exit 0
fi
npm ci --prefix "$web" --no-audit --no-fund --loglevel=error
src="$web/node_modules/three"
mkdir -p "$vendor/addons/loaders" "$vendor/addons/utils" "$vendor/addons/controls"
cp "$src/build/three.module.js" "$vendor/three.module.js"
cp "$src/examples/jsm/loaders/GLTFLoader.js" "$vendor/addons/loaders/"
cp "$src/examples/jsm/utils/BufferGeometryUtils.js" "$vendor/addons/utils/"
cp "$src/examples/jsm/controls/OrbitControls.js" "$vendor/addons/controls/"
cp "$src/LICENSE" "$vendor/LICENSE"
node -p "require('./$src/package.json').version" > "$vendor/VERSION"
touch "$stamp"
echo "setup-studio: three.js $(cat "$vendor/VERSION") copied to $vendor"
