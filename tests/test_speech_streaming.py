"""The streaming recogniser (mimika.speech.streaming): features and classes do not depend on
how the audio is chunked, each frame is decided once after a fixed look-ahead, offline
recognition gives the same classes, the shipped model says where it comes from."""

import numpy as np
import pytest

from mimika.errors import ParameterError
from mimika.speech import streaming


def _speechlike(sr: int, seconds: float = 1.6, seed: int = 0) -> np.ndarray:
    """Voiced bursts (harmonics of a moving pitch) between silences and noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * sr)) / sr
    f0 = 110 + 30 * np.sin(2 * np.pi * 1.3 * t)
    voiced = sum(np.sin(2 * np.pi * k * np.cumsum(f0) / sr) / k for k in range(1, 12))
    env = (np.sin(2 * np.pi * 2.5 * t) > 0.2).astype(float)
    noise = rng.standard_normal(len(t)) * ((t % 0.4) > 0.3)
    return (0.1 * voiced * env + 0.02 * noise).astype(np.float32)


def _chunks(a: np.ndarray, rng: np.random.Generator):
    k = 0
    while k < len(a):
        n = int(rng.integers(1, 2000))
        yield a[k:k + n], k + n >= len(a)
        k += n


@pytest.mark.parametrize("sr", [16000, 22050, 8000])
def test_features_and_classes_do_not_depend_on_the_chunks(sr):
    a = _speechlike(sr)
    whole = streaming.Features(sr).push(a, final=True)
    assert len(whole) == int(np.ceil(len(a) / sr * streaming.RATE))
    f, rec = streaming.Features(sr), streaming.Recogniser(sr)
    parts, classes = [], []
    for c, last in _chunks(a, np.random.default_rng(1)):
        parts.append(f.push(c, final=last))
        classes += rec.push(c, final=last)
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=1e-5, atol=1e-4)
    assert classes == streaming.recognise_classes(a, sr=sr)
    assert len(classes) == len(whole) and set(classes) <= set(streaming.model().classes)


def test_each_frame_is_decided_after_the_fixed_lookahead():
    sr = 16000
    a = _speechlike(sr, 2.0)
    rec = streaming.Recogniser(sr)
    assert 0.05 < rec.lookahead < 0.1
    fed = 0
    for k in range(0, len(a), 160):
        rec.push(a[k:k + 160])
        fed = min(k + 160, len(a))
        # frame i (centre (i + 0.5) / RATE) is final once the look-ahead past it has come
        expect = int(np.floor((fed / sr - rec.lookahead) * streaming.RATE - 0.5 + 1e-6)) + 1
        assert rec.n == max(expect, 0), (fed, rec.n, expect)
    assert len(rec.decoder.back) == rec.decoder.lag  # memory: only the undecided frames


def test_recognise_tiles_the_recording_with_the_classes_as_phones():
    from mimika.speech.alignment import recognise
    from mimika.speech.phonemes import classify

    sr = 22050
    a = _speechlike(sr)
    u = recognise(a, sr=sr)
    assert u.meta["engine"] == "frames" and u.words == []
    assert u.phonemes[0].start == 0 and u.phonemes[-1].end == pytest.approx(len(a) / sr)
    assert all(p.end == q.start for p, q in zip(u.phonemes, u.phonemes[1:], strict=False))
    got = [classify(p.symbol)[0] for p in u.phonemes]
    classes = streaming.recognise_classes(a, sr=sr)
    runs = [c for i, c in enumerate(classes) if i == 0 or classes[i - 1] != c]
    assert got == runs
    with pytest.raises(ParameterError, match="engine"):
        recognise(a, sr=sr, engine="whisper")


def test_every_class_symbol_reads_back_as_its_class():
    from mimika.speech.phonemes import classify

    for cls, sym in streaming.SYMBOL.items():
        assert classify(sym, "en") == (cls,)


def test_the_shipped_model_is_small_and_says_where_it_comes_from():
    from importlib import resources

    size = resources.files("mimika.speech").joinpath(streaming.MODEL).read_bytes()
    assert len(size) < 400_000
    m = streaming.model()
    assert "GRID" in m.meta["data"] and "CC BY 4.0" in m.meta["data"]
    assert m.meta["train"] and set(m.meta["decoder"]) == {"lag", "switch", "prior_weight"}
    assert "bilabial" in m.classes and "sil" in m.classes
