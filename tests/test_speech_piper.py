"""The neural Piper voice: default for English, any voice by path or name, timing from the
model's own durations, deterministic audio, espeak-ng as the fallback."""

import hashlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mimika.errors import DataError, ParameterError
from mimika.speech import piper
from mimika.speech.phonemes import classify
from mimika.speech.tts import choose_engine, synthesize

BUNDLED = piper.default_voice("en") if piper.available() else None
pytestmark = pytest.mark.skipif(BUNDLED is None, reason="piper-tts or its English voice is "
                                                        "not installed")
SENT = "Peter bought a map, and the prime minister met the press."


@pytest.fixture(autouse=True)
def auto_engine(monkeypatch, tmp_path):
    """What a user gets: no engine pinned, an empty voice folder."""
    monkeypatch.delenv("MIMIKA_TTS", raising=False)
    monkeypatch.setenv(piper.ENV_VOICES, str(tmp_path / "voices"))


def _copy_voice(folder, name):
    """The bundled voice under another name (hard links: no copy of 63 MB)."""
    folder.mkdir(parents=True, exist_ok=True)
    m = folder / f"{name}.onnx"
    os.link(BUNDLED.model, m)
    os.link(BUNDLED.config, folder / f"{name}.onnx.json")
    return m


def test_english_speaks_with_the_bundled_neural_voice():
    for lang in ("en", "en-us", "en_GB"):
        kind, info = choose_engine(None, lang, None)
        assert (kind, info.name) == ("piper", piper.BUNDLED)
    u = synthesize("Good evening.")
    assert u.meta["source"] == "piper" and u.meta["voice"] == piper.BUNDLED
    assert u.lang.startswith("en") and np.abs(u.audio).max() > 0.1


def test_other_languages_and_espeak_voices_keep_espeak():
    assert choose_engine(None, "de", None) == ("espeak", None)
    assert choose_engine(None, "en", "f3") == ("espeak", None)
    assert choose_engine("espeak", "en", None) == ("espeak", None)
    with pytest.raises(ParameterError, match=r"no Piper voice for language 'de'.*--engine espeak"):
        choose_engine("piper", "de", None)
    with pytest.raises(ParameterError, match="unknown speech engine 'festival'"):
        choose_engine("festival", "en", None)


def test_a_voice_by_path_and_by_name_in_the_voice_folder(tmp_path):
    m = _copy_voice(tmp_path / "voices", "en_GB-test-medium")
    by_path = piper.find_voice(str(m))
    assert by_path.source == "path" and by_path.language == "en-us"
    assert piper.find_voice("test").name == "en_GB-test-medium"
    assert piper.find_voice("en_gb-test-medium").source == "folder"
    names = [v.name for v in piper.list_voices("en")]
    assert names[0] == piper.BUNDLED and "en_GB-test-medium" in names
    u = synthesize("Good evening.", voice=str(m))
    assert u.meta["voice"] == "en_GB-test-medium"


def test_broken_voices_give_one_clear_error(tmp_path):
    m = tmp_path / "x.onnx"
    m.write_bytes(b"not a model")
    with pytest.raises(ParameterError, match=r"no config 'x\.onnx\.json' beside it"):
        piper.read_info(m)
    (tmp_path / "x.onnx.json").write_text(json.dumps({"audio": {}}))
    with pytest.raises(DataError, match="not a Piper voice config"):
        piper.read_info(m)
    with pytest.raises(ParameterError, match="does not exist"):
        choose_engine(None, "en", str(tmp_path / "missing.onnx"))


def test_phones_tile_the_audio_and_words_are_as_written():
    u = synthesize("Good evening. Prices rose by 3 % on Monday.")
    assert u.phonemes[0].start == 0 and u.phonemes[-1].end == pytest.approx(u.duration)
    for a, b in zip(u.phonemes, u.phonemes[1:], strict=False):
        assert a.end == pytest.approx(b.start) and b.end > b.start
    assert [w.text for w in u.words] == ["Good", "evening", "Prices", "rose", "by", "3", "%",
                                         "on", "Monday"]
    assert all(a.end <= b.start + 1e-9 for a, b in zip(u.words, u.words[1:], strict=False))
    text = u.text
    assert all(text[w.offset:w.offset + len(w.text)] == w.text for w in u.words)


