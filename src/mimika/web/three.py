"""The three.js modules the studio's and ``mimika serve``'s pages import: copied from npm's
``three`` package (pinned in ``npm/package-lock.json``) into ``vendor/three``, served at
:data:`URL`."""

from __future__ import annotations

import json
import logging
import shutil
import subprocess
from pathlib import Path

from mimika.errors import DataError

log = logging.getLogger(__name__)

HERE = Path(__file__).parent
NPM = HERE / "npm"
VENDOR = HERE / "vendor" / "three"
#: where both servers mount :data:`VENDOR` (the pages' import maps point here)
URL = "/vendor/three"
#: files the page imports (source path in the npm package → path under ``VENDOR``)
FILES = {
    "build/three.module.js": "three.module.js",
    "examples/jsm/loaders/GLTFLoader.js": "addons/loaders/GLTFLoader.js",
    "examples/jsm/utils/BufferGeometryUtils.js": "addons/utils/BufferGeometryUtils.js",
    "examples/jsm/controls/OrbitControls.js": "addons/controls/OrbitControls.js",
    "LICENSE": "LICENSE",
}


def vendor_ready() -> bool:
    return all((VENDOR / dst).is_file() for dst in FILES.values())


def ensure_vendor(*, install: bool = True) -> Path:
    """Make sure ``vendor/three`` holds the modules; runs ``npm ci`` in ``npm/`` if
    ``install`` and the package is not installed yet. Raises :class:`DataError` if impossible."""
    if vendor_ready():
        return VENDOR
    src = NPM / "node_modules" / "three"
    if not src.is_dir():
        npm = shutil.which("npm")
        if not (install and npm):
            raise DataError("the studio and serve pages need three.js from npm: run "
                            "'bash scripts/setup-studio.sh' (needs node and npm: "
                            "sudo apt-get install -y nodejs npm)")
        log.info("npm ci in %s", NPM)
        r = subprocess.run([npm, "ci", "--no-audit", "--no-fund", "--loglevel=error"], cwd=NPM,
                           capture_output=True, text=True, timeout=600, check=False)
        if r.returncode != 0 or not src.is_dir():
            raise DataError(f"npm ci in {NPM} failed: {(r.stderr or r.stdout).strip()[-400:]}")
    for s, d in FILES.items():
        (VENDOR / d).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src / s, VENDOR / d)
    version = json.loads((src / "package.json").read_text("utf-8"))["version"]
    (VENDOR / "VERSION").write_text(version + "\n", "utf-8")
    log.info("three.js %s copied to %s", version, VENDOR)
    return VENDOR
