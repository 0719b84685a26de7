"""Project names that cannot leave the projects folder."""

from __future__ import annotations

import unicodedata
from pathlib import Path

from mimika.errors import ParameterError

_RESERVED = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)),
             *(f"lpt{i}" for i in range(10))}
#: characters allowed besides letters and digits (any script)
_EXTRA = "-_ "
#: longest name in characters, and in UTF-8 bytes (file names end at 255 bytes)
MAX_CHARS, MAX_BYTES = 64, 200
SUFFIX = ".json"
RULE = "use 1–64 letters, digits, '-', '_' or spaces between them (no dots or slashes)"


def _allowed(ch: str) -> bool:
    return ch.isalnum() or ch in _EXTRA


def check_project_name(name: str) -> str:
    """Return ``name`` (NFC-normalised) if it is a safe project name, else raise
    :class:`ParameterError`.

    Allowed: 1–64 letters or digits of any script, ``-``, ``_`` and inner spaces
    (``Grüße``, ``Zażółć``, ``-draft`` are fine). Rejected: dots, slashes, backslashes,
    colons, control characters, leading or trailing spaces and Windows device names.
    """
    if not isinstance(name, str) or not name.strip():
        raise ParameterError(f"the project needs a name: {RULE}")
    name = unicodedata.normalize("NFC", name)
    if len(name) > MAX_CHARS or len(name.encode("utf-8")) > MAX_BYTES:
        raise ParameterError(f"the project name “{name[:20]}…” is too long: use at most "
                             f"{MAX_CHARS} characters")
    bad = sorted({ch for ch in name if not _allowed(ch)})
    if bad:
        shown = ", ".join(repr(c) if c.isprintable() else f"U+{ord(c):04X}" for c in bad[:4])
        raise ParameterError(f"the project name “{name}” is not allowed: it contains {shown}; "
                             f"{RULE}")
    if name != name.strip():
        raise ParameterError(f"the project name “{name}” is not allowed: it starts or ends "
                             f"with a space; {RULE}")
    if name.lower() in _RESERVED:
        raise ParameterError(f"the project name “{name}” is not allowed: it is a reserved "
                             "device name on Windows; choose another")
    return name


def project_path(projects_dir: Path, name: str) -> Path:
    """The file of project ``name`` inside ``projects_dir`` (checked to stay inside it)."""
    name = check_project_name(name)
    root = projects_dir.resolve()
    p = (root / (name + SUFFIX)).resolve()
    if p.parent != root:
        raise ParameterError(f"the project name “{name}” would leave the projects folder")
    return p
