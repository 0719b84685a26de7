"""Parse mimika scripts: SSML plus mimika elements → :class:`~mimika.timeline.Timeline`.

A script is SSML (``speak``, ``p``, ``s``, ``break``, ``prosody``, ``mark``, ``lang``, ``sub``,
``say-as`` … are kept) with mimika elements — prefixed (``<m:expr>``, namespace
``https://mimika.dev/ns/1``; the prefix ``m`` works even undeclared) or unprefixed
(``<expr>``). Text is speech; an element wrapping words spans them under text timing. Plain
text (not starting with ``<``) is a valid script. See ``docs/script.md`` for the reference.

Every error is a :class:`ScriptError` naming ``file:line:col`` and how to fix it.
"""

from __future__ import annotations

import difflib
import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from xml.parsers import expat

from mimika import limits
from mimika.errors import DataError, MimikaError, ParameterError
from mimika.facs.catalogue import parse_au_values, parse_intensity
from mimika.markup.elements import (
    ATTRS,
    MIMIKA_ELEMENTS,
    MIMIKA_NS,
    REQUIRED,
    SSML_ELEMENTS,
    SSML_NS,
    derived_timing,
)
from mimika.timeline.easing import check_easing
from mimika.timeline.model import (
    DEFAULT_CHANNEL,
    Channel,
    Close,
    Empty,
    Event,
    Open,
    Speech,
    Text,
    Timeline,
)
from mimika.timeline.speech import break_seconds, parse_time, rate_factor, time_speech

log = logging.getLogger(__name__)

__all__ = ["ScriptError", "load_script", "parse_script"]

_WRAP = "<speak>"
_ROOT_RE = re.compile(
    r"^\s*(?:<\?xml[^>]*\?>)?\s*(?:<!--.*?-->\s*)*<([A-Za-z_][\w.\-]*:)?([\w.\-]+)", re.DOTALL)


_ILLEGAL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


class ScriptError(DataError):
    """A script problem at ``source:line:col`` (1-based)."""

    def __init__(self, message: str, *, source: str = "<script>", line: int = 0, col: int = 0):
        self.source, self.line, self.col = source, line, col
        where = f"{source}:{line}:{col}" if line else source
        super().__init__(f"{where}: {message}")
        self.detail = message


@dataclass
class _Pending:
    """A mimika element between its start and end tag."""

    local: str
    attrs: dict[str, str]
    p0: int
    line: int
    col: int


@dataclass
class _Frame:
    kind: str  # "ssml" | "mimika" | "root"
    local: str
    qname: str
    ns: dict[str, str]
    token_index: int = -1  # index of its Open token (ssml)
    children: bool = False
    pending: _Pending | None = None


@dataclass
class _State:
    tokens: list = field(default_factory=list)
    root_attrs: tuple = ()
    stack: list[_Frame] = field(default_factory=list)
    pending: list[tuple[_Pending, int]] = field(default_factory=list)  # (element, p1)
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    text: list[str] = field(default_factory=list)


def _suggest(bad: str, options: list[str] | tuple[str, ...]) -> str:
    close = difflib.get_close_matches(bad, list(options), n=1, cutoff=0.5)
    return f"; did you mean {close[0]!r}?" if close else ""


def _bool(v: str, what: str) -> bool:
    t = v.strip().lower()
    if t in ("true", "yes", "1"):
        return True
    if t in ("false", "no", "0"):
        return False
    raise ParameterError(f"{what}={v!r} must be true or false")


def _float(v: str, what: str) -> float:
    try:
        f = float(v)
    except ValueError:
        raise ParameterError(f"{what}={v!r} is not a number") from None
    if not math.isfinite(f):
        raise ParameterError(f"{what}={v!r} must be finite")
    return f


