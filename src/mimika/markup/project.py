"""Project files: a timeline plus settings as versioned JSON (``docs/project.md``).

``{"format": "mimika-project", "version": 1, "settings": {…}, "timeline": {…}}``. Saving is
atomic (temp file in the same folder, fsync, ``os.replace``); loading validates everything and
reports *every* problem as ``path: message`` in one :class:`ProjectError`. Older versions are
migrated (see :data:`MIGRATIONS`) or refused; newer ones are refused ("written by a newer
mimika"). The JSON Schema is ``mimika/markup/data/project.schema.json``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mimika.errors import DataError, MimikaError
from mimika.io.atomic import atomic_write, sweep_stale
from mimika.limits import check_json_tree, loads_json
from mimika.timeline.model import (
    KINDS,
    Channel,
    Close,
    Empty,
    Event,
    Open,
    Speech,
    Text,
    Timeline,
)

__all__ = [
    "FORMAT",
    "VERSION",
    "Project",
    "ProjectError",
    "load_project",
    "project_from_dict",
    "project_to_dict",
    "save_project",
]

FORMAT = "mimika-project"
VERSION = 1
#: version → function upgrading a document of that version to version + 1
MIGRATIONS: dict[int, Callable[[dict], dict]] = {}
#: the oldest version this mimika can still read (through MIGRATIONS)
OLDEST = 1

#: "head": the default character (mimika.face.heads.DEFAULT_HEAD; markup does not import face)
DEFAULT_SETTINGS: dict[str, Any] = {"head": "amara", "fps": 25.0, "view": "front",
                                    "lang": "en", "blend": False, "size": [640, 480]}
_VIEWS = ("front", "three-quarter", "profile")
_LANGS = ("en", "de", "pl")


class ProjectError(DataError):
    """Problems in a project file; ``problems`` lists ``"path: message"`` strings. The message
    is one line: every problem after its place (``file:line:col`` when ``text``, the file's
    JSON, is given), separated by ``; ``."""

    def __init__(self, source: str, problems: list[str], *, text: str | None = None):
        from mimika.io.jsonpos import where

        self.problems = problems
        parts = [f"{where(text, source, problems[0])}: {problems[0]}"]
        for prob in problems[1:]:
            place = where(text, source, prob)[len(source) + 1:]
            parts.append(f"{place}: {prob}" if place else prob)
        super().__init__("; ".join(parts))


@dataclass(frozen=True)
class Project:
    """A timeline and the settings to render it (head, fps, view, lang, blend, size)."""

    timeline: Timeline = field(default_factory=Timeline)
    settings: dict[str, Any] = field(default_factory=lambda: dict(DEFAULT_SETTINGS))


# -- to JSON -------------------------------------------------------------------------------------
def _tok(t) -> dict:
    if isinstance(t, Text):
        return {"text": t.text}
    if isinstance(t, Open):
        return {"open": t.tag, "attrs": [list(a) for a in t.attrs]}
    if isinstance(t, Close):
        return {"close": t.tag}
    return {"empty": t.tag, "attrs": [list(a) for a in t.attrs]}


def _event(e: Event) -> dict:
    d: dict[str, Any] = {"kind": e.kind, "start": e.start, "duration": e.duration}
    if e.name:
        d["name"] = e.name
    if e.aus:
        d["aus"] = [[c, v] for c, v in e.aus]
    if e.intensity != 1.0:
        d["intensity"] = e.intensity
    for k in ("onset", "offset", "ease", "at"):
        if getattr(e, k) is not None:
            d[k] = getattr(e, k)
    if e.count != 1:
        d["count"] = e.count
    if e.anchor is not None:
        d["anchor"] = list(e.anchor)
    return d


def timeline_to_dict(tl: Timeline) -> dict:
    return {
        "rate": tl.rate,
        "mood": tl.mood,
        "duration": tl.duration,
        "speech": {"attrs": [list(a) for a in tl.speech.attrs],
                   "tokens": [_tok(t) for t in tl.speech.tokens]},
        "channels": [{"name": c.name, "override": c.override, "ease": c.ease,
                      "bridge": None if math.isinf(c.bridge) else c.bridge,
                      "events": [_event(e) for e in c.events]} for c in tl.channels],
    }


def project_to_dict(project: Project) -> dict:
    return {"format": FORMAT, "version": VERSION,
            "settings": {**DEFAULT_SETTINGS, **project.settings},
            "timeline": timeline_to_dict(project.timeline)}


# -- from JSON, collecting every problem ---------------------------------------------------------
class _Check:
    def __init__(self) -> None:
        self.problems: list[str] = []

    def add(self, path: str, msg: str) -> None:
        self.problems.append(f"{path}: {msg}")

    def typed(self, d: dict, key: str, types, path: str, *, required: bool = True,
              default: Any = None) -> Any:
        if key not in d:
            if required:
                self.add(f"{path}.{key}" if path else key, "missing")
            return default
        v = d[key]
        if not isinstance(v, types) or (isinstance(v, bool) and bool not in
                                        (types if isinstance(types, tuple) else (types,))):
            names = ("/".join(t.__name__ for t in types) if isinstance(types, tuple)
                     else types.__name__)
            self.add(f"{path}.{key}" if path else key,
                     f"must be {names.replace('NoneType', 'null')}, got {json.dumps(v)[:40]}")
            return default
        return v


_NUM = (int, float)


def _pairs(c: _Check, v: Any, path: str) -> tuple[tuple[str, str], ...]:
    if not isinstance(v, list) or not all(isinstance(p, list) and len(p) == 2 and
                                          all(isinstance(x, str) for x in p) for p in v):
        c.add(path, "must be a list of [name, value] string pairs")
        return ()
    return tuple((a, b) for a, b in v)


def _speech(c: _Check, d: Any, path: str) -> Speech:
    if not isinstance(d, dict):
        c.add(path, "must be an object with attrs and tokens")
        return Speech()
    attrs = _pairs(c, d.get("attrs", []), f"{path}.attrs")
    toks = []
    raw = d.get("tokens", [])
    if not isinstance(raw, list):
        c.add(f"{path}.tokens", "must be a list")
        raw = []
    depth = 0
    for i, t in enumerate(raw):
        p = f"{path}.tokens[{i}]"
        if not isinstance(t, dict) or len({"text", "open", "close", "empty"} & set(t)) != 1:
            c.add(p, "must be one of {text}, {open, attrs}, {close}, {empty, attrs}")
            continue
        if "text" in t:
            if not isinstance(t["text"], str):
                c.add(f"{p}.text", "must be a string")
                continue
            toks.append(Text(t["text"]))
        elif "open" in t:
            depth += 1
            toks.append(Open(str(t["open"]), _pairs(c, t.get("attrs", []), f"{p}.attrs")))
        elif "close" in t:
            depth -= 1
            if depth < 0:
                c.add(p, f"closes {t['close']!r}, which is not open")
            toks.append(Close(str(t["close"])))
        else:
            toks.append(Empty(str(t["empty"]), _pairs(c, t.get("attrs", []), f"{p}.attrs")))
    if depth > 0:
        c.add(f"{path}.tokens", f"{depth} element(s) opened but not closed")
    return Speech(tuple(toks), attrs)


def _event_from(c: _Check, d: Any, path: str) -> Event | None:
    if not isinstance(d, dict):
        c.add(path, "must be an object")
        return None
    n = len(c.problems)
    kind = c.typed(d, "kind", str, path)
    if kind is not None and kind not in KINDS:
        c.add(f"{path}.kind", f"{kind!r} must be one of {', '.join(KINDS)}")
    start = c.typed(d, "start", _NUM, path)
    dur = c.typed(d, "duration", _NUM, path)
    kw: dict[str, Any] = {}
    for key, types in (("name", str), ("intensity", _NUM), ("onset", _NUM),
                       ("offset", _NUM), ("ease", str), ("count", int), ("at", _NUM)):
        v = c.typed(d, key, types, path, required=False)
        if v is not None:
            kw[key] = v
    if "aus" in d:
        aus = d["aus"]
        if isinstance(aus, dict):
            aus = list(aus.items())
        if not isinstance(aus, list) or not all(
                isinstance(p, list | tuple) and len(p) == 2 and isinstance(p[0], str)
                and isinstance(p[1], _NUM) and not isinstance(p[1], bool) for p in aus):
            c.add(f"{path}.aus", 'must be [["AU12", 0.8], …]')
        else:
            kw["aus"] = tuple((a, float(b)) for a, b in aus)
    if "anchor" in d:
        a = d["anchor"]
        if not (isinstance(a, list) and len(a) == 2 and all(isinstance(x, int) and
                                                             not isinstance(x, bool)
                                                             for x in a)):
            c.add(f"{path}.anchor", "must be [first, last] token positions")
        else:
            kw["anchor"] = tuple(a)
    bad = len(c.problems) > n
    unknown = set(d) - {"kind", "start", "duration", "name", "aus", "intensity", "onset",
                        "offset", "ease", "count", "anchor", "at"}
    for k in sorted(unknown):
        c.add(f"{path}.{k}", "unknown key")
    if bad:
        return None
    try:
        ev = Event(kind, start, dur, **kw)
    except MimikaError as e:
        c.add(path, str(e))
        return None
    return None if unknown else ev


def _timeline(c: _Check, d: Any, path: str = "timeline") -> Timeline | None:
    if not isinstance(d, dict):
        c.add(path, "must be an object")
        return None
    n = len(c.problems)
    rate = c.typed(d, "rate", _NUM, path, required=False, default=0.16)
    mood = c.typed(d, "mood", (str, type(None)), path, required=False)
    duration = c.typed(d, "duration", (*_NUM, type(None)), path, required=False)
    speech = _speech(c, d.get("speech", {}), f"{path}.speech")
    chans = []
    raw = d.get("channels", [])
    if not isinstance(raw, list):
        c.add(f"{path}.channels", "must be a list")
        raw = []
    for i, ch in enumerate(raw):
        p = f"{path}.channels[{i}]"
        if not isinstance(ch, dict):
            c.add(p, "must be an object")
            continue
        name = c.typed(ch, "name", str, p)
        override = c.typed(ch, "override", bool, p, required=False, default=False)
        ease = c.typed(ch, "ease", str, p, required=False, default="cosine")
        bridge = c.typed(ch, "bridge", (*_NUM, type(None)), p, required=False)
        evs_raw = ch.get("events", [])
        if not isinstance(evs_raw, list):
            c.add(f"{p}.events", "must be a list")
            evs_raw = []
        evs = [_event_from(c, e, f"{p}.events[{j}]") for j, e in enumerate(evs_raw)]
        if name is None:
            continue
        try:
            chans.append(Channel(name, tuple(e for e in evs if e is not None),
                                 override=override, ease=ease,
                                 bridge=math.inf if bridge is None else bridge))
        except MimikaError as e:
            c.add(p, str(e))
    if mood is not None:
        try:
            from mimika.knowledge import get_mood

            get_mood(mood)
        except MimikaError as e:
            c.add(f"{path}.mood", str(e))
    if len(c.problems) > n:
        return None
    try:
        return Timeline(tuple(chans), speech, rate=rate, mood=mood, duration=duration)
    except MimikaError as e:
        c.add(path, str(e))
        return None


def _settings(c: _Check, d: Any) -> dict[str, Any]:
    if not isinstance(d, dict):
        c.add("settings", "must be an object")
        return dict(DEFAULT_SETTINGS)
    out = dict(DEFAULT_SETTINGS)
    out.update(d)
    if not isinstance(out["head"], str) or not out["head"]:
        c.add("settings.head", "must be a head name or path (a character, builtin, ict, …)")
    fps = out["fps"]
    if not isinstance(fps, _NUM) or isinstance(fps, bool) or not (0 < fps <= 1000):
        c.add("settings.fps", f"must be a number in (0, 1000], got {json.dumps(fps)}")
    if out["view"] not in _VIEWS:
        c.add("settings.view", f"{out['view']!r} must be one of {', '.join(_VIEWS)}")
    if out["lang"] not in _LANGS:
        c.add("settings.lang", f"{out['lang']!r} must be one of {', '.join(_LANGS)}")
    if not isinstance(out["blend"], bool):
        c.add("settings.blend", "must be true or false")
    s = out["size"]
    if not (isinstance(s, list) and len(s) == 2 and all(isinstance(x, int) and 16 <= x <= 8192
                                                        for x in s)):
        c.add("settings.size", "must be [width, height] in pixels (16…8192)")
    return out


def project_from_dict(data: Any, *, source: str = "<project>") -> Project:
    """Validate ``data`` (parsed JSON) and build a :class:`Project`; migrates old versions.

    Everything wrong is one :class:`ProjectError` listing ``path: problem`` — including what
    :mod:`mimika.limits` refuses (deep nesting, huge integers, NaN/Infinity, events past
    ``max_duration``)."""
    problems = check_json_tree(data)
    if problems:
        raise ProjectError(source, problems)
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ProjectError(source, [f'format: not a mimika project (expected "format": '
                                    f'"{FORMAT}")'])
    ver = data.get("version")
    if not isinstance(ver, int) or isinstance(ver, bool):
        raise ProjectError(source, [f"version: must be a whole number, got {json.dumps(ver)}"])
    if ver > VERSION:
        raise ProjectError(source, [f"version: {ver} was written by a newer mimika (this one "
                                    f"reads versions {OLDEST}–{VERSION}); upgrade mimika"])
    if ver < OLDEST:
        raise ProjectError(source, [f"version: {ver} is too old for this mimika (it reads "
                                    f"versions {OLDEST}–{VERSION}); open it with an older "
                                    "mimika and save it again"])
    while ver < VERSION:
        data = MIGRATIONS[ver](data)
        ver += 1
    c = _Check()
    for k in sorted(set(data) - {"format", "version", "settings", "timeline"}):
        c.add(k, "unknown key")
    settings = _settings(c, data.get("settings", {}))
    tl = _timeline(c, data.get("timeline", {}))
    if c.problems or tl is None:
        raise ProjectError(source, c.problems or ["timeline: invalid"])
    return Project(tl, settings)


def load_project(path: str | Path) -> Project:
    """Read and validate a project file; every problem is listed in one :class:`ProjectError`."""
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except FileNotFoundError:
        raise DataError(f"project file {p} does not exist") from None
    except (OSError, UnicodeDecodeError) as e:
        raise DataError(f"cannot read project {p}: {e}") from None
    data = loads_json(text, str(p), check=False)  # project_from_dict lists what it refuses
    try:
        return project_from_dict(data, source=str(p))
    except ProjectError as e:  # again, with the place of each problem in the file
        raise ProjectError(str(p), e.problems, text=text) from None


def save_project(project: Project, path: str | Path) -> Path:
    """Write ``project`` as JSON to ``path`` atomically; returns the path."""
    text = json.dumps(project_to_dict(project), indent=1, ensure_ascii=False,
                      allow_nan=False) + "\n"
    sweep_stale(path)  # temp files of saves that were killed
    return atomic_write(path, text)
