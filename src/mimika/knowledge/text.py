"""Text defaults (seed 002 §6.4–6.5): questions, exclamations, emotional words, assent phrases.

Every default is a :class:`~mimika.knowledge.rules.Suggestion` placed with the vowel-unit text
timing; an event already linked to the word (≤ 12 frames, Eq 6.13) satisfies it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mimika.knowledge._data import section
from mimika.knowledge.lexicon import default_lexicon, valid_lang
from mimika.knowledge.textsync import LINK_FRAMES, Component, Constituent

if TYPE_CHECKING:
    from mimika.knowledge.rules import _Ctx

#: removal policy per category rule (seed §6.5: removing anger for irritation → warning)
_CATEGORY_RULES = {"Irritation": "warn", "Disapproval": "warn", "Fright": "free"}


def _place(ctx: _Ctx, rule: str, kind: str, start: float, end_at: float | None, reason: str,
           removal: str, strength: str, link_span: tuple[float, float]) -> None:
    from mimika.knowledge.rules import Event
    from mimika.knowledge.timing import timing_limit

    if ctx.has(kind, link_span, frames=LINK_FRAMES):
        return  # a given event is linked to this place, or a suggested one overlaps it
    dur = ctx.duration(kind)
    if end_at is not None:  # ends with the sentence, starts no earlier than the sentence
        lim = timing_limit(kind)
        shortest = lim.possible[0] if lim else 0.0
        start = max(start, end_at - dur)
        start = max(0.0, min(start, end_at - shortest))
        dur = end_at - start
    ctx.suggest(rule, Event("template/" + kind, round(start, 3), round(dur, 3),
                            ctx.intensity(strength)), reason, removal)


def text_rules(ctx: _Ctx, constituents: list[Constituent], lang: str) -> list[dict[str, Any]]:
    """Apply the text defaults; return the emotional words found (with times)."""
    lang = valid_lang(lang)
    cfg = section("text")
    lex = default_lexicon()
    assent = [tuple(p.lower().split()) for p in cfg["assent"][lang]]
    words_out: list[dict[str, Any]] = []
    for c in constituents:
        words: list[Component] = c.words
        low = [w.text.lower() for w in words]
        # questions and exclamations: at the end of the sentence
        if c.words and c.final_punct:
            last, punct = c.words[-1], c.components[-1]
            span = (last.start, punct.end)
            if c.is_question:
                _place(ctx, "text.question", cfg["question"], c.start, punct.end,
                       "every question ends with surprise by default", "free", "low", span)
            if c.is_exclamation:
                _place(ctx, "text.exclamation", cfg["exclamation"], c.start, punct.end,
                       "an exclamation mark is accompanied by anger by default", "free", "high",
                       span)
        # emotional words
        for m in lex.find([w.text for w in words], lang):
            first, lastw = words[m.first], words[m.last]
            if any(w["category"] == m.category and w["start"] == round(first.start, 3)
                   for w in words_out):
                continue  # the same word listed twice in App. D.1 (obawa / strach: afraid)
            words_out.append({"word": m.text, "category": m.category, "no": m.entry.no,
                              "start": round(first.start, 3), "end": round(lastw.end, 3)})
            kinds = cfg["categories"].get(m.category, [])
            for kind in kinds:
                _place(ctx, f"text.{m.category.lower()}", kind, first.start, None,
                       f"{m.category} word {m.text!r} is accompanied by "
                       f"{' + '.join(kinds)} by default", _CATEGORY_RULES[m.category], "high",
                       (first.start, lastw.end))
        # assent phrases
        for i in range(len(low)):
            for p in assent:
                if tuple(low[i:i + len(p)]) == p:
                    end = words[i + len(p) - 1].end
                    _place(ctx, "text.assent", "surprise", words[i].start, None,
                           f"assent ({' '.join(p)!r}) is accompanied by surprise by default",
                           "free", "low", (words[i].start, end))
    return words_out
