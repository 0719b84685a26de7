"""Recorded speech + transcript → phoneme timing (TTS-independent viseme input).

Two engines (:func:`align`, ``engine=``): English goes through pocketsphinx's forced
alignment (:mod:`mimika.speech.sphinx`); every other espeak-ng language (and English without
pocketsphinx) through DTW against an espeak-ng rendition, below. Both then move word edges
next to pauses onto the recording's energy (:mod:`mimika.speech.vad`), and time the words as
written (:mod:`mimika.speech.words`). Real-speech figures: ``bench/bench_align_real.py``.
A recording over a minute goes to pocketsphinx piece by piece, cut at pauses a DTW alignment
of the whole finds (:mod:`mimika.speech.pieces`), so memory stays linear up to
``max_recording`` (30 min at 16 kHz: 5.1 GB → 0.85 GB; ``bench/bench_align_memory.py``).

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
* DTW (:mod:`mimika.speech.dtw`): symmetric step pattern (diagonal weight 2,
  horizontal/vertical 1.5), first on 20 ms frames inside a Sakoe–Chiba band of ±(25 % + 1 s),
  then on 5 ms frames inside ±50 ms of the coarse path; past about two minutes the 20 ms level
  is itself found through coarser ones, so memory stays linear in the recording's length.

Measured on espeak speech with known timing (rate 0.8×/1.25×, pitch/voice changes, speed
change by resampling, noise at 20/10 dB SNR): see ``bench/bench_align.py`` and docs/speech.md.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np

from mimika.errors import ParameterError
from mimika.speech.audio import resample, valid_audio
from mimika.speech.dtw import time_map, warp
from mimika.speech.utterance import Phone, Sentence, Utterance, Word

log = logging.getLogger(__name__)

FEAT_SR = 16000
HOP = 0.005  #: feature hop in seconds
WIN = 0.025
#: feature frames computed at once (bounds the memory of the spectra of a long recording)
BLOCK = 4096


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
    if not len(a):
        a = np.zeros(1, np.float32)
    h, w = round(hop * FEAT_SR), round(win * FEAT_SR)
    n = max(1, math.ceil(len(a) / h))
    n_fft = 512
    fb = _mel_filterbank(n_fft, FEAT_SR, n_mels, 60.0, 7600.0).T
    window = np.hamming(w)[None, :]
    out = np.empty((n, n_mels))
    for s in range(0, n, BLOCK):  # block by block: the spectra of a long recording are GBs
        k = min(n, s + BLOCK) - s
        seg = _emphasised(a, s * h - w // 2, s * h - w // 2 + (k - 1) * h + w)
        idx = np.arange(w)[None, :] + h * np.arange(k)[:, None]
        spec = np.abs(np.fft.rfft(seg[idx] * window, n=n_fft, axis=1)) ** 2
        out[s:s + k] = spec @ fb
    return out


def _emphasised(a: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Samples ``lo … hi − 1`` of ``a`` after pre-emphasis (``a[t] − 0.97·a[t−1]``; the first
    as it is), zero outside ``a``."""
    out = np.zeros(hi - lo, np.float32)
    s, e = max(lo, 0), min(hi, len(a))
    if e > s:
        seg = a[max(s - 1, 0):e]
        y = seg[1:] - 0.97 * seg[:-1] if s > 0 else np.append(seg[0], seg[1:] - 0.97 * seg[:-1])
        out[s - lo:e - lo] = y
    return out


