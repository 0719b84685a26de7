"""Project names that cannot leave the projects folder."""

from __future__ import annotations

import re
from pathlib import Path

from mimika.errors import ParameterError

#: letters, digits, '-', '_' and inner spaces; 1–64 characters; no dots, no slashes
_NAME_RE = re.compile(r"^[A-Za-z0-9](?:[A-Za-z0-9 _\-]{0,62}[A-Za-z0-9_\-])?$")
_RESERVED = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)),
             *(f"lpt{i}" for i in range(10))}
SUFFIX = ".json"


def check_project_name(name: str) -> str:
    """Return ``name`` if it is a safe project name, else raise :class:`ParameterError`.

    Allowed: 1–64 letters, digits, ``-``, ``_`` and inner spaces, starting with a letter or
    digit. Rejected: ``..``, slashes, backslashes, absolute paths, dots, control characters.
    """
    if not isinstance(name, str) or not name:
        raise ParameterError("project name is empty; use letters, digits, '-', '_' or spaces")
    if len(name) > 64:
        raise ParameterError(f"project name {name[:20]!r}… is {len(name)} characters; "
                             "use at most 64")
    if not _NAME_RE.match(name) or name.lower() in _RESERVED:
        raise ParameterError(f"project name {name!r} is not allowed: use 1–64 letters, digits, "
                             "'-', '_' or inner spaces (no dots, slashes or '..')")
    return name


def project_path(projects_dir: Path, name: str) -> Path:
    """The file of project ``name`` inside ``projects_dir`` (checked to stay inside it)."""
    check_project_name(name)
    root = projects_dir.resolve()
    p = (root / (name + SUFFIX)).resolve()
    if p.parent != root:
        raise ParameterError(f"project name {name!r} would leave the projects folder")
    return p
