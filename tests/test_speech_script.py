"""Words as written, SSML that reaches the voice, recordings in the newsreader, mood."""

import json
from pathlib import Path

import numpy as np
import pytest

from mimika.speech.audio import write_wav
from mimika.speech.tts import synthesize

CORPUS = json.loads((Path(__file__).parent / "data" / "spoken_words.json").read_text("utf-8"))


@pytest.mark.parametrize("lang", ["en", "de", "pl"])
def test_numbers_currency_abbreviations_and_punctuation_time_the_written_words(lang):
    for case in CORPUS[lang]:
        u = synthesize(case["text"], lang=lang)
        assert [w.text for w in u.words] == case["words"], case["text"]
        for a, b in zip(u.words, u.words[1:], strict=False):
            assert a.start < a.end <= b.start + 1e-9
        for w in u.words:
            assert case["text"][w.offset:w.offset + len(w.text)] == w.text
            if w.text in case.get("long", []):
                assert w.end - w.start >= 0.6, (w, case["text"])


def _dur(doc: str) -> float:
    return synthesize(doc, ssml=True).duration


def test_ssml_break_adds_the_silence_it_asks_for():
    base = _dur("<speak>Good evening, here is the news.</speak>")
    longer = _dur('<speak>Good evening, <break time="2s"/> here is the news.</speak>')
    assert longer - base == pytest.approx(2.0, abs=0.25)


def test_ssml_prosody_rate_changes_the_length():
    base = _dur("<speak>Good evening, here is the news from the city.</speak>")
    half = _dur('<speak><prosody rate="50%">Good evening, here is the news from the city.'
                "</prosody></speak>")
    fast = _dur('<speak><prosody rate="x-fast">Good evening, here is the news from the city.'
                "</prosody></speak>")
    assert half / base == pytest.approx(2.0, rel=0.25)
    assert fast < 0.85 * base


def test_ssml_volume_pitch_sub_and_phoneme_change_the_speech():
    text = "Good evening from the city."
    plain = synthesize(f"<speak>{text}</speak>", ssml=True)
    soft = synthesize(f'<speak><prosody volume="x-soft">{text}</prosody></speak>', ssml=True)
    assert np.abs(soft.audio).max() < 0.5 * np.abs(plain.audio).max()
    high = synthesize(f'<speak><prosody pitch="x-high">{text}</prosody></speak>', ssml=True)
    assert not np.array_equal(high.audio[:len(plain.audio)], plain.audio[:len(high.audio)])
    sub = synthesize('<speak>Visit <sub alias="the World Wide Web">WWW</sub> now.</speak>',
                     ssml=True)
    assert [w.text for w in sub.words] == ["Visit", "WWW", "now"]
    assert "w" in [p.symbol for p in sub.phonemes]  # "world" was spoken, not "W W W"
    ph = synthesize('<speak>A <phoneme alphabet="ipa" ph="təˈmɑːtoʊ">tomato</phoneme>.</speak>',
                    ssml=True)
    assert "A:" in [p.symbol for p in ph.phonemes]  # the British /ɑː/ of the ph attribute
    lang = synthesize('<speak>Hello <lang xml:lang="de">Guten Tag</lang>.</speak>', ssml=True)
    assert "A:" in [p.symbol for p in lang.phonemes]  # German "Tag", not English


def test_ssml_audio_is_spliced_in(tmp_path):
    beep = (0.3 * np.sin(2 * np.pi * 440 * np.arange(8000) / 16000)).astype(np.float32)
    write_wav(tmp_path / "beep.wav", beep, sr=16000)
    from mimika.speech.ssml import parse, speak

    u, _ = speak(parse('<speak>Before <audio src="beep.wav">a beep</audio> after.</speak>'),
                 base=tmp_path)
    plain, _ = speak(parse("<speak>Before after.</speak>"))
    assert 0.45 <= u.duration - plain.duration <= 1.2  # the beep + espeak's pauses around it
    assert [w.text for w in u.words] == ["Before", "after"]
    gap = u.audio[round(u.words[0].end * u.sr):round(u.words[1].start * u.sr)]
    win = round(0.4 * u.sr)
    rms = [np.sqrt(np.mean(gap[i:i + win] ** 2)) for i in range(0, len(gap) - win, 200)]
    assert max(rms) == pytest.approx(0.3 / np.sqrt(2), rel=0.1)  # the 440 Hz tone is there