class _Parser:
    def __init__(self, text: str, *, source: str, library: Any, word_times, rate: float | None):
        self.text = text
        self.source = source
        self.library = library
        self.word_times = word_times
        self.rate = rate
        self.st = _State()
        self.col_shift = 0
        self.p: Any = None

    # -- locations
    def _loc(self) -> tuple[int, int]:
        line = self.p.CurrentLineNumber
        col = self.p.CurrentColumnNumber + 1
        if line == 1:
            col -= self.col_shift
        return line, col

    def error(self, msg: str, line: int | None = None, col: int | None = None) -> ScriptError:
        if line is None:
            line, col = self._loc()
        return ScriptError(msg, source=self.source, line=line, col=col or 0)

    # -- parsing
    def run(self) -> Timeline:
        text = self.text
        bad = _ILLEGAL.search(text)
        if bad:
            line = text.count("\n", 0, bad.start()) + 1
            col = bad.start() - (text.rfind("\n", 0, bad.start()) + 1) + 1
            raise ScriptError(f"character U+{ord(bad.group()):04X} is not allowed in a script "
                              "(XML forbids control characters); remove it",
                              source=self.source, line=line, col=col)
        if not text.lstrip().startswith("<"):
            st = self.st
            st.tokens = [Text(text)] if text else []
            return self.finish()
        m = _ROOT_RE.match(text)
        if m is None or m.group(2) != "speak":
            decl = re.match(r"^\s*<\?xml[^>]*\?>", text)
            if decl:  # keep line/col: blank the declaration out
                text = re.sub(r"[^\n]", " ", decl.group(0)) + text[decl.end():]
            text = _WRAP + text + "</speak>"
            self.col_shift = len(_WRAP)
        p = expat.ParserCreate()
        p.ordered_attributes = True
        p.buffer_text = True
        p.StartElementHandler = self.start
        p.EndElementHandler = self.end
        p.CharacterDataHandler = self.chars
        self.p = p
        try:
            p.Parse(text, True)
        except expat.ExpatError as e:
            line, col = e.lineno, e.offset + 1
            if line == 1:
                col = max(1, col - self.col_shift)
            msg = expat.ErrorString(e.code)
            hint = {
                "not well-formed (invalid token)": "; escape a literal '<' as &lt; and '&' as "
                                                   "&amp;",
                "mismatched tag": "; every element must be closed in the order it was opened",
                "unclosed token": "; a tag or comment is not closed",
                "no element found": "; the script ends inside an element",
                "undefined entity": "; use &amp; &lt; &gt; &quot; &apos; or &#NNN;",
                "junk after document element": "; put everything inside one <speak> element",
                "unbound prefix": "; declare the prefix (xmlns:m=\"https://mimika.dev/ns/1\")",
            }.get(msg, "")
            raise ScriptError(f"malformed XML: {msg}{hint}", source=self.source, line=line,
                              col=col) from None
        except RecursionError:  # pragma: no cover - expat is iterative; handlers are shallow
            raise self.error("the script is nested too deeply") from None
        return self.finish()

    def _flush(self) -> None:
        if self.st.text:
            s = "".join(self.st.text)
            self.st.text.clear()
            if self.st.stack and self.st.stack[-1].kind == "mimika" and \
                    self.st.stack[-1].local in ("channel", "settings", "mood") and s.strip():
                raise self.error(f"<{self.st.stack[-1].qname}> cannot contain text")
            self.st.tokens.append(Text(s))

    def chars(self, data: str) -> None:
        self.st.text.append(data)
        if self.st.stack:
            self.st.stack[-1].children = True

    def _resolve(self, qname: str, ns: dict[str, str]) -> tuple[str, str]:
        """(namespace kind 'ssml'|'mimika', local name) of an element."""
        prefix, _, local = qname.rpartition(":")
        if prefix:
            uri = ns.get(prefix, MIMIKA_NS if prefix == "m" else None)
            if uri is None:
                raise self.error(f"unknown prefix {prefix!r} in <{qname}>; use m: for mimika "
                                 f"elements (xmlns:m=\"{MIMIKA_NS}\") or no prefix")
            if uri == MIMIKA_NS:
                if local not in MIMIKA_ELEMENTS:
                    raise self.error(f"unknown mimika element <{qname}>"
                                     f"{_suggest(local, list(MIMIKA_ELEMENTS))} (see "
                                     "docs/script.md)")
                return "mimika", local
            if uri == SSML_NS:
                if local not in SSML_ELEMENTS:
                    raise self.error(f"unknown SSML element <{qname}>"
                                     f"{_suggest(local, sorted(SSML_ELEMENTS))}")
                return "ssml", local
            raise self.error(f"element <{qname}> is in namespace {uri!r}, which mimika does "
                             f"not know; use SSML ({SSML_NS}) or mimika ({MIMIKA_NS})")
        uri = ns.get("", SSML_NS)
        if uri == MIMIKA_NS and local in MIMIKA_ELEMENTS:
            return "mimika", local
        if local in SSML_ELEMENTS:
            return "ssml", local
        if local in MIMIKA_ELEMENTS:
            return "mimika", local
        opts = sorted(SSML_ELEMENTS | set(MIMIKA_ELEMENTS))
        raise self.error(f"unknown element <{qname}>{_suggest(local, opts)} (mimika elements: "
                         f"{', '.join(sorted(MIMIKA_ELEMENTS))}; see docs/script.md)")

    def start(self, qname: str, attr_list: list[str]) -> None:
        self._flush()
        st = self.st
        line, col = self._loc()
        pairs = list(zip(attr_list[::2], attr_list[1::2], strict=True))
        parent_ns = st.stack[-1].ns if st.stack else {}
        ns = dict(parent_ns)
        for k, v in pairs:
            if k == "xmlns":
                ns[""] = v
            elif k.startswith("xmlns:"):
                ns[k[6:]] = v
        attrs = [(k, v) for k, v in pairs if k != "xmlns" and not k.startswith("xmlns:")]
        if st.stack:
            st.stack[-1].children = True
            parent = st.stack[-1]
            if parent.kind == "mimika" and parent.local in ("channel", "settings", "mood"):
                raise self.error(f"<{parent.qname}> must be empty")
        if len(st.stack) > limits.current().max_depth:
            raise self.error(str(limits.over("max_depth", "the elements are nested "
                                                          f"{len(st.stack)} levels deep")))
        kind, local = self._resolve(qname, ns)
        if not st.stack:  # the root
            if kind != "ssml" or local != "speak":  # pragma: no cover - wrapped above
                raise self.error("the root element must be <speak>")
            st.root_attrs = tuple((k, v) for k, v in attrs if k != "version")
            st.stack.append(_Frame("root", local, qname, ns))
            return
        if kind == "ssml":
            if local == "speak":
                raise self.error("<speak> may only be the outermost element")
            self._check_ssml(local, dict(attrs))
            st.tokens.append(Open(local, tuple(attrs)))
            st.stack.append(_Frame("ssml", local, qname, ns, len(st.tokens) - 1))
            return
        allowed = ATTRS[local]
        for k, _ in attrs:
            if k not in allowed:
                raise self.error(f"<{qname}> has no attribute {k!r}{_suggest(k, allowed)} "
                                 f"(it takes: {', '.join(allowed)})")
        a = dict(attrs)
        for k in REQUIRED.get(local, ()):
            if k not in a:
                raise self.error(f"<{qname}> needs the attribute {k}=\"…\"")
        pend = _Pending(local, a, len(st.tokens), line, col)
        st.stack.append(_Frame("mimika", local, qname, ns, pending=pend))

    def _check_ssml(self, local: str, a: dict[str, str]) -> None:
        try:
            if local == "break":
                v = break_seconds(a)
                if v < 0:
                    raise ParameterError(f"break time={a['time']!r} must be ≥ 0")
                limits.check_duration(v, f"break time={a.get('time', '')!r}")
            elif local == "prosody" and "rate" in a:
                rate_factor(a["rate"])
        except ParameterError as e:
            raise self.error(str(e)) from None

    def end(self, qname: str) -> None:
        self._flush()
        st = self.st
        frame = st.stack.pop()
        if frame.kind == "root":
            return
        if frame.kind == "ssml":
            tok = st.tokens[frame.token_index]
            if not frame.children and frame.token_index == len(st.tokens) - 1:
                st.tokens[frame.token_index] = Empty(tok.tag, tok.attrs)
            else:
                st.tokens.append(Close(frame.local))
            return
        pend = frame.pending
        assert pend is not None
        if frame.local in ("channel", "settings", "mood"):
            self._declaration(pend)
            return
        st.pending.append((pend, len(st.tokens)))

    # -- declarations
    def _declaration(self, pend: _Pending) -> None:
        a, st = pend.attrs, self.st
        try:
            if pend.local == "channel":
                name = a["name"].strip()
                if name in st.channels:
                    raise ParameterError(f"channel {name!r} is declared twice")
                spec: dict[str, Any] = {}
                if "override" in a:
                    spec["override"] = _bool(a["override"], "override")
                if "ease" in a:
                    spec["ease"] = check_easing(a["ease"])
                if "bridge" in a:
                    spec["bridge"] = (math.inf if a["bridge"].strip() in ("inf", "none")
                                      else parse_time(a["bridge"], what="bridge"))
                Channel(name, **spec)  # validates
                st.channels[name] = spec
            elif pend.local == "mood":
                self._set("mood", self._mood(a["name"]))
            else:
                if "rate" in a:
                    self._set("rate", parse_time(a["rate"], what="rate"))
                if "mood" in a:
                    self._set("mood", self._mood(a["mood"]))
                if "duration" in a:
                    self._set("duration", parse_time(a["duration"], what="duration"))
        except ParameterError as e:
            raise self.error(str(e), pend.line, pend.col) from None

    def _mood(self, name: str) -> str:
        from mimika.knowledge import get_mood

        return get_mood(name).name

    def _set(self, key: str, value: Any) -> None:
        old = self.st.settings.get(key)
        if old is not None and old != value:
            raise ParameterError(f"{key} is set twice ({old!r} and {value!r})")
        self.st.settings[key] = value

    # -- events
    def finish(self) -> Timeline:
        st = self.st
        toks = st.tokens
        # leading and trailing whitespace of the script is layout, not speech
        lead = 0
        while lead < len(toks) and isinstance(toks[lead], Text) and not toks[lead].text.strip():
            lead += 1
        stop = len(toks)
        while stop > lead and isinstance(toks[stop - 1], Text) and not toks[stop - 1].text.strip():
            stop -= 1
        toks = toks[lead:stop]

        def adj(p: int) -> int:
            return min(max(p - lead, 0), len(toks))

        speech = Speech(tuple(toks), tuple(st.root_attrs))
        rate = st.settings.get("rate", self.rate or 0.16)
        mood = st.settings.get("mood")
        try:
            timing = time_speech(speech, rate=rate, word_times=self.word_times)
        except ParameterError as e:
            raise ScriptError(str(e), source=self.source) from None
        by_channel: dict[str, list[Event]] = {n: [] for n in st.channels}
        for pend, p1 in st.pending:
            pend.p0, p1 = adj(pend.p0), adj(p1)
            try:
                ch, ev = self._event(pend, p1, timing.times, mood)
            except ParameterError as e:  # an Event's message starts with its place already
                msg = getattr(e, "detail", str(e))
                msg = msg.removeprefix(f"{self.source}:{pend.line}:{pend.col}: ")
                raise ScriptError(msg, source=self.source, line=pend.line,
                                  col=pend.col) from None
            by_channel.setdefault(ch, []).append(ev)
        speech, by_channel = _merge_texts(speech, by_channel)
        try:
            chans = [Channel(n, tuple(evs), **st.channels.get(n, {}))
                     for n, evs in by_channel.items()]
            return Timeline(tuple(chans), speech, rate=rate, mood=mood,
                            duration=st.settings.get("duration"))
        except ParameterError as e:
            m = re.match(r"^(.*?):(\d+):(\d+): (.*)$", str(e), re.DOTALL)
            if m and m.group(1) == self.source:
                raise ScriptError(m.group(4), source=self.source, line=int(m.group(2)),
                                  col=int(m.group(3))) from None
            raise ScriptError(str(e), source=self.source) from None

    def _event(self, pend: _Pending, p1: int, times: tuple[float, ...],
               mood: str | None) -> tuple[str, Event]:
        a = dict(pend.attrs)
        local = pend.local
        kind = MIMIKA_ELEMENTS[local]
        assert kind is not None
        where = f"{self.source}:{pend.line}:{pend.col}"
        name = ""
        aus: tuple = ()
        count = 1
        if local == "neutral":
            name = "neutral"
        elif kind == "expression":
            name = self._expression_name(a["name"])
        elif kind == "aus":
            items = [x for x in re.split(r"[\s,;]+", a["set"].strip()) if x]
            if not items:
                raise ParameterError('set="" names no AU; write e.g. set="AU06=0.8 AU12"')
            aus = tuple(parse_au_values(items).items())
        elif kind in ("gaze", "tilt", "turn"):
            name = a["dir"].strip().lower()
        elif kind == "blink":
            name = a.get("side", "both").strip().lower()
        if kind in ("nod", "shake") and "count" in a:
            try:
                count = int(a["count"])
            except ValueError:
                raise ParameterError(f"count={a['count']!r} must be a whole number") from None
            if not 1 <= count <= 100:
                raise ParameterError(f"count={count} must be within 1…100")
        for x, y in (("start", "at"), ("end", "dur")):
            if x in a and y in a:
                raise ParameterError(f"give either {x} or {y}, not both")
        at = parse_time(a["at"], what="at", signed=True) if "at" in a else None
        anchor: tuple[int, int] | None = (pend.p0, p1)
        wraps = p1 > pend.p0
        if "start" in a and not wraps:
            anchor = None
        start_d, dur_d = derived_timing(kind, name, count, times, anchor, at,
                                        library=self.library, mood=mood)
        start = parse_time(a["start"], what="start") if "start" in a else start_d
        assert start is not None
        if start < 0:
            raise ParameterError(f"the element starts at {start:g} s, before the script "
                                 "begins; use a smaller shift (at=…)")
        if "end" in a:
            dur = parse_time(a["end"], what="end") - start
            if dur <= 0:
                raise ParameterError(f"end={a['end']!r} is not after start ({start:g} s)")
        elif "dur" in a:
            dur = parse_time(a["dur"], what="dur")
        else:
            dur = dur_d
        intensity = parse_intensity(a["intensity"]) if "intensity" in a else 1.0
        ev = Event(
            kind, start, dur, name=name, aus=aus, intensity=intensity,
            onset=parse_time(a["onset"], what="onset") if "onset" in a else None,
            offset=parse_time(a["offset"], what="offset") if "offset" in a else None,
            ease=a.get("ease"), count=count, anchor=anchor, at=at, where=where)
        channel = a.get("channel", DEFAULT_CHANNEL[kind]).strip()
        if not channel or any(c.isspace() for c in channel):
            raise ParameterError(f"channel={a.get('channel')!r} must be a single word")
        return channel, ev

    def _expression_name(self, raw: str) -> str:
        name = raw.strip()
        lib = self.library
        if hasattr(lib, "resolve"):
            lib.resolve(name)  # raises with suggestions
            return name.lower().replace(" ", "-")
        lib.get(name)
        return name