def mfcc_features(mel: np.ndarray, *, n_mfcc: int = 13) -> np.ndarray:
    """Normalised MFCC features from mel power (n_frames, n_mels) → (n_frames, 2·n_mfcc − 1):
    c1…c12 and the deltas of c0…c12, each column mean 0 / variance 1."""
    from scipy.fft import dct

    logmel = mel + 1e-10  # in place from here on: a long recording's arrays are 100s of MB
    np.log(logmel, out=logmel)
    c = dct(logmel, type=2, norm="ortho", axis=1, overwrite_x=True)[:, :n_mfcc].copy()
    del logmel
    k = 2
    pad = np.pad(c, ((k, k), (0, 0)), mode="edge")
    delta = sum(i * (pad[k + i:len(c) + k + i] - pad[k - i:len(c) + k - i])
                for i in range(1, k + 1)) / (2 * sum(i * i for i in range(1, k + 1)))
    del pad
    f = np.hstack([c[:, 1:], delta])
    del c, delta
    mu, sd = f.mean(axis=0), f.std(axis=0)
    f -= mu
    f /= sd + 1e-8
    return f.astype(np.float32)


def _noise_and_level(rec: np.ndarray) -> tuple[np.ndarray, float]:
    """The recording's mel noise floor (10th percentile per band) and its speech level above
    it (mean power of the louder half of its frames), for :func:`_match_noise`."""
    noise = np.percentile(rec, 10, axis=0)
    e_rec = rec.sum(axis=1)
    return noise, float(e_rec[e_rec >= np.percentile(e_rec, 50)].mean() - noise.sum())


def _match_noise(ref: np.ndarray, noise: np.ndarray, level: float) -> np.ndarray:
    """Level-match the reference mel power to the recording's ``level`` and add its
    ``noise`` floor (:func:`_noise_and_level`)."""
    e_ref = ref.sum(axis=1)
    top_ref = e_ref >= np.percentile(e_ref, 50)
    gain = max(level, 1e-12) / max(float(e_ref[top_ref].mean()), 1e-12)
    out = gain * ref
    out += noise[None, :]
    return out


#: reverberation times (s) a reverberant recording's room is chosen from: the reference gets
#: the one whose rendition fits the recording best (lowest path cost)
ROOMS = (0.0, 0.2, 0.35, 0.5, 0.8)
#: a recording whose steepest falls of energy are slower than this is reverberant (dB/s over
#: 50 ms, :func:`fastest_fall`): dry speech falls 320–720 where sounds end (GRID's recordings,
#: also with white noise at 20 and 10 dB SNR; espeak's voices), a room's tail holds it back
#: (RT60 0.4 s: 190–220, 0.7 s: 140–190; 0.25 s: 230–310, half of it caught)
DRY_FALL = -280.0
#: in a reverberant recording a word before a pause ends at its last frame this far from the
#: noise floor to the speech level (:func:`mimika.speech.vad.above`; 0.3 elsewhere)
ROOM_END_THRESHOLD = 0.6


def fastest_fall(mel: np.ndarray, *, hop: float = HOP) -> float:
    """How fast the energy falls where sounds end: the 1st percentile of its change over 50 ms
    (dB/s) among frames within 20 dB of the speech level, in the mel bands where speech
    stands 30 dB above the noise floor (at least the 8 clearest); mel power (n_frames,
    n_mels)."""
    db = np.log10(mel.astype(np.float32) + np.float32(1e-10))
    db *= 10.0
    # the bands where speech stands well above the noise (white noise fills the high ones)
    span = np.percentile(db, 95, axis=0) - np.percentile(db, 10, axis=0)
    e = db[:, span >= min(30.0, float(np.sort(span)[-8]))].mean(axis=1)
    k = max(1, round(0.05 / hop))
    if len(e) <= k:
        return -np.inf
    loud = e[:-k] > np.percentile(e, 95) - 20.0
    fall = (e[k:] - e[:-k])[loud] / (k * hop)
    return float(np.percentile(fall, 1)) if len(fall) else -np.inf


def reverberate(mel: np.ndarray, t60: float, *, hop: float = HOP) -> np.ndarray:
    """Mel power (n_frames, n_mels) as heard in a room whose sound decays 60 dB in ``t60`` s:
    the direct sound plus its exponentially decaying tail, at the same mean power."""
    from scipy.signal import lfilter

    a = 10.0 ** (-6.0 * hop / t60)
    return a * mel + (1.0 - a) * lfilter([1.0], [1.0, -a], mel, axis=0)


