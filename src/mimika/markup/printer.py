"""Print a :class:`~mimika.timeline.Timeline` as a script: ``parse_script(to_script(t)) == t``.

Events anchored in the speech are written where they stood (wrapping their words); their
timing attributes are written only where they differ from what the position gives, as exact
decimal floats. Events placed by absolute time follow the speech, grouped by channel.
"""

from __future__ import annotations

import math
from typing import Any

from mimika.markup.elements import MIMIKA_NS, PRINT_NAME, SSML_NS, derived_timing
from mimika.timeline.model import (
    DEFAULT_CHANNEL,
    Channel,
    Close,
    Empty,
    Event,
    Open,
    Text,
    Timeline,
)
from mimika.timeline.speech import format_time, time_speech

__all__ = ["to_script"]


def _esc_text(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace(
        "\r", "&#13;")


def _esc_attr(s: str) -> str:
    return (_esc_text(s).replace('"', "&quot;").replace("\n", "&#10;").replace("\t", "&#9;"))


def _attrs(pairs) -> str:
    return "".join(f' {k}="{_esc_attr(str(v))}"' for k, v in pairs)


def _num(x: float) -> str:
    s = repr(float(x))
    return s[:-2] if s.endswith(".0") else s


def _balanced(tokens, p0: int, p1: int) -> bool:
    depth = 0
    for tok in tokens[p0:p1]:
        if isinstance(tok, Open):
            depth += 1
        elif isinstance(tok, Close):
            depth -= 1
            if depth < 0:
                return False
    return depth == 0


def _event_xml(ch: str, e: Event, times, *, library: Any, mood: str | None,
               anchored: bool, body: str | None) -> str:
    tag = "m:neutral" if (e.kind == "expression" and e.name == "neutral") else \
        "m:" + PRINT_NAME[e.kind]
    attrs: list[tuple[str, str]] = []
    if e.kind == "expression" and e.name != "neutral":
        attrs.append(("name", e.name))
    elif e.kind == "aus":
        attrs.append(("set", " ".join(f"{c}={_num(v)}" for c, v in e.aus)))
    elif e.kind in ("gaze", "tilt", "turn"):
        attrs.append(("dir", e.name))
    elif e.kind == "blink" and e.name != "both":
        attrs.append(("side", e.name))
    if e.kind in ("nod", "shake") and e.count != 1:
        attrs.append(("count", str(e.count)))
    if e.intensity != 1.0:
        attrs.append(("intensity", _num(e.intensity)))
    anchor = e.anchor if anchored else None
    start_d, dur_d = derived_timing(e.kind, e.name, e.count, times, anchor,
                                    e.at if anchored else None, library=library, mood=mood)
    if anchored and start_d == e.start:
        if e.at is not None:
            attrs.append(("at", format_time(e.at, signed=True)))
    else:
        attrs.append(("start", format_time(e.start)))
    if dur_d != e.duration:
        attrs.append(("dur", format_time(e.duration)))
    if e.onset is not None:
        attrs.append(("onset", format_time(e.onset)))
    if e.offset is not None:
        attrs.append(("offset", format_time(e.offset)))
    if e.ease is not None:
        attrs.append(("ease", e.ease))
    if ch != DEFAULT_CHANNEL[e.kind]:
        attrs.append(("channel", ch))
    head = f"<{tag}{_attrs(attrs)}"
    return head + "/>" if body is None else head + ">"


def _channel_decl(c: Channel) -> str | None:
    attrs = [("name", c.name)]
    if c.override:
        attrs.append(("override", "true"))
    if c.ease != "cosine":
        attrs.append(("ease", c.ease))
    if not math.isinf(c.bridge):
        attrs.append(("bridge", format_time(c.bridge)))
    if len(attrs) == 1 and c.events:
        return None
    return f"<m:channel{_attrs(attrs)}/>"


def to_script(timeline: Timeline, *, library: Any = None, word_times=None) -> str:
    """The script of ``timeline`` (SSML + mimika elements), ready to save as ``.xml``."""
    if library is None and any(e.kind == "expression" for _, e in timeline.events):
        from mimika.timeline.player import default_library

        library = default_library()
    sp = timeline.speech
    tokens = sp.tokens
    times = time_speech(sp, rate=timeline.rate, word_times=word_times).times
    mood = timeline.mood

    # which anchored events can be written in place (properly nested), which go to the end
    placed: list[tuple[str, Event]] = []
    loose: list[tuple[str, Event]] = []
    for ch, e in timeline.events:
        ok = e.anchor is not None and e.anchor[1] <= len(tokens) and _balanced(tokens, *e.anchor)
        (placed if ok else loose).append((ch, e))
    # wrappers must nest among themselves: drop crossing ones to 'loose'
    wrappers = sorted([x for x in placed if x[1].anchor[1] > x[1].anchor[0]],
                      key=lambda x: (x[1].anchor[0], -x[1].anchor[1]))
    stack: list[tuple[int, int]] = []
    good = set()
    for ch, e in wrappers:
        a, b = e.anchor
        while stack and stack[-1][1] <= a:
            stack.pop()
        if stack and b > stack[-1][1]:
            loose.append((ch, e))
            continue
        stack.append((a, b))
        good.add(id(e))
    placed = [(c, e) for c, e in placed if e.anchor[1] == e.anchor[0] or id(e) in good]

    opens: dict[int, list[tuple[str, Event]]] = {}
    for ch, e in placed:
        opens.setdefault(e.anchor[0], []).append((ch, e))

    # pieces: strings; NL marks a place for a newline, written only between two tags (a
    # newline next to text would change the speech)
    out: list[str | None] = [None]
    settings = []
    if timeline.rate != 0.16:
        settings.append(("rate", format_time(timeline.rate)))
    if mood:
        settings.append(("mood", mood))
    if timeline.duration is not None:
        settings.append(("duration", format_time(timeline.duration)))
    if settings:
        out += [f"<m:settings{_attrs(settings)}/>", None]
    for c in timeline.channels:
        d = _channel_decl(c)
        if d:
            out += [d, None]

    open_stack: list[tuple[int, str]] = []  # (end position, closing tag)

    def emit_at(p: int) -> None:
        while open_stack and open_stack[-1][0] == p:
            out.append(open_stack.pop()[1])
        here = opens.get(p, [])
        points = [x for x in here if x[1].anchor[1] == p]
        wraps = sorted([x for x in here if x[1].anchor[1] > p], key=lambda x: -x[1].anchor[1])
        for ch, e in points:
            out.append(_event_xml(ch, e, times, library=library, mood=mood, anchored=True,
                                  body=None))
        for ch, e in wraps:
            xml = _event_xml(ch, e, times, library=library, mood=mood, anchored=True, body="")
            out.append(xml)
            tag = xml[1:].split(" ", 1)[0].split(">", 1)[0]
            open_stack.append((e.anchor[1], f"</{tag}>"))

    for p, tok in enumerate(tokens):
        emit_at(p)
        if isinstance(tok, Text):
            out.append(_esc_text(tok.text))
        elif isinstance(tok, Open):
            out.append(f"<{tok.tag}{_attrs(tok.attrs)}>")
        elif isinstance(tok, Close):
            out.append(f"</{tok.tag}>")
        elif isinstance(tok, Empty):
            out.append(f"<{tok.tag}{_attrs(tok.attrs)}/>")
    emit_at(len(tokens))
    while open_stack:  # pragma: no cover - every wrapper ends within the tokens
        out.append(open_stack.pop()[1])
    out.append(None)
    for ch, e in sorted(loose, key=lambda x: (x[0], x[1].start)):
        out += [_event_xml(ch, e, times, library=library, mood=mood, anchored=False, body=None),
                None]
    text: list[str] = []
    for i, piece in enumerate(out):
        if piece is not None:
            text.append(piece)
            continue
        prev = next((x for x in reversed(out[:i]) if x is not None), "<speak>")
        nxt = next((x for x in out[i + 1:] if x is not None), "</speak>")
        if prev.endswith(">") and nxt.startswith("<") and not (text and text[-1] == "\n"):
            text.append("\n")
    root = _attrs(sp.attrs)
    return (f'<speak version="1.1" xmlns="{SSML_NS}" xmlns:m="{MIMIKA_NS}"{root}>'
            + "".join(text) + "</speak>\n")
