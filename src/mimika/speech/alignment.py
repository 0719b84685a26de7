"""Recorded speech + transcript → phoneme timing (TTS-independent viseme input).

Two engines (:func:`align`, ``engine=``): English goes through pocketsphinx's forced
alignment (:mod:`mimika.speech.sphinx`); every other espeak-ng language (and English without
pocketsphinx) through DTW against an espeak-ng rendition, below. Both then move word edges
next to pauses onto the recording's energy (:mod:`mimika.speech.vad`), and time the words as
written (:mod:`mimika.speech.words`). Real-speech figures: ``bench/bench_align_real.py``.

DTW method: the recording is cut to its speech (sustained energy, ± 0.1 s), so silence, clicks
and breaths around it cannot drag the edge words; the transcript is synthesised with espeak-ng
(which gives exact phone boundaries for its own rendition, also cut to its speech), warped
onto the recording with dynamic time warping on MFCC features, and the boundaries are carried
across the warping path.

* Features: numpy/scipy MFCCs (16 kHz, 25 ms Hamming window, 5 ms hop, 40 mel bands
  60–7600 Hz, c1–c12 + Δc0–Δc12), mean/variance normalised per utterance so that voice,
  pitch and level differences cancel. We use our own ~40 lines instead of librosa to keep the
  dependency set light (librosa pulls in numba/llvmlite, ~150 MB) — the features are the same.
* Noise matching: the recording's noise floor (per mel band, 10th percentile over frames) is
  added to the level-matched reference's mel power before the log, so that silence and weak
  consonants look alike in both under additive noise.
* DTW: symmetric step pattern (diagonal weight 2, horizontal/vertical 1.5), first on 20 ms
  frames inside a Sakoe–Chiba band of ±(25 % + 1 s), then on 5 ms frames inside ±50 ms of the
  coarse path. Each row is vectorised (the horizontal recursion is a running minimum), so
  cost is O(N·W) in numpy.

Measured on espeak speech with known timing (rate 0.8×/1.25×, pitch/voice changes, speed
change by resampling, noise at 20/10 dB SNR): see ``bench/bench_align.py`` and docs/speech.md.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from mimika.errors import ParameterError
from mimika.speech.audio import resample, valid_audio
from mimika.speech.utterance import Phone, Sentence, Utterance, Word

log = logging.getLogger(__name__)

FEAT_SR = 16000
HOP = 0.005  #: feature hop in seconds
WIN = 0.025
COARSE = 4  #: fine frames per coarse frame
RADIUS = 10  #: fine-pass half-width around the coarse path, in fine frames
#: weight of a horizontal or vertical DTW step (a diagonal step weighs 2): above 1 it costs to
#: stretch one signal against the other, so real speech cannot squeeze three words into 30 ms
#: and stretch the next across a second (GRID dev, 60 utterances: 58.9 % → 73.3 % of word
#: boundaries within 50 ms; synthetic bench p90 15.7 → 12.6 ms)
HV_WEIGHT = 1.5


def _mel_filterbank(n_fft: int, sr: int, n_mels: int, fmin: float, fmax: float) -> np.ndarray:
    def hz2mel(f):
        return 2595.0 * np.log10(1.0 + np.asarray(f) / 700.0)

    def mel2hz(m):
        return 700.0 * (10 ** (np.asarray(m) / 2595.0) - 1.0)

    freqs = np.linspace(0, sr / 2, n_fft // 2 + 1)
    pts = mel2hz(np.linspace(hz2mel(fmin), hz2mel(fmax), n_mels + 2))
    fb = np.zeros((n_mels, len(freqs)))
    for m in range(n_mels):
        lo, c, hi = pts[m], pts[m + 1], pts[m + 2]
        fb[m] = np.clip(np.minimum((freqs - lo) / (c - lo), (hi - freqs) / (hi - c)), 0, None)
    return fb


def mel_power(audio: np.ndarray, *, sr: int, hop: float = HOP, win: float = WIN,
              n_mels: int = 40) -> np.ndarray:
    """Mel power spectrogram, shape (n_frames, n_mels); frame *i* is centred at ``i·hop`` s."""
    a = valid_audio(audio, sr=sr)
    a = resample(a, orig_sr=int(sr), target_sr=FEAT_SR)
    a = np.append(a[0] if len(a) else 0.0, a[1:] - 0.97 * a[:-1])
    h, w = round(hop * FEAT_SR), round(win * FEAT_SR)
    n = max(1, math.ceil(len(a) / h))
    a = np.pad(a, (w // 2, w + n * h))
    idx = np.arange(w)[None, :] + h * np.arange(n)[:, None]
    frames = a[idx] * np.hamming(w)[None, :]
    n_fft = 512
    spec = np.abs(np.fft.rfft(frames, n=n_fft, axis=1)) ** 2
    return spec @ _mel_filterbank(n_fft, FEAT_SR, n_mels, 60.0, 7600.0).T


def mfcc_features(mel: np.ndarray, *, n_mfcc: int = 13) -> np.ndarray:
    """Normalised MFCC features from mel power (n_frames, n_mels) → (n_frames, 2·n_mfcc − 1):
    c1…c12 and the deltas of c0…c12, each column mean 0 / variance 1."""
    from scipy.fft import dct

    logmel = np.log(mel + 1e-10)
    c = dct(logmel, type=2, norm="ortho", axis=1)[:, :n_mfcc]
    k = 2
    pad = np.pad(c, ((k, k), (0, 0)), mode="edge")
    delta = sum(i * (pad[k + i:len(c) + k + i] - pad[k - i:len(c) + k - i])
                for i in range(1, k + 1)) / (2 * sum(i * i for i in range(1, k + 1)))
    f = np.hstack([c[:, 1:], delta])
    f = (f - f.mean(axis=0)) / (f.std(axis=0) + 1e-8)
    return f.astype(np.float32)


def _match_noise(ref: np.ndarray, rec: np.ndarray) -> np.ndarray:
    """Level-match the reference mel power to the recording and add its noise floor."""
    noise = np.percentile(rec, 10, axis=0)
    e_rec, e_ref = rec.sum(axis=1), ref.sum(axis=1)
    top_rec = e_rec >= np.percentile(e_rec, 50)
    top_ref = e_ref >= np.percentile(e_ref, 50)
    gain = max(float(e_rec[top_rec].mean() - noise.sum()), 1e-12) / max(
        float(e_ref[top_ref].mean()), 1e-12)
    return gain * ref + noise[None, :]


def dtw_path(x: np.ndarray, y: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """DTW between feature rows ``x`` (N, F) and ``y`` (M, F) restricted to columns
    ``[lo[i], hi[i])`` of row *i* (both non-decreasing); Euclidean local cost, symmetric steps.

    Returns the warping path, shape (L, 2) of (i, j) from (0, 0) to (N−1, M−1).
    """
    n, m = len(x), len(y)
    inf = np.inf
    ptrs: list[np.ndarray] = []
    prev = None
    prev_lo = 0
    for i in range(n):
        a, b = int(lo[i]), int(hi[i])
        c = np.sqrt(((y[a:b] - x[i]) ** 2).sum(axis=1))
        if prev is None:
            d = np.cumsum(HV_WEIGHT * c) if a == 0 else np.full(b - a, inf)
            p = np.full(b - a, 2, np.int8)
        else:
            ext = np.full(b - a + 1, inf)  # D_prev at columns a−1 … b−1
            s0, s1 = max(a - 1, prev_lo), min(b, prev_lo + len(prev))
            if s1 > s0:
                ext[s0 - (a - 1):s1 - (a - 1)] = prev[s0 - prev_lo:s1 - prev_lo]
            diag = ext[:-1] + 2 * c
            vert = ext[1:] + HV_WEIGHT * c
            bmin = np.minimum(diag, vert)
            s = np.cumsum(HV_WEIGHT * c)
            with np.errstate(invalid="ignore"):
                d = s + np.minimum.accumulate(bmin - s)
            d = np.where(np.isnan(d), inf, d)
            p = np.where(diag <= vert, 0, 1).astype(np.int8)
            p[d < bmin - 1e-9] = 2
        ptrs.append(p)
        prev, prev_lo = d, a
    if not np.isfinite(prev[m - 1 - prev_lo]):
        raise ParameterError("alignment failed: the recording and transcript cannot be matched")
    i, j = n - 1, m - 1
    path = [(i, j)]
    while i > 0 or j > 0:
        step = ptrs[i][j - int(lo[i])]
        if step == 0:
            i, j = i - 1, j - 1
        elif step == 1:
            i -= 1
        else:
            j -= 1
        if i < 0 or j < 0:
            break
        path.append((i, j))
    return np.array(path[::-1])


def _band(n: int, m: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    centre = np.arange(n) * (m - 1) / max(n - 1, 1)
    lo = np.clip(np.floor(centre - width), 0, m - 1).astype(int)
    hi = np.clip(np.ceil(centre + width) + 1, 1, m).astype(int)
    lo[0], hi[-1] = 0, m
    return lo, hi


def warp(ref_feat: np.ndarray, rec_feat: np.ndarray) -> np.ndarray:
    """Two-pass DTW (coarse band, then fine around the coarse path); path shape (L, 2)."""
    n, m = len(ref_feat), len(rec_feat)

    def pool(f):
        k = len(f) // COARSE * COARSE
        g = f[:k].reshape(-1, COARSE, f.shape[1]).mean(axis=1)
        return g if k == len(f) else np.vstack([g, f[k:].mean(axis=0)])

    cx, cy = pool(ref_feat), pool(rec_feat)
    width = int(0.25 * max(len(cx), len(cy)) + 1.0 / (HOP * COARSE))
    cpath = dtw_path(cx, cy, *_band(len(cx), len(cy), width))
    lo = np.full(n, m, int)
    hi = np.zeros(n, int)
    for ci, cj in cpath:
        r0, r1 = ci * COARSE, min(n, (ci + 1) * COARSE)
        lo[r0:r1] = np.minimum(lo[r0:r1], cj * COARSE - RADIUS)
        hi[r0:r1] = np.maximum(hi[r0:r1], (cj + 1) * COARSE + RADIUS)
    lo = np.clip(np.minimum.accumulate(lo[::-1])[::-1], 0, m - 1)
    hi = np.clip(np.maximum.accumulate(hi), 1, m)
    lo[0], hi[-1] = 0, m
    return dtw_path(ref_feat, rec_feat, lo, hi)


def time_map(path: np.ndarray, *, hop: float = HOP) -> tuple[np.ndarray, np.ndarray]:
    """Monotone piecewise-linear map ref time → recording time from a DTW path:
    knots at ref frame edges ``(i − ½)·hop`` mapped to the middle of the recording frames
    between ``max j(i−1)`` and ``min j(i)``. Returns ``(ref_knots, rec_knots)`` in seconds."""
    i, j = path[:, 0], path[:, 1]
    n = int(i.max()) + 1
    jmin = np.full(n, np.iinfo(np.int64).max)
    jmax = np.full(n, -1)
    np.minimum.at(jmin, i, j)
    np.maximum.at(jmax, i, j)
    ref = (np.arange(1, n) - 0.5) * hop
    rec = (jmax[:-1] + jmin[1:]) * 0.5 * hop
    return ref, np.maximum.accumulate(rec)


ENGINES = ("auto", "sphinx", "dtw")
#: recording kept around the detected speech before DTW (s)
MARGIN = 0.1


def _dtw_phones(a: np.ndarray, sr: int, transcript: str, lang: str, voice: str | None,
                act: np.ndarray) -> tuple[list[Phone], float]:
    """espeak's phones of ``transcript`` warped onto the speech part of the recording."""
    from mimika.speech.tts import synthesize
    from mimika.speech.vad import activity, speech_span

    dur = len(a) / sr
    span = speech_span(act) or (0.0, dur)
    c0, c1 = max(0.0, span[0] - MARGIN), min(dur, span[1] + MARGIN)
    rec = a[int(c0 * sr):round(c1 * sr)]
    ref = synthesize(transcript, lang=lang, voice=voice, engine="espeak")
    rspan = speech_span(activity(ref.audio, sr=ref.sr)) or (0.0, ref.duration)
    r0, r1 = max(0.0, rspan[0] - MARGIN), min(ref.duration, rspan[1] + MARGIN)
    ref_mel = mel_power(ref.audio[int(r0 * ref.sr):round(r1 * ref.sr)], sr=ref.sr)
    rec_mel = mel_power(rec, sr=sr)
    x = mfcc_features(_match_noise(ref_mel, rec_mel))
    y = mfcc_features(rec_mel)
    path = warp(x, y)
    cost = float(np.sqrt(((x[path[:, 0]] - y[path[:, 1]]) ** 2).sum(axis=1)).mean())
    knots_ref, knots_rec = time_map(path)

    def mp(t: float) -> float:
        return float(np.clip(c0 + np.interp(t - r0, knots_ref, knots_rec), 0.0, dur))

    phones: list[Phone] = []
    for k, p in enumerate(ref.phonemes):
        s = 0.0 if k == 0 else phones[-1].end
        e = dur if k == len(ref.phonemes) - 1 else max(mp(p.end), s)
        phones.append(Phone(p.symbol, s, e, p.stress))
    return phones, cost