ENGINES = ("auto", "sphinx", "dtw")
#: recording kept around the detected speech before DTW (s)
MARGIN = 0.1


#: a silence at least this long inside the speech, where the reference has no pause, is a
#: pause the speaker made (s): the reference gets one there and is warped again
SPEAKER_PAUSE = 0.25
#: how far from such a silence the word boundary it falls on may be mapped (s)
PAUSE_REACH = 0.5


def _dtw_phones(a: np.ndarray, sr: int, transcript: str, toks, lang: str, voice: str | None,
                act: np.ndarray, raw: np.ndarray
                ) -> tuple[list[Phone], list[int], float, float]:
    """espeak's phones of ``transcript`` warped onto the speech part of the recording, the
    token index of each (see :func:`~mimika.speech.words.assign_phones`), the path cost and
    the reverberation time of the room the recording was heard to be in (0: dry).
    ``act``: the recording's sustained activity, ``raw``: its frames above the threshold
    (:func:`mimika.speech.vad.above`; ``act`` is it :func:`~mimika.speech.vad.sustained`).

    espeak pauses at sentence ends and breaks only; where the speaker paused elsewhere, the
    warp would stretch the words next to it over the silence — so the reference gets the
    speaker's pauses (silence spliced in at the nearest word boundary) and is warped again.
    """
    from mimika.speech.tts import synthesize
    from mimika.speech.words import assign_phones

    ref = synthesize(transcript, lang=lang, voice=voice, engine="espeak")
    rec = _Recording(a, sr, act)
    phones, cost = rec.fit_room(ref.audio, ref.sr, ref.phonemes)
    owner = assign_phones(phones, toks, lang=lang)
    # every frame quiet: two stop closures around a short word are no pause
    cuts = _speaker_pauses(phones, owner, _quiet_runs(raw) if _quiet_runs(act) else [])
    if cuts:
        audio, ref_phones = _splice_pauses(ref.audio, ref.sr, ref.phonemes, cuts)
        phones, cost = rec.warp(audio, ref.sr, ref_phones)
        owner = assign_phones(phones, toks, lang=lang)
    return phones, owner, cost, rec.t60


