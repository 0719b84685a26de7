#!/usr/bin/env bash
# Install the node tools the tests use (glTF-Validator, three.js, glTF-Transform) into tools/node_modules.
# Skips quietly when node/npm are absent (the glTF tests then skip with a reason).
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v npm >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup-node: installing nodejs and npm (for the glTF validator and three.js tests)"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null
  else
    echo "setup-node: npm not found; glTF validator tests will be skipped." >&2
    echo "  install it with: sudo apt-get install -y nodejs npm" >&2
    exit 0
  fi
fi
if [ -f tools/node_modules/.package-lock.json ] && [ tools/node_modules/.package-lock.json -nt tools/package-lock.json ]; then
  exit 0
fi
npm ci --prefix tools --no-audit --no-fund --loglevel=error