def test_script_events_stay_on_their_words_when_the_speech_changes():
    from mimika.newsreader import news_track, parse_article

    art = parse_article('<speak>Good evening. <break time="1.5s"/> '
                        '<expr name="happiness">Wonderful news</expr> today.</speak>')
    nt = news_track(art, layers=["skin"], fps=25)
    u = nt.utterance
    w = {x.text: x for x in u.words}
    t = np.arange(nt.track.n_frames) / 25
    au06 = nt.track["AU06"]  # the cheeks: lip shapes of the speech do not touch them
    inside = (t > w["Wonderful"].start + 0.3) & (t < w["news"].start + 0.1)
    before = t < w["Wonderful"].start - 0.3  # includes the 1.5 s break
    after = t > w["today"].end
    assert au06[inside].min() > 0.3
    assert au06[before].max() < 0.05 and au06[after].max() < 0.05
    assert w["Wonderful"].start - w["evening"].end > 1.4  # the break reached the voice


def test_mood_changes_how_often_and_how_strongly_the_layers_act():
    from mimika.behaviour.speaking import speaking_behaviour

    u = synthesize("Good evening. " * 3 + "Prices rose sharply across the country today, "
                   "and the government promised to act quickly. " * 4)

    def activity(mood):
        merged, layers = speaking_behaviour(u, fps=25, mood=mood, seed=3,
                                            layers=["head", "brows", "smile"])
        brows = layers["brows"]["AU01"] if "AU01" in layers["brows"].channels else 0
        return (np.abs(np.diff(merged["AU53"] + merged["AU54"])).sum(), np.sum(brows),
                layers["smile"]["AU12"].max())

    happy, sad = activity("happy"), activity("depressed")
    assert happy[0] > sad[0] and happy[1] > sad[1] and happy[2] > sad[2]
    _, only = speaking_behaviour(u, fps=25, layers=["blink"])
    assert list(only) == ["blink"]


@pytest.mark.render
def test_news_with_a_recording_lasts_exactly_as_long_as_the_recording(tmp_path):
    from mimika.newsreader import render_news
    from mimika.render.video import probe

    rec = synthesize("Good evening. Bob bought a big map.", voice="f3", rate=150)
    audio = np.concatenate([np.zeros(11025, np.float32), rec.audio]) * 0.8
    write_wav(tmp_path / "reading.wav", audio, sr=rec.sr)
    out = tmp_path / "news.mp4"
    res = render_news("Good evening. Bob bought a big map.", out=out, size=(160, 120),
                      audio=tmp_path / "reading.wav", workers=1, layers=["skin"])
    import av

    with av.open(str(out)) as c:
        a = c.streams.audio[0]
        assert float(a.duration * a.time_base) == pytest.approx(len(audio) / rec.sr, abs=0.001)
    info = probe(out)
    assert abs(info["video_duration"] - len(audio) / rec.sr) <= 1 / 25
    assert res.track is not None and res.duration == pytest.approx(len(audio) / rec.sr)
    srt = out.with_suffix(".srt").read_text()
    assert "Bob bought a big map." in srt


@pytest.mark.render
def test_render_script_to_a_spoken_video(tmp_path):
    from mimika.cli import main
    from mimika.render.video import probe

    script = tmp_path / "s.xml"
    script.write_text('<speak><expr name="happiness">Good evening.</expr>'
                      '<break time="1s"/>Here is the news.</speak>')
    assert main(["render", str(script), "-o", str(tmp_path / "s.mp4"), "-q"]) == 0
    info = probe(tmp_path / "s.mp4")
    assert info["audio_codec"] == "aac" and info["video_duration"] > 2.5