class _Recording:
    """The speech part of a recording (± :data:`MARGIN`) as DTW features, to warp
    references onto."""

    def __init__(self, a: np.ndarray, sr: int, act: np.ndarray) -> None:
        from mimika.speech.vad import speech_span

        self.dur = len(a) / sr
        span = speech_span(act) or (0.0, self.dur)
        self.c0, c1 = max(0.0, span[0] - MARGIN), min(self.dur, span[1] + MARGIN)
        mel = mel_power(a[int(self.c0 * sr):round(c1 * sr)], sr=sr)
        self.noise, self.level = _noise_and_level(mel)
        self.reverberant = fastest_fall(mel) > DRY_FALL
        #: the room the references are heard in (reverberation time, s; 0: none)
        self.t60 = 0.0
        self.y = mfcc_features(mel)

    def fit_room(self, ref_audio: np.ndarray, ref_sr: int, ref_phones: Sequence[Phone]
                 ) -> tuple[list[Phone], float]:
        """:meth:`warp`, in a reverberant recording first in each of :data:`ROOMS`: the one
        that fits best is kept (:attr:`t60`) for this and later warps."""
        ref = self._reference(ref_audio, ref_sr)
        if not self.reverberant:
            return self._warp(*ref, ref_phones)
        best = None
        for t60 in ROOMS:
            self.t60 = t60
            out = self._warp(*ref, ref_phones)
            if best is None or out[1] < best[1][1]:
                best = (t60, out)
        self.t60 = best[0]
        log.debug("reverberant recording: the reference is heard in a %.2f s room", self.t60)
        return best[1]

    def warp(self, ref_audio: np.ndarray, ref_sr: int, ref_phones: Sequence[Phone],
             ) -> tuple[list[Phone], float]:
        """The reference's phones mapped onto the recording, and the path cost."""
        return self._warp(*self._reference(ref_audio, ref_sr), ref_phones)

    @staticmethod
    def _reference(ref_audio: np.ndarray, ref_sr: int) -> tuple[np.ndarray, float]:
        """The reference's speech part (± :data:`MARGIN`) as mel power, and where it starts."""
        from mimika.speech.vad import activity, speech_span

        ref_dur = len(ref_audio) / ref_sr
        rspan = speech_span(activity(ref_audio, sr=ref_sr)) or (0.0, ref_dur)
        r0, r1 = max(0.0, rspan[0] - MARGIN), min(ref_dur, rspan[1] + MARGIN)
        return mel_power(ref_audio[int(r0 * ref_sr):round(r1 * ref_sr)], sr=ref_sr), r0

    def _warp(self, ref_mel: np.ndarray, r0: float, ref_phones: Sequence[Phone]
              ) -> tuple[list[Phone], float]:
        if self.t60 > 0:
            ref_mel = reverberate(ref_mel, self.t60)
        x = mfcc_features(_match_noise(ref_mel, self.noise, self.level))
        y = self.y
        path = warp(x, y, hop=HOP)
        cost = float(np.sqrt(((x[path[:, 0]] - y[path[:, 1]]) ** 2).sum(axis=1)).mean())
        knots_ref, knots_rec = time_map(path, hop=HOP)

        def mp(t: float) -> float:
            return float(np.clip(self.c0 + np.interp(t - r0, knots_ref, knots_rec), 0.0,
                                 self.dur))

        phones: list[Phone] = []
        for k, p in enumerate(ref_phones):
            s = 0.0 if k == 0 else phones[-1].end
            e = self.dur if k == len(ref_phones) - 1 else max(mp(p.end), s)
            phones.append(Phone(p.symbol, s, e, p.stress))
        return phones, cost


def _quiet_runs(act: np.ndarray) -> list[tuple[float, float]]:
    """``(start, end)`` s of each run of inactive frames of at least :data:`SPEAKER_PAUSE`
    between the first and the last active frame."""
    from mimika.speech.vad import HOP as ACT_HOP

    on = np.flatnonzero(act)
    if not len(on):
        return []
    quiet = ~act[on[0]:on[-1] + 1]
    edges = np.flatnonzero(np.diff(np.r_[0, quiet.astype(np.int8), 0])) + on[0]
    return [(q0 * ACT_HOP, q1 * ACT_HOP) for q0, q1 in zip(edges[::2], edges[1::2], strict=True)
            if (q1 - q0) * ACT_HOP >= SPEAKER_PAUSE - 1e-9]


def _speaker_pauses(phones: list[Phone], owner: list[int], runs: list[tuple[float, float]]
                    ) -> list[tuple[int, float]]:
    """``(phone index, seconds)`` for each silence of ``runs`` (:func:`_quiet_runs`) that no
    pause phone covers: the first phone of the word whose mapped start is nearest to it
    (within :data:`PAUSE_REACH`), and the silence's length. A silence nearest to the first
    word's start or the last word's end is not between words (a breath or a click beyond the
    words)."""
    words = sorted(set(o for o in owner if o >= 0))
    if not runs or len(words) < 2:
        return []
    first: dict[int, int] = {}
    for i, o in enumerate(owner):
        if o >= 0:
            first.setdefault(o, i)
    last = max(i for i, o in enumerate(owner) if o >= 0)
    # candidate places: every word's start, and the end of the last word
    at = [phones[first[w]].start for w in words] + [phones[last].end]
    out: dict[int, float] = {}
    for t0, t1 in runs:
        covered = sum(max(0.0, min(p.end, t1) - max(p.start, t0)) for p in phones if p.is_pause)
        if covered >= 0.5 * (t1 - t0):
            continue
        gap = [max(t0 - t, t - t1, 0.0) for t in at]
        k = int(np.argmin(gap))
        if 0 < k < len(words) and gap[k] <= PAUSE_REACH:
            i = first[words[k]]
            out[i] = max(out.get(i, 0.0), t1 - t0)
    return sorted(out.items())