#: recording kept around the detected speech for pocketsphinx (s)
SPHINX_MARGIN = 0.5


def _sphinx_phones(a: np.ndarray, sr: int, toks, lang: str, act: np.ndarray
                   ) -> tuple[list[Phone], list[int]]:
    """pocketsphinx on the speech part (± 0.5 s): what lies further out is a pause."""
    from mimika.speech import sphinx
    from mimika.speech.vad import speech_span

    dur = len(a) / sr
    span = speech_span(act) or (0.0, dur)
    c0 = max(0.0, span[0] - SPHINX_MARGIN)
    c1 = min(dur, span[1] + SPHINX_MARGIN)
    k0, k1 = round(c0 * sr), round(c1 * sr)
    c0 = k0 / sr
    phones, owner = sphinx.force_align(a[k0:k1], sr=sr, toks=toks, lang=lang)
    out = [Phone(p.symbol, p.start + c0, p.end + c0, p.stress) for p in phones]
    own = list(owner)
    if c0 > 0:
        if out[0].is_pause:
            out[0] = Phone("_", 0.0, out[0].end)
        else:
            out.insert(0, Phone("_", 0.0, c0))
            own.insert(0, -1)
    if out[-1].end < dur:
        if out[-1].is_pause:
            out[-1] = Phone("_", out[-1].start, dur)
        else:
            out.append(Phone("_", out[-1].end, dur))
            own.append(-1)
    return out, own


