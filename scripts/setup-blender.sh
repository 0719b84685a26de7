#!/usr/bin/env bash
# Install Debian's Blender for the headless glTF import tests (tests/blender_app.py). As root:
# apt-get installs it (measured: 222 MB of packages, 777 MB installed, about 2.5 min). Its glTF
# importer needs python3-numpy. Otherwise: print the command; those tests then skip.
set -euo pipefail
if command -v blender >/dev/null 2>&1 && dpkg-query -W python3-numpy >/dev/null 2>&1; then
  exit 0
fi
cmd="apt-get update && apt-get install -y blender python3-numpy"
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "setup-blender: installing blender (for the glTF import tests)"
  DEBIAN_FRONTEND=noninteractive apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq blender python3-numpy >/dev/null
else
  echo "setup-blender: blender is missing; the Blender import tests will be skipped." >&2
  echo "  install it with: sudo sh -c '$cmd'" >&2
fi