def _splice_pauses(audio: np.ndarray, sr: int, phones: Sequence[Phone],
                   cuts: list[tuple[int, float]]) -> tuple[np.ndarray, list[Phone]]:
    """The reference with ``seconds`` of silence before each phone index of ``cuts`` (a pause
    phone already there grows instead); phone times move with it."""
    parts, out = [], []
    k0, shift, todo = 0, 0.0, dict(cuts)
    for i, p in enumerate(phones):
        if i in todo:
            at = round(p.start * sr)
            n = round(todo[i] * sr)
            parts += [audio[k0:at], np.zeros(n, audio.dtype)]
            k0 = at
            t = p.start + shift
            if out and out[-1].is_pause:
                out[-1] = Phone(out[-1].symbol, out[-1].start, t + n / sr, out[-1].stress)
            else:
                out.append(Phone("_", t, t + n / sr))
            shift += n / sr
        out.append(Phone(p.symbol, p.start + shift, p.end + shift, p.stress))
    parts.append(audio[k0:])
    return np.concatenate(parts), out


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


def _word_spans(phones: list[Phone], owner: list[int], n: int) -> np.ndarray:
    """(start, end) of each of ``n`` words from its phones; a word without phones sits where
    the word before it ends."""
    spans = np.full((n, 2), np.nan)
    for p, o in zip(phones, owner, strict=True):
        if o >= 0:
            if np.isnan(spans[o, 0]):
                spans[o, 0] = p.start
            spans[o, 1] = p.end
    end = 0.0
    for k in range(n):
        if np.isnan(spans[k, 0]):
            spans[k] = end
        end = spans[k, 1]
    return spans


def _sphinx_long(a: np.ndarray, sr: int, transcript: str, toks, lang: str, voice: str | None,
                 act: np.ndarray, raw: np.ndarray, *, strict: bool
                 ) -> tuple[list[Phone], list[int], dict]:
    """pocketsphinx on a long recording, piece by piece (:mod:`mimika.speech.pieces`: cut at
    pauses found with a DTW alignment of the whole), so its memory stays bounded; a piece it
    cannot align keeps the DTW phones (``strict``: raises instead)."""
    from mimika.speech import pieces
    from mimika.speech.vad import HOP as ACT_HOP
    from mimika.speech.words import as_read

    dphones, downer, *_ = _dtw_phones(a, sr, as_read(transcript), toks, lang, voice, act,
                                      raw)
    spans = _word_spans(dphones, downer, len(toks))
    cuts = [round(t * sr) for t in pieces.cut_times(spans, act, len(a) / sr)]
    bounds = [0, *cuts, len(a)]
    parts, fallbacks = [], 0
    for k, words in enumerate(pieces.assign(spans, [c / sr for c in cuts])):
        k0, k1 = bounds[k], bounds[k + 1]
        t0, t1 = k0 / sr, k1 / sr
        if not words:
            parts.append(([Phone("_", t0, t1)], [-1]))
            continue
        try:
            ps, own = _sphinx_phones(a[k0:k1], sr, [toks[i] for i in words], lang,
                                     act[round(t0 / ACT_HOP):round(t1 / ACT_HOP)])
            parts.append(pieces.shift(ps, own, t0, words.start))
        except ParameterError as e:
            if strict:
                raise
            log.warning("%s (%.1f–%.1f s); that piece keeps its DTW alignment", e, t0, t1)
            fallbacks += 1
            parts.append(pieces.clip(dphones, downer, t0, t1))
    phones, owner = pieces.join(parts)
    return phones, owner, {"pieces": len(parts), "dtw_pieces": fallbacks}


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
    from mimika.speech import espeak, pieces, sphinx
    from mimika.speech.phonemes import is_stop
    from mimika.speech.tts import split_sentences
    from mimika.speech.vad import (
        above,
        frame_energy,
        pad,
        refine_edges,
        sustained,
        to_silence,
        trailing,
        unpad,
    )
    from mimika.speech.words import Token, as_read, tokens

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
    energy = frame_energy(a, sr=sr)
    raw = above(energy)  # every frame above the threshold
    act = sustained(raw)
    use = engine if engine != "auto" else ("sphinx" if sphinx.serves(code) else "dtw")
    meta: dict = {"source": "alignment"}
    room = 0.0  # the reverberation time DTW heard the recording in
    if use == "sphinx":
        try:
            if len(a) / sr > pieces.PIECE:
                phones, owner, more = _sphinx_long(a, int(sr), transcript, toks, code, voice,
                                                   act, raw, strict=engine == "sphinx")
                meta.update(more)
            else:
                phones, owner = _sphinx_phones(a, int(sr), toks, code, act)
        except ParameterError as e:
            if engine == "sphinx":
                raise
            log.warning("%s; aligning by DTW instead", e)
            use = "dtw"
    if use == "dtw":
        phones, owner, cost, room = _dtw_phones(a, int(sr), as_read(transcript), toks, code,
                                                voice, act, raw)
        meta["alignment_cost"] = round(cost, 4)
    phones, owner = pad(phones, owner)
    # a room's tail holds the energy up after a sound ends: words before a pause end where
    # it is still near the speech level; in a dry one a short last syllable after a closure
    # still belongs to the word
    ends = sustained(above(energy, ROOM_END_THRESHOLD)) if room else to_silence(
        trailing(act, raw), energy)
    phones = refine_edges(phones, act, ends=ends, is_stop=lambda sym: is_stop(sym, code))
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