def _merge_texts(speech: Speech, by_channel: dict[str, list[Event]]):
    """Join text runs split only by elements placed by absolute time (no anchor), so the
    speech does not depend on where such elements stood (the printer puts them last)."""
    from dataclasses import replace

    cuts = {p for evs in by_channel.values() for e in evs if e.anchor for p in e.anchor}
    toks: list = []
    for i, tok in enumerate(speech.tokens):
        if isinstance(tok, Text) and toks and isinstance(toks[-1], Text) and i not in cuts:
            toks[-1] = Text(toks[-1].text + tok.text)
        else:
            toks.append(tok)
    if len(toks) == len(speech.tokens):
        return speech, by_channel
    # a position p (before token p) maps to the index the token p starts at in the new list
    start_of = [0] * (len(speech.tokens) + 1)
    k = 0
    for i, tok in enumerate(speech.tokens):
        merged = isinstance(tok, Text) and i > 0 and isinstance(speech.tokens[i - 1], Text) \
            and i not in cuts
        if not merged:
            start_of[i] = k
            k += 1
        else:
            start_of[i] = k  # inside a merged run: never an anchor (not in cuts)
    start_of[len(speech.tokens)] = k
    out = {c: [replace(e, anchor=(start_of[e.anchor[0]], start_of[e.anchor[1]]))
               if e.anchor else e for e in evs] for c, evs in by_channel.items()}
    return Speech(tuple(toks), speech.attrs), out


