"""espeak-ng TTS: audio, timing, languages, parameters, SSML, errors, WAV I/O, lazy loading."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from mimika.errors import DataError, ParameterError

pytest.importorskip("espeakng_loader")

from mimika.speech.audio import read_wav, write_wav
from mimika.speech.tts import split_sentences, synthesize


@pytest.mark.parametrize("lang,text", [
    ("en", "Hello world. How are you?"),
    ("en-us", "Hello world."),
    ("de", "Guten Abend, meine Damen und Herren. Schöne Grüße!"),
    ("pl", "Dobry wieczór państwu. Chrząszcz brzmi w trzcinie."),
])
def test_synthesize_timing_tiles_audio(lang, text):
    u = synthesize(text, lang=lang)
    assert u.sr == 22050 and u.audio.dtype == np.float32 and u.audio.ndim == 1
    assert 0.5 < u.duration < 10
    assert u.phonemes[0].start == 0.0
    assert u.phonemes[-1].end == pytest.approx(u.duration, abs=1e-6)
    for a, b in zip(u.phonemes, u.phonemes[1:], strict=False):
        assert a.end == pytest.approx(b.start) and a.end > a.start
    words = [w.text.strip(",.!?") for w in u.words]
    assert words == [w.strip(",.!?") for w in text.split()]
    for w in u.words:  # offsets point into the text
        assert text[w.offset:w.offset + len(w.text)] == w.text
        assert 0 <= w.start <= w.end <= u.duration
    assert len(u.sentences) == len(split_sentences(text))


def test_rate_and_pitch_change_the_audio():
    slow = synthesize("The news at nine.", rate=120)
    fast = synthesize("The news at nine.", rate=300)
    assert slow.duration > 1.6 * fast.duration
    f0 = [_f0(synthesize("The news at nine.", pitch=p)) for p in (10, 90)]
    assert f0[1] > 1.3 * f0[0]


def _f0(u) -> float:
    """Median autocorrelation pitch (Hz) of the vowels, on the signal low-passed at 400 Hz."""
    spec = np.fft.rfft(u.audio.astype(np.float64))
    spec[np.fft.rfftfreq(len(u.audio), 1 / u.sr) > 400] = 0
    y = np.fft.irfft(spec, n=len(u.audio))
    out = []
    for p in u.phonemes:
        if p.symbol in ("u:", "aI", "a", "@") and p.duration > 0.06:
            x = y[int(p.start * u.sr):int(p.end * u.sr)]
            ac = np.correlate(x, x, "full")[len(x) - 1:]
            lo, hi = int(u.sr / 400), int(u.sr / 50)
            out.append(u.sr / (lo + int(np.argmax(ac[lo:hi]))))
    return float(np.median(out))


def test_ssml_break_and_prosody():
    plain = synthesize("<speak>Hello world.</speak>", ssml=True)
    brk = synthesize('<speak>Hello <break time="800ms"/> world.</speak>', ssml=True)
    assert brk.duration > plain.duration + 0.5
    assert max(p.duration for p in brk.phonemes if p.is_pause) > 0.6
    slow = synthesize('<speak><prosody rate="x-slow">Hello world.</prosody></speak>', ssml=True)
    assert slow.duration > plain.duration * 1.3
    assert [w.text for w in brk.words] == ["Hello", "world"]


def test_sentence_split_keeps_abbreviations():
    s = split_sentences("Dr. Smith came at 3.5 p.m. today. Was it z.B. gut? Ja!\n\nNeu.")
    assert [x for x, _ in s] == ["Dr. Smith came at 3.5 p.m. today.", "Was it z.B. gut?", "Ja!",
                                 "Neu."]


def test_a_sentence_may_end_with_etc_or_p_m():
    """ "etc." and "p.m." end a sentence when a capitalised word follows (they were kept in
    one, with no pause and one subtitle cue); "Jr." and "Inc." do not ("King Jr. Day")."""
    s = split_sentences("It ended at 5 p.m. The crowd left, pears etc. and more. King Jr. Day "
                        "came. Pears etc. Then apples.")
    assert [x for x, _ in s] == ["It ended at 5 p.m.", "The crowd left, pears etc. and more.",
                                 "King Jr. Day came.", "Pears etc.", "Then apples."]


def test_empty_text_is_a_clear_error():
    with pytest.raises(ParameterError, match="text is empty"):
        synthesize("   ")


def test_unknown_language_lists_close_languages():
    with pytest.raises(ParameterError, match=r"unknown language 'eng'.*close: .*en"):
        synthesize("hello", lang="eng")


def test_bad_parameters():
    with pytest.raises(ParameterError, match="rate=20"):
        synthesize("hello", rate=20)
    with pytest.raises(ParameterError, match="pitch=101"):
        synthesize("hello", pitch=101)
    with pytest.raises(ParameterError, match="unknown voice"):
        synthesize("hello", voice="nosuchvoice")


def test_voice_variant():
    u = synthesize("Hello.", voice="f3")
    assert u.duration > 0.2


def test_list_voices():
    from mimika.speech.espeak import list_voices

    names = {v.name for v in list_voices("de")}
    assert "German" in names
    assert any("en-us" in v.languages for v in list_voices("en"))


def test_wav_roundtrip(tmp_path):
    u = synthesize("Hello.")
    p = tmp_path / "a.wav"
    write_wav(p, u.audio, sr=u.sr)
    a, sr = read_wav(p)
    assert sr == u.sr and len(a) == len(u.audio)
    assert np.max(np.abs(a - u.audio)) < 1e-3
    with pytest.raises(DataError, match="does not exist"):
        read_wav(tmp_path / "missing.wav")
    (tmp_path / "bad.wav").write_bytes(b"not a wav")
    with pytest.raises(DataError, match="PCM WAV"):
        read_wav(tmp_path / "bad.wav")


def test_timing_json_roundtrip(tmp_path):
    from mimika.speech.utterance import Utterance

    u = synthesize("Good evening.")
    u.save_timing(tmp_path / "t.json")
    v = Utterance.load_timing(tmp_path / "t.json")
    assert [p.symbol for p in v.phonemes] == [p.symbol for p in u.phonemes]
    assert v.phonemes[-1].end == pytest.approx(u.duration, abs=1e-3)


def test_import_mimika_does_not_load_espeak():
    code = ("import sys, mimika, mimika.speech, mimika.tracks; "
            "print(any('espeak' in m for m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
