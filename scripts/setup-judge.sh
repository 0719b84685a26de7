#!/usr/bin/env bash
# Install the development expression judge (bench/judge: face-api's emotion recogniser and
# landmark detector on TensorFlow.js' WebAssembly backend, weights inside the npm package).
# Needed only by bench/expression_judge.py; the tests do not use it.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v npm >/dev/null 2>&1; then
  echo "setup-judge: npm not found; install it with: sudo apt-get install -y nodejs npm" >&2
  exit 2
fi
if [ -f bench/judge/node_modules/.package-lock.json ] && \
   [ bench/judge/node_modules/.package-lock.json -nt bench/judge/package-lock.json ]; then
  exit 0
fi
npm ci --prefix bench/judge --ignore-scripts --no-audit --no-fund --loglevel=error
