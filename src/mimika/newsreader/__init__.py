"""The virtual newsreader (seed 004): an article is read by a face in a studio, to MP4 + SRT.

:func:`render_news` runs the whole pipeline — article (plain text or ``<speak>`` script) →
espeak-ng speech with newsreader pauses → mouth AUs (lip-sync with /p b m/ closures) +
behaviour layers (head motion, gaze, blinks, brows, smiles, idle, knowledge defaults) → AU
Blender → rig → skin-shaded frames → H.264/AAC MP4 with SRT subtitles beside it.
"""

from __future__ import annotations

import functools
from importlib import resources

from mimika.errors import ParameterError
from mimika.newsreader.article import Article, parse_article, speak_article
from mimika.newsreader.pipeline import (
    ABLATIONS,
    FEATURES,
    FLAG_NAMES,
    NewsResult,
    NewsTrack,
    news_track,
    render_ablations,
    render_news,
)
from mimika.newsreader.subtitles import Cue, parse_srt, sentence_cues, srt_text, write_srt

#: example bulletins shipped as package data, by language
EXAMPLES = {"en": "bulletin_en.txt", "de": "bulletin_de.txt"}

__all__ = [
    "ABLATIONS", "EXAMPLES", "FEATURES", "FLAG_NAMES", "Article", "Cue", "NewsResult",
    "NewsTrack", "example_bulletin", "news_track", "parse_article", "parse_srt",
    "render_ablations", "render_news", "sentence_cues", "speak_article", "srt_text", "write_srt",
]


@functools.cache
def example_bulletin(lang: str = "en") -> str:
    """The text of the example bulletin in ``lang`` (``en`` ≈ 30 s, ``de`` shorter)."""
    if lang not in EXAMPLES:
        raise ParameterError(f"no example bulletin for {lang!r}; examples: "
                             f"{', '.join(EXAMPLES)}")
    return resources.files("mimika.newsreader").joinpath(f"data/{EXAMPLES[lang]}").read_text(
        "utf-8")
