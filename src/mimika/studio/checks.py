"""The studio's checks of a project document, beyond the file format: the head exists, every
expression a trigger names is in the library, the studio's own settings are valid.

Problems are phrased for the person editing (``Expressions track, trigger 2 (at 1.50 s):
there is no expression called “smirk” in your library``), not as JSON paths.
"""

from __future__ import annotations

import re
from typing import Any

from mimika.errors import ParameterError

#: the studio's settings (kept in the project file; other tools ignore them)
LOOKS = ("plain", "news")
TRACK_LABELS = {"face": "Expressions", "head": "Head", "gaze": "Gaze", "blink": "Blinks"}
_PATH = re.compile(r"^timeline\.channels\[(\d+)\](?:\.events\[(\d+)\])?(?:\.(\w+))?: ?")


def track_label(name: str) -> str:
    return f"{TRACK_LABELS.get(name, name)} track"


def plain_problem(problem: str, doc: Any) -> str:
    """``timeline.channels[0].events[1].start: …`` → ``Expressions track, trigger 2, start: …``."""
    m = _PATH.match(problem)
    if not m:
        return problem
    ci, ei, field = m.groups()
    try:
        name = doc["timeline"]["channels"][int(ci)]["name"]
    except (KeyError, IndexError, TypeError):
        name = f"track {int(ci) + 1}"
    where = track_label(str(name))
    if ei is not None:
        where += f", trigger {int(ei) + 1}"
    if field:
        where += f", {field}"
    return f"{where}: {problem[m.end():]}"


def studio_problems(project: Any, *, library: Any, heads: list[str]) -> list[str]:
    """What the studio cannot use in a (format-valid) ``project``."""
    from mimika.behaviour.sentences import SPEECH_LAYERS
    from mimika.facs.blender import Blender

    out: list[str] = []
    st = project.settings
    if st.get("head") not in heads:
        out.append(f"head: the studio has the heads {', '.join(heads)}, not "
                   f"“{st.get('head')}”")
    for ch in project.timeline.channels:
        for i, ev in enumerate(ch.events):
            if ev.kind == "expression" and ev.name not in library:
                out.append(f"{track_label(ch.name)}, trigger {i + 1} (at {ev.start:.2f} s): "
                           f"there is no expression called “{ev.name}” in your library")
    layers = st.get("behaviour", list(SPEECH_LAYERS))
    if not (isinstance(layers, list) and all(x in SPEECH_LAYERS for x in layers)):
        out.append(f"behaviour: must list some of {', '.join(SPEECH_LAYERS)}")
    off = st.get("blender_off", [])
    if not isinstance(off, list) or not all(isinstance(x, str) for x in off):
        out.append("blender_off: must be a list of AU Blender rules such as 12<15Z")
    else:
        blender = Blender.default()
        for r in off:
            try:
                blender.rule(r)
            except ParameterError:
                out.append(f"blender_off: there is no AU Blender rule “{r}”")
    if st.get("look", "plain") not in LOOKS:
        out.append(f"look: must be {' or '.join(LOOKS)}")
    return out


def check_project(doc: Any, name: str, *, library: Any, heads: list[str]) -> Any:
    """The :class:`~mimika.markup.project.Project` of ``doc``; raises
    :class:`~mimika.markup.project.ProjectError` listing every problem in plain words."""
    from mimika.markup.project import ProjectError, project_from_dict

    if not isinstance(doc, dict):
        raise ParameterError("this is not a mimika project: a project file is a JSON object")
    try:
        proj = project_from_dict(doc, source=name)
    except ProjectError as e:
        raise ProjectError(name, [plain_problem(p, doc) for p in e.problems]) from None
    problems = studio_problems(proj, library=library, heads=heads)
    if problems:
        raise ProjectError(name, problems)
    return proj


def blend_settings(settings: dict[str, Any]) -> tuple[bool, list[str]]:
    """``(blend, disabled rules)`` of a project's settings."""
    return bool(settings.get("blend")), list(settings.get("blender_off", []))