def test_bilabials_fall_on_the_silent_closures_of_the_voice():
    """/p b/ timed by the voice's own durations sit on its lip closures: the first 60 % of
    every /p b/ is far quieter than its vowels (a timing off by a phone would not be)."""
    for text in (SENT, "Bob put the big blue box by the pub."):
        u = synthesize(text)
        a, sr = u.audio, u.sr

        def rms(s, e, a=a, sr=sr):
            return float(np.sqrt(np.mean(a[int(s * sr):int(e * sr)] ** 2)))

        vowels = np.median([rms(p.start, p.end) for p in u.phonemes
                            if classify(p.symbol, u.lang)[0].startswith("vowel")])
        stops = [p for p in u.phonemes if p.symbol in ("p", "b")]
        assert len(stops) >= 4
        for p in stops:
            assert rms(p.start, p.start + 0.6 * p.duration) < 0.5 * vowels, (text, p)
        for p in (p for p in u.phonemes if p.symbol in ("p", "b", "m")):
            mid = 0.5 * (p.start + p.end)
            assert any(w.start <= mid <= w.end and set(w.text.lower()) & set("pbm")
                       for w in u.words), p


def test_timing_agrees_with_an_independent_aligner():
    from mimika.speech.alignment import align

    u = synthesize(SENT)
    a = align(u.audio, sr=u.sr, transcript=SENT, engine="dtw")
    d = [abs(x.start - y.start) for x, y in zip(u.words, a.words, strict=True)]
    assert np.median(d) < 0.04 and max(d) < 0.2


def test_same_text_same_audio_in_any_process():
    a = synthesize(SENT).audio
    synthesize("Something else first.")
    assert np.array_equal(a, synthesize(SENT).audio)
    code = ("import hashlib, os; os.environ.pop('MIMIKA_TTS', None); "
            "from mimika.speech import synthesize; "
            f"print(hashlib.sha256(synthesize({SENT!r}).audio.tobytes()).hexdigest())")
    env = {k: v for k, v in os.environ.items() if k != "MIMIKA_TTS"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True).stdout.split()[-1]
    assert out == hashlib.sha256(a.tobytes()).hexdigest()


@pytest.mark.parametrize("engine", ["piper", "espeak"])
def test_sentences_keep_their_pause(engine):
    u = synthesize("The vote is today. Results follow tonight.", engine=engine)
    gap = [p for p in u.phonemes if p.is_pause and u.sentences[0].start < p.start
           < u.sentences[1].start + 0.01]
    assert gap and max(p.duration for p in gap) >= 0.3 - 1e-6


def test_rate_changes_the_pace():
    slow = synthesize(SENT, rate=120).duration
    fast = synthesize(SENT, rate=240).duration
    assert slow > 1.6 * fast


def test_cli_say_with_a_voice_path_and_voices_listing(tmp_path, capsys):
    from mimika.cli import main

    wav, timing = tmp_path / "s.wav", tmp_path / "s.json"
    assert main(["say", SENT, "--voice", str(BUNDLED.model), "-o", str(wav),
                 "--timing", str(timing)]) == 0
    meta = json.loads(timing.read_text())["meta"]
    assert meta["source"] == "piper" and wav.stat().st_size > 40000
    assert main(["say", "Hallo.", "--engine", "piper", "--lang", "de", "-o",
                 str(tmp_path / "x.wav")]) == 2
    assert "no Piper voice for language 'de'" in capsys.readouterr().err
    assert main(["voices", "--lang", "en"]) == 0
    out = capsys.readouterr().out
    assert piper.BUNDLED in out and "espeak-ng voices" in out


def test_the_newsreader_reads_with_the_neural_voice():
    from mimika.newsreader.pipeline import news_track

    nt = news_track("Good evening. Here is the news.", supported=None)
    assert nt.utterance.meta["source"] == "piper"
    assert nt.track.n_frames >= 25


def test_ssml_reaches_the_neural_voice():
    plain = synthesize("<speak>Good evening, here is the news.</speak>", ssml=True)
    assert plain.meta["source"] == "piper"
    pause = synthesize('<speak>Good evening, <break time="1500ms"/> here is the news.</speak>',
                       ssml=True)
    assert pause.duration - plain.duration == pytest.approx(1.5, abs=0.2)
    slow = synthesize('<speak><prosody rate="slow">Good evening, here is the news.</prosody>'
                      '</speak>', ssml=True)
    assert slow.duration > 1.15 * plain.duration
    u = synthesize('<speak><sub alias="World Health Organisation">WHO</sub> met on '
                   '<say-as interpret-as="date">10/03/2024</say-as>.</speak>', ssml=True)
    assert [w.text for w in u.words] == ["WHO", "met", "on", "10/03/2024"]
    assert u.words[0].end - u.words[0].start > 0.6 and u.words[3].end - u.words[3].start > 1.0


def test_a_script_is_read_by_the_neural_voice():
    from mimika.newsreader.pipeline import news_track

    nt = news_track('<speak>Good evening. <break time="500ms"/> Here is the news.</speak>')
    assert nt.utterance.meta["source"] == "piper"
    assert [w.text for w in nt.utterance.words] == ["Good", "evening", "Here", "is", "the",
                                                     "news"]
