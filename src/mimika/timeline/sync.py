"""The synchroniser: apply the knowledge base's timing rules to a timeline (issue 4).

Expression events are checked against seed 002's Table 6.15 limits
(:func:`mimika.knowledge.timing_limit`) and the co-occurrence / mood / role rules
(:func:`mimika.knowledge.check`). ``mode`` decides what happens to a duration outside the limits:

* ``"warn"`` — nothing changes; every problem is returned as a finding;
* ``"clamp"`` — durations outside the *possible* range (and with ``probable=True`` the probable
  range) are clamped — never into the next event of the channel — and reported;
* ``"error"`` — the first error raises :class:`~mimika.errors.ParameterError`.

Suggested default events (e.g. surprise framing an astonishment) are returned, and with
``accept=True`` added to a ``knowledge`` channel. Nothing is ever silent.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Any

from mimika.errors import ParameterError
from mimika.timeline.model import Channel, Event, Timeline

log = logging.getLogger(__name__)

MODES = ("warn", "clamp", "error")


@dataclass(frozen=True)
class SyncFinding:
    """A knowledge-base message about the timeline: level, rule, text, time (s), channel."""

    level: str
    rule: str
    message: str
    time: float | None = None
    channel: str | None = None
    fix: dict[str, Any] | None = None


@dataclass(frozen=True)
class SyncResult:
    timeline: Timeline
    findings: list[SyncFinding] = field(default_factory=list)
    suggestions: list[Any] = field(default_factory=list)  #: knowledge ``Suggestion`` s

    @property
    def errors(self) -> list[SyncFinding]:
        return [f for f in self.findings if f.level == "error"]


def synchronise(
    timeline: Timeline,
    *,
    mode: str = "warn",
    probable: bool = False,
    accept: bool = False,
    fps: float = 25.0,
    context: str = "conversation",
    role: str = "speaker",
    library: Any = None,
) -> SyncResult:
    """Check (and with ``mode="clamp"`` fix) the timing of ``timeline``'s expressions.

    Parameters
    ----------
    mode : warn | clamp | error (see the module docstring)
    probable : clamp to the *probable* range too (mode clamp)
    accept : add the knowledge base's suggested events to a ``knowledge`` channel
    fps : frame rate of the frame-based rules (the seed's 25 by default)
    context, role : passed to :func:`mimika.knowledge.check`
    library : resolves expression names (default: the knowledge base's library)
    """
    from mimika.knowledge import check, timing_limit
    from mimika.knowledge.timing import fmt_range

    if mode not in MODES:
        raise ParameterError(f"mode={mode!r} must be one of {', '.join(MODES)}")
    if library is None:
        from mimika.timeline.player import default_library

        library = default_library()
    findings: list[SyncFinding] = []
    channels: list[Channel] = []
    for ch in timeline.channels:
        evs = list(ch.events)
        for i, e in enumerate(evs):
            if e.kind != "expression":
                continue
            name = library.resolve(e.name) if hasattr(library, "resolve") else e.name
            lim = timing_limit(name)
            if lim is None:
                continue
            where = f"{e.where}: " if e.where else ""
            for level, rng, active in (("error", lim.possible, True),
                                       ("warning", lim.probable, probable or mode != "clamp")):
                if rng[0] <= e.duration <= rng[1]:
                    continue
                target = lim.clamp(e.duration, probable=level == "warning")
                nxt = evs[i + 1].start if i + 1 < len(evs) else None
                msg = (f"{where}{e.name} at {e.start:g} s lasts {e.duration:g} s, outside the "
                       f"{'possible' if level == 'error' else 'probable'} range "
                       f"{fmt_range(rng)} (seed 002 Table 6.15)")
                if mode == "error" and level == "error":
                    raise ParameterError(msg + f"; make it {target:g} s")
                if mode == "clamp" and (level == "error" or probable) and active:
                    if nxt is not None and e.start + target > nxt:
                        target = max(nxt - e.start, 1e-3)
                        msg += f"; clamped to {target:g} s (the next event starts at {nxt:g} s)"
                    else:
                        msg += f"; clamped to {target:g} s"
                    on = e.onset
                    off = e.offset
                    if (on or 0) + (off or 0) > target:
                        k = target / ((on or 0) + (off or 0))
                        on = None if on is None else on * k
                        off = None if off is None else off * k
                    e = replace(e, duration=target, onset=on, offset=off)
                    evs[i] = e
                    rule = "timing.possible" if level == "error" else "timing.probable"
                    findings.append(SyncFinding("warning", rule, msg, e.start, ch.name,
                                                {"duration": target}))
                else:
                    findings.append(SyncFinding(level, "timing.possible" if level == "error"
                                                else "timing.probable", msg + f"; {target:g} s "
                                                "would fit", e.start, ch.name,
                                                {"duration": target}))
                break
        channels.append(replace(ch, events=tuple(evs)))
    tl = timeline.with_channels(channels)
    # the other knowledge rules, on all expression events together
    events = [(c, e) for c, e in tl.events if e.kind == "expression"]
    from mimika.knowledge import Event as KEvent

    kev = [KEvent(library.resolve(e.name) if hasattr(library, "resolve") else e.name,
                  e.start, e.duration, e.intensity) for _, e in events]
    report = check(kev, mood=tl.mood, fps=fps, context=context, role=role,
                   library=library if hasattr(library, "names") else None)
    for f in report.findings:
        if f.rule.startswith("timing."):
            continue  # handled above, per event
        findings.append(SyncFinding(f.level, f.rule, f.message, f.time, None, f.fix))
    if accept and report.suggestions:
        added = []
        for s in report.suggestions:
            added.append(Event("expression", s.event.start, s.event.duration, name=s.event.name,
                               intensity=s.event.intensity))
        ch = Channel("knowledge", tuple(_fit(added)))
        others = [c for c in tl.channels if c.name != "knowledge"]
        if any(c.name == "knowledge" for c in tl.channels):
            old = tl.channel("knowledge")
            ch = replace(old, events=tuple(_fit([*old.events, *added])))
        tl = tl.with_channels([*others, ch])
    for f in findings:
        log.info("%s %s: %s", f.level, f.rule, f.message)
    return SyncResult(tl, findings, list(report.suggestions))


def _fit(events: list[Event]) -> list[Event]:
    """Drop events that would overlap an earlier one (suggestions may overlap each other)."""
    out: list[Event] = []
    for e in sorted(events, key=lambda e: e.start):
        if out and e.start < out[-1].end - 1e-9:
            log.info("suggested %s at %g s overlaps %s; not added", e.label, e.start,
                     out[-1].label)
            continue
        out.append(e)
    return out
