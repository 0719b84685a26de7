"""The knowledge base (seed 002 §6.5): defaults and warnings for timed expression events.

Timeline-independent: the input is a list of :class:`Event` (name, start, duration, intensity)
and/or a text; the output is a :class:`Report` with :class:`Finding` s (error / warning /
suggestion — never silent) and :class:`Suggestion` s: default events the caller may accept or
drop. Dropping a default is free, warned about, or an error, as the seed says per rule:

====================================  =============================  ===================
rule                                  default                        if dropped
====================================  =============================  ===================
``timing.possible`` / ``.probable``   Table 6.15 limits              (error / warning)
``cooc.sadness-gap``                  sadness ≥ 1 s after others     (warning)
``cooc.astonishment-surprise``        3 frames of surprise around    error
``cooc.disgust-anger``                anger around disgust           warning
``cooc.disbelief-anger``              anger after disbelief          free
``cooc.happiness-surprise``           surprise before happiness      free
``cooc.grief-surprise``               surprise blended with grief    free
``listener.frequency``                ≤ 6 expressions / min          (warning)
``listener.expressions``              sadness, regret, disbelief …   (suggestion)
``mood.defaults`` / ``mood.frequency`` mood-scaled timing            (suggestion/warning)
``text.question``                     surprise ends each question    free
``text.exclamation``                  anger with "!"                 free
``text.irritation`` / ``.disapproval``  anger at the word            warning
``text.fright``                       surprise + grief at the word   free
``text.assent``                       surprise at yes/sure/…         free
====================================  =============================  ===================
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from mimika.errors import ParameterError
from mimika.knowledge._data import knowledge_data, section
from mimika.knowledge.expressions import TEMPLATE_PREFIX, ExpressionLibrary, builtin_expressions
from mimika.knowledge.mood import Mood, get_mood
from mimika.knowledge.textsync import Constituent, linked
from mimika.knowledge.timing import fmt_range, timing_limit

log = logging.getLogger(__name__)

LEVELS = ("error", "warning", "suggestion")
ROLES = ("speaker", "listener")


@dataclass(frozen=True)
class Event:
    """A timed expression: ``name`` from the library, times in seconds, intensity in [0, 1]."""

    name: str
    start: float
    duration: float
    intensity: float = 1.0

    def __post_init__(self) -> None:
        for what, v in (("start", self.start), ("duration", self.duration)):
            if not math.isfinite(float(v)):
                raise ParameterError(f"event {self.name!r}: {what}={v!r} must be finite")
        if self.start < 0:
            raise ParameterError(f"event {self.name!r}: start={self.start:g} s must be ≥ 0")
        if self.duration < 0:
            raise ParameterError(f"event {self.name!r}: duration={self.duration:g} s must be ≥ 0")
        if not 0.0 <= self.intensity <= 1.0:
            raise ParameterError(f"event {self.name!r}: intensity={self.intensity:g} must be "
                                 "within [0, 1]")

    @property
    def end(self) -> float:
        return self.start + self.duration

    @property
    def kind(self) -> str:
        """``template/surprise`` → ``surprise`` (the knowledge base reasons about kinds)."""
        return self.name.removeprefix(TEMPLATE_PREFIX)

    @property
    def span(self) -> tuple[float, float]:
        return (self.start, self.end)

    def to_dict(self) -> dict[str, Any]:
        return {k: (round(v, 3) if isinstance(v, float) else v) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Event:
        try:
            return cls(str(d["name"]), float(d["start"]), float(d["duration"]),
                       float(d.get("intensity", 1.0)))
        except (KeyError, TypeError, ValueError) as e:
            raise ParameterError(f"event {dict(d)!r} needs name, start, duration "
                                 f"(and optional intensity): {e}") from None


@dataclass(frozen=True)
class Finding:
    """One message from the knowledge base; ``fix`` says how to comply (or what to add)."""

    level: str  #: error | warning | suggestion
    rule: str
    message: str
    time: float | None = None
    fix: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Suggestion:
    """A default event the caller may accept (add to its timeline) or drop (by ``id``)."""

    id: str
    rule: str
    event: Event
    reason: str
    removal: str  #: free | warn | forbidden — what dropping it causes

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "rule": self.rule, "event": self.event.to_dict(),
                "reason": self.reason, "removal": self.removal}


@dataclass
class Report:
    """Findings (errors first), suggested events, the timed text and its emotional words."""

    findings: list[Finding] = field(default_factory=list)
    suggestions: list[Suggestion] = field(default_factory=list)
    constituents: list[Constituent] = field(default_factory=list)
    words: list[dict[str, Any]] = field(default_factory=list)

    def by_level(self, level: str) -> list[Finding]:
        return [f for f in self.findings if f.level == level]

    @property
    def errors(self) -> list[Finding]:
        return self.by_level("error")

    @property
    def warnings(self) -> list[Finding]:
        return self.by_level("warning")

    def rules(self) -> set[str]:
        return {f.rule for f in self.findings}

    def to_dict(self) -> dict[str, Any]:
        return {"findings": [f.to_dict() for f in self.findings],
                "suggestions": [s.to_dict() for s in self.suggestions],
                "words": list(self.words),
                "sentences": [{"text": c.text, "start": round(c.start, 3),
                               "end": round(c.end, 3)} for c in self.constituents]}


class _Ctx:
    """Shared state of one :func:`check` run."""

    def __init__(self, events: Sequence[Event], *, fps: float, context: str, mood: Mood,
                 dropped: Iterable[str], library: ExpressionLibrary | None):
        self.events = list(events)
        self.fps = fps
        self.mood = mood
        ranges = section("context")
        if context not in ranges:
            raise ParameterError(f"context={context!r} must be one of {', '.join(ranges)}")
        self.range = tuple(float(x) for x in ranges[context])
        self.dropped = set(dropped)
        self.library = library
        self.findings: list[Finding] = []
        self.suggestions: list[Suggestion] = []
        self.cooc = section("cooccurrence")

    def intensity(self, kind: str) -> float:
        lo, hi = self.range
        return {"low": lo, "high": hi}.get(kind, round((lo + hi) / 2, 3))

    def duration(self, kind: str) -> float:
        """Default duration of expression kind ``kind`` under the mood, within Table 6.15."""
        expr = builtin_expressions().get(TEMPLATE_PREFIX + kind) or builtin_expressions()[kind]
        d = expr.duration * self.mood.duration_scale
        lim = timing_limit(kind)
        return round(lim.clamp(d) if lim else d, 3)

    def add(self, level: str, rule: str, message: str, time: float | None = None,
            fix: dict[str, Any] | None = None) -> None:
        self.findings.append(Finding(level, rule, message,
                                     None if time is None else round(time, 3), fix))

    def has(self, kind: str, span: tuple[float, float], *, frames: float = 0.0) -> bool:
        """Is a given event of ``kind`` within ``frames`` of ``span``, or does an already
        suggested one overlap it?"""
        return any(e.kind == kind and linked(e.span, span, fps=self.fps, max_frames=frames)
                   for e in self.events) or any(
            s.event.kind == kind and linked(s.event.span, span, fps=self.fps, max_frames=0)
            for s in self.suggestions)

    def suggest(self, rule: str, event: Event, reason: str, removal: str) -> None:
        sid = f"{rule}:{event.kind}@{event.start:.2f}"
        if {sid, rule, f"{rule}:{event.kind}"} & self.dropped:
            if removal == "warn":
                self.add("warning", rule, f"dropped default {event.kind} at {event.start:.2f} s: "
                         f"{reason}; removing it is not advised", event.start,
                         {"add": event.to_dict(), "id": sid})
            elif removal == "forbidden":
                self.add("error", rule, f"{event.kind} at {event.start:.2f} s cannot be removed: "
                         f"{reason}; shorten or lengthen it instead", event.start,
                         {"add": event.to_dict(), "id": sid})
            return
        self.suggestions.append(Suggestion(sid, rule, event, reason, removal))
        self.add("suggestion", rule, f"add {event.name} {event.start:.2f}–{event.end:.2f} s "
                 f"(intensity {event.intensity:g}): {reason}", event.start,
                 {"add": event.to_dict(), "id": sid})


# -- event rules ------------------------------------------------------------------------------
def _timing(ctx: _Ctx) -> None:
    for e in ctx.events:
        lim = timing_limit(e.name)
        if lim is None:
            continue
        if not lim.possible[0] <= e.duration <= lim.possible[1]:
            ctx.add("error", "timing.possible",
                    f"{e.kind} at {e.start:.2f} s lasts {e.duration:g} s, outside the possible "
                    f"range {fmt_range(lim.possible)} (Table 6.15)", e.start,
                    {"duration": lim.clamp(e.duration)})
        elif not lim.probable[0] <= e.duration <= lim.probable[1]:
            frame = 1.0 / ctx.fps
            if e.kind == "surprise" and any(
                    a.kind == "astonishment" and linked(a.span, e.span, fps=ctx.fps, max_frames=1)
                    and e.duration <= 4 * frame for a in ctx.events):
                continue  # the short surprise framing an astonishment is the default itself
            ctx.add("warning", "timing.probable",
                    f"{e.kind} at {e.start:.2f} s lasts {e.duration:g} s, outside the probable "
                    f"range {fmt_range(lim.probable)} (Table 6.15)", e.start,
                    {"duration": lim.clamp(e.duration, probable=True)})


def _cooccurrence(ctx: _Ctx) -> None:
    c, fps = ctx.cooc, ctx.fps
    frame = 1.0 / fps
    gap = float(c["sadness_gap_s"])
    for s in (e for e in ctx.events if e.kind == "sadness"):
        for o in ctx.events:
            if o is not s and o.kind != "sadness" and o.start < s.start < o.end + gap:
                ctx.add("warning", "cooc.sadness-gap",
                        f"sadness at {s.start:.2f} s starts {max(s.start - o.end, 0):.2f} s after "
                        f"the end of {o.kind} ({o.end:.2f} s); sadness needs {gap:g} s after any "
                        "other expression", s.start, {"start": round(o.end + gap, 3)})
                break
    n = int(c["astonishment_frame_frames"])
    for a in (e for e in ctx.events if e.kind == "astonishment"):
        before = any(e.kind == "surprise" and e.start < a.start and e.end >= a.start - frame
                     for e in ctx.events)
        after = any(e.kind == "surprise" and e.end > a.end and e.start <= a.end + frame
                    for e in ctx.events)
        why = "astonishment is always framed by surprise (seed 002 §6.5)"
        if not before and a.start > 0:
            st = max(0.0, a.start - n * frame)
            ctx.suggest("cooc.astonishment-surprise",
                        Event("template/surprise", st, a.start - st, a.intensity), why,
                        "forbidden")
        if not after:
            ctx.suggest("cooc.astonishment-surprise",
                        Event("template/surprise", a.end, n * frame, a.intensity), why, "forbidden")
    m = float(c["disgust_anger_margin_s"])
    for d in (e for e in ctx.events if e.kind == "disgust"):
        if not ctx.has("anger", d.span):
            st = max(0.0, d.start - m)
            ctx.suggest("cooc.disgust-anger",
                        Event("template/anger", st, d.end + m - st, d.intensity),
                        "disgust is combined with anger by default (77 % of disgust segments; "
                        "anger usually contains disgust)", "warn")
    w = float(c["follow_window_s"])
    for d in (e for e in ctx.events if e.kind == "disbelief"):
        if not any(e.kind == "anger" and d.start < e.start <= d.end + w for e in ctx.events):
            ctx.suggest("cooc.disbelief-anger",
                        Event("template/anger", d.end, ctx.duration("anger"), d.intensity),
                        "disbelief is followed by anger by default", "free")
    for h in (e for e in ctx.events if e.kind == "happiness"):
        if h.start <= frame:
            continue
        if not any(e.kind == "surprise" and e.start < h.start and e.end >= h.start - w
                   for e in ctx.events):
            st = max(0.0, h.start - 0.5)
            ctx.suggest("cooc.happiness-surprise",
                        Event("template/surprise", st, h.start - st + 2 * frame, h.intensity),
                        "happiness is preceded by surprise by default", "free")
    p = float(c["grief_blend_probability"])
    for g in (e for e in ctx.events if e.kind == "grief"):
        if not any(o is not g and linked(o.span, g.span, fps=fps, max_frames=0)
                   for o in ctx.events):
            ctx.suggest("cooc.grief-surprise",
                        Event("template/surprise", g.start, g.duration, g.intensity),
                        f"grief appears together with another expression in more than {p:.0%} of "
                        "cases, most often blended with surprise", "free")


def _role(ctx: _Ctx, role: str) -> None:
    if role not in ROLES:
        raise ParameterError(f"role={role!r} must be one of {', '.join(ROLES)}")
    if role != "listener" or not ctx.events:
        return
    cfg = section("listener")
    span = max(e.end for e in ctx.events) - min(e.start for e in ctx.events)
    per_min = len(ctx.events) / max(span, 60.0) * 60.0
    if per_min > cfg["max_per_minute"]:
        ctx.add("warning", "listener.frequency",
                f"{len(ctx.events)} expressions in {span:.1f} s ({per_min:.1f}/min) make an "
                f"unrealistically expressive listener (at most {cfg['max_per_minute']}/min)",
                None, {"max_per_minute": cfg["max_per_minute"]})
    other = sorted({e.kind for e in ctx.events} - set(cfg["suggested"]))
    if other:
        ctx.add("suggestion", "listener.expressions",
                f"a listener mostly shows {', '.join(cfg['suggested'])}; consider replacing "
                f"{', '.join(other)}", None, {"prefer": list(cfg["suggested"])})


def _mood(ctx: _Ctx, given: bool) -> None:
    if not given:
        return
    m = ctx.mood
    ctx.add("suggestion", "mood.defaults", m.describe() + "; default durations are adjusted",
            None, {"interval_s": m.interval_s, "duration_scale": m.duration_scale})
    starts = sorted(e.start for e in ctx.events)
    if len(starts) >= 3:
        mean = (starts[-1] - starts[0]) / (len(starts) - 1)
        if mean < 0.5 * m.interval_s:
            ctx.add("warning", "mood.frequency",
                    f"expressions start every {mean:.2f} s on average; too frequent for mood "
                    f"{m.name!r} (about every {m.interval_s:g} s)", None,
                    {"interval_s": m.interval_s})
        elif mean > 2.0 * m.interval_s and m.frequency == "frequent":
            ctx.add("suggestion", "mood.frequency",
                    f"expressions start every {mean:.2f} s on average; mood {m.name!r} usually "
                    f"shows one about every {m.interval_s:g} s", None,
                    {"interval_s": m.interval_s})


def check(
    events: Iterable[Event | Mapping[str, Any]] = (),
    *,
    text: str | None = None,
    lang: str = "en",
    context: str = "conversation",
    mood: str | None = None,
    role: str = "speaker",
    start: float = 0.0,
    rate: float | None = None,
    fps: float | None = None,
    dropped: Iterable[str] = (),
    library: ExpressionLibrary | None = None,
) -> Report:
    """Check timed expression events and/or a text against the knowledge base.

    Parameters
    ----------
    events : Event objects or dicts (name, start, duration[, intensity]); times in seconds
    text : a script; it is timed by :func:`~mimika.knowledge.textsync.sync_text` from ``start``
    lang : en | de | pl (lexicon and assent phrases)
    context : news | narration | conversation | drama (intensity range of suggestions)
    mood : e.g. depressed, happy, confused (see ``knowledge.json``); None = neutral
    role : speaker | listener
    rate : seconds per vowel unit for the text (default 0.16)
    fps : frame rate for frame-based rules (default 25, the seed's)
    dropped : suggestion ids, ``rule`` or ``rule:kind`` names the caller removed
    library : resolves event names (built-ins only when None)

    Returns
    -------
    Report : findings sorted errors → warnings → suggestions, then by time
    """
    from mimika.knowledge.text import text_rules
    from mimika.knowledge.textsync import DEFAULT_RATE, sync_text

    evs = [e if isinstance(e, Event) else Event.from_dict(e) for e in events]
    lib = library
    known = set(lib.names()) if lib else set(builtin_expressions())
    for e in evs:
        if e.name not in known and TEMPLATE_PREFIX + e.name not in known:
            raise ParameterError(_unknown(e.name, known))
    fps = float(fps or knowledge_data()["fps"])
    ctx = _Ctx(sorted(evs, key=lambda e: e.start), fps=fps, context=context,
               mood=get_mood(mood), dropped=dropped, library=lib)
    _timing(ctx)
    _cooccurrence(ctx)
    _role(ctx, role)
    _mood(ctx, mood is not None)
    report = Report()
    if text is not None:
        report.constituents = sync_text(text, start=start, rate=rate or DEFAULT_RATE)
        report.words = text_rules(ctx, report.constituents, lang)
    order = {lvl: i for i, lvl in enumerate(LEVELS)}
    report.findings = sorted(ctx.findings, key=lambda f: (order[f.level],
                                                          -1 if f.time is None else f.time))
    report.suggestions = sorted(ctx.suggestions, key=lambda s: s.event.start)
    log.debug("check: %d finding(s), %d suggestion(s)", len(report.findings),
              len(report.suggestions))
    return report


def _unknown(name: str, known: set[str]) -> str:
    import difflib

    pool = sorted(known | {k.removeprefix(TEMPLATE_PREFIX) for k in known})
    close = difflib.get_close_matches(name.lower(), pool, n=3, cutoff=0.6)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    return f"unknown expression {name!r}{hint} (run 'mimika expressions list' for all names)"
