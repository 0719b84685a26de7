"""Knowledge base (seed 002 §5.3, §6.4–6.5): expression library, timing limits, co-occurrence
defaults, mood, text rules, emotional-word lexicon (en/de/pl) and text timing without audio.

Must not import render, face or speech modules.
"""

from mimika.knowledge.expressions import (
    Expression,
    ExpressionLibrary,
    builtin_expressions,
    default_library_path,
    expression_aus,
    get_expression,
)
from mimika.knowledge.lexicon import Lexicon, default_lexicon
from mimika.knowledge.mood import Mood, get_mood, moods
from mimika.knowledge.rules import Event, Finding, Report, Suggestion, check
from mimika.knowledge.textsync import Component, Constituent, sync_text, vowel_units
from mimika.knowledge.timing import TimingLimit, timing_limit, timing_limits

__all__ = [
    "Component",
    "Constituent",
    "Event",
    "Expression",
    "ExpressionLibrary",
    "Finding",
    "Lexicon",
    "Mood",
    "Report",
    "Suggestion",
    "TimingLimit",
    "builtin_expressions",
    "check",
    "default_lexicon",
    "default_library_path",
    "expression_aus",
    "get_expression",
    "get_mood",
    "moods",
    "sync_text",
    "timing_limit",
    "timing_limits",
    "vowel_units",
]