RECOGNISERS = ("frames", "sphinx")  #: engines of :func:`recognise`


def recognise(audio: np.ndarray, *, sr: int, lang: str = "en", engine: str = "frames"
              ) -> Utterance:
    """Lip-sync input from audio alone: the phones heard, no transcript, so no words.

    ``engine``: ``frames`` (default) — the streaming recogniser's mouth classes
    (:mod:`mimika.speech.streaming`, every 10 ms decided after a 72 ms look-ahead, as
    ``mimika serve``'s ``listen`` gets them), each class as one phone; ``sphinx`` — the phones
    pocketsphinx's en-us phone model hears in the whole recording. Every language goes
    through the English model (its classes cover the mouth shapes of most languages; vowels
    of other languages land on the nearest English one); ``lang`` only selects the viseme
    overrides.
    """
    from mimika.speech import espeak, sphinx

    a = valid_audio(audio, sr=sr)
    if len(a) < sr * 0.1:
        raise ParameterError(f"audio is {len(a) / sr:.3f} s long; need at least 0.1 s of speech")
    if engine not in RECOGNISERS:
        raise ParameterError(f"engine {engine!r} is not one of {', '.join(RECOGNISERS)}")
    code = espeak.check_lang(lang)
    if engine == "sphinx":
        if not sphinx.available():
            raise ParameterError("lip-sync without a transcript needs pocketsphinx "
                                 "(pip install 'pocketsphinx==5.1.1'); or give --transcript")
        phones = sphinx.recognise_phones(a, sr=int(sr))
        name = "sphinx-phones"
    else:
        from mimika.speech import streaming

        dur = len(a) / sr
        phones = [Phone(p.symbol, p.start, min(p.end, dur), p.stress)
                  for p in streaming.class_phones(streaming.recognise_classes(a, sr=int(sr)))]
        name = "frames"
    return Utterance(a, int(sr), phones, [], [], lang="en" if code.startswith("en") else code,
                     text="", meta={"source": "recognition", "engine": name})