def align(audio: np.ndarray, *, sr: int, transcript: str, lang: str = "en",
          voice: str | None = None, engine: str = "auto") -> Utterance:
    """Phoneme/word/sentence timing of a recording of ``transcript``.

    Parameters
    ----------
    audio : ndarray, shape (n_samples,)
        Mono speech (float in [-1, 1] or integer PCM), any silence or noise around it.
    sr : int
        Its sample rate in Hz (any; features are computed at 16 kHz).
    transcript : str
        What is said (plain text, any espeak-ng language); numbers, abbreviations and symbols
        as written — word timings carry the written words.
    lang, voice : str
        espeak-ng language (and optional voice for the DTW reference).
    engine : ``auto`` | ``sphinx`` | ``dtw``
        ``sphinx``: pocketsphinx forced alignment (English); ``dtw``: DTW of the speech part
        against an espeak-ng rendition (every language); ``auto``: sphinx for English when
        pocketsphinx is installed (falling back to dtw if it fails), else dtw.

    Returns
    -------
    Utterance
        ``audio``/``sr`` are the recording's; phones tile it; words are the transcript's
        written words; ``meta["engine"]`` says which engine ran.
    """
    from mimika.speech import espeak, sphinx
    from mimika.speech.tts import split_sentences
    from mimika.speech.vad import activity, pad, refine_edges, unpad
    from mimika.speech.words import Token, as_read, assign_phones, tokens

    if engine not in ENGINES:
        raise ParameterError(f"engine={engine!r} must be one of {', '.join(ENGINES)}")
    a = valid_audio(audio, sr=sr)
    if len(a) < sr * 0.1:
        raise ParameterError(f"audio is {len(a) / sr:.3f} s long; need at least 0.1 s of speech")
    if not isinstance(transcript, str) or not transcript.strip():
        raise ParameterError("transcript is empty; give the words spoken in the recording")
    code = espeak.check_lang(lang)
    toks = [Token(t.text, t.offset, as_read(t.text) if as_read(t.text) != t.text else None)
            for t in tokens(transcript)]
    if not toks:
        raise ParameterError("transcript has no words; give the words spoken in the recording")
    act = activity(a, sr=sr)
    use = engine if engine != "auto" else ("sphinx" if sphinx.serves(code) else "dtw")
    meta: dict = {"source": "alignment"}
    if use == "sphinx":
        try:
            phones, owner = _sphinx_phones(a, int(sr), toks, code, act)
        except ParameterError as e:
            if engine == "sphinx":
                raise
            log.warning("%s; aligning by DTW instead", e)
            use = "dtw"
    if use == "dtw":
        phones, cost = _dtw_phones(a, int(sr), as_read(transcript), code, voice, act)
        owner = assign_phones(phones, toks, lang=code)
        meta["alignment_cost"] = round(cost, 4)
    phones, owner = pad(phones, owner)
    phones = refine_edges(phones, act)
    spans: dict[int, list[float]] = {}  # from every phone, even one DTW squeezed to nothing
    for p, o in zip(phones, owner, strict=True):
        if o >= 0:
            spans.setdefault(o, [p.start, p.end])[1] = p.end
    words = [Word(t.text, spans[k][0], spans[k][1], t.offset)
             for k, t in enumerate(toks) if k in spans]
    phones, owner = unpad(phones, owner)
    sents = []
    for text, c0 in split_sentences(transcript, lang):
        ws = [w for w in words if c0 <= w.offset < c0 + len(text)]
        if ws:
            sents.append(Sentence(text, ws[0].start, ws[-1].end))
    meta["engine"] = use
    log.debug("aligned %.2f s of audio to %d phones with %s", len(a) / sr, len(phones), use)
    return Utterance(a, int(sr), phones, words, sents, lang=code, text=transcript, meta=meta)


def recognise(audio: np.ndarray, *, sr: int, lang: str = "en") -> Utterance:
    """Lip-sync input from audio alone: the phones pocketsphinx's en-us phone model hears.

    No transcript, so no words. Every language goes through the English phone model (its 39
    phones cover the mouth shapes — viseme classes — of most languages; vowels of other
    languages land on the nearest English one); ``lang`` only selects the viseme overrides.
    """
    from mimika.speech import espeak, sphinx

    a = valid_audio(audio, sr=sr)
    if len(a) < sr * 0.1:
        raise ParameterError(f"audio is {len(a) / sr:.3f} s long; need at least 0.1 s of speech")
    code = espeak.check_lang(lang)
    if not sphinx.available():
        raise ParameterError("lip-sync without a transcript needs pocketsphinx "
                             "(pip install 'pocketsphinx==5.1.1'); or give --transcript")
    phones = sphinx.recognise_phones(a, sr=int(sr))
    return Utterance(a, int(sr), phones, [], [], lang="en" if code.startswith("en") else code,
                     text="", meta={"source": "recognition", "engine": "sphinx-phones"})
