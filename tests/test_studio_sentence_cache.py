"""Studio speech under load (issue 27): a sentence is synthesised once, whatever text it comes
in — 30 clients speaking pairs of eight sentences no longer synthesise every pair anew — and
the kept sentences stay within half of ``max_cache_mb``."""

from __future__ import annotations

import pytest

from mimika import limits


@pytest.fixture()
def state(tmp_path):
    from mimika.studio.state import StudioState

    return StudioState(tmp_path / "projects", head="builtin", library_path=tmp_path / "l.json")


def test_a_sentence_is_synthesised_once_in_any_text(state, monkeypatch):
    import mimika.speech
    from mimika.studio import speaking
    from mimika.studio.state import SpeechEntry

    said = []
    real = mimika.speech.synthesize
    monkeypatch.setattr(mimika.speech, "synthesize",
                        lambda text, **k: (said.append(text), real(text, **k))[1])
    a = speaking.synth_all(state, SpeechEntry("a" * 20, "Good evening. Here is the news.",
                                              "en", 175), fps=30)
    b = speaking.synth_all(state, SpeechEntry("b" * 20, "Here is the news. Good evening.",
                                              "en", 175), fps=30)
    assert said == ["Good evening.", "Here is the news."]
    assert b.segments[0].utterance is a.segments[1].utterance
    assert b.segments[1].t0 == pytest.approx(b.segments[0].duration)


def test_kept_sentences_stay_within_the_cache_budget(state):
    import numpy as np

    from mimika.speech import Utterance

    def utt(seconds: float) -> Utterance:
        return Utterance(np.zeros(int(seconds * 22050), np.float32), 22050, [], [], [],
                         lang="en", text="x")

    with limits.override(max_cache_mb=1):  # half of it: 500 kB, about 5.7 s of audio
        for k in range(20):
            state.put_sentence((f"s{k}", "en", 175), utt(1.0))
    assert state._sentence_bytes <= 500_000 and len(state._sentences) == 5
    assert state.sentence(("s19", "en", 175)) is not None
    assert state.sentence(("s0", "en", 175)) is None
