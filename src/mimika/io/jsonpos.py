"""Where a key path (``settings.fps``, ``timeline.channels[0].events[2].start``) stands in a
JSON text, so that a problem found in the parsed data is reported as ``file:line:col``.

One linear scan with a token regex; containers off the path are skipped by counting brackets,
so any depth costs the same. Text that is not valid JSON gives what was found before it.
"""

from __future__ import annotations

import json
import re

_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"?|[{}\[\],:]|[^\s{}\[\],:"]+')
_STEP = re.compile(r"\[(\d+)\]|\.?([^.\[\]]+)")


def parse_path(path: str) -> list[str | int] | None:
    """``a.b[2].c`` → ``["a", "b", 2, "c"]``; None when it is not such a path."""
    out: list[str | int] = []
    pos = 0
    while pos < len(path):
        m = _STEP.match(path, pos)
        if not m or (m.group(2) is not None and pos and path[pos] != "."):
            return None
        out.append(int(m.group(1)) if m.group(1) is not None else m.group(2))
        pos = m.end()
    return out or None


def _text(token: str) -> str:
    try:
        return json.loads(token)
    except ValueError:
        return token


def locate(text: str, path: str) -> tuple[int, int] | None:
    """1-based (line, column) of the value — or key — at ``path`` in JSON ``text``; of its
    deepest part that is there when the rest is missing; None when not even the first is."""
    want = parse_path(path)
    if want is None:
        return None
    frames: list[list] = []  # along the path: [is an object, key or index, a key comes next]
    skip = 0  # containers open inside a value off the path
    best, best_pos = 0, -1
    for m in _TOKEN.finditer(text):
        t = m.group()
        if skip:
            skip += (t == "{" or t == "[") - (t == "}" or t == "]")
            continue
        if t in ("}", "]"):
            if frames:
                frames.pop()
            if not frames:
                break
            continue
        if t == "," and frames:
            top = frames[-1]
            top[2], top[1] = (True, top[1]) if top[0] else (False, top[1] + 1)
            continue
        if t in (":", ","):
            continue
        opens = t in ("{", "[")
        if not frames:  # the document itself
            if not opens:
                break
            frames.append([t == "{", 0, t == "{"])
            continue
        top = frames[-1]
        d = len(frames) - 1
        if d >= len(want):
            skip = int(opens)
            continue
        if top[0] and top[2]:  # a key: where the path points when it names it
            top[1], top[2] = _text(t), False
            if top[1] == want[d] and d + 1 > best:
                best, best_pos = d + 1, m.start()
                if best == len(want):
                    break
            continue
        if top[1] != want[d]:
            skip = int(opens)
            continue
        if d + 1 > best:
            best, best_pos = d + 1, m.start()
        if best == len(want):
            break
        if opens:
            frames.append([t == "{", 0, t == "{"])
    if best_pos < 0:
        return None
    line = text.count("\n", 0, best_pos) + 1
    return line, best_pos - (text.rfind("\n", 0, best_pos) + 1) + 1


def where(text: str | None, source: str, problem: str) -> str:
    """``source:line:col`` of the key path a ``"path: message"`` problem starts with (just
    ``source`` when it cannot be found)."""
    if text is not None and ": " in problem:
        pos = locate(text, problem.split(": ", 1)[0])
        if pos is not None:
            return f"{source}:{pos[0]}:{pos[1]}"
    return source