def parse_script(text: str, *, source: str = "<script>", library: Any = None,
                 word_times=None, rate: float | None = None) -> Timeline:
    """Parse a script (SSML + mimika elements, or plain text) into a :class:`Timeline`.

    Parameters
    ----------
    text : the script
    source : name used in error messages (a file name)
    library : resolves expression names (default: the knowledge base's library)
    word_times : (start, end) seconds per word from TTS or alignment (default: text timing)
    rate : seconds per vowel unit when the script does not set one (default 0.16)

    Raises
    ------
    ScriptError : with ``source:line:col`` and a hint
    """
    if not isinstance(text, str):
        raise ParameterError(f"script must be text, got {type(text).__name__}")
    if library is None:
        from mimika.timeline.player import default_library

        library = default_library()
    try:
        limits.check_text(text, "the script")
        return _Parser(text, source=source, library=library, word_times=word_times,
                       rate=rate).run()
    except ScriptError:
        raise
    except MimikaError as e:  # a check deep inside, without a location
        raise ScriptError(str(e), source=source) from None


def load_script(path: str | Path, **kwargs) -> Timeline:
    """Read and parse a script file (UTF-8)."""
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except FileNotFoundError:
        raise DataError(f"script file {p} does not exist") from None
    except UnicodeDecodeError as e:
        raise DataError(f"{p}: not UTF-8 text (byte {e.start}); save the script as UTF-8"
                        ) from None
    except OSError as e:
        raise DataError(f"cannot read script {p}: {e.strerror}") from None
    return parse_script(text, source=str(p), **kwargs)
