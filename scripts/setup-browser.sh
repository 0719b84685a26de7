#!/usr/bin/env bash
# Install Debian's Chromium for the studio's browser tests (Playwright drives it; we never run
# 'playwright install'). As root: apt-get installs it. Otherwise: print the command; the browser
# tests then skip with that reason.
set -euo pipefail
if [ -x /usr/bin/chromium ]; then
  exit 0
fi
cmd="apt-get update && apt-get install -y chromium"
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "setup-browser: installing chromium (for the studio browser tests)"
  DEBIAN_FRONTEND=noninteractive apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
else
  echo "setup-browser: /usr/bin/chromium is missing; the browser tests will be skipped." >&2
  echo "  install it with: sudo sh -c '$cmd'" >&2
fi
